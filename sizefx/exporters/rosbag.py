"""ROS 2 bag of ``sensor_msgs/Imu``, written by ``rosbags`` (MCAP or sqlite3 storage).

Axes
    The source bag's convention when the record came from one (``/source`` ``axes``: REP 103
    forward-left-up unless it was read from ``*_ned`` frames), else forward-left-up, REP 103's
    default, or ``axes`` given: body FRD turned by :func:`sizefx.frames.ros_from_body`.
Stamps
    ``header.stamp`` (and the bag's receive time) is the record's time after the source's first
    stamp (``/source`` ``stamp_origin_ns``), so an imported bag goes back with the stamps it came
    with, to the nanosecond; a record from elsewhere starts at its own time.
Topic and frame
    The source's IMU topic and ``frame_id``, else ``/imu/data`` and ``imu_link``.
Covariances
    ``orientation_covariance[0] = -1``: the message carries no orientation (REP 145); the rate and
    acceleration covariances are zeros, "unknown" in the message's definition.

The bag is a folder (``metadata.yaml`` and one storage file), written to a temporary folder and
renamed into place (:func:`sizefx.io.files.atomic_folder_output`); ``--force`` replaces only a
folder that is a ROS 2 bag. rosbags is an optional dependency (``pip install 'sizefx[ros]'``).
"""

from __future__ import annotations

import shlex
from pathlib import Path

import numpy as np

from ..constants import ROS_STORAGES
from ..errors import ConfigError, OutputError
from ..frames import ROS_AXES, ros_from_body
from ..io.files import atomic_folder_output, check_output_folder_replace
from ..ros import IMU, NS_PER_S, require_rosbags, stamp_text
from . import ExportDetails, refuse_separate_accel_stamps

__all__ = ["write", "check_output", "is_bag_folder", "STORAGES", "OUTPUT_IS_FOLDER"]

#: The output is a folder (the export stage checks it with :func:`check_output`, not as a file).
OUTPUT_IS_FOLDER = True
#: Storage plugins of a ROS 2 bag: MCAP (the default since ROS 2 Iron) or sqlite3.
STORAGES = ROS_STORAGES
DEFAULT_TOPIC = "/imu/data"
DEFAULT_FRAME_ID = "imu_link"
#: Bytes a message takes in the bag, about (an Imu is 300 bytes in CDR, plus the storage's index).
BYTES_PER_MESSAGE = 400
#: ``builtin_interfaces/Time.sec`` is an int32: the stamps a ROS 2 message can hold [ns].
STAMP_RANGE_NS = (-(2**31) * NS_PER_S, (2**31 - 1) * NS_PER_S)
AXES_WORDS = {
    "flu": "body forward-left-up (REP 103): (x, -y, -z) of FRD",
    "frd": "body forward-right-down (REP 103's *_ned frames): FRD as it is",
}


def is_bag_folder(folder) -> bool:
    """Whether ``folder`` is a ROS 2 bag (it holds ``metadata.yaml``): what ``--force`` may replace."""
    return (Path(folder) / "metadata.yaml").is_file()


#: Names that readers take for a storage file, not a folder (a folder ``run.bag`` reads as ROS 1).
FILE_SUFFIXES = (".bag", ".mcap", ".db3")


def check_output(output, *, inputs=(), force: bool = False) -> None:
    """The pre-flight of the bag folder (:func:`sizefx.io.files.check_output_folder_replace`); its
    name may not end like a storage file's (:data:`FILE_SUFFIXES`)."""
    output = Path(output)
    if output.suffix in FILE_SUFFIXES:
        raise OutputError(
            f"{output}: a ROS 2 bag is a folder, and a name ending in {output.suffix} reads as a file; "
            f"give it a name without one (-o {output.with_suffix('')})"
        )
    check_output_folder_replace(output, inputs=inputs, force=force, replaceable=is_bag_folder, what="ROS 2 bag")


