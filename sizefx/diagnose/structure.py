"""What the final model leaves unexplained: tests for structure in each channel's residual.

After the fit, :func:`unexplained` asks of every channel's residual whether it is white noise
or still holds structure that none of the candidates explains, and names each structure it
finds: its channel, its kind, its size in SI, and a sentence in report units with a plausible
physical cause. This is how diagnose names a cause that is not among its candidates.

Rows and gaps
-------------
The rows are uniformly spaced in time (``dt``, samples or block means of samples). Rows not
``keep`` (gaps, edges) and jumps in ``t_s`` larger than :data:`GAP_FACTOR` ``dt`` cut the record
into runs; no test bridges a cut: Welch segments lie inside one run, and the time-domain tests
use means of kept rows over time blocks (a block that is mostly gap is dropped).

The four kinds, tested per channel in this order
--------------------------------------------------
Every test carries its share of the family-wise level ``alpha`` (:data:`ALPHA_SHARE`: a quarter
per kind, split equally over the six channels, then Bonferroni over the tests of that kind:
frequency bins, split times, regressors). The probability of any false finding in the whole
report is at most ``alpha`` (weighted Bonferroni) when the standard errors hold; ``p_value`` is
the adjusted one (the raw p-value times the number of tests of its kind on its channel, at most
1); a finding has ``p_value <= alpha * ALPHA_SHARE[kind] / 6``.

1. ``correlation``: the residual follows a regressor (rate, angular acceleration, omega^2,
   specific force). Regressor and residual are first freed of a quadratic in time (a drift must
   not pass for a correlation); the slope ``beta = sum(x y) / sum(x^2)`` is tested with a
   batch-means standard error: the sums ``S_b = sum_b x e`` over :data:`CORRELATION_BATCHES`
   batches of consecutive time blocks, ``var(beta) = B / (B - 1) sum_b (S_b - mean S)^2 /
   (sum x^2)^2``, a Student t with ``B - 1`` degrees of freedom. That error holds for any
   product ``x e`` correlated over less than a batch (the HAC estimator with a flat kernel over
   whole batches). Greedy: the most significant
   regressor is taken, added to the nuisance, and the others tested again, at most
   :data:`MAX_CORRELATIONS` per channel. ``size`` = ``|beta|`` times the RMS of the regressor
   (freed of the quadratic in time). The found correlations are removed before the next tests.
2. ``step`` and 3. ``trend``: the means over time blocks (:data:`MIN_BLOCK_S` or longer, at most
   :data:`MAX_BLOCKS`) fitted by a quadratic in time plus a step at the best block boundary, and a
   quadratic in time against a constant: F tests against the residual's own low-frequency spectrum,
   not a white-noise formula (:mod:`.trends`, which gives the method). ``size`` = the step height,
   the peak-to-peak of the drift.
4. ``spectral_line``: the Welch spectrum of what remains after the correlations, each bin's power
   against the median of its neighbours (:mod:`.lines`, which gives the method). ``size`` = the
   line's amplitude.

A structure is reported only if its RMS over the record is at least :data:`SIZE_FLOOR` times the
channel's white noise sigma (:mod:`.kinds`, which also words each finding).
"""

from __future__ import annotations

import math

import numpy as np

from .kinds import ALPHA_SHARE, KINDS, SIZE_FLOOR, _sentence, _unit
from .lines import (
    FLOOR_HALF_BINS,
    GUARD_BINS,
    MAX_LINES,
    MIN_FLOOR_BINS,
    SIDELOBE_FRACTION,
    WELCH_MAX_NPERSEG,
    WELCH_MIN_NPERSEG,
    WELCH_MIN_SEGMENTS,
    _lines,
)
from .reference import DiagnoseError
from .theta import CHANNELS
from .trends import EXTRAPOLATION_Z, MAX_NOISE_SLOPE, _steps_and_trends, _time_poly

__all__ = [
    "unexplained",
    "KINDS",
    "ALPHA_SHARE",
    "SIZE_FLOOR",
    "MIN_BLOCK_S",
    "MAX_BLOCKS",
    "MIN_BLOCKS",
    "WELCH_MIN_SEGMENTS",
    "WELCH_MAX_NPERSEG",
    "WELCH_MIN_NPERSEG",
    "FLOOR_HALF_BINS",
    "GUARD_BINS",
    "MIN_FLOOR_BINS",
    "SIDELOBE_FRACTION",
    "MAX_LINES",
    "MAX_CORRELATIONS",
    "CORRELATION_BATCHES",
    "MAX_NOISE_SLOPE",
    "EXTRAPOLATION_Z",
    "GAP_FACTOR",
]

