"""What the ROS bag importer and exporter share: the message types, time stamps, and the optional
``rosbags`` library.

``rosbags`` (Ternaris, pure Python) reads ROS 1 ``.bag`` files, ROS 2 bags (a folder with
``metadata.yaml``, or one ``.mcap`` or ``.db3`` storage file) and writes both, without a ROS
installation. It is an optional dependency (``pip install 'sizefx[ros]'``): :func:`require_rosbags`
turns its absence into one line that says so. The frame conventions (REP 103) are
:data:`sizefx.frames.ROS_AXES`.
"""

from __future__ import annotations

from pathlib import Path

from .errors import SourceError

__all__ = [
    "IMU",
    "POSE",
    "POSE_COVARIANCE",
    "ODOMETRY",
    "TF_TYPES",
    "NAVSAT",
    "INSTALL",
    "NS_PER_S",
    "require_rosbags",
    "stamp_ns",
    "stamp_text",
    "storage_of",
    "ROS2_STORAGE_SUFFIXES",
    "bag_files",
]

#: Message types as ``rosbags`` names them (ROS 1 names are normalised to the ROS 2 form).
IMU = "sensor_msgs/msg/Imu"
POSE = "geometry_msgs/msg/PoseStamped"
POSE_COVARIANCE = "geometry_msgs/msg/PoseWithCovarianceStamped"
ODOMETRY = "nav_msgs/msg/Odometry"
#: tf2's message, and the one of ROS 1's older ``tf`` package (the same fields)
TF_TYPES = ("tf2_msgs/msg/TFMessage", "tf/msg/tfMessage")
NAVSAT = "sensor_msgs/msg/NavSatFix"

#: How to install the optional library, as every message about it says.
INSTALL = "pip install 'sizefx[ros]'"
NS_PER_S = 1_000_000_000
#: Suffixes of the storage files in a ROS 2 bag folder (``.zstd``: a file-compressed one).
ROS2_STORAGE_SUFFIXES = (".mcap", ".db3", ".zstd")


def require_rosbags(what: str):
    """Import ``rosbags``; without it, an ``ImportError`` whose text is the one line for ``what``
    (the caller wraps it in its own error class, naming its file)."""
    try:
        import rosbags.highlevel
        import rosbags.rosbag2
        import rosbags.typesys
    except ImportError:
        raise ImportError(f"{what} needs the rosbags package: {INSTALL}") from None
    return rosbags


def stamp_ns(stamp) -> int:
    """A ``builtin_interfaces/Time`` (ROS 1 ``time`` alike) as integer nanoseconds since its epoch."""
    return int(stamp.sec) * NS_PER_S + int(stamp.nanosec)


def stamp_text(ns: int) -> str:
    """Nanoseconds as seconds with all nine decimals (``1700000000.005000000 s``): a stamp printed
    as a float would hide the nanoseconds that make two stamps differ."""
    sign = "-" if ns < 0 else ""
    ns = abs(int(ns))
    return f"{sign}{ns // NS_PER_S}.{ns % NS_PER_S:09d} s"


def storage_of(path: Path) -> str:
    """What kind of bag ``path`` is, in words, from its name (a folder is a ROS 2 bag)."""
    path = Path(path)
    if path.is_dir():
        return "ROS 2 bag folder"
    return {".bag": "ROS 1 bag", ".mcap": "ROS 2 bag (MCAP)", ".db3": "ROS 2 bag (sqlite3)"}.get(path.suffix, "ROS bag")


def bag_files(path) -> list[Path]:
    """The files a bag is: a ROS 1 ``.bag`` or a ROS 2 storage file itself; a ROS 2 bag folder's
    ``metadata.yaml`` and its storage files (:data:`ROS2_STORAGE_SUFFIXES`), in name order.
    A folder without ``metadata.yaml`` is not a bag: a :class:`~sizefx.errors.SourceError` says so."""
    path = Path(path)
    if not path.is_dir():
        return [path]
    meta = path / "metadata.yaml"
    if not meta.is_file():
        raise SourceError(
            path,
            "is a folder without metadata.yaml, so not a ROS 2 bag; give the folder ros2 bag record "
            "wrote, a .mcap or .db3 file, or a ROS 1 .bag",
        )
    return [meta, *sorted(f for f in path.iterdir() if f.suffix in ROS2_STORAGE_SUFFIXES and f.is_file())]
