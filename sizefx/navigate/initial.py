"""The initial state of a navigation run: from ``/reference``, or by static alignment.

Alignment (``init="align"``): the record must be stationary over the window.

1. Coarse: TRIAD on the mean specific force (levelling) and the mean angular
   rate (gyrocompassing) against ``-g_n`` and ``omega_ie_n``.
2. Fine: a batch zero-velocity fit. The mechanisation is run over the window from
   the coarse attitude, from three slightly rotated ones, and with a small north
   gyro drift. The resulting velocity histories give the sensitivity of the
   velocity to each parameter. The least-squares correction that brings the
   window's velocity closest to zero is then applied (two iterations). This
   uses the whole nonlinear mechanisation, Earth rate and Schuler coupling
   included. It reaches what the sensors allow: tilt to accelerometer bias / g,
   heading to gyro bias / (Omega_E cos lat).
"""

from __future__ import annotations

import numpy as np

from .. import earth
from ..constants import SECONDS_PER_HOUR
from ..errors import ConfigError
from ..kernels.strapdown import VERTICAL_HELD, pack_state
from ..rotation import mat_to_euler, mat_to_quat, rotvec_to_mat
from .config import STATIONARY_SPAN_M, NavConfig
from .steps import integrate

__all__ = ["choose", "coarse_alignment", "fine_alignment", "initial_state"]


def choose(path, ref, approximate: bool, cfg: NavConfig, t_start: float):
    """Initialisation and vertical mode for this record: ``(init, vertical, stationary)``.

    ``ref``: the reference, or a stand-in with its first stamp and position extremes
    (:meth:`sizefx.io.telemetry.ReferenceStream.summary`), or None; ``approximate``: the
    importer marked its attitude approximate (not for initialisation).
    """
    covers = ref is not None and ref.time_s[0] <= t_start + 1e-9 and not approximate
    init = cfg.init
    if init == "auto":
        init = "reference" if covers else "align"
    if init == "reference" and not covers:
        raise ConfigError(
            f"{path}: --init reference needs a /reference that covers the start "
            f"(t = {t_start:.3f} s) and is not approximate; use --init align"
        )
    vertical = cfg.vertical
    stationary = True
    if ref is not None and ref.has_position:
        r_mer, r_tr = earth.radii_m(ref.lat_rad[0])
        span = max(
            np.ptp(ref.lat_rad) * r_mer, np.ptp(ref.lon_rad) * r_tr * np.cos(ref.lat_rad[0]), np.ptp(ref.height_m)
        )
        stationary = span < STATIONARY_SPAN_M
    if vertical == "auto":
        if stationary:
            vertical = "held"
        elif ref is not None and ref.has_position:
            vertical = "reference"
        else:
            vertical = "free"
    if vertical == "reference" and (ref is None or not ref.has_position):
        raise ConfigError(f"{path}: --vertical reference needs /reference/position")
    return init, vertical, stationary


def coarse_alignment(f_b, omega_b, lat_rad, h_m) -> np.ndarray:
    """``mat_nb`` from mean specific force and angular rate (TRIAD: gravity trusted, heading from Earth rate)."""
    f_n = -earth.gravity_n(lat_rad, h_m)
    w_n = earth.omega_ie_n(lat_rad)

    def triad(f, w):
        v1 = f / np.linalg.norm(f)
        v2 = np.cross(f, w)
        v2 /= np.linalg.norm(v2)
        return np.column_stack([v1, v2, np.cross(v1, v2)])

    return triad(f_n, w_n) @ triad(np.asarray(f_b), np.asarray(omega_b)).T


