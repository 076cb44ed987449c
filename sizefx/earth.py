"""WGS-84 Earth model: radii of curvature, normal gravity, Earth and transport rates.

All functions are vectorised over NumPy arrays (latitude ``lat_rad``, height
``h_m``, NED velocity ``v_n`` of shape ``[..., 3]``). The simulator and the
navigator share these functions, so simulated telemetry and its navigation
use the same Earth.

References
----------
P. D. Groves, *Principles of GNSS, Inertial, and Multisensor Integrated
Navigation Systems*, 2nd ed., 2013, sections 2.4 and 2.5.
"""

from __future__ import annotations

import numpy as np

from .constants import (
    GAMMA_EQUATOR_MPS2,
    OMEGA_EARTH_RAD_S,
    SOMIGLIANA_K,
    WGS84_A_M,
    WGS84_B_M,
    WGS84_E2,
    WGS84_F,
    WGS84_GM_M3_S2,
)

__all__ = [
    "radii_m",
    "radii_derivative_m_per_rad",
    "gravity_n",
    "omega_ie_n",
    "omega_en_n",
    "omegadot_in_n",
]


def radii_m(lat_rad):
    """Meridian and transverse radii of curvature (Groves eqs. 2.105, 2.106).

    Returns
    -------
    r_meridian_m, r_transverse_m : ndarray
        North-south (R_N in Groves) and east-west (R_E) radii [m].
    """
    s2 = np.sin(lat_rad) ** 2
    w = 1.0 - WGS84_E2 * s2
    r_transverse = WGS84_A_M / np.sqrt(w)
    r_meridian = WGS84_A_M * (1.0 - WGS84_E2) / w**1.5
    return r_meridian, r_transverse


def radii_derivative_m_per_rad(lat_rad):
    """Derivatives of :func:`radii_m` with respect to latitude [m/rad]."""
    s = np.sin(lat_rad)
    c = np.cos(lat_rad)
    w = 1.0 - WGS84_E2 * s * s
    d_transverse = WGS84_A_M * WGS84_E2 * s * c / w**1.5
    d_meridian = 3.0 * WGS84_A_M * (1.0 - WGS84_E2) * WGS84_E2 * s * c / w**2.5
    return d_meridian, d_transverse


def gravity_n(lat_rad, h_m):
    """Normal gravity (gravitation plus centrifugal) in NED [m/s^2], shape ``[..., 3]``.

    Somigliana's formula on the ellipsoid (Groves eq. 2.134) with the
    second-order free-air height correction and the small north component
    (Groves eq. 2.139); accurate to about 1e-6 m/s^2 below 10 km.
    """
    lat_rad = np.asarray(lat_rad, dtype=float)
    h_m = np.asarray(h_m, dtype=float)
    s2 = np.sin(lat_rad) ** 2
    gamma0 = GAMMA_EQUATOR_MPS2 * (1.0 + SOMIGLIANA_K * s2) / np.sqrt(1.0 - WGS84_E2 * s2)
    m = OMEGA_EARTH_RAD_S**2 * WGS84_A_M**2 * WGS84_B_M / WGS84_GM_M3_S2
    g_down = gamma0 * (
        1.0 - 2.0 / WGS84_A_M * (1.0 + WGS84_F + m - 2.0 * WGS84_F * s2) * h_m + 3.0 / WGS84_A_M**2 * h_m**2
    )
    g_north = -8.08e-9 * h_m * np.sin(2.0 * lat_rad)
    out = np.zeros(np.broadcast(lat_rad, h_m).shape + (3,))
    out[..., 0] = g_north
    out[..., 2] = g_down
    return out


def omega_ie_n(lat_rad):
    """Earth rate in NED [rad/s], shape ``[..., 3]`` (Groves eq. 2.123)."""
    lat_rad = np.asarray(lat_rad, dtype=float)
    out = np.zeros(lat_rad.shape + (3,))
    out[..., 0] = OMEGA_EARTH_RAD_S * np.cos(lat_rad)
    out[..., 2] = -OMEGA_EARTH_RAD_S * np.sin(lat_rad)
    return out


def omega_en_n(lat_rad, h_m, v_n):
    """Transport rate of the NED frame over the Earth [rad/s] (Groves eq. 5.44)."""
    r_meridian, r_transverse = radii_m(lat_rad)
    v_n = np.asarray(v_n, dtype=float)
    out = np.empty(v_n.shape)
    out[..., 0] = v_n[..., 1] / (r_transverse + h_m)
    out[..., 1] = -v_n[..., 0] / (r_meridian + h_m)
    out[..., 2] = -v_n[..., 1] * np.tan(lat_rad) / (r_transverse + h_m)
    return out


def omegadot_in_n(lat_rad, h_m, v_n, vdot_n):
    """Time derivative of ``omega_ie_n + omega_en_n`` [rad/s^2] for a moving point.

    Analytic differentiation of Groves eqs. 2.123 and 5.44 with
    ``lat' = v_N / (R_M + h)``, ``h' = -v_D`` and the latitude derivatives of
    the radii; needed for the tangential term of the size effect on a vehicle
    (it is zero at rest).
    """
    v_n = np.asarray(v_n, dtype=float)
    vdot_n = np.asarray(vdot_n, dtype=float)
    r_mer, r_tr = radii_m(lat_rad)
    d_mer, d_tr = radii_derivative_m_per_rad(lat_rad)
    lat_dot = v_n[..., 0] / (r_mer + h_m)
    h_dot = -v_n[..., 2]
    out = np.empty(v_n.shape)
    e1 = v_n[..., 1] / (r_tr + h_m)
    d1 = vdot_n[..., 1] / (r_tr + h_m) - v_n[..., 1] * (d_tr * lat_dot + h_dot) / (r_tr + h_m) ** 2
    d2 = -vdot_n[..., 0] / (r_mer + h_m) + v_n[..., 0] * (d_mer * lat_dot + h_dot) / (r_mer + h_m) ** 2
    tan_lat = np.tan(lat_rad)
    out[..., 0] = -OMEGA_EARTH_RAD_S * np.sin(lat_rad) * lat_dot + d1
    out[..., 1] = d2
    out[..., 2] = -OMEGA_EARTH_RAD_S * np.cos(lat_rad) * lat_dot - d1 * tan_lat - e1 * lat_dot / np.cos(lat_rad) ** 2
    return out