#: Shortest time block of the time-domain tests [s]: five times the 0.2 s correlation time of a
#: typical coloured residual, so that block means are nearly independent (lag-one correlation
#: about 0.2 for an AR(1) of 0.2 s; the whitening of the block tests allows for the rest).
MIN_BLOCK_S = 1.0
#: Most time blocks: 2 % of the record per block resolves a step's time to a few percent, and
#: 50 blocks give the F and t tests 45 or more degrees of freedom.
MAX_BLOCKS = 50
#: Fewest blocks for the time-domain tests (8 residual degrees of freedom for the step test);
#: shorter records are not tested for correlation, steps and trends.
MIN_BLOCKS = 12
#: Batches of the correlation test's batch-means error (consecutive time blocks merged): few and
#: long, since a slow regressor (a 0.1 Hz sway) times a slow residual (flicker) stays correlated over
#: many seconds; the Student t with CORRELATION_BATCHES - 1 degrees of freedom pays for the few.
CORRELATION_BATCHES = 12
#: Regressors a channel may follow, at most.
MAX_CORRELATIONS = 3
#: A jump in t_s larger than this many dt cuts the record like a row not kept.
GAP_FACTOR = 1.5


# --------------------------------------------------------------------------- the entry point


def unexplained(t_s, residual, keep, regressors, noise_sigma, *, alpha=0.01, max_line_hz=None) -> list[dict]:
    """Structure left in each channel's final residual: lines, trends, steps, correlations.

    Parameters
    ----------
    t_s : array [m]
        Row times [s], uniformly spaced by ``dt`` (the median spacing).
    residual : array [m, 6]
        Final residual per channel (:data:`sizefx.diagnose.theta.CHANNELS`), SI (rad/s, m/s^2).
    keep : bool array [m]
        Usable rows; the others (gaps, edges) are never bridged.
    regressors : dict name -> array [m]
        Physical quantities the residual may follow (``omega_x`` rad/s, ``omega_sq`` rad^2/s^2,
        ``omegadot_x`` rad/s^2, ``f_x`` m/s^2, ...).
    noise_sigma : array [6]
        Each channel's white (row-to-row) noise sigma, SI: the scale of the size floor.
    alpha : float
        Family-wise false-alarm level over every test of every channel.
    max_line_hz : float or None
        Look for spectral lines only up to this frequency (rows low-passed before: above the
        filter's pass band the spectrum is the filter's, not the residual's).

    Returns
    -------
    list of dict
        One per finding: ``channel``, ``kind`` (:data:`KINDS`), ``frequency_hz`` (lines, else
        None), ``regressor`` (correlations, else None), ``time_s`` (steps: the step's time [s],
        else None), ``size`` (SI, in ``unit``), ``unit``,
        ``statistic`` (the line's power over its floor, F for steps and trends, t for
        correlations), ``p_value`` (family-wise adjusted), ``sentence`` (report units).
        Ordered by channel, then kind as in :data:`KINDS`. Empty when every channel is
        consistent with (possibly coloured) noise.
    """
    t, y, keep, names, X, sigma = _checked(t_s, residual, keep, regressors, noise_sigma, alpha)
    dt = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    runs = _runs(t, keep, dt)
    level = {kind: alpha * share / len(CHANNELS) for kind, share in ALPHA_SHARE.items()}  # per channel and kind
    blocks = _blocks(t, keep, runs)
    design = _Design(t, X, blocks) if blocks is not None else None
    out = []
    for c, channel in enumerate(CHANNELS):
        found = []
        yc = y[:, c].copy()
        if blocks is not None:
            corr, yc = _correlations(yc, names, design, sigma[c], level["correlation"])
            yc[~keep] = 0.0
            found += corr
            found += _steps_and_trends(t, yc, keep, blocks, sigma[c], level)
        found += _lines(yc, runs, dt, sigma[c], level["spectral_line"], max_line_hz)
        for f in found:
            f["channel"] = channel
            f["unit"] = _unit(c)
            f["sentence"] = _sentence(c, f, t, keep)
        out += sorted(found, key=lambda f: KINDS.index(f["kind"]))
    return [
        {
            k: f.get(k)
            for k in (
                "channel",
                "kind",
                "frequency_hz",
                "regressor",
                "time_s",
                "size",
                "unit",
                "statistic",
                "p_value",
                "sentence",
            )
        }
        for f in out
    ]


