"""ROS bags written by ``rosbags``' own writers from a simulated record with known truth, for the ROS
bag importer's and exporter's tests (tests/test_import_rosbag.py, tests/test_export.py).

The record's truth is sizefx's (body FRD, NED, scalar-first ``q_nb``); the bag is written in ROS's
convention (REP 103: body forward-left-up, world east-north-up, quaternions x, y, z, w), converted
here with plain matrices and scipy's ``Rotation`` (scalar-last, as ROS writes them), not with
sizefx's :mod:`sizefx.frames`, so that the tests compare two independent conversions.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

#: Body FRD from FLU: the flip of y and z. World NED from ENU: swap x and y, negate z.
FRD_FLU = np.diag([1.0, -1.0, -1.0])
NED_ENU = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
#: The first IMU stamp of every bag [ns]: a Unix time with nanoseconds that a float64 of seconds
#: would round (1.7e9 s carries 0.2 us steps), so that the tests see whether they are kept.
START_NS = 1_700_000_000_123_456_789
#: The recorder receives each message this late [ns] (the receive time is the bag's own stamp).
LATENCY_NS = 2_000_000


def simulated(duration_s: float = 8.0, rate_hz: float = 100.0):
    """A tumble (every axis turns, gravity sweeps every body axis) at ``rate_hz``, ideal sensors:
    a :class:`~sizefx.io.telemetry.Telemetry` with its reference at the IMU rate (the truth)."""
    from sizefx import scenarios
    from sizefx.simulate import simulate_in_memory

    traj = scenarios.tumble(duration_s, amplitudes_deg=(60.0, 30.0, 40.0), freqs_hz=(0.3, 0.41, 0.53))
    return simulate_in_memory(traj, rate_hz=rate_hz, form="rates", seed=1)


def ros_quaternions(quat_nb, body: str = "flu") -> np.ndarray:
    """ROS ``x, y, z, w`` of the body (FLU or FRD axes) in the world (ENU or NED), from sizefx ``q_nb``."""
    from scipy.spatial.transform import Rotation

    q = np.asarray(quat_nb, dtype=float)
    mat_nb = Rotation.from_quat(q[:, [1, 2, 3, 0]]).as_matrix()  # scipy takes x, y, z, w
    if body == "flu":
        mat = NED_ENU.T @ mat_nb @ FRD_FLU  # ENU <- NED <- FRD <- FLU
    else:
        mat = mat_nb
    return Rotation.from_matrix(mat).as_quat()  # x, y, z, w


def flu(v_b) -> np.ndarray:
    return np.asarray(v_b, dtype=float) @ FRD_FLU.T


@dataclass
class Bag:
    """What to write: the IMU topic, optionally a reference, a fix, extra topics."""

    imu_topic: str = "/imu/data"
    imu_frame: str = "imu_link"
    reference: str | None = "odometry"  #: odometry | pose | posecov | tf | None
    reference_topic: str = "/odom"
    world_frame: str = "odom"
    child_frame: str = "imu_link"
    #: twist (FLU, child frame) of each reference row [m/s]; default: zero
    twist_flu: np.ndarray | None = None
    navsat: tuple | None = None  #: (lat_deg, lon_deg, alt_m) of a /fix topic, the first message without a fix
    extra_imu_topics: tuple = ()
    images: int = 0  #: sensor_msgs/Image messages on /camera/image_raw
    image_bytes: int = 1024
    body: str = "flu"
    #: a function of the IMU header stamps [ns] returning the stamps to write (stamps going back...)
    edit_stamps: object = None
    extra: dict = field(default_factory=dict)


def _time(ts, ns: int):
    return ts.types["builtin_interfaces/msg/Time"](sec=int(ns // 1_000_000_000), nanosec=int(ns % 1_000_000_000))


def _header(ts, ns: int, frame: str, seq: int):
    Header = ts.types["std_msgs/msg/Header"]
    if "seq" in dict(ts.fielddefs["std_msgs/msg/Header"][1]):  # ROS 1
        return Header(seq=seq, stamp=_time(ts, ns), frame_id=frame)
    return Header(stamp=_time(ts, ns), frame_id=frame)


def write_bag(path: Path, tel, spec: Bag | None = None, *, kind: str = "mcap") -> Path:
    """Write ``tel`` (and its reference) as a bag: ``kind`` ``ros1`` (``path`` a ``.bag``), or a ROS 2
    bag folder of ``mcap`` or ``sqlite3`` storage. Returns ``path``."""
    from rosbags.rosbag1 import Writer as Writer1
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Writer2
    from rosbags.typesys import Stores, get_typestore

    spec = spec or Bag()
    path = Path(path)
    ros1 = kind == "ros1"
    ts = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.LATEST)
    serialize = ts.serialize_ros1 if ros1 else ts.serialize_cdr
    T = ts.types
    V, Q = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Quaternion"]

    ns = START_NS + np.round(tel.time_s * 1e9).astype(np.int64)
    header_ns = ns if spec.edit_stamps is None else spec.edit_stamps(ns.copy())
    gyro, accel = (flu(tel.gyro_rad_s), flu(tel.accel_mps2)) if spec.body == "flu" else (tel.gyro_rad_s, tel.accel_mps2)
    queue = []  # (receive ns, topic, type, bytes), written in receive order

    def imu_msg(k, frame):
        return T["sensor_msgs/msg/Imu"](
            header=_header(ts, int(header_ns[k]), frame, k),
            orientation=Q(x=0.0, y=0.0, z=0.0, w=1.0),
            orientation_covariance=np.r_[-1.0, np.zeros(8)],
            angular_velocity=V(x=gyro[k, 0], y=gyro[k, 1], z=gyro[k, 2]),
            angular_velocity_covariance=np.zeros(9),
            linear_acceleration=V(x=accel[k, 0], y=accel[k, 1], z=accel[k, 2]),
            linear_acceleration_covariance=np.zeros(9),
        )

    for topic in (spec.imu_topic, *spec.extra_imu_topics):
        for k in range(tel.n_samples):
            queue.append(
                (
                    int(ns[k]) + LATENCY_NS,
                    topic,
                    "sensor_msgs/msg/Imu",
                    serialize(imu_msg(k, spec.imu_frame), "sensor_msgs/msg/Imu"),
                )
            )
    ref = tel.reference
    if spec.reference is not None and ref is not None:
        q = ros_quaternions(ref.quat_nb, spec.body)
        ref_ns = START_NS + np.round(ref.time_s * 1e9).astype(np.int64)
        twist = np.zeros((ref.time_s.size, 3)) if spec.twist_flu is None else spec.twist_flu
        Pose = T["geometry_msgs/msg/Pose"]
        for k in range(ref.time_s.size):
            orientation = Q(x=q[k, 0], y=q[k, 1], z=q[k, 2], w=q[k, 3])
            pose = Pose(position=T["geometry_msgs/msg/Point"](x=1.0, y=2.0, z=3.0), orientation=orientation)
            header = _header(ts, int(ref_ns[k]), spec.world_frame, k)
            if spec.reference == "odometry":
                msgtype = "nav_msgs/msg/Odometry"
                twist_msg = T["geometry_msgs/msg/Twist"](
                    linear=V(x=twist[k, 0], y=twist[k, 1], z=twist[k, 2]), angular=V(x=0.0, y=0.0, z=0.0)
                )
                msg = T[msgtype](
                    header=header,
                    child_frame_id=spec.child_frame,
                    pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.zeros(36)),
                    twist=T["geometry_msgs/msg/TwistWithCovariance"](twist=twist_msg, covariance=np.zeros(36)),
                )
                topic = spec.reference_topic
            elif spec.reference == "pose":
                msgtype = "geometry_msgs/msg/PoseStamped"
                msg = T[msgtype](header=header, pose=pose)
                topic = spec.reference_topic
            elif spec.reference == "posecov":
                msgtype = "geometry_msgs/msg/PoseWithCovarianceStamped"
                with_covariance = T["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.zeros(36))
                msg = T[msgtype](header=header, pose=with_covariance)
                topic = spec.reference_topic
            else:
                msgtype = "tf2_msgs/msg/TFMessage"
                transform = T["geometry_msgs/msg/Transform"](translation=V(x=1.0, y=2.0, z=3.0), rotation=orientation)
                other = T["geometry_msgs/msg/TransformStamped"](
                    header=_header(ts, int(ref_ns[k]), "map", 0),
                    child_frame_id=spec.world_frame,
                    transform=T["geometry_msgs/msg/Transform"](
                        translation=V(x=0.0, y=0.0, z=0.0), rotation=Q(x=0.0, y=0.0, z=0.0, w=1.0)
                    ),
                )
                mine = T["geometry_msgs/msg/TransformStamped"](
                    header=header, child_frame_id=spec.child_frame, transform=transform
                )
                msg = T[msgtype](transforms=[other, mine])
                topic = "/tf"
            queue.append((int(ref_ns[k]) + LATENCY_NS, topic, msgtype, serialize(msg, msgtype)))
    if spec.navsat is not None:
        lat, lon, alt = spec.navsat
        Fix, Status = T["sensor_msgs/msg/NavSatFix"], T["sensor_msgs/msg/NavSatStatus"]
        for k, status in enumerate((-1, 0, 0)):
            msg = Fix(
                header=_header(ts, START_NS + k * 1_000_000_000, "gps", k),
                status=Status(status=status, service=1),
                latitude=lat + k if status >= 0 else 0.0,
                longitude=lon if status >= 0 else 0.0,
                altitude=alt,
                position_covariance=np.zeros(9),
                position_covariance_type=0,
            )
            queue.append(
                (
                    START_NS + k * 1_000_000_000,
                    "/fix",
                    "sensor_msgs/msg/NavSatFix",
                    serialize(msg, "sensor_msgs/msg/NavSatFix"),
                )
            )
    if spec.images:
        Image = T["sensor_msgs/msg/Image"]
        pixels = np.zeros(spec.image_bytes, dtype=np.uint8)
        step = max(1, tel.n_samples // spec.images)
        for k in range(spec.images):
            msg = Image(
                header=_header(ts, int(ns[min(k * step, tel.n_samples - 1)]), "camera", k),
                height=1,
                width=spec.image_bytes,
                encoding="mono8",
                is_bigendian=0,
                step=spec.image_bytes,
                data=pixels,
            )
            queue.append(
                (
                    int(ns[min(k * step, tel.n_samples - 1)]) + LATENCY_NS + 1,
                    "/camera/image_raw",
                    "sensor_msgs/msg/Image",
                    serialize(msg, "sensor_msgs/msg/Image"),
                )
            )
    queue.sort(key=lambda item: item[0])
    if ros1:
        writer = Writer1(path)
    else:
        plugin = StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3
        writer = Writer2(path, version=9, storage_plugin=plugin)
    with writer as w:
        connections = {}
        for receive, topic, msgtype, raw in queue:
            if topic not in connections:
                connections[topic] = w.add_connection(topic, msgtype, typestore=ts)
            w.write(connections[topic], receive, raw)
    return path
