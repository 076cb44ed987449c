"""The per-chunk steps of navigation: the sampling grid, rates to increments, the strapdown kernel."""

from __future__ import annotations

import numpy as np

from ..errors import TelemetryError
from ..io.telemetry import Telemetry
from ..kernels.checks import worst_grid_offset
from ..kernels.increments import rates_to_increments
from ..kernels.strapdown import coning_coefficients, strapdown
from .config import GRID_TOLERANCE

__all__ = ["uniform_period_s", "grid_offsets_periods", "increments_of", "increments_from", "integrate"]


def uniform_period_s(t_first: float, t_last: float, n: int) -> float:
    """The sample period of a uniformly sampled record: its span over ``n - 1`` steps.

    Not the median step: stamps like k / 1600 round differently along a long record, and
    the median of the whole record and of its first chunk differ in the 11th digit, which
    a streamed run must not.
    """
    return (float(t_last) - float(t_first)) / (n - 1)


def grid_offsets_periods(time_s, t_first: float, dt: float, first_row: int = 0) -> np.ndarray:
    """How far each stamp lies from its point of the uniform grid ``t_first + k dt`` [periods];
    ``first_row`` is the grid index of ``time_s[0]``. The NumPy twin of
    :func:`sizefx.kernels.checks.worst_grid_offset`, which the navigation loop uses."""
    return (np.asarray(time_s) - (t_first + (first_row + np.arange(len(time_s))) * dt)) / dt


def increments_of(
    tel: Telemetry, dt: float | None = None, first_row: int = 0, *, t_first: float | None = None, row0: int = 0
):
    """``(t_end [N'], dtheta [N',3], dvel [N',3], dt, jitter)`` for a record of either form
    (:func:`increments_from`, on the record's arrays; its accelerometers already synced)."""
    gyro_like, accel_like = tel.imu_arrays()
    return increments_from(
        tel.time_s, gyro_like, accel_like, tel.form, dt, first_row, t_first=t_first, row0=row0, path=tel.path
    )


def increments_from(
    time_s,
    gyro_like,
    accel_like,
    form: str,
    dt: float | None = None,
    first_row: int = 0,
    *,
    t_first: float | None = None,
    row0: int = 0,
    path=None,
):
    """``(t_end [N'], dtheta [N',3], dvel [N',3], dt, jitter)`` from rates or increments [N, 3].

    ``dt``: the record's period when the arrays are a chunk of it (default: their own span);
    ``first_row``: the row of the first sample counted from the record's first, whose time is
    ``t_first`` (default: the chunk's own first); ``row0``: the file row of the record's first sample
    (a segment's), and ``path`` the file, for messages. The stamps must lie on the uniform grid within
    :data:`GRID_TOLERANCE` periods; ``jitter`` is the largest distance of one from it [periods].
    Rates become increments by the fourth-order stencil (one fewer than the samples); increments
    are returned as they are.
    """
    n = len(time_s)
    if dt is None:
        dt = uniform_period_s(time_s[0], time_s[-1], n)
    if t_first is None:
        t_first = float(time_s[0]) - first_row * dt
    worst, offset = worst_grid_offset(
        np.ascontiguousarray(time_s, dtype=np.float64), float(t_first), float(dt), int(first_row)
    )
    jitter = float(abs(offset))
    if jitter > GRID_TOLERANCE:
        raise TelemetryError(
            path,
            "/imu/time",
            f"sampling is not uniform: the stamp of row {row0 + first_row + worst} "
            f"is {offset:+.3g} periods off the uniform grid of "
            f"{dt:.6g} s; navigation integrates on that grid and accepts "
            f"jitter up to {GRID_TOLERANCE} period (resample the record, "
            "or cut it where the rate changes)",
        )
    if form == "increments":
        return time_s, np.ascontiguousarray(gyro_like), np.ascontiguousarray(accel_like), dt, jitter
    dtheta = np.empty((n - 1, 3))
    dvel = np.empty((n - 1, 3))
    rates_to_increments(np.ascontiguousarray(gyro_like), dt, dtheta)
    rates_to_increments(np.ascontiguousarray(accel_like), dt, dvel)
    return time_s[1:], dtheta, dvel, dt, jitter


def integrate(dtheta, dvel, n_sub, dt, state, mode, h_hold, h_ref, vd_ref):
    """The strapdown kernel over whole navigation intervals of ``n_sub`` increments each.

    ``state`` (:func:`sizefx.kernels.strapdown.pack_state`) is updated in place, so the next
    call continues where this one stopped. Returns ``(quat_nb, v_n, lat, lon, h)`` per interval.
    """
    n_steps = dtheta.shape[0] // n_sub
    out_q = np.empty((n_steps, 4))
    out_v = np.empty((n_steps, 3))
    out_lat = np.empty(n_steps)
    out_lon = np.empty(n_steps)
    out_h = np.empty(n_steps)
    strapdown(
        dtheta,
        dvel,
        n_sub,
        coning_coefficients(n_sub),
        n_sub * dt,
        state,
        mode,
        h_hold,
        h_ref,
        vd_ref,
        out_q,
        out_v,
        out_lat,
        out_lon,
        out_h,
    )
    return out_q, out_v, out_lat, out_lon, out_h