def _checked(t_s, residual, keep, regressors, noise_sigma, alpha):
    t = np.asarray(t_s, dtype=float)
    y = np.asarray(residual, dtype=float)
    keep = np.asarray(keep)
    sigma = np.asarray(noise_sigma, dtype=float)
    m = t.size
    if t.ndim != 1 or y.shape != (m, len(CHANNELS)) or keep.shape != (m,) or keep.dtype != bool:
        raise ValueError(
            f"unexplained: t_s [m], residual [m, 6], keep [m] bool expected; got {t.shape}, "
            f"{y.shape}, {keep.shape} {keep.dtype}"
        )
    if sigma.shape != (len(CHANNELS),) or not np.all(np.isfinite(sigma) & (sigma > 0.0)):
        raise ValueError(f"unexplained: noise_sigma must be 6 positive finite sigmas, got {sigma}")
    if not 0.0 < alpha < 1.0:
        raise ValueError(f"unexplained: alpha {alpha} must lie in (0, 1)")
    if m > 1 and not np.all(np.diff(t) > 0.0):
        raise ValueError("unexplained: t_s must increase strictly")
    names = list(regressors)
    X = np.empty((m, len(names)))
    for j, name in enumerate(names):
        x = np.asarray(regressors[name], dtype=float)
        if x.shape != (m,):
            raise ValueError(f"unexplained: regressor {name} has shape {x.shape}, expected ({m},)")
        X[:, j] = x
    bad = ~np.all(np.isfinite(y[keep]), axis=1) | ~np.all(np.isfinite(X[keep]), axis=1) | ~np.isfinite(t[keep])
    if bad.any():
        k = int(np.flatnonzero(keep)[np.argmax(bad)])
        raise DiagnoseError(
            f"the residual or a regressor is not finite at t = {t[k]:g} s (row {k}) of a row marked "
            "usable; mask such rows (a reference dropout) before the structure tests"
        )
    return t, np.where(keep[:, None], y, 0.0), keep, names, np.where(keep[:, None], X, 0.0), sigma


def _runs(t, keep, dt):
    """[start, stop) of each stretch of kept rows without a time jump."""
    if t.size == 0:
        return []
    cut = np.zeros(t.size + 1, dtype=bool)
    cut[1:-1] = np.diff(t) > GAP_FACTOR * dt
    k = np.concatenate(([False], keep, [False]))
    starts = np.flatnonzero(k[1:-1] & (~k[:-2] | cut[:-1]))
    stops = np.flatnonzero(k[1:-1] & (~k[2:] | cut[1:])) + 1
    return list(zip(starts.tolist(), stops.tolist()))


# --------------------------------------------------------------------------- time blocks


