"""The accelerometers on the gyro time base: the one place that does this, for compensate,
correct, navigate, calibrate and diagnose alike.

Accelerometers stamped apart (``/imu/accel_time``) or late by a known delay are resampled
by a not-a-knot cubic spline (the Numba kernels of :mod:`sizefx.kernels.sync`, the same
results as scipy's ``CubicSpline`` to rounding). For increments, the spline interpolates
the cumulative velocity, which is then differenced. The phase error is below 1e-5 rad for
a 50 Hz tone at 1600 Hz.

A spline value depends on samples k rows away as (2 - sqrt(3))^k, so a chunk read with 64
extra rows on each side syncs, inside, as the whole record does
(:mod:`sizefx.navigate.loop`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .io.telemetry import Telemetry
from .kernels import sync as _sync

__all__ = ["resample_onto", "resample_increments", "sync_accelerometers", "synced_accel"]


def _times(name, t) -> np.ndarray:
    t = np.ascontiguousarray(t, dtype=np.float64)
    if t.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {t.shape}")
    return t


def _by_three(values, rows: int, name: str, call):
    """Run a 3-channel spline kernel over ``values [N]`` or ``[N, C]``, three channels at a time
    (channels padded with zeros); ``call(y [N, 3], out [rows, 3]) -> (bad_knot, bad_target)``."""
    v = np.asarray(values, dtype=np.float64)
    flat = v.ndim == 1
    v2 = v.reshape(v.shape[0], -1) if v.ndim else v.reshape(1, 1)
    n_ch = v2.shape[1]
    out = np.empty((rows, n_ch))
    for c0 in range(0, n_ch, 3):
        if n_ch == 3:
            y, part = np.ascontiguousarray(v2), out
        else:
            y = np.zeros((v2.shape[0], 3))
            y[:, : min(3, n_ch - c0)] = v2[:, c0 : c0 + 3]
            part = np.empty((rows, 3))
        bad_knot, bad_target = call(y, part)
        if bad_knot >= 0:
            raise ValueError(
                f"{name}: the times must increase strictly and be finite; they do not at row {bad_knot + 1}"
            )
        if bad_target >= 0:
            raise ValueError(
                f"{name}: the target times must be finite and non-decreasing; they are not at row {bad_target}"
            )
        if part is not out:
            out[:, c0 : c0 + 3] = part[:, : min(3, n_ch - c0)]
    return out[:, 0] if flat else out.reshape((rows,) + v.shape[1:])


def resample_onto(values, t_from, t_to):
    """Samples ``values [N, 3]`` at ``t_from [N]`` -> at ``t_to [K]`` (not-a-knot cubic spline).

    The same as scipy's ``CubicSpline(t_from, values, bc_type="not-a-knot")(t_to)`` to
    rounding, by the Numba kernel :func:`sizefx.kernels.sync.resample` (a Thomas solve and
    a merge walk; ``benchmarks/bench_kernels.py`` compares their speeds). ``t_from``
    increases strictly (N >= 2), ``t_to`` does not decrease; outside ``t_from`` the end
    cubics extrapolate. ``values`` may also be ``[N]`` or ``[N, C]``.
    """
    x, t = _times("t_from", t_from), _times("t_to", t_to)
    if x.size < 2 or np.shape(values)[:1] != (x.size,):
        raise ValueError(
            f"resample_onto: {np.shape(values)} values at {x.size} times; need the same number, at least 2"
        )
    inv_h, u, d = np.empty(x.size - 1), np.empty(x.size), np.empty((x.size, 3))
    return _by_three(values, t.size, "resample_onto", lambda y, out: _sync.resample(x, y, t, inv_h, u, d, out))


def _edges(t):
    """Interval edges ``[N + 1]`` of increments ending at ``t [N]``: the first interval starts one
    median period before ``t[0]`` (``np.median(np.diff(t))``, as before the kernels)."""
    e = np.empty(t.size + 1)
    e[0] = t[0] - _sync.median_step(t)
    e[1:] = t
    return e


def resample_increments(incr, t_end_from, t_end_to):
    """Increments ``[N, 3]`` over ``(t_from[k-1], t_from[k]]`` -> over ``(t_to[k-1], t_to[k]]``.

    The not-a-knot spline of the cumulative sum (a smooth function of time), differenced
    (:func:`sizefx.kernels.sync.resample_increments`, which forms only differences of the
    sum: no rounding grows with the record); the first interval of each starts one median
    period before its first stamp. The same as
    ``np.diff(CubicSpline(edges_from, cumsum)(edges_to), axis=0)`` to the rounding of that
    cumulative sum.
    """
    x, f = _times("t_end_from", t_end_from), _times("t_end_to", t_end_to)
    if x.size < 2 or f.size < 2 or np.shape(incr)[:1] != (x.size,):
        raise ValueError(
            f"resample_increments: {np.shape(incr)} increments ending at {x.size} times onto "
            f"{f.size}; need the same number, at least 2 of each"
        )
    e, g = _edges(x), _edges(f)
    inv_h, u, d = np.empty(e.size - 1), np.empty(e.size), np.empty((e.size, 3))
    return _by_three(
        incr, f.size, "resample_increments", lambda y, out: _sync.resample_increments(e, y, g, inv_h, u, d, out)
    )


def sync_accelerometers(tel: Telemetry, tau_s: float = 0.0) -> Telemetry:
    """The accelerometers on the gyro time base: ``/imu/accel_time`` and a known delay ``tau_s`` undone.

    Accelerometer samples stamped ``t_a`` represent the specific force at ``t_a - tau``;
    rates are resampled by cubic spline, increments through their cumulative sum. The
    one place that does this, for compensate, navigate and calibrate alike.
    """
    if tel.accel_time_s is None and tau_s == 0.0:
        return tel
    synced = synced_accel(tel.time_s, tel.imu_arrays()[1], tel.accel_time_s, tau_s, tel.form)
    if tel.form == "rates":
        return replace(tel, accel_mps2=synced, accel_time_s=None)
    return replace(tel, dvel_mps=synced, accel_time_s=None)


def synced_accel(time_s, accel_like, accel_time_s, tau_s: float, form: str) -> np.ndarray:
    """:func:`sync_accelerometers` on arrays: ``accel_like`` [N, 3] (rates or increments, by ``form``)
    stamped ``accel_time_s`` (None: ``time_s``) and late by ``tau_s``, on the gyros' ``time_s``;
    the array itself when there is nothing to undo."""
    if accel_time_s is None and tau_s == 0.0:
        return accel_like
    t_accel = (accel_time_s if accel_time_s is not None else time_s) - tau_s
    if form == "rates":
        return resample_onto(accel_like, t_accel, time_s)
    return resample_increments(accel_like, t_accel, time_s)