def fine_alignment(dtheta, dvel, dt, mat_nb0, lat, lon, h, n_sub, iterations: int = 2):
    """Refine ``mat_nb0`` so that navigating the (stationary) window gives the least velocity.

    Parameters fitted: the attitude error about north, east and down, and a gyro
    drift about north. Without the drift, a north drift (whose east-velocity
    error grows as t^2) would be absorbed into a wrong roll. A drift about east
    cannot be told from a heading error: that is the gyrocompassing limit,
    heading error = east drift / (Omega_E cos lat).

    Returns ``(mat_nb, north_drift_rad_s)``.
    """
    empty = np.zeros(0)
    mat = mat_nb0
    eps = 1e-5  # rad: small enough for linearity (errors ~ eps^2), large enough against rounding
    eps_drift = 1e-9  # rad/s (0.0002 deg/h): the same order of velocity response over minutes
    drift = 0.0

    def velocities(trial_mat, drift_n):
        bias_b = trial_mat.T @ np.array([drift_n, 0.0, 0.0])  # static: a fixed body vector
        state = pack_state(mat_to_quat(trial_mat), np.zeros(3), lat, lon, h)
        _, v, _, _, _ = integrate(dtheta - bias_b * dt, dvel, n_sub, dt, state, VERTICAL_HELD, h, empty, empty)
        return v[:, :2].ravel()

    for _ in range(iterations):
        base = velocities(mat, drift)
        cols = [(velocities(rotvec_to_mat(eps * np.eye(3)[k]) @ mat, drift) - base) / eps for k in range(3)]
        cols.append((velocities(mat, drift + eps_drift) - base) / eps_drift)
        x, *_ = np.linalg.lstsq(np.column_stack(cols), -base, rcond=None)
        mat = rotvec_to_mat(x[:3]) @ mat
        drift += x[3]
    return mat, drift


def initial_state(
    path, cfg: NavConfig, init: str, ref0, site, dt: float, n_sub: int, n_increments: int, alignment_window
):
    """Start attitude, velocity and position, and the alignment details for the configuration.

    ``ref0``: the reference at the start (:func:`sizefx.navigate.reference.reference_at`) or None; ``alignment_window(n)``
    returns the first ``n`` angle and velocity increments (whole record or stream alike).
    Returns ``(quat0, v0, (lat0, lon0, h0), details)``.
    """
    if ref0 is not None and "lat" in ref0:
        lat0, lon0, h0 = float(ref0["lat"][0]), float(ref0["lon"][0]), float(ref0["h"][0])
    elif site is not None:
        lat0, lon0, h0 = float(site.lat_rad), float(site.lon_rad), float(site.height_m)
    else:
        raise ConfigError(
            f"{path}: no start position: the file has neither root latitude/longitude/height "
            "nor /reference/position; add the site attributes (sizefx import --site-deg)"
        )
    if init == "reference":
        v0 = ref0["v_n"][0] if "v_n" in ref0 else np.zeros(3)
        return ref0["quat_nb"][0], v0, (lat0, lon0, h0), {}
    n_align = int(round(cfg.align_s / dt))
    n_align -= n_align % n_sub
    if n_align < n_sub * 10 or n_align > n_increments:
        raise ConfigError(
            f"{path}: alignment window of {cfg.align_s} s does not fit a record of "
            f"{n_increments * dt:.1f} s; choose --align-s"
        )
    dtheta, dvel = alignment_window(n_align)
    f_b = dvel.sum(axis=0) / (n_align * dt)
    w_b = dtheta.sum(axis=0) / (n_align * dt)
    mat_c = coarse_alignment(f_b, w_b, lat0, h0)
    mat_f, drift_n = fine_alignment(dtheta, dvel, dt, mat_c, lat0, lon0, h0, n_sub)
    roll_c, pitch_c, heading_c = mat_to_euler(mat_c)
    roll, pitch, heading = mat_to_euler(mat_f)
    details = {
        "align_window_s": n_align * dt,
        "coarse_roll_pitch_heading_deg": [float(np.degrees(a)) for a in (roll_c, pitch_c, heading_c % (2 * np.pi))],
        "fine_roll_pitch_heading_deg": [float(np.degrees(a)) for a in (roll, pitch, heading % (2 * np.pi))],
        "mean_specific_force_mps2": f_b.tolist(),
        "north_gyro_drift_deg_per_h": float(np.degrees(drift_n) * SECONDS_PER_HOUR),
    }
    return mat_to_quat(mat_f), np.zeros(3), (lat0, lon0, h0), details
