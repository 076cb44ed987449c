"""The windows the units checks (:mod:`sizefx.sanity`) judge a record on, and which of them rest.

A record is cut into windows of :data:`~sizefx.sanity.thresholds.WINDOW_S` (at most
:data:`~sizefx.sanity.thresholds.MAX_WINDOWS` of them, in evenly spread runs), each with its mean
specific force and angular rate; a window rests when its accelerometers are steady and its gyros
quiet, for :data:`~sizefx.sanity.thresholds.REST_MIN_WINDOWS` windows in a row. Check (a) reads the
specific force at rest; check (c) finds its quasi-static moments among the windows and takes the gyro
bias from those at rest.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..constants import GAP_FACTOR
from .thresholds import (
    MAX_WINDOWS,
    MIN_WINDOW_SAMPLES,
    REST_GYRO_FACTOR,
    REST_GYRO_PERCENTILE,
    REST_MIN_WINDOWS,
    REST_STEADINESS,
    WINDOW_S,
)

# nothing public: these helpers are imported by name within sizefx.sanity
__all__: list[str] = []


@dataclass
class _Windows:
    t_center: np.ndarray  #: [W] s
    f_b: np.ndarray  #: [W, 3] mean specific force (SI as read)
    omega_b: np.ndarray  #: [W, 3] mean angular rate (SI as read)
    steadiness: np.ndarray  #: [W] max axis std of f / |mean f|
    rest: np.ndarray  #: [W] bool


def _rates(tel, rows, period):
    """Angular rate and specific force of ``rows`` (an index array), whatever the form."""
    g, a = tel.imu_arrays()
    if tel.form == "rates":
        return g[rows], a[rows]
    return g[rows] / period, a[rows] / period


def _runs_at_least(mask: np.ndarray, joined: np.ndarray, length: int) -> np.ndarray:
    """``mask`` kept only in runs of at least ``length`` consecutive windows (``joined[k]``: window
    k follows window k - 1 without a break)."""
    out = np.zeros_like(mask)
    k = 0
    n = mask.size
    while k < n:
        if not mask[k]:
            k += 1
            continue
        end = k + 1
        while end < n and mask[end] and joined[end]:
            end += 1
        if end - k >= length:
            out[k:end] = True
        k = end
    return out


def _windows(tel, period: float) -> _Windows:
    n = tel.n_samples
    width = max(MIN_WINDOW_SAMPLES, int(round(WINDOW_S / period)))
    total = n // width
    if total == 0:
        empty = np.zeros((0, 3))
        return _Windows(np.zeros(0), empty, empty, np.zeros(0), np.zeros(0, bool))
    index = np.arange(total)
    if total > MAX_WINDOWS:  # evenly spread runs of consecutive windows, so that rest can still be seen
        run = 2 * REST_MIN_WINDOWS
        firsts = np.linspace(0, total - run, MAX_WINDOWS // run).round().astype(int)
        index = np.unique((firsts[:, None] + np.arange(run)[None, :]).ravel())
    rows = (index * width)[:, None] + np.arange(width)[None, :]  # [W, width]
    t = tel.time_s
    span = t[rows[:, -1]] - t[rows[:, 0]]
    whole = span <= (width - 1 + GAP_FACTOR - 1.0) * period  # no gap inside
    rows, index = rows[whole], index[whole]
    joined = np.r_[False, np.diff(index) == 1]
    if rows.shape[0] > 1:  # a gap between two windows breaks a run too
        joined[1:] &= t[rows[1:, 0]] - t[rows[:-1, -1]] <= GAP_FACTOR * period
    w, f = _rates(tel, rows, period)  # [W, width, 3]
    f_mean = f.mean(axis=1)
    w_mean = w.mean(axis=1)
    f_norm = np.linalg.norm(f_mean, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        steadiness = f.std(axis=1).max(axis=1) / f_norm
    steady = np.isfinite(steadiness) & (steadiness < REST_STEADINESS)
    rest = np.zeros(rows.shape[0], bool)
    if steady.any():
        w_norm = np.linalg.norm(w_mean, axis=1)
        quiet_level = np.percentile(w_norm[steady], REST_GYRO_PERCENTILE)
        rest = _runs_at_least(steady & (w_norm <= REST_GYRO_FACTOR * quiet_level), joined, REST_MIN_WINDOWS)
    return _Windows(0.5 * (t[rows[:, 0]] + t[rows[:, -1]]), f_mean, w_mean, steadiness, rest)
