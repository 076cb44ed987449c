"""Closed-form error figures that the numerical results are checked against.

- :func:`coning_residual_rad_s`: drift of the n-sub-sample coning algorithm in pure coning
  (Ignagni 1996; Savage 1998, sec. 7.1.1).
- :func:`sculling_residual_mps2`: rectified velocity error of the n-sub-sample sculling
  algorithm in classical sculling (its dual; Ignagni 1998).
- :func:`schuler_period_s`, :func:`schuler_peak_error_m`: free-inertial response to an
  accelerometer bias b: x(t) = b / w_s^2 (1 - cos w_s t), w_s = sqrt(g / R).
"""

from __future__ import annotations

import numpy as np

from . import earth
from .kernels.strapdown import coning_coefficients

__all__ = ["coning_residual_rad_s", "sculling_residual_mps2", "schuler_period_s", "schuler_peak_error_m"]


def coning_residual_rad_s(freq_hz: float, half_angle_rad: float, n_sub: int, sample_s: float) -> float:
    """Attitude drift [rad/s] left by the n_sub-sample coning correction (signed, about the cone axis).

    True rotation about the cone axis over an interval T = n_sub h:
    a^2/2 (Omega T - sin Omega T), a = sin(half angle). Algorithm: sum k_ij (a_i x a_j),
    |a_i x a_j| = 4 a^2 sin^2(Omega h / 2) sin((j - i) Omega h). Leading order in a.
    """
    w, a, h = 2 * np.pi * freq_hz, np.sin(half_angle_rad), sample_s
    T = n_sub * h
    k = coning_coefficients(n_sub)
    true = 0.5 * a * a * (w * T - np.sin(w * T))
    alg = sum(
        k[i, j] * 4 * a * a * np.sin(w * h / 2) ** 2 * np.sin((j - i) * w * h)
        for i in range(n_sub)
        for j in range(i + 1, n_sub)
    )
    return float((true - alg) / T)


def sculling_residual_mps2(
    freq_hz: float, angle_amp_rad: float, accel_amp_mps2: float, n_sub: int, sample_s: float
) -> float:
    """Rectified velocity error [m/s^2] left by the n_sub-sample sculling correction (signed).

    Motion: angle A sin(Omega t) about one axis, specific force B sin(Omega t) along a
    perpendicular one. Per interval the algorithm's rectified term is
    1/2 (a x u) + sum k_ij (a_i x u_j + u_i x a_j), the exact one (leading order) the
    integral of alpha x f. Phase averages use <sin(W(t0 + p h)) cos(W(t0 + q h))> =
    1/2 sin(W h (p - q)); error = (<algorithm> - A B (T/2 - sin(W T) / (2 W))) / T.
    """
    w, A, B, h = 2 * np.pi * freq_hz, angle_amp_rad, accel_amp_mps2, sample_s
    T = n_sub * h
    k = coning_coefficients(n_sub)

    def sc(p, q):
        return 0.5 * np.sin(w * h * (p - q))

    def a_u(i, j):  # <a_i u_j>: a_i = A (S_i - S_(i-1)), u_j = B / W (C_(j-1) - C_j)
        return A * B / w * (sc(i, j - 1) - sc(i, j) - sc(i - 1, j - 1) + sc(i - 1, j))

    total = A * B / w * (sc(n_sub, 0) - sc(n_sub, n_sub) - sc(0, 0) + sc(0, n_sub))
    alg = 0.5 * total + sum(
        k[i - 1, j - 1] * (a_u(i, j) - a_u(j, i)) for i in range(1, n_sub + 1) for j in range(i + 1, n_sub + 1)
    )
    true = A * B * (T / 2 - np.sin(w * T) / (2 * w))
    return float((alg - true) / T)


def _schuler(lat_rad, h_m):
    r_mer, r_tr = earth.radii_m(lat_rad)
    return float(np.sqrt(r_mer * r_tr) + h_m), float(earth.gravity_n(lat_rad, h_m)[2])


def schuler_period_s(lat_rad: float, h_m: float) -> float:
    """2 pi sqrt(R / g), R the Gaussian mean radius plus height."""
    R, g = _schuler(lat_rad, h_m)
    return float(2 * np.pi * np.sqrt(R / g))


def schuler_peak_error_m(bias_mps2: float, lat_rad: float, h_m: float) -> float:
    """Peak position error 2 b R / g of an uncompensated accelerometer bias b."""
    R, g = _schuler(lat_rad, h_m)
    return 2 * bias_mps2 * R / g
