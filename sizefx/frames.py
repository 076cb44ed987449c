"""Conversions from other axis conventions into sizefx's (body FRD, navigation NED).

Every matrix here is a proper rotation (determinant +1) named by the frames it
connects: ``MAT_NED_ENU @ v_enu = v_ned``. The same permutation
``[[0, 1, 0], [1, 0, 0], [0, 0, -1]]`` takes East-North-Up to North-East-Down
and Right-Forward-Up (PSINS's body axes) to Forward-Right-Down; the flip
``diag(1, -1, -1)`` takes Forward-Left-Up to Forward-Right-Down.

A turntable's gimbals (:func:`table_attitude`): the attitude its encoder angles give, through the
level table frame (x its zero direction, y to the right, z down) and up to three axes, outer to
inner, each turning about an axis of that frame in its parent gimbal; the convention is stated
with its formula in :mod:`sizefx.importers.table_log` and ``docs/import.md``.

ROS (REP 103) writes bodies forward-left-up and worlds east-north-up, and frames named
``*_ned`` forward-right-down and north-east-down; its quaternions are scalar-last
``(x, y, z, w)`` and rotate the child (body) frame's vectors into the parent (world) frame.
:data:`ROS_AXES` holds both conventions, and :func:`quat_nb_from_ros` and
:func:`ros_quat_from_nb` turn one attitude into the other.
"""

from __future__ import annotations

import numpy as np

from . import earth
from .motion import RotationChain
from .rotation import axis_angle_mat, mat_to_quat, quat_to_mat

__all__ = [
    "MAT_NED_ENU",
    "MAT_FRD_RFU",
    "MAT_FRD_FLU",
    "ROS_AXES",
    "enu_to_ned",
    "body_from_ros",
    "ros_from_body",
    "quat_nb_from_ros",
    "ros_quat_from_nb",
    "mat_nb_from_enu_body",
    "psins_mat_enu_rfu",
    "geodetic_from_local_ned",
    "TABLE_AXES",
    "gimbal_axes",
    "table_attitude",
]

MAT_NED_ENU = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
MAT_FRD_RFU = MAT_NED_ENU.copy()  # the same permutation: right->y, forward->x, up->-z
MAT_FRD_FLU = np.diag([1.0, -1.0, -1.0])

#: The axes of a ROS message, by convention name: ``(mat_b_src, mat_n_src)``, sizefx body FRD
#: from the message's body axes and NED from its world axes. ``flu``: REP 103's default, body
#: forward-left-up and world east-north-up; ``frd``: REP 103's ``*_ned`` frames, body
#: forward-right-down and world north-east-down (sizefx's own).
ROS_AXES = {"flu": (MAT_FRD_FLU, MAT_NED_ENU), "frd": (np.eye(3), np.eye(3))}
#: The axes of a turntable's level frame, by name: x its zero direction, y to the right, z down.
TABLE_AXES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}


def enu_to_ned(v_enu):
    """East-North-Up vectors ``[..., 3]`` to North-East-Down."""
    return np.asarray(v_enu, dtype=float) @ MAT_NED_ENU.T


def mat_nb_from_enu_body(mat_enu_src, mat_src_b):
    """``mat_nb`` (body to NED) from an attitude ``mat_enu_src`` (source body to ENU).

    ``mat_src_b`` maps sizefx body (FRD) vectors into the source's body axes,
    e.g. ``MAT_FRD_RFU.T`` for PSINS or ``MAT_FRD_FLU.T`` for an FLU sensor:
    ``mat_nb = MAT_NED_ENU @ mat_enu_src @ mat_src_b``.
    """
    return MAT_NED_ENU @ np.asarray(mat_enu_src) @ mat_src_b


def quat_nb_from_enu_body(quat_enu_src, mat_src_b):
    """Scalar-first ``q_nb`` from scalar-first ``q_enu_src`` (see :func:`mat_nb_from_enu_body`)."""
    return mat_to_quat(mat_nb_from_enu_body(quat_to_mat(quat_enu_src), mat_src_b))


def psins_mat_enu_rfu(pitch_rad, roll_rad, yaw_rad):
    """PSINS attitude: ``C_nb = Rz(yaw) Rx(pitch) Ry(roll)``, n = ENU, b = RFU (yaw counter-clockwise)."""
    return (
        axis_angle_mat([0.0, 0.0, 1.0], yaw_rad)
        @ axis_angle_mat([1.0, 0.0, 0.0], pitch_rad)
        @ axis_angle_mat([0.0, 1.0, 0.0], roll_rad)
    )


def geodetic_from_local_ned(ned_m, lat0_rad, lon0_rad, h0_m):
    """Latitude, longitude [rad], height [m] of points ``ned_m [..., 3]`` metres from a site.

    First order in distance / Earth radius: exact to about 1e-7 m for the
    metre-scale offsets of a motion-capture lab.
    """
    ned = np.asarray(ned_m, dtype=float)
    r_mer, r_tr = earth.radii_m(lat0_rad)
    lat = lat0_rad + ned[..., 0] / (r_mer + h0_m)
    lon = lon0_rad + ned[..., 1] / ((r_tr + h0_m) * np.cos(lat0_rad))
    return lat, lon, h0_m - ned[..., 2]


def _ros_axes(convention: str):
    if convention not in ROS_AXES:
        raise ValueError(f"ROS axes '{convention}': use one of {', '.join(ROS_AXES)}")
    return ROS_AXES[convention]


