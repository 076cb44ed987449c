"""Conversions from other axis conventions into sizefx's (body FRD, navigation NED).

Every matrix here is a proper rotation (determinant +1) named by the frames it
connects: ``MAT_NED_ENU @ v_enu = v_ned``. The same permutation
``[[0, 1, 0], [1, 0, 0], [0, 0, -1]]`` takes East-North-Up to North-East-Down
and Right-Forward-Up (PSINS's body axes) to Forward-Right-Down; the flip
``diag(1, -1, -1)`` takes Forward-Left-Up to Forward-Right-Down.
"""

from __future__ import annotations

import numpy as np

from . import earth
from .rotation import axis_angle_mat, mat_to_quat, quat_to_mat

__all__ = [
    "MAT_NED_ENU",
    "MAT_FRD_RFU",
    "MAT_FRD_FLU",
    "enu_to_ned",
    "mat_nb_from_enu_body",
    "psins_mat_enu_rfu",
    "geodetic_from_local_ned",
]

MAT_NED_ENU = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
MAT_FRD_RFU = MAT_NED_ENU.copy()  # the same permutation: right->y, forward->x, up->-z
MAT_FRD_FLU = np.diag([1.0, -1.0, -1.0])


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
