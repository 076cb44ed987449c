"""Where two tracks lie relative to each other on WGS-84: arrays in, arrays out, no files.

- :func:`horizontal_offset_m`: the chord between two points placed on the ellipsoid surface,
  and its north and east parts at the second point;
- :func:`along_cross_track_m`: that offset split along and across a direction of motion;
- :func:`velocity_from_position`: NED velocity of a track that stores none.

Used by :func:`sizefx.compare.metrics.compare` and by the paper's experiments
(:mod:`sizefx.experiments.paper`, "``sizefx compare``'s measure").
"""

from __future__ import annotations

import numpy as np

from .. import earth
from ..constants import WGS84_A_M, WGS84_E2

__all__ = [
    "MIN_GROUND_SPEED_MPS",
    "along_cross_track_m",
    "horizontal_offset_m",
    "surface_ecef_m",
    "velocity_from_position",
]

#: Below this ground speed of B [m/s] its direction of motion is not defined well enough to split
#: A - B into along- and cross-track parts: at rest, or hovering, the direction of B's velocity
#: (or of its position differences) is that of noise and vibration, and turns from sample to sample.
MIN_GROUND_SPEED_MPS = 0.5


def surface_ecef_m(lat_rad, lon_rad) -> np.ndarray:
    """ECEF position [m], shape ``[..., 3]``, of points on the WGS-84 ellipsoid surface (h = 0).

    ``x = N cos(lat) cos(lon), y = N cos(lat) sin(lon), z = N (1 - e^2) sin(lat)``,
    ``N = a / sqrt(1 - e^2 sin^2(lat))`` (Groves 2013, eq. 2.112 with h = 0).
    """
    lat = np.asarray(lat_rad, dtype=float)
    lon = np.asarray(lon_rad, dtype=float)
    n = WGS84_A_M / np.sqrt(1.0 - WGS84_E2 * np.sin(lat) ** 2)
    return np.stack(
        [n * np.cos(lat) * np.cos(lon), n * np.cos(lat) * np.sin(lon), n * (1.0 - WGS84_E2) * np.sin(lat)], axis=-1
    )


def horizontal_offset_m(lat_a_rad, lon_a_rad, lat_b_rad, lon_b_rad):
    """Horizontal distance from B to A, and its north and east components at B.

    Both points are placed on the WGS-84 surface (h = 0, so height differences do
    not enter) and the distance is the straight line (chord) between them in ECEF.
    Against the distance along the surface ``s`` the chord is short by
    ``s^3 / (24 R^2)`` (R the radius of curvature along the line): 1.0 mm at 10 km,
    1.0 m at 100 km (``tests/test_compare.py`` pins this on the equator and a meridian).

    Returns
    -------
    chord_m : ndarray [...]
        ``|p_a - p_b|`` [m].
    north_m, east_m : ndarray [...]
        ``p_a - p_b`` resolved along B's local north and east [m]. They omit the
        chord's component along B's vertical (``s^2 / (2 R)``, 7.8 m at 10 km), so
        ``hypot(north, east)`` is short of the chord by about ``s^3 / (8 R^2)``
        (3 mm at 10 km).
    """
    lat_b = np.asarray(lat_b_rad, dtype=float)
    lon_b = np.asarray(lon_b_rad, dtype=float)
    d_e = surface_ecef_m(lat_a_rad, lon_a_rad) - surface_ecef_m(lat_b, lon_b)
    sl, cl, so, co = np.sin(lat_b), np.cos(lat_b), np.sin(lon_b), np.cos(lon_b)
    north = -sl * co * d_e[..., 0] - sl * so * d_e[..., 1] + cl * d_e[..., 2]
    east = -so * d_e[..., 0] + co * d_e[..., 1]
    return np.linalg.norm(d_e, axis=-1), north, east


def along_cross_track_m(north_m, east_m, v_n_b_mps, min_speed_mps: float = MIN_GROUND_SPEED_MPS):
    """Split a horizontal offset A - B into along- and cross-track parts of B's motion.

    With B's ground velocity ``(v_N, v_E)`` and speed ``V``:
    ``along = (north v_N + east v_E) / V`` (positive: A ahead of B) and
    ``cross = (east v_N - north v_E) / V`` (positive: A to the right of B's track,
    looking along it; flying north, right is east).

    Parameters
    ----------
    north_m, east_m : ndarray [K]
        Offset of A from B along B's local north and east [m].
    v_n_b_mps : ndarray [K, 3]
        B's NED velocity [m/s] (only north and east are used).
    min_speed_mps : float
        Below this ground speed the direction is undefined: NaN.

    Returns
    -------
    along_m, cross_m : ndarray [K]
        NaN where B's ground speed is under ``min_speed_mps``.
    """
    v = np.asarray(v_n_b_mps, dtype=float)
    speed = np.hypot(v[:, 0], v[:, 1])
    ok = speed >= min_speed_mps
    with np.errstate(invalid="ignore", divide="ignore"):
        along = np.where(ok, (north_m * v[:, 0] + east_m * v[:, 1]) / speed, np.nan)
        cross = np.where(ok, (east_m * v[:, 0] - north_m * v[:, 1]) / speed, np.nan)
    return along, cross


def velocity_from_position(time_s, lat_rad, lon_rad, height_m) -> np.ndarray:
    """NED velocity [m/s], ``[M, 3]``, from positions by central differences.

    ``v_N = lat' (R_M + h)``, ``v_E = lon' (R_T + h) cos(lat)``, ``v_D = -h'``
    (Groves 2013, eq. 2.111), derivatives by :func:`numpy.gradient` (second order
    inside, also for uneven steps; first order at the two ends). Longitude is unwrapped
    first, so a track across +-180 deg is differentiated correctly.
    """
    t = np.asarray(time_s, dtype=float)
    lat = np.asarray(lat_rad, dtype=float)
    h = np.asarray(height_m, dtype=float)
    r_mer, r_tr = earth.radii_m(lat)
    return np.column_stack(
        [
            np.gradient(lat, t) * (r_mer + h),
            np.gradient(np.unwrap(np.asarray(lon_rad, dtype=float)), t) * (r_tr + h) * np.cos(lat),
            -np.gradient(h, t),
        ]
    )
