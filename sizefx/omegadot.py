"""Angular acceleration estimators, with their noise gain and frequency response in closed form.

- ``central``: response ``i sin(2 pi f h) / h`` (ideal ``i 2 pi f``); noise gain
  (std out / std in, white rate noise) ``1 / (sqrt(2) h)``.
- ``savgol``: response ``sum_k c_k exp(i 2 pi f k h)`` with ``c`` the Savitzky-Golay
  derivative coefficients; noise gain ``sqrt(sum c_k^2)``.
- ``increments`` (increment data): no derivative is formed; the tangential *velocity
  increment* is ``(omega(t_k) - omega(t_k-1)) x r`` with edge rates averaged from
  adjacent increments. Its noise per increment is ``|r| sigma_omega / sqrt(2)``
  (``sigma_omega`` the per-sample rate noise), with no ``1/h``.

All three are centred (zero group delay), so the estimate lines up in time with
the accelerometer sample it compensates; ``savgol`` trades bandwidth for noise.
"""

from __future__ import annotations

import numpy as np

__all__ = ["central", "savgol", "edges_from_increments", "response", "noise_gain", "ESTIMATORS"]

ESTIMATORS = ("central", "savgol", "increments")

#: default Savitzky-Golay window: 41 samples (25 ms at 1600 Hz), quadratic; its -3 dB point
#: lies near 30 Hz, above turntable and sway motion, and cuts the noise gain about 35 times.
SAVGOL_WINDOW = 41
SAVGOL_ORDER = 2


def central(omega, dt):
    """``(omega[k+1] - omega[k-1]) / (2 dt)``; one-sided at the ends. [N, 3] rad/s -> rad/s^2."""
    return np.gradient(np.asarray(omega, dtype=float), dt, axis=0)


def savgol(omega, dt, window: int = SAVGOL_WINDOW, order: int = SAVGOL_ORDER):
    """Centred Savitzky-Golay first derivative (scipy); ends by polynomial fit ('interp')."""
    from scipy.signal import (
        savgol_filter,  # scipy.signal is imported here, not at module level: it costs 0.9 s at start-up
    )

    return savgol_filter(np.asarray(omega, dtype=float), window, order, deriv=1, delta=dt, axis=0, mode="interp")


def edges_from_increments(dtheta, dt):
    """Rates at the interval edges ``[N + 1, 3]`` from increments: the mean of adjacent intervals' rates.

    Second order inside; the two outer edges extrapolate linearly.
    """
    w = np.asarray(dtheta, dtype=float) / dt
    edges = np.empty((w.shape[0] + 1, w.shape[1]))
    edges[1:-1] = 0.5 * (w[1:] + w[:-1])
    edges[0] = 1.5 * w[0] - 0.5 * w[1]
    edges[-1] = 1.5 * w[-1] - 0.5 * w[-2]
    return edges


def _savgol_kernel(dt, window, order):
    from scipy.signal import savgol_coeffs

    # savgol_coeffs with use='dot' gives c such that estimate = c . x[k - m .. k + m]
    return savgol_coeffs(window, order, deriv=1, delta=dt, use="dot")


def response(estimator: str, freq_hz, dt, window: int = SAVGOL_WINDOW, order: int = SAVGOL_ORDER):
    """Complex response to a unit complex exponential of frequency ``freq_hz`` (ideal: i 2 pi f)."""
    f = np.asarray(freq_hz, dtype=float)
    if estimator == "central":
        return 1j * np.sin(2 * np.pi * f * dt) / dt
    if estimator == "savgol":
        c = _savgol_kernel(dt, window, order)
        m = (window - 1) // 2
        k = np.arange(-m, m + 1)
        return np.exp(1j * 2 * np.pi * np.multiply.outer(f, k) * dt) @ c
    raise ValueError(f"no rate-domain response for estimator {estimator!r}")


def noise_gain(estimator: str, dt, window: int = SAVGOL_WINDOW, order: int = SAVGOL_ORDER) -> float:
    """Std of the estimate for unit-std white rate noise (rate-domain estimators)."""
    if estimator == "central":
        return 1.0 / (np.sqrt(2.0) * dt)
    if estimator == "savgol":
        return float(np.sqrt(np.sum(_savgol_kernel(dt, window, order) ** 2)))
    raise ValueError(f"no rate-domain noise gain for estimator {estimator!r}")