def write(
    tel,
    output: Path,
    *,
    force: bool = False,
    inputs=(),
    storage: str = "mcap",
    topic: str | None = None,
    frame_id: str | None = None,
    axes: str | None = None,
) -> ExportDetails:
    """Write the IMU of ``tel`` (rates) as ``sensor_msgs/Imu`` into the ROS 2 bag folder ``output``."""
    output = Path(output)
    check_output(output, inputs=inputs, force=force)
    if storage not in STORAGES:
        raise ConfigError(f"export rosbag: --storage {storage}: use one of {', '.join(STORAGES)}")
    if axes is not None and axes not in ROS_AXES:
        raise ConfigError(f"export rosbag: --frame {axes}: use one of {', '.join(ROS_AXES)}")
    if topic is not None and (not topic.strip() or any(c.isspace() for c in topic)):
        raise ConfigError(f"export rosbag: --imu-topic '{topic}' is not a topic name (e.g. /imu/data)")
    try:
        require_rosbags(f"writing the ROS 2 bag {output.name}")
    except ImportError as exc:
        raise OutputError(f"{output}: {exc}") from None
    if tel.form != "rates":
        raise ConfigError(
            f"{tel.path}: holds increments (/imu/dtheta, /imu/dvel) and sensor_msgs/Imu carries rates; "
            "export csv keeps the increments"
        )
    refuse_separate_accel_stamps(tel, "a sensor_msgs/Imu message")
    from_bag = tel.source is not None and tel.source.format == "rosbag"
    src = tel.source.extra if tel.source is not None else {}  # the bag importer's own fields
    axes = axes or (str(src.get("axes")) if from_bag and src.get("axes") in ROS_AXES else "flu")
    topic = topic or (str(src["imu_topic"]) if from_bag and src.get("imu_topic") else DEFAULT_TOPIC)
    if frame_id is None:
        frame_id = str(src["imu_frame_id"]) if from_bag and "imu_frame_id" in src else DEFAULT_FRAME_ID
    origin_ns = int(src.get("stamp_origin_ns", 0)) if from_bag else 0
    stamps_ns = origin_ns + np.round(tel.time_s * NS_PER_S).astype(np.int64)
    lo, hi = STAMP_RANGE_NS
    if stamps_ns[0] < lo or stamps_ns[-1] > hi:
        raise ConfigError(
            f"{tel.path}: its stamps run {stamp_text(int(stamps_ns[0]))} .. {stamp_text(int(stamps_ns[-1]))}, "
            "beyond the int32 seconds of a ROS 2 stamp"
        )
    gyro = ros_from_body(tel.gyro_rad_s, axes)
    accel = ros_from_body(tel.accel_mps2, axes)
    _write_bag(output, topic, frame_id, storage, stamps_ns, gyro, accel, force=force, inputs=inputs)
    stamps_from = (
        f"the source bag's {src.get('stamps', 'header')} stamps"
        if from_bag
        else "the record's own time (no ROS origin)"
    )
    lines = [
        f"topic {topic} (sensor_msgs/Imu), frame_id '{frame_id}', ROS 2 bag, {storage} storage",
        f"axes: {AXES_WORDS[axes]}" + (", the source bag's" if from_bag else ""),
        f"header.stamp: {stamp_text(origin_ns)} + the record's time, {stamps_from}",
        "no orientation (orientation_covariance[0] = -1, REP 145); rate and acceleration covariances unknown (zeros)",
    ]
    args = ["sizefx", "import", "rosbag", str(output), "-o", str(output.with_name(output.name + ".h5"))]
    if axes != "flu":
        args += ["--frame", axes]
    if tel.site is not None:
        site = (np.degrees(tel.site.lat_rad), np.degrees(tel.site.lon_rad), tel.site.height_m)
        args += ["--site-deg", ",".join(f"{float(v):.12g}" for v in site)]  # 1e-10 deg: 0.01 mm
    return ExportDetails(lines=lines, reimport=shlex.join(args))


def _write_bag(output: Path, topic, frame_id, storage, stamps_ns, gyro, accel, *, force, inputs) -> None:
    from rosbags.rosbag2 import StoragePlugin, Writer, WriterError
    from rosbags.typesys import Stores, get_typestore

    typestore = get_typestore(Stores.LATEST)
    types = typestore.types
    Imu, Header, Time = types[IMU], types["std_msgs/msg/Header"], types["builtin_interfaces/msg/Time"]
    Quaternion, Vector3 = types["geometry_msgs/msg/Quaternion"], types["geometry_msgs/msg/Vector3"]
    no_orientation = Quaternion(x=0.0, y=0.0, z=0.0, w=0.0)
    orientation_covariance = np.zeros(9)
    orientation_covariance[0] = -1.0  # REP 145: no orientation estimate
    unknown = np.zeros(9)
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    n = stamps_ns.shape[0]
    with atomic_folder_output(
        output,
        inputs=inputs,
        force=force,
        replaceable=is_bag_folder,
        what="ROS 2 bag",
        expected_bytes=n * BYTES_PER_MESSAGE,
    ) as tmp:
        try:
            with Writer(tmp, version=Writer.VERSION_LATEST, storage_plugin=plugin) as writer:
                connection = writer.add_connection(topic, IMU, typestore=typestore)
                for k in range(n):
                    ns = int(stamps_ns[k])
                    sec, nanosec = divmod(ns, NS_PER_S)
                    msg = Imu(
                        header=Header(stamp=Time(sec=sec, nanosec=nanosec), frame_id=frame_id),
                        orientation=no_orientation,
                        orientation_covariance=orientation_covariance,
                        angular_velocity=Vector3(x=float(gyro[k, 0]), y=float(gyro[k, 1]), z=float(gyro[k, 2])),
                        angular_velocity_covariance=unknown,
                        linear_acceleration=Vector3(x=float(accel[k, 0]), y=float(accel[k, 1]), z=float(accel[k, 2])),
                        linear_acceleration_covariance=unknown,
                    )
                    writer.write(connection, ns, typestore.serialize_cdr(msg, IMU))
        except WriterError as exc:
            raise OutputError(f"{output}: the bag cannot be written ({' '.join(str(exc).split())})") from None
