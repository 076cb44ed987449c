"""The residual (measured minus predicted) under one model vector, span by span, and what is
measured of it: its rows, its mean squares, per-sample statistics of the record.

Nothing here holds more than one span (:data:`sizefx.diagnose.normal.CHUNK_SAMPLES`) of the
prediction at a time: the fit (:mod:`.fit`) and the held-out checks (:mod:`.holdout`) keep only
the rows of :class:`sizefx.diagnose.normal.Rows`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .normal import CHUNK_SAMPLES, Rows, block_means, huber_weights
from .predictor import Predictor

__all__ = ["Residual", "residual_under", "noise_of", "rms", "white", "per_sample", "predicted", "KAPPA_BLOCK_S"]

#: Shortest block for the variance inflation kappa of a channel's residual [s]; longer ones, by
#: factors of 4, up to a twentieth of the record.
KAPPA_BLOCK_S = 0.5


@dataclass
class Residual:
    """Measured minus predicted under one model vector, as the fit holds it: its rows, and what the
    report needs of the samples themselves (nothing else per sample is kept)."""

    rows: np.ndarray | None  #: [m, 6] the rows of :class:`Rows` (SI), or None before the rows are known
    ms_full: np.ndarray  #: [6] mean square over the usable samples, full band (SI^2)
    series: np.ndarray | None = None  #: [n, 6] float32, for the plots only


def residual_under(
    pred: Predictor, rows_of: Rows | None, theta, *, series: bool = False, within: tuple | None = None
) -> Residual:
    """The residual under ``theta``, span by span (:meth:`Rows.spans`): each span's prediction is
    formed, reduced to its rows and its sums of squares, and dropped. ``rows_of`` None: the full-band
    sums only. ``series``: keep the residual per sample in float32 (for the plots: 7 significant
    digits of a residual drawn at 0.1 s means and as a spectrum, against 48 bytes per sample).
    ``within=(t0, t1)`` [s]: only the samples of that window are formed, from the first whole row on
    (the other rows stay zero, and ``ms_full`` covers the window only)."""
    n = pred.n
    rows = None if rows_of is None else np.zeros((rows_of.t.size, 6))
    out = np.empty((n, 6), dtype=np.float32) if series else None
    sumsq = np.zeros(6)
    count = 0
    spans = (
        rows_of.spans()
        if rows_of is not None
        else [(lo, min(n, lo + CHUNK_SAMPLES)) for lo in range(0, n, CHUNK_SAMPLES)]
    )
    L = 1 if rows_of is None else rows_of.L
    if within is not None:
        a = int(np.searchsorted(pred.t, within[0])) // L * L
        b = min(n, -(-int(np.searchsorted(pred.t, within[1])) // L) * L)
        step = spans[0][1] - spans[0][0] if spans else n
        spans = [(lo, min(b, lo + step)) for lo in range(a, b, step)]
    for lo, hi in spans:
        a, b = (lo, hi) if rows_of is None else rows_of.extended(lo, hi)
        res = pred.measured_span(a, b) - pred.predict_span(theta, a, b)
        inner = res[lo - a : hi - a]
        usable = pred.mask[lo:hi]
        sumsq += np.sum(inner[usable] ** 2, axis=0)
        count += int(usable.sum())
        if out is not None:
            out[lo:hi] = inner
        if rows is not None:
            assert rows_of is not None  # rows are made with rows_of
            r = rows_of.span_rows(res, a, lo, hi)
            rows[lo // L : lo // L + r.shape[0]] = r
    return Residual(rows, sumsq / max(1, count), out)


def noise_of(rows_of: Rows, rows, robust: bool):
    """Per channel: sigma (1.4826 MAD) and kappa (variance inflation of block means); per row: Huber
    weights (all 1 unless ``robust``).

    kappa is 1 for white noise and grows with colour (drift, unmodelled slow terms, a low-pass):
    the weights ``1 / (sigma^2 kappa)`` then count a coloured channel as fewer samples. Rows beyond
    Huber's constant are clipped before kappa is measured, so that a glitch does not pass for colour.
    """
    r = rows[rows_of.keep]
    med = np.median(r, axis=0)
    sigma = np.maximum(1.4826 * np.median(np.abs(r - med), axis=0), 1e-300)
    u = (rows - med) / sigma
    weights = huber_weights(u) if robust else np.ones_like(u)
    clipped = np.clip(u[rows_of.keep], -3.0, 3.0) * sigma
    clipped -= clipped.mean(axis=0)
    kappa = np.ones(6)
    B = max(2, round(KAPPA_BLOCK_S / rows_of.dt))
    while clipped.shape[0] // B >= 20:  # 0.5 s, 2 s, 8 s, ...: a random walk shows only in the long blocks
        kappa = np.maximum(kappa, block_means(clipped, B).var(axis=0) * B / sigma**2)
        B *= 4
    return sigma, kappa, weights


def rms(rows_of: Rows, rows):
    """Per channel: the RMS of the rows ``rows_of.keep``."""
    return np.sqrt(np.mean(rows[rows_of.keep] ** 2, axis=0))


def white(rows_of: Rows, rows):
    """Per channel: the rows' sample-to-sample noise, sqrt(mean(diff^2) / 2)."""
    return np.sqrt(np.mean(np.diff(rows[rows_of.keep], axis=0) ** 2, axis=0) / 2.0)


def per_sample(pred: Predictor, stat) -> np.ndarray:
    """``stat(lo, hi) -> [hi - lo]`` for every sample, span by span (8 bytes per sample, no temporaries
    of the record's length)."""
    out = np.empty(pred.n)
    for lo in range(0, pred.n, CHUNK_SAMPLES):
        hi = min(pred.n, lo + CHUNK_SAMPLES)
        out[lo:hi] = stat(lo, hi)
    return out


def predicted(pred: Predictor, theta, lo: int, hi: int) -> np.ndarray:
    """The prediction ``[hi - lo, 6]`` under ``theta`` of the samples ``lo:hi``, formed
    :data:`CHUNK_SAMPLES` at a time (its terms take about 1 kB per sample; the result 48 bytes)."""
    out = np.empty((hi - lo, 6))
    for a in range(lo, hi, CHUNK_SAMPLES):
        b = min(hi, a + CHUNK_SAMPLES)
        out[a - lo : b - lo] = pred.predict_span(theta, a, b)
    return out
