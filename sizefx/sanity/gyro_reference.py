"""Check (b) of :mod:`sizefx.sanity`: the gyros against a reference attitude.

Over reference intervals that really rotate (a net angle of at least
:data:`~sizefx.sanity.thresholds.REF_MIN_ANGLE_RAD`, a path short enough that the angle is not
ambiguous), the integrated gyro vector has the length of the reference rotation angle; the median
ratio is 57.3 for deg/s read as rad/s, 1/57.3 for the reverse. :func:`_reference_starts` finds the
intervals (half spread evenly, half where the reference turns), as :func:`sizefx.sanity.sample_blocks`
finds the blocks of a streamed record.
"""

from __future__ import annotations

import numpy as np

from ..constants import GAP_FACTOR
from ..rotation import quat_angle_between
from .thresholds import (
    GYRO_BAND,
    REF_COARSE_ROWS,
    REF_CONSECUTIVE,
    REF_END_OFFSETS,
    REF_MAX_INTERVAL_S,
    REF_MAX_PATH_RAD,
    REF_MAX_STARTS,
    REF_MIN_ANGLE_RAD,
    REF_MIN_INTERVALS,
)
from .verdict import FORM_QUANTITIES, Check, looks_like

# nothing public: these helpers are imported by name within sizefx.sanity
__all__: list[str] = []


def _integral(tel, t_a: float, t_b: float, period: float):
    """Integrated angular rate [3] (SI as read) over ``[t_a, t_b]``, or None across an IMU gap."""
    t = tel.time_s
    g, _ = tel.imu_arrays()
    n = t.size
    k0 = max(0, int(np.searchsorted(t, t_a)) - 1)
    k1 = min(n - 1, int(np.searchsorted(t, t_b)) + 1)
    if k1 - k0 < 1 or t[k0] > t_a or t[k1] < t_b:
        return None
    tt = t[k0 : k1 + 1]
    dt = np.diff(tt)
    if np.any(dt > GAP_FACTOR * period):
        return None
    if tel.form == "rates":
        w = g[k0 : k1 + 1]
        cum = np.vstack([np.zeros(3), np.cumsum(0.5 * (w[1:] + w[:-1]) * dt[:, None], axis=0)])
    else:  # increment k covers (t[k-1], t[k]]
        cum = np.vstack([np.zeros(3), np.cumsum(g[k0 + 1 : k1 + 1], axis=0)])
    return np.array([np.interp(t_b, tt, cum[:, i]) - np.interp(t_a, tt, cum[:, i]) for i in range(3)])


def _reference_starts(q, lo: int, hi: int, far: int) -> np.ndarray:
    """Start rows of the intervals to examine in reference rows ``[lo, hi)``: half spread evenly,
    half in the stretches that turn (a flight turns in a few per cent of its record).

    The stretches are found on a coarse grid of rows ``far`` apart (at most
    :data:`REF_COARSE_ROWS` of them): a cell turns when its two ends differ by
    :data:`REF_MIN_ANGLE_RAD`.
    """
    last = hi - 2
    n_even = min(REF_MAX_STARTS // 2, last - lo + 1)
    even = np.linspace(lo, last, n_even).round().astype(int)
    step = max(far, (hi - lo) // REF_COARSE_ROWS)
    coarse = np.arange(lo, hi, step)
    turning = np.flatnonzero(quat_angle_between(q[coarse[:-1]], q[coarse[1:]]) >= REF_MIN_ANGLE_RAD)
    if turning.size == 0:
        return even
    where = np.linspace(0, turning.size * step - 1, REF_MAX_STARTS - n_even).round().astype(int)
    inside = coarse[turning[where // step]] + where % step
    return np.unique(np.r_[even, np.minimum(inside, last)])


def _check_gyro_reference(tel, period: float, dataset: str, declared: str) -> Check | str:
    """(b); a reason string when no verdict is possible."""
    ref = tel.reference
    if ref is None:
        return "no reference"
    tr, q = ref.time_s, ref.quat_nb
    t = tel.time_s
    lo = int(np.searchsorted(tr, t[0]))
    hi = int(np.searchsorted(tr, t[-1], side="right"))  # rows [lo, hi) inside the IMU span
    if hi - lo < 3:
        return "the reference has too few rows inside the IMU record"
    ref_step = float(np.median(np.diff(tr[lo : min(hi, lo + (1 << 16))])))
    far = max(REF_CONSECUTIVE + 1, int(REF_MAX_INTERVAL_S / ref_step))
    starts = _reference_starts(q, lo, hi, far)
    offsets = np.unique(
        np.r_[
            np.arange(REF_CONSECUTIVE + 1),
            np.geomspace(REF_CONSECUTIVE, far, REF_END_OFFSETS - REF_CONSECUTIVE).round(),
        ]
    ).astype(int)
    idx = np.minimum(starts[:, None] + offsets[None, :], hi - 1)  # [K, E]: interval ends tried
    t_idx = tr[idx]
    step_dt = np.diff(t_idx, axis=1)
    # a reference gap (or the end of the rows) inside an interval ends it
    broken = np.cumsum((step_dt <= 0.0) | (step_dt > GAP_FACTOR * ref_step * np.diff(offsets)[None, :]), axis=1) > 0
    path = np.cumsum(quat_angle_between(q[idx[:, :-1]], q[idx[:, 1:]]), axis=1)
    ok = ~broken & (path <= REF_MAX_PATH_RAD) & (t_idx[:, 1:] - t_idx[:, :1] <= REF_MAX_INTERVAL_S)
    # ok only turns false along a row (path, span and breaks only grow): take the last true end
    n_ok = np.where(ok.all(axis=1), ok.shape[1], np.argmin(ok, axis=1))
    ends = idx[np.arange(starts.size), n_ok]
    has = n_ok > 0
    net = np.zeros(starts.size)
    net[has] = quat_angle_between(q[starts[has]], q[ends[has]])
    use = np.flatnonzero(has & (net >= REF_MIN_ANGLE_RAD))
    if use.size < REF_MIN_INTERVALS:
        return (
            f"the reference rotates by {REF_MIN_ANGLE_RAD:g} rad in only {use.size} intervals "
            f"(needs {REF_MIN_INTERVALS})"
        )
    ratios = []
    for k in use:
        vec = _integral(tel, float(tr[starts[k]]), float(tr[ends[k]]), period)
        if vec is not None:
            ratios.append(float(np.linalg.norm(vec)) / net[k])
    if len(ratios) < REF_MIN_INTERVALS:
        return f"only {len(ratios)} rotating reference intervals have continuous IMU samples"
    ratio = float(np.median(ratios))
    count = len(ratios)
    quantity = FORM_QUANTITIES[tel.form][0]
    if 1.0 / GYRO_BAND <= ratio <= GYRO_BAND:
        return Check(
            "gyro",
            dataset,
            declared,
            "ok",
            f"gyro against the reference attitude: ratio {ratio:.3f} over {count} rotating intervals",
            "reference",
            ratio,
            count,
        )
    unit = looks_like(quantity, declared, ratio, GYRO_BAND)
    detail = (
        f"integrates to {ratio:.4g} times the rotation of the reference attitude "
        f"(median over {count} rotating intervals, read as '{declared}')"
    )
    return Check("gyro", dataset, declared, "wrong" if unit else "odd", detail, "reference", ratio, count, unit)