def body_from_ros(v_src, convention: str):
    """Body FRD vectors ``[..., 3]`` from a ROS message's body-axis vectors (``convention`` of :data:`ROS_AXES`):
    ``v_b = mat_b_src @ v_src``, for ``flu`` ``(x, -y, -z)``."""
    mat_b_src, _ = _ros_axes(convention)
    return np.asarray(v_src, dtype=float) @ mat_b_src.T


def ros_from_body(v_b, convention: str):
    """The inverse of :func:`body_from_ros`: ``v_src = mat_b_src.T @ v_b``."""
    mat_b_src, _ = _ros_axes(convention)
    return np.asarray(v_b, dtype=float) @ mat_b_src


def quat_nb_from_ros(quat_xyzw, convention: str):
    """Scalar-first ``q_nb`` ``[..., 4]`` from ROS attitudes ``[..., 4]`` (scalar-last ``x, y, z, w``)
    rotating the message's body axes into its world axes.

    ``mat_nb = mat_n_src @ mat_world_body @ mat_b_src.T``: body FRD vectors are turned into the
    message's body axes, rotated into its world axes, then into NED.
    """
    mat_b_src, mat_n_src = _ros_axes(convention)
    q = np.asarray(quat_xyzw, dtype=float)
    q_wxyz = q[..., [3, 0, 1, 2]]
    return mat_to_quat(mat_n_src @ quat_to_mat(q_wxyz) @ mat_b_src.T)


def ros_quat_from_nb(quat_nb, convention: str):
    """The inverse of :func:`quat_nb_from_ros`: ROS ``x, y, z, w`` ``[..., 4]`` from scalar-first ``q_nb``."""
    mat_b_src, mat_n_src = _ros_axes(convention)
    q_wxyz = mat_to_quat(mat_n_src.T @ quat_to_mat(np.asarray(quat_nb, dtype=float)) @ mat_b_src)
    return q_wxyz[..., [1, 2, 3, 0]]


def gimbal_axes(spec) -> list[tuple[str, float]]:
    """``("z", "-x", "y")`` -> ``[("z", 1.0), ("x", -1.0), ("y", 1.0)]``, outer to inner; a
    ValueError saying what is wrong (one to three axes of x, y, z, no two neighbours alike)."""
    items = [str(a).strip().lower() for a in spec]
    if not 1 <= len(items) <= 3:
        raise ValueError(f"names {len(items)} axes; a table has one to three, outer to inner (e.g. z or z,x,y)")
    out = []
    for item in items:
        axis = item.lstrip("+-")
        if axis not in TABLE_AXES or len(item) - len(axis) > 1:
            raise ValueError(f"'{item}' is not an axis (x, y or z of the table, with an optional minus)")
        out.append((axis, -1.0 if item.startswith("-") else 1.0))
    for k in range(1, len(out)):
        if out[k][0] == out[k - 1][0]:
            raise ValueError(f"axes {k} and {k + 1} both turn about {out[k][0]}: one angle, not two encoders")
    return out


class _Logged:
    """An axis angle [rad] and rate [rad/s] at the log's rows, as a profile
    :class:`~sizefx.motion.RotationChain` evaluates (exact at those rows; the chain asks for no other)."""

    def __init__(self, t, theta, rate):
        self.t, self.theta, self.rate = t, theta, rate

    def evaluate(self, t):
        return np.interp(t, self.t, self.theta), np.interp(t, self.t, self.rate), np.zeros(np.shape(t))


def table_attitude(axes, theta_rad, rate_rad_s, time_s, *, heading_rad: float = 0.0, mat_pb=None):
    """``mat_nb [M, 3, 3]`` and the body rate ``omega_nb_b [M, 3]`` [rad/s] of a turntable's log::

        mat_nb = Rz(heading) @ R(a_1, s_1 theta_1) @ ... @ R(a_K, s_K theta_K) @ mat_pb

    ``axes``: :func:`gimbal_axes`' list (outer to inner) of the table axes a_k (:data:`TABLE_AXES`)
    and signs s_k; ``theta_rad``, ``rate_rad_s``: ``[M, K]`` encoder angles and rates at ``time_s
    [M]``; ``heading_rad``: the heading of the table's zero direction; ``mat_pb``: the IMU's mount
    on the inner platform (body to platform; identity by default). With every angle zero each
    gimbal frame is the table frame; axis k turns its gimbal about a_k in its parent's frame, so
    ``omega_nb_b`` is the sum of the axes' rates, each carried into the body by the gimbals inside
    it (:class:`sizefx.motion.RotationChain`, the simulator's chain). :mod:`sizefx.importers.table_log`
    states the convention for the user.
    """
    mat_pb = np.eye(3) if mat_pb is None else np.asarray(mat_pb, dtype=float)
    chain = RotationChain(
        [sign * np.asarray(TABLE_AXES[axis]) for axis, sign in axes],
        [_Logged(time_s, theta_rad[:, k], rate_rad_s[:, k]) for k in range(len(axes))],
        mat_0=axis_angle_mat(TABLE_AXES["z"], heading_rad),
    )
    mat_np, omega_np_p, _ = chain.evaluate(time_s)
    return mat_np @ mat_pb, omega_np_p @ mat_pb  # omega_b = mat_pb^T omega_p, as rows
