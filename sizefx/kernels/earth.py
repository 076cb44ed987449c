"""Scalar WGS-84 functions for kernels (same formulas as :mod:`sizefx.earth`, which the tests compare)."""

from __future__ import annotations

import math

from ..constants import (
    GAMMA_EQUATOR_MPS2,
    OMEGA_EARTH_RAD_S,
    SOMIGLIANA_K,
    WGS84_A_M,
    WGS84_B_M,
    WGS84_E2,
    WGS84_F,
    WGS84_GM_M3_S2,
)
from .jit import kernel

_M = OMEGA_EARTH_RAD_S**2 * WGS84_A_M**2 * WGS84_B_M / WGS84_GM_M3_S2


@kernel
def radii_m(lat_rad):
    """(meridian, transverse) radii of curvature [m] (Groves eqs. 2.105-2.106)."""
    s = math.sin(lat_rad)
    w = 1.0 - WGS84_E2 * s * s
    return WGS84_A_M * (1.0 - WGS84_E2) / (w * math.sqrt(w)), WGS84_A_M / math.sqrt(w)


@kernel
def gravity_ned(lat_rad, h_m):
    """(north, down) components of normal gravity [m/s^2] (Groves eqs. 2.134, 2.139)."""
    s = math.sin(lat_rad)
    s2 = s * s
    gamma0 = GAMMA_EQUATOR_MPS2 * (1.0 + SOMIGLIANA_K * s2) / math.sqrt(1.0 - WGS84_E2 * s2)
    g_down = gamma0 * (
        1.0 - 2.0 / WGS84_A_M * (1.0 + WGS84_F + _M - 2.0 * WGS84_F * s2) * h_m + 3.0 / WGS84_A_M**2 * h_m * h_m
    )
    g_north = -8.08e-9 * h_m * math.sin(2.0 * lat_rad)
    return g_north, g_down
