"""The reference side of the ROS bag importer (:mod:`sizefx.importers.rosbag`): which topic (or
``tf:PARENT/CHILD``) holds it, its messages' orientations and twists as rows, and ``/reference``
in NED and body FRD built from them."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..constants import QUATERNION_NORM_TOLERANCE
from ..errors import SourceError
from ..frames import body_from_ros, quat_nb_from_ros
from ..io.telemetry import Reference
from ..ros import NS_PER_S, ODOMETRY, POSE, POSE_COVARIANCE, TF_TYPES, stamp_ns
from ..rotation import quat_to_mat
from . import REFERENCE_GRAVITY_ANGLE_MAX_DEG, reference_up_angle_deg
from .rosbag_common import TF_TOPIC, _check_order, _frame, _listing, _one_value, _Rows, _short

__all__ = ["REFERENCE_TYPES", "MAX_PAIRS_KEPT", "WORLD_WORDS"]

#: Message types a reference topic may hold (a tf reference is ``tf:PARENT/CHILD``).
REFERENCE_TYPES = (POSE, POSE_COVARIANCE, ODOMETRY)
#: Distinct tf frame pairs remembered for a refusal's listing (a bag of many robots has hundreds).
MAX_PAIRS_KEPT = 1000
#: What the ROS world axes are, in words, for the summary.
WORLD_WORDS = {"flu": "ENU", "frd": "NED"}


@dataclass
class _ReferenceSpec:
    """The reference asked for: a topic of :data:`REFERENCE_TYPES`, or ``tf:PARENT/CHILD``."""

    kind: str  #: pose | odometry | tf
    topic: str
    asked: str  #: what the option said
    pair: str | None = None  #: tf: "PARENT/CHILD", without leading slashes
    world: str | None = None  #: the world frame found (header.frame_id, or tf's parent)
    child: str | None = None  #: the body frame found (child_frame_id); None for a pose
    rows: _Rows = field(default_factory=lambda: _Rows(7))  #: x, y, z, w, then the twist (NaN: none)
    pairs_seen: set = field(default_factory=set)  #: tf: the parent/child pairs of /tf
    matched: set = field(default_factory=set)  #: tf: the (parent, child) pairs that read as ``pair``

    @property
    def label(self) -> str:
        return f"{TF_TOPIC} ({self.pair})" if self.kind == "tf" else self.topic


def _reference_spec(path: Path, topics: dict, reference: str) -> _ReferenceSpec:
    if reference.startswith("tf:"):
        pair = "/".join(_frame(p) for p in reference[3:].strip().split("/") if p)
        if "/" not in pair:
            raise SourceError(
                path,
                f"--reference-topic {reference}: name the parent and the child frame, tf:PARENT/CHILD (e.g. tf:odom/base_link)",
            )
        tf = topics.get(TF_TOPIC)
        if tf is None or tf.msgtype not in TF_TYPES:
            found = "no such topic" if tf is None else f"it holds {_short(tf.msgtype)}"
            raise SourceError(
                path, f"--reference-topic {reference}: the transforms are read from {TF_TOPIC}, and the bag has {found}"
            )
        return _ReferenceSpec("tf", TF_TOPIC, reference, pair=pair)
    accepted = ", ".join(_short(t) for t in REFERENCE_TYPES)
    if reference not in topics:
        usable = sorted(name for name, info in topics.items() if info.msgtype in REFERENCE_TYPES)
        tf = " or tf:PARENT/CHILD from /tf" if TF_TOPIC in topics else ""
        raise SourceError(
            path,
            f"--reference-topic {reference}: the bag has no such topic; its topics of {accepted}: {_listing(usable)}{tf}",
        )
    msgtype = topics[reference].msgtype
    if msgtype not in REFERENCE_TYPES:
        raise SourceError(
            path, f"--reference-topic {reference}: the topic holds {_short(msgtype)}; a reference is one of {accepted}"
        )
    return _ReferenceSpec("odometry" if msgtype == ODOMETRY else "pose", reference, reference)


def _pose_values(msg, kind: str) -> tuple:
    """x, y, z, w of the orientation, then the twist's linear velocity (NaN for a pose)."""
    if kind == "odometry":
        q, v = msg.pose.pose.orientation, msg.twist.twist.linear
        return (q.x, q.y, q.z, q.w, v.x, v.y, v.z)
    pose = msg.pose.pose if hasattr(msg.pose, "pose") else msg.pose  # PoseWithCovarianceStamped
    q = pose.orientation
    return (q.x, q.y, q.z, q.w, np.nan, np.nan, np.nan)


def _add_pose(path: Path, ref: _ReferenceSpec, msg, receive_ns: int, index: int, *, max_rows: int) -> None:
    """One pose or odometry message into ``ref``'s rows (at most ``max_rows``: the importer's
    :data:`~sizefx.constants.MAX_WHOLE_READ_ROWS`, as :mod:`sizefx.importers.rosbag` reads it)."""
    world = _frame(msg.header.frame_id)
    ref.world = _one_value(
        path, ref.topic, index, ref.world, world, "is in frame", "in ", "a reference is in one world frame"
    )
    if ref.kind == "odometry":
        child = _frame(msg.child_frame_id)
        ref.child = _one_value(
            path, ref.topic, index, ref.child, child, "describes child frame", "", "a reference describes one body"
        )
    if ref.rows.n >= max_rows:
        raise SourceError(path, f"topic {ref.topic} holds more than {max_rows} messages; cut the bag first")
    ref.rows.add(stamp_ns(msg.header.stamp), receive_ns, _pose_values(msg, ref.kind))