def _blocks(t, keep, runs):
    """Row indices (kept rows only) of each time block, or None when the record is too short."""
    if not runs:
        return None
    t0, t1 = t[runs[0][0]], t[runs[-1][1] - 1]
    n_blocks = min(MAX_BLOCKS, int((t1 - t0) // MIN_BLOCK_S))
    if n_blocks < MIN_BLOCKS:
        return None
    edges = np.linspace(t0, t1, n_blocks + 1)
    edges[-1] = np.nextafter(t1, np.inf)
    idx = np.flatnonzero(keep)
    which = np.searchsorted(edges, t[idx], side="right") - 1
    bounds = np.searchsorted(which, np.arange(n_blocks + 1))
    blocks = [idx[bounds[b] : bounds[b + 1]] for b in range(n_blocks)]
    full = np.median([b.size for b in blocks])
    blocks = [b for b in blocks if b.size >= 0.5 * full]  # mostly gap: its mean is another quantity
    return blocks if len(blocks) >= MIN_BLOCKS else None


class _Design:
    """The kept rows of the time blocks, in order, and the regressors freed of a quadratic in time
    (shared by the six channels' correlation tests)."""

    def __init__(self, t, X, blocks):
        self.rows = np.concatenate(blocks)
        # batches of consecutive blocks: a slow regressor times a slow residual stays correlated over
        # several seconds, so the batch-means error needs long batches (CORRELATION_BATCHES of them)
        group = np.arange(len(blocks)) * CORRELATION_BATCHES // len(blocks)
        sizes = np.bincount(group, weights=[b.size for b in blocks]).astype(int)
        self.offsets = np.cumsum(np.concatenate(([0], sizes[:-1])))
        self.n_blocks = sizes.size
        self.q, _ = np.linalg.qr(_time_poly(t[self.rows], t[self.rows[0]], t[self.rows[-1]]))
        self.X = X
        self.Xt = self.free_of_time(X[self.rows])
        self.xx_blocks = np.add.reduceat(self.Xt**2, self.offsets, axis=0)  # [B, R]: per-block sums of x^2
        self.xx_raw = np.sum(X[self.rows] ** 2, axis=0)  # [R]: the regressors' energy before the time fit

    def free_of_time(self, A):
        return A - self.q @ (self.q.T @ A)


#: A regressor whose RMS, freed of the quadratic in time, is under this fraction of its raw RMS is
#: left out of the correlation tests (1e-6: far above rounding, far below any motion).
_CONSTANT_REGRESSOR = 1e-6


def _correlations(y, names, design, sigma, level):
    """Greedy block-t tests of one channel's residual ``y`` [m] on each regressor; returns the
    findings and the residual with the found correlations removed (on every row)."""
    from scipy.stats import t as student

    found: list[dict] = []
    if not names:
        return found, y
    d = design
    yt0 = d.free_of_time(y[d.rows])
    basis = np.empty((d.rows.size, 0))  # orthonormal basis of the chosen regressors (freed of time)
    chosen: list[int] = []
    for _ in range(min(MAX_CORRELATIONS, len(names))):
        free = [j for j in range(len(names)) if j not in chosen]
        if chosen:
            yt = yt0 - basis @ (basis.T @ yt0)
            xt = d.Xt[:, free] - basis @ (basis.T @ d.Xt[:, free])
            xx_blocks = np.add.reduceat(xt**2, d.offsets, axis=0)
        else:
            yt, xt, xx_blocks = yt0, d.Xt, d.xx_blocks
        sxx = xx_blocks.sum(axis=0)
        # a regressor this record holds (nearly) constant or quadratic in time is no regressor here: what is
        # left of it is rounding, and a residual "follows" rounding only by chance (f_z on a heading sway)
        ok = sxx > _CONSTANT_REGRESSOR**2 * d.xx_raw[free]
        beta = np.where(ok, xt.T @ yt / np.where(ok, sxx, 1.0), 0.0)
        # batch-means standard error: the per-block sums of x e, e = y - beta x
        s = np.add.reduceat(xt * yt[:, None], d.offsets, axis=0) - xx_blocks * beta[None, :]
        var = d.n_blocks / (d.n_blocks - 1.0) * np.sum((s - s.mean(axis=0)) ** 2, axis=0) / np.where(ok, sxx, 1.0) ** 2
        tstat = np.where(ok & (var > 0.0), np.abs(beta) / np.sqrt(np.where(var > 0.0, var, 1.0)), 0.0)
        p_adj = np.minimum(1.0, 2.0 * student.sf(tstat, d.n_blocks - 1) * len(names))
        size = np.abs(beta) * np.sqrt(sxx / d.rows.size)
        candidates = [i for i in range(len(free)) if p_adj[i] <= level and size[i] >= SIZE_FLOOR * sigma]
        if not candidates:
            break
        i = min(candidates, key=lambda i: (p_adj[i], -tstat[i]))
        chosen.append(free[i])
        found.append(
            {
                "kind": "correlation",
                "frequency_hz": None,
                "regressor": names[free[i]],
                "size": float(size[i]),
                "statistic": float(tstat[i]),
                "p_value": float(p_adj[i]),
            }
        )
        basis = np.column_stack((basis, xt[:, i] / math.sqrt(sxx[i])))
    if not chosen:
        return found, y
    # the joint fit of the chosen regressors (the time polynomial a nuisance), removed on every row
    coef, *_ = np.linalg.lstsq(d.Xt[:, chosen], yt0, rcond=None)
    # only the time-free part of the regressors was fitted: removing their raw values would put their
    # slow part back into the residual, where the trend and step tests would read it as a drift
    out = y.copy()
    out[d.rows] -= d.Xt[:, chosen] @ coef
    return found, out
