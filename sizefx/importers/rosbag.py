"""ROS bags via ``rosbags``: ROS 1 ``.bag``, ROS 2 bag folders, ``.mcap`` and ``.db3`` files.

IMU
    ``sensor_msgs/Imu`` on the topic ``imu`` names (found when the bag holds exactly one):
    ``angular_velocity`` [rad/s] and ``linear_acceleration`` [m/s^2, specific force: +g up at
    rest, REP 145]. Its ``orientation`` is the driver's estimate, not truth, and is not read.
    Every message must be in one frame (``header.frame_id``).
Reference (optional)
    ``geometry_msgs/PoseStamped`` (or ``PoseWithCovarianceStamped``) or ``nav_msgs/Odometry`` on
    a topic, or the ``tf2_msgs/TFMessage`` entries of ``/tf`` for one parent and child frame
    (``reference="tf:PARENT/CHILD"``). The orientation rotates the child (body) frame's vectors
    into ``header.frame_id`` (the world); an Odometry's twist is in the child frame (ROS's
    convention) and becomes the NED velocity; positions, in a local frame's metres, are not used.
    The child frame must be the body frame: the IMU's ``frame_id`` unless ``body_frame`` names
    another whose axes are the IMU's (a PoseStamped names no child: it is taken to be the body).
Frames (REP 103)
    ``frame="flu"`` (the default): body forward-left-up, world east-north-up, converted by
    :func:`sizefx.frames.body_from_ros` (``(x, -y, -z)``) and :func:`sizefx.frames.quat_nb_from_ros`
    (``mat_nb = MAT_NED_ENU @ mat_world_body @ MAT_FRD_FLU.T``); ``frame="frd"``: REP 103's
    ``*_ned`` frames, sizefx's own axes. ROS quaternions are scalar-last (x, y, z, w).
Stamps
    ``header.stamp`` (``stamps="header"``) or the time the recorder received each message
    (``stamps="receive"``), for the IMU and the reference alike. The record's times are seconds
    after the first IMU stamp, kept as ``stamp_origin_ns`` in ``/source`` (the ROS bag export
    restores it). Stamps that repeat or go back are refused, naming the topic, the message and
    the stamps, as the telemetry contract refuses them; gaps are declared by the import stage.
Site
    ``site_deg``, or the first message of the ``sensor_msgs/NavSatFix`` topic ``navsat`` that holds
    a fix (status >= STATUS_FIX).

Memory: only the chosen topics' messages are read and deserialised (a bag full of camera images
costs their reading, not their memory), and the values go into numpy blocks of
:data:`BLOCK_ROWS` rows; at most :data:`~sizefx.constants.MAX_WHOLE_READ_ROWS` IMU messages (the
rows every command that loads a record whole takes). rosbags is an optional dependency
(``pip install 'sizefx[ros]'``).
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..constants import DEG, MAX_WHOLE_READ_ROWS
from ..errors import ConfigError, SourceError
from ..frames import ROS_AXES, body_from_ros
from ..io.files import HASH_CHUNK_BYTES
from ..io.telemetry import Site, Telemetry, nominal_period_s
from ..ros import IMU, NAVSAT, NS_PER_S, bag_files, require_rosbags, stamp_ns, stamp_text, storage_of
from . import provenance
from .rosbag_common import BLOCK_ROWS, TF_TOPIC, _check_order, _frame, _listing, _one_value, _Rows, _short
from .rosbag_reference import (
    REFERENCE_TYPES,
    _add_pose,
    _add_transforms,
    _build_reference,
    _reference_spec,
    _ReferenceSpec,
)

#: REFERENCE_TYPES (:mod:`.rosbag_reference`), BLOCK_ROWS and TF_TOPIC (:mod:`.rosbag_common`): re-exported
__all__ = ["load", "STAMPS", "REFERENCE_TYPES", "BLOCK_ROWS", "TF_TOPIC"]

#: Where the times come from: the messages' ``header.stamp``, or the bag's receive time.
STAMPS = ("header", "receive")
#: What the ROS axes are, in words, for the summary.
AXES_WORDS = {
    "flu": "body forward-left-up -> FRD (x, -y, -z), world east-north-up -> NED (REP 103)",
    "frd": "body forward-right-down and world north-east-down (REP 103's *_ned frames): as they are",
}
#: What repairs a bag that a recording cut short (its index or footer missing), by storage file suffix.
REPAIR = {".bag": "rosbag reindex", ".mcap": "mcap recover"}


def _unreadable(path: Path, exc: Exception, where: str = "") -> SourceError:
    detail = " ".join(str(exc).split())[:160] or type(exc).__name__
    at = f" at {where}" if where else ""
    tool = None if path.is_dir() else REPAIR.get(path.suffix)
    repair = f" ({tool} repairs one cut short)" if tool else ""
    return SourceError(
        path, f"cannot be read as a {storage_of(path)}{at} ({detail}); is it truncated, damaged or not a bag?{repair}"
    )


def _open_reader(path: Path):
    """An open ``AnyReader`` of the bag, or a one-line SourceError (no rosbags, not a bag, truncated)."""
    try:
        require_rosbags(f"reading {path.name}")
    except ImportError as exc:
        raise SourceError(path, str(exc)) from None
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    if not path.is_dir() and path.suffix not in (".bag", ".mcap", ".db3"):
        raise SourceError(
            path, "is not a ROS bag by its name: give a ROS 1 .bag, a ROS 2 bag folder, or a .mcap or .db3 file"
        )
    # a ROS 2 bag recorded before Iron carries no message definitions: the standard ones then
    reader = AnyReader([path], default_typestore=get_typestore(Stores.LATEST))
    try:
        reader.open()
    except Exception as exc:  # rosbags' ReaderError, AnyReaderError, and what a damaged file raises
        raise _unreadable(path, exc) from None
    return reader


def _messages(path: Path, reader, connections) -> Iterator[tuple]:
    """``(connection, receive_ns, message)`` of ``connections`` in the bag's order, deserialised one
    at a time; what rosbags raises on a damaged bag becomes a SourceError naming it."""
    stream = reader.messages(connections=connections)
    while True:
        try:
            item = next(stream)
        except StopIteration:
            return
        except Exception as exc:
            raise _unreadable(path, exc) from None
        conn, receive_ns, raw = item
        try:
            msg = reader.deserialize(raw, conn.msgtype)
        except Exception as exc:
            raise _unreadable(path, exc, f"a message of {conn.topic}") from None
        yield conn, int(receive_ns), msg


def _choose_imu(path: Path, topics: dict, imu: str | None) -> str:
    imus = sorted(name for name, info in topics.items() if info.msgtype == IMU)
    everything = sorted(f"{name} ({_short(info.msgtype)})" for name, info in topics.items())
    if imu is None:
        if len(imus) == 1:
            return imus[0]
        if not imus:
            raise SourceError(path, f"holds no sensor_msgs/Imu topic; its topics: {_listing(everything)}")
        raise SourceError(
            path, f"holds {len(imus)} sensor_msgs/Imu topics ({_listing(imus)}); choose one with --imu-topic"
        )
    if imu not in topics:
        listed = f"its sensor_msgs/Imu topics: {_listing(imus)}" if imus else f"its topics: {_listing(everything)}"
        raise SourceError(path, f"--imu-topic {imu}: the bag has no such topic; {listed}")
    if topics[imu].msgtype != IMU:
        raise SourceError(
            path,
            f"--imu-topic {imu}: the topic holds {_short(topics[imu].msgtype)}, not sensor_msgs/Imu; its "
            f"sensor_msgs/Imu topics: {_listing(imus)}",
        )
    return imu


def _bag_sha256(path: Path) -> str:
    """SHA-256 of the bag's bytes: its file, or a folder's files in name order (``cat`` of
    :func:`sizefx.ros.bag_files`, as ``sha256sum`` would take them), read in bounded chunks."""
    digest = hashlib.sha256()
    for f in bag_files(path):
        with open(f, "rb") as fh:
            while chunk := fh.read(HASH_CHUNK_BYTES):
                digest.update(chunk)
    return digest.hexdigest()


def _imu_values(msg) -> tuple:
    w, a = msg.angular_velocity, msg.linear_acceleration
    return (w.x, w.y, w.z, a.x, a.y, a.z)


@dataclass
class _Imu:
    topic: str
    rows: _Rows = field(default_factory=lambda: _Rows(6))
    frame: str | None = None


@dataclass
class _Fix:
    """The site from a NavSatFix topic: the first message with a fix."""

    topic: str
    seen: int = 0
    found: tuple | None = None  #: (lat_deg, lon_deg, altitude_m, message index)


def _read(path: Path, reader, imu: _Imu, ref: _ReferenceSpec | None, fix: _Fix | None) -> None:
    """One pass over the chosen topics' messages, in the bag's order."""
    topics = {imu.topic, *([ref.topic] if ref else []), *([fix.topic] if fix else [])}
    connections = [c for c in reader.connections if c.topic in topics]
    declared = sum(c.msgcount for c in connections if c.topic == imu.topic)
    if declared > MAX_WHOLE_READ_ROWS:
        raise SourceError(path, _too_many(imu.topic, declared, declared=True))
    ref_index = 0
    for conn, receive_ns, msg in _messages(path, reader, connections):
        topic = conn.topic
        try:
            if topic == imu.topic:
                imu.frame = _one_value(
                    path,
                    topic,
                    imu.rows.n,
                    imu.frame,
                    msg.header.frame_id,
                    "is in frame",
                    "in ",
                    "one IMU is in one frame",
                )
                if imu.rows.n >= MAX_WHOLE_READ_ROWS:
                    raise SourceError(path, _too_many(topic, imu.rows.n + 1))
                imu.rows.add(stamp_ns(msg.header.stamp), receive_ns, _imu_values(msg))
            elif ref is not None and topic == ref.topic:
                if ref.kind == "tf":
                    _add_transforms(path, ref, msg, receive_ns, max_rows=MAX_WHOLE_READ_ROWS)
                else:
                    _add_pose(path, ref, msg, receive_ns, ref_index, max_rows=MAX_WHOLE_READ_ROWS)
                    ref_index += 1
            elif fix is not None and topic == fix.topic:
                if fix.found is None and int(msg.status.status) >= 0:  # STATUS_FIX and better
                    lat, lon, alt = float(msg.latitude), float(msg.longitude), float(msg.altitude)
                    if np.isfinite([lat, lon, alt]).all():
                        fix.found = (lat, lon, alt, fix.seen)
                fix.seen += 1
        except AttributeError as exc:  # a type of that name with other fields (a custom definition)
            raise SourceError(
                path, f"topic {topic}: its {_short(conn.msgtype)} messages lack a field ({exc}); not the standard type"
            ) from None


def _too_many(topic: str, n: int, *, declared: bool = False) -> str:
    held = f"holds {n} messages (its index says)" if declared else f"holds more than {n - 1} messages"
    return (
        f"topic {topic} {held}; an import takes at most {MAX_WHOLE_READ_ROWS} IMU "
        "messages (2 h at 1600 Hz, what the commands that load a record whole take): cut the bag first "
        "(rosbag filter, ros2 bag convert)"
    )


def load(
    path: Path,
    *,
    imu: str | None = None,
    reference: str | None = None,
    body_frame: str | None = None,
    stamps: str = "header",
    frame: str = "flu",
    site_deg=None,
    navsat: str | None = None,
    keep_invalid: bool = False,
) -> Telemetry:
    """A ROS bag's IMU topic (and reference, and site) as :class:`~sizefx.io.telemetry.Telemetry`
    in SI, body FRD, NED; see the module docstring for the rules.

    ``keep_invalid``: keep IMU messages holding NaN or inf (for ``--drop-invalid-rows``) instead of
    refusing the bag at the first.
    """
    path = Path(path)
    if stamps not in STAMPS:
        raise ConfigError(f"import rosbag: --stamps {stamps}: use one of {', '.join(STAMPS)}")
    if frame not in ROS_AXES:
        raise ConfigError(f"import rosbag: --frame {frame}: use one of {', '.join(ROS_AXES)}")
    if site_deg is not None and navsat is not None:
        raise ConfigError("import rosbag: give the site once: --site-deg or --navsat-topic")
    reader = _open_reader(path)
    try:
        topics = reader.topics
        imu_topic = _choose_imu(path, topics, imu)
        ref = None if reference is None else _reference_spec(path, topics, reference)
        fix = None
        if navsat is not None:
            if navsat not in topics or topics[navsat].msgtype != NAVSAT:
                fixes = sorted(name for name, info in topics.items() if info.msgtype == NAVSAT)
                found = "no such topic" if navsat not in topics else f"{_short(topics[navsat].msgtype)} there"
                raise SourceError(
                    path,
                    f"--navsat-topic {navsat}: the bag has {found}; its sensor_msgs/NavSatFix topics: {_listing(fixes)}",
                )
            fix = _Fix(navsat)
        state = _Imu(imu_topic)
        _read(path, reader, state, ref, fix)
    finally:
        reader.close()
    return _telemetry(path, state, ref, fix, stamps, frame, body_frame, site_deg, keep_invalid)


def _telemetry(path, state: _Imu, ref, fix, stamps, frame, body_frame, site_deg, keep_invalid) -> Telemetry:
    topic = state.topic
    ns_both, values = state.rows.arrays()
    if ns_both.shape[0] < 2:
        raise SourceError(path, f"topic {topic} holds {ns_both.shape[0]} message(s); at least 2 are needed")
    column = 0 if stamps == "header" else 1
    ns = ns_both[:, column]
    _check_order(path, topic, ns, stamps)
    bad = ~np.isfinite(values)
    if bad.any() and not keep_invalid:
        k, c = (int(v) for v in np.argwhere(bad)[0])
        field_name = ("angular_velocity", "linear_acceleration")[c // 3]
        raise SourceError(
            path,
            f"topic {topic}: message {k} holds NaN/Inf in {field_name}.{'xyz'[c % 3]}; IMU samples must be "
            "finite (--drop-invalid-rows leaves such messages out, as gaps)",
        )
    origin_ns = int(ns[0])
    time_s = (ns - origin_ns) / NS_PER_S
    gyro_b = body_from_ros(values[:, :3], frame)
    accel_b = body_from_ros(values[:, 3:], frame)
    imu_frame = state.frame or ""  # as the messages write it (the export writes it back so)
    body = _frame(imu_frame if body_frame is None else body_frame)
    rate_hz = 1.0 / nominal_period_s(time_s)
    conversion = [
        f"{AXES_WORDS[frame]}; ROS quaternions x, y, z, w (scalar last) -> q_nb (scalar first)",
        f"time: the {stamps} stamps of {topic}, in seconds after the first, {stamp_text(origin_ns)} "
        "(/source stamp_origin_ns)",
    ]
    source: dict[str, Any] = {
        "storage": storage_of(path),
        "imu_topic": topic,
        "imu_frame_id": imu_frame,
        "axes": frame,
        "stamps": stamps,
        "stamp_origin_ns": origin_ns,
    }
    if body_frame is not None:
        source["body_frame"] = body_frame
    description = (
        f"{storage_of(path)} {path.name}, topic {topic} (sensor_msgs/Imu, frame '{imu_frame}'): "
        f"{time_s.size} samples at {rate_hz:.6g} Hz, {stamps} stamps, {AXES_WORDS[frame]}"
    )
    tel = Telemetry(time_s=time_s, form="rates", gyro_rad_s=gyro_b, accel_mps2=accel_b)
    if ref is not None:
        tel.reference, words = _build_reference(path, ref, stamps, frame, body, imu_frame, topic, origin_ns, tel)
        conversion.append(words)
        description += "; " + words
        source.update(
            reference=ref.asked,
            reference_type=ref.kind,
            reference_world_frame=ref.world or "",
            reference_body_frame=ref.child if ref.child is not None else body,
            reference_rows=int(tel.reference.time_s.shape[0]),
        )
    if site_deg is not None:
        tel.site = Site(site_deg[0] * DEG, site_deg[1] * DEG, float(site_deg[2]))
        conversion.append("site: from --site-deg")
    elif fix is not None:
        if fix.found is None:
            raise SourceError(
                path,
                f"--navsat-topic {fix.topic}: none of its {fix.seen} messages holds a fix (status >= STATUS_FIX "
                "with finite latitude, longitude, altitude); give the site with --site-deg",
            )
        lat, lon, alt, k = fix.found
        tel.site = Site(lat * DEG, lon * DEG, alt)
        conversion.append(
            f"site: the first fix of {fix.topic} (message {k}): {lat:.7f} deg, {lon:.7f} deg, {alt:.2f} m (WGS-84)"
        )
        source.update(site_from=fix.topic, site_message=k)
    else:
        conversion.append("site: none (navigation needs one: --site-deg or --navsat-topic)")
    tel.description = description
    source["conversion"] = conversion
    if path.is_dir():  # the files the checksum is of
        source["bag_files"] = [f.name for f in bag_files(path)]
    tel.source = provenance(path, "rosbag", digest=_bag_sha256(path), **source)
    return tel
