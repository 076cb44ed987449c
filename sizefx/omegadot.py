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

import functools

import numpy as np

from .constants import ESTIMATORS
from .kernels.omegadot import savgol_derivative, savgol_weights

__all__ = ["central", "savgol", "savgol_rows", "edges_from_increments", "response", "noise_gain", "ESTIMATORS"]

#: default Savitzky-Golay window: 41 samples (25 ms at 1600 Hz), quadratic; its -3 dB point
#: lies near 30 Hz, above turntable and sway motion, and cuts the noise gain about 35 times.
SAVGOL_WINDOW = 41
SAVGOL_ORDER = 2


def central(omega, dt):
    """``(omega[k+1] - omega[k-1]) / (2 dt)``; one-sided at the ends. [N, 3] rad/s -> rad/s^2."""
    return np.gradient(np.asarray(omega, dtype=float), dt, axis=0)


@functools.lru_cache(maxsize=16)
def _savgol_weights(dt, window, order):
    """:func:`sizefx.kernels.omegadot.savgol_weights`, checked, and kept for the next chunk
    (read-only arrays)."""
    if not (isinstance(window, (int, np.integer)) and window >= 3 and window % 2 == 1):
        raise ValueError(f"Savitzky-Golay window {window!r}: give an odd number of samples, at least 3")
    if not (isinstance(order, (int, np.integer)) and 1 <= order < window):
        raise ValueError(f"Savitzky-Golay order {order!r}: give 1 .. window - 1 (a derivative needs order >= 1)")
    if not (np.isfinite(dt) and dt > 0.0):
        raise ValueError(f"sample period {dt!r}: give a positive, finite period in seconds")
    weights = savgol_weights(int(window), int(order), float(dt))
    for w in weights:
        w.flags.writeable = False
    return weights


def savgol(omega, dt, window: int = SAVGOL_WINDOW, order: int = SAVGOL_ORDER):
    """Centred Savitzky-Golay first derivative of ``omega [N, C]`` (rad/s -> rad/s^2, any
    quantity per second), the polynomial fit at the ends (scipy's ``mode="interp"``).

    The Numba kernel :func:`sizefx.kernels.omegadot.savgol_derivative` on the whole record
    (:func:`savgol_rows` for a part of one); the same as ``scipy.signal.savgol_filter(omega,
    window, order, deriv=1, delta=dt, axis=0, mode="interp")`` to rounding (see
    ``tests/test_stream_kernels.py`` for the tolerance). Needs ``N >= window``.
    """
    x = np.asarray(omega, dtype=np.float64)
    return savgol_rows(x, 0, x.shape[0], 0, x.shape[0], dt, window, order)


def savgol_rows(
    rows, lo: int, n_record: int, j0: int, j1: int, dt, window: int = SAVGOL_WINDOW, order: int = SAVGOL_ORDER
):
    """:func:`savgol` of record rows ``[j0, j1)``, given ``rows``, the record's rows
    ``[lo, lo + len(rows))`` of ``n_record``. Returns ``[j1 - j0, C]`` (``[j1 - j0]`` for ``[R]``).

    The rows must hold every row's window: ``[j0 - m, j1 + m)`` clipped to the record
    (``m = window // 2``), and, when a row within m of a record end is asked for, that end's
    whole window (``[0, window)`` or ``[n_record - window, n_record)``), which the end rows'
    fitted polynomial uses.

    The ends' polynomial fit applies only at the record's own ends (rows below m and from
    ``n_record - m``), so a record processed in chunks gives the same derivative, bit for bit,
    as processed whole (each row sums the same taps in the same order).
    """
    given = np.asarray(rows, dtype=np.float64)
    x = np.ascontiguousarray(given.reshape(given.shape[0], -1))
    taps, head, tail = _savgol_weights(dt, window, order)
    m = taps.size
    if n_record < window:
        raise ValueError(
            f"Savitzky-Golay window of {window} samples on a record of {n_record}: it needs at least {window}"
        )
    need_lo, need_hi = max(0, j0 - m), min(n_record, j1 + m)
    if j0 < j1 and j0 < m:
        need_hi = max(need_hi, window)
    if j0 < j1 and j1 > n_record - m:
        need_lo = min(need_lo, n_record - window)
    if not (0 <= j0 <= j1 <= n_record and lo <= need_lo and need_hi <= lo + x.shape[0] <= n_record):
        raise ValueError(
            f"savgol_rows: rows [{j0}, {j1}) of {n_record} need rows [{need_lo}, {need_hi}); "
            f"given [{lo}, {lo + x.shape[0]})"
        )
    out = np.empty((j1 - j0, x.shape[1]))
    savgol_derivative(x, lo, n_record, j0, j1, taps, head, tail, out)
    return out.reshape((j1 - j0,) + given.shape[1:])


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
    """The centred weights ``c [window]``: estimate ``= c . x[k - m .. k + m]`` (the kernel's taps)."""
    taps = _savgol_weights(dt, window, order)[0]
    return np.concatenate([-taps[::-1], [0.0], taps])


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