def _add_transforms(path: Path, ref: _ReferenceSpec, msg, receive_ns: int, *, max_rows: int) -> None:
    """The transforms of one /tf message that read as ``ref.pair`` into its rows (at most ``max_rows``)."""
    for tf in msg.transforms:
        parent, child = _frame(tf.header.frame_id), _frame(tf.child_frame_id)
        if f"{parent}/{child}" != ref.pair:
            if len(ref.pairs_seen) < MAX_PAIRS_KEPT:
                ref.pairs_seen.add(f"{parent}/{child}")
            continue
        ref.matched.add((parent, child))
        if len(ref.matched) > 1:
            shown = " and ".join(f"parent '{p}', child '{c}'" for p, c in sorted(ref.matched))
            raise SourceError(
                path,
                f"--reference-topic {ref.asked}: {TF_TOPIC} has two transforms that read so ({shown}); rename a frame",
            )
        ref.world, ref.child = parent, child
        if ref.rows.n >= max_rows:
            raise SourceError(path, f"{TF_TOPIC} holds more than {max_rows} transforms {ref.pair}; cut the bag first")
        q = tf.transform.rotation
        ref.rows.add(stamp_ns(tf.header.stamp), receive_ns, (q.x, q.y, q.z, q.w, np.nan, np.nan, np.nan))


def _build_reference(path, ref: _ReferenceSpec, stamps, frame, body, imu_frame, imu_topic, origin_ns, tel):
    """``/reference`` in NED and body FRD from the collected rows, and the words for the summary."""
    ns_both, values = ref.rows.arrays()
    if ref.kind == "tf" and not ref.matched:
        raise SourceError(
            path,
            f"--reference-topic {ref.asked}: {TF_TOPIC} has no transform with parent and child {ref.pair}; the "
            f"frames it holds (parent/child): {_listing(sorted(ref.pairs_seen))}",
        )
    if ref.child is not None and ref.child != body:
        whose = "--body-frame" if body != _frame(imu_frame) else f"the frame of {imu_topic}"
        raise SourceError(
            path,
            f"--reference-topic {ref.asked}: the reference describes frame '{ref.child}' in '{ref.world}', and the "
            f"body is '{body}' ({whose}): the attitude must describe the IMU's axes; give "
            f"--reference-topic tf:{ref.world}/{body} if the bag's {TF_TOPIC} has it, or --body-frame {ref.child} "
            "if the two frames have the same axes",
        )
    if ns_both.shape[0] < 2:
        raise SourceError(
            path, f"topic {ref.label} holds {ns_both.shape[0]} reference message(s); at least 2 are needed"
        )
    ns = ns_both[:, 0 if stamps == "header" else 1]
    _check_order(path, ref.label, ns, stamps, "transform" if ref.kind == "tf" else "message")
    keep = np.isfinite(values[:, :4]).all(axis=1)
    dropouts = int(np.count_nonzero(~keep))
    q_xyzw = values[keep, :4]
    ref_t = (ns[keep] - origin_ns) / NS_PER_S
    norm = np.linalg.norm(q_xyzw, axis=1)
    err = np.abs(norm - 1.0)
    if err.size and err.max() > QUATERNION_NORM_TOLERANCE:
        j = int(np.flatnonzero(keep)[int(np.argmax(err))])
        raise SourceError(
            path,
            f"topic {ref.label}: message {j} holds an orientation of norm {norm[int(np.argmax(err))]:.9g} "
            f"(x, y, z, w = {', '.join(f'{v:.6g}' for v in values[j, :4])}); a unit quaternion is needed",
        )
    if ref_t.size < 2 or ref_t[-1] < tel.time_s[0] or ref_t[0] > tel.time_s[-1]:
        raise SourceError(
            path,
            f"topic {ref.label}: the reference spans {ref_t[0] if ref_t.size else 0:.6g} .. "
            f"{ref_t[-1] if ref_t.size else 0:.6g} s and the IMU 0 .. {tel.time_s[-1]:.6g} s after the first "
            f"IMU stamp: they do not overlap ({stamps} stamps)",
        )
    quat_nb = quat_nb_from_ros(q_xyzw / norm[:, None], frame)
    reference = Reference(time_s=ref_t, quat_nb=quat_nb)
    world = WORLD_WORDS[frame]
    parts = [f"reference: {ref.asked} ({ref.kind}), world frame '{ref.world}' taken as {world} -> NED"]
    if ref.kind == "odometry":
        v_b = body_from_ros(values[keep, 4:], frame)
        reference.velocity_n_mps = np.einsum("kij,kj->ki", quat_to_mat(quat_nb), v_b)
        parts.append(f"velocity: the twist in the child frame '{ref.child}', turned into NED")
    if ref.child is None:
        parts.append(f"a pose names no body frame: taken as '{body}'")
    else:
        parts.append(f"body frame '{ref.child}'")
    if ref.kind != "tf":
        parts.append("positions (local metres) not used")
    if dropouts:
        parts.append(f"{dropouts} messages with NaN left out")
    angle_deg = reference_up_angle_deg(reference, tel.time_s, tel.accel_mps2, 0.0, "rates")
    if angle_deg is not None and angle_deg > REFERENCE_GRAVITY_ANGLE_MAX_DEG:
        raise SourceError(
            path,
            f"--reference-topic {ref.asked}: the reference attitude puts 'up' {angle_deg:.0f} deg (median) from the "
            f"specific force {imu_topic} reads; at rest they agree. Is world frame '{ref.world}' "
            f"{world} and body frame '{ref.child or body}' the IMU's axes (--frame {frame})?",
        )
    return reference, ", ".join(parts)
