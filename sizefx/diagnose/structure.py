"""What the final model leaves unexplained: tests for structure in each channel's residual.

One module of some 600 lines on purpose: the four tests share the rows, the runs between gaps, the
time blocks and the family-wise level, and the correlations found are removed before the others
run; split, each would need all of that passed in.

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
2. ``step``: block means ``y_b`` (:data:`MIN_BLOCK_S` or longer, at most :data:`MAX_BLOCKS`)
   are fitted by a quadratic in time plus a step ``H(t - t_j)`` at each block boundary with at
   least two blocks on each side, by generalised least squares under the noise model below; the
   largest F statistic (1 and ``B - 4`` degrees of freedom),
   Bonferroni over the boundaries. The step time is then refined row by row over the two blocks
   at the boundary (the split that maximises ``k (n - k) (mean_left - mean_right)^2``).
   ``size`` = the step height.
3. ``trend``: the same block means, a quadratic in time (plus the step, if one was found) against
   a constant (plus the step): an F test with 2 and ``B - p`` degrees of freedom. ``size`` = the
   peak-to-peak of the fitted drift over the record.

   Both block tests are a test against the residual's own low-frequency spectrum, not a
   white-noise formula: block means of coloured noise (flicker, a random walk) are not
   independent, and a smooth contrast of them is much more variable than white noise would
   allow. The block means are taken to the DCT-II basis, where such noise is nearly uncorrelated,
   and each coefficient is divided by the square root of a power law ``k^-gamma`` (``gamma`` in
   [0, :data:`MAX_NOISE_SLOPE`]) fitted to the fuller model's residual (:func:`_whitener`); the
   F tests are then ordinary F tests of the whitened rows. The drift's own two lowest
   coefficients get the spectrum extrapolated :data:`EXTRAPOLATION_Z` standard errors of the
   slope upwards.
4. ``spectral_line``: the Welch spectrum (Hann window, 50 % overlap, constant detrend, segments
   of :data:`WELCH_MIN_SEGMENTS` or more per record, inside runs) of what remains after the
   correlations. Each bin's power is compared with the median of its neighbours (at most
   :data:`FLOOR_HALF_BINS` on each side, symmetric so that the median of a monotone spectrum,
   1/f or 1/f^2, is the spectrum at the bin itself; :data:`GUARD_BINS` on each side left out for
   the window's main lobe), corrected for the median's bias. The ratio is an F variable with
   Welch's equivalent degrees of freedom ``nu`` (``2 K`` corrected for the overlap, Percival &
   Walden 1993, eq. 292b) over those of the floor (``nu`` times the neighbours, times 2/pi for a
   median, times 1/2 for the correlation of adjacent bins): nearly the chi-square test of
   ``nu P / floor``, with the floor's own scatter allowed for. Bonferroni over all tested bins
   (bins with fewer than :data:`MIN_FLOOR_BINS` neighbours are not tested: the lowest few
   frequencies belong to the trend test). Adjacent significant bins form one line, at the peak,
   its frequency interpolated on the log power; a weaker peak within the floor window at less
   than :data:`SIDELOBE_FRACTION` of a stronger one is taken for its leakage. ``size`` = the
   amplitude ``sqrt(2 sum (P - floor) df)`` over the line's main lobe.

Size floor
----------
A structure is reported only if its RMS over the record is at least :data:`SIZE_FLOOR` times the
channel's white noise sigma (``noise_sigma``): a line ``A / sqrt(2)``, a drift its RMS about the
mean, a step ``h sqrt(p (1 - p))`` (``p`` the share of the record before it), a correlation
``|beta| rms(x)``. Below it the structure adds less than 1 % to the residual's variance, and a
huge record makes it significant without making it worth a sentence.

At most :data:`MAX_LINES` lines (the largest) are reported per channel.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from ..constants import DEG_PER_H, MICRO_G
from .reference import DiagnoseError
from .theta import CHANNELS

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

#: The kinds of structure, in the order they are tested.
KINDS = ("correlation", "step", "trend", "spectral_line")
#: Share of the family-wise level per kind (they sum to one: weighted Bonferroni).
ALPHA_SHARE = {kind: 0.25 for kind in KINDS}
#: Smallest reported structure, as its RMS over the record relative to the white noise sigma:
#: 0.1 adds 1 % to the residual's variance, less than the scatter of a fitted sigma is worth.
SIZE_FLOOR = 0.1
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
#: Welch: at least this many half-overlapping segments per record (``nu`` about 30 at the least).
WELCH_MIN_SEGMENTS = 16
#: Welch: the longest segment [rows] (0.1 Hz resolution at 1600 Hz; longer adds nothing to the
#: lines of mounts and fixtures, and costs degrees of freedom).
WELCH_MAX_NPERSEG = 16384
#: Welch: the shortest segment [rows]; runs shorter than this are left out of the spectrum.
WELCH_MIN_NPERSEG = 64
#: Neighbours on each side of a bin for its noise floor (a running median).
FLOOR_HALF_BINS = 16
#: Bins on each side of a bin left out of its floor: the Hann window's main lobe is +-2 bins.
GUARD_BINS = 3
#: Fewest neighbours (both sides together) for a bin to be tested.
MIN_FLOOR_BINS = 8
#: A weaker peak within FLOOR_HALF_BINS of a stronger one, under this share of its power, is
#: its leakage (Hann sidelobes: -31 dB at 2.5 bins, falling 18 dB per octave), not a line.
SIDELOBE_FRACTION = 1e-2
#: Lines reported per channel at most (the largest).
MAX_LINES = 5
#: Batches of the correlation test's batch-means error (consecutive time blocks merged): few and
#: long, since a slow regressor (a 0.1 Hz sway) times a slow residual (flicker) stays correlated over
#: many seconds; the Student t with CORRELATION_BATCHES - 1 degrees of freedom pays for the few.
CORRELATION_BATCHES = 12
#: Regressors a channel may follow, at most.
MAX_CORRELATIONS = 3
#: Steepest power law of the block means' noise spectrum the block tests allow for: 2, a random
#: walk (a bias random walk is sensor noise, not a drift); steeper would let a drift explain itself.
MAX_NOISE_SLOPE = 2.0
#: Standard errors of the fitted noise slope added when the block tests extrapolate the noise
#: spectrum to the two lowest coefficients (where a drift lies): one, so that a flicker whose slope
#: the record measures poorly does not pass for a drift (tests/test_diagnose_structure.py, coloured).
EXTRAPOLATION_Z = 1.0
#: A jump in t_s larger than this many dt cuts the record like a row not kept.
GAP_FACTOR = 1.5

#: Physical causes, per kind, for the sentences.
_CAUSE = {
    "spectral_line": "a vibration or structural resonance outside the model",
    "trend": "a drifting bias (temperature?)",
    "step": "a step: a re-mount, a range switch or a reference jump",
}


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


def _time_poly(t, t0, t1):
    """[1, tau, tau^2] with tau = t scaled to [-1, 1] over [t0, t1] (well conditioned)."""
    tau = (2.0 * (t - t0) / (t1 - t0) - 1.0) if t1 > t0 else np.zeros_like(t)
    return np.column_stack((np.ones_like(t), tau, tau**2))


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


@functools.lru_cache(maxsize=4)
def _dct_matrix(n):
    """The orthonormal DCT-II matrix [n, n] (read-only: shared between calls)."""
    from scipy.fft import dct

    out = dct(np.eye(n), norm="ortho", axis=0)
    out.flags.writeable = False
    return out


def _whitener(e):
    """[B, B]: the orthonormal DCT-II of the block means, each coefficient k divided by the square
    root of a power law ``k^-gamma`` fitted to the log power of coefficients 3..B-1 of the fuller
    model's residual ``e`` (``gamma`` in [0, 2]: white to random walk). Block means of coloured
    noise (flicker, a random walk) are nearly uncorrelated in this basis with that spectrum; the
    two lowest coefficients, which a drift occupies, take the extrapolated spectrum, raised by
    EXTRAPOLATION_Z standard errors of the fitted slope (the log of a chi-square(1) power scatters
    by pi / sqrt(2)): a drift must stand out from the noise's low end, not just from its fit."""
    n = e.size
    dct_matrix = _dct_matrix(n)
    k = np.arange(n, dtype=float)
    power = (dct_matrix @ e) ** 2
    fit = slice(3, n)
    ok = power[fit] > 0.0
    gamma, margin = 0.0, np.zeros(n)
    if ok.sum() >= 3:
        log_k = np.log(k[fit][ok])
        gamma = -float(np.polyfit(log_k, np.log(power[fit][ok]), 1)[0])
        gamma = min(max(gamma, 0.0), MAX_NOISE_SLOPE)
        se_gamma = (math.pi / math.sqrt(2.0)) / math.sqrt(float(np.sum((log_k - log_k.mean()) ** 2)))
        margin[1:3] = EXTRAPOLATION_Z * se_gamma * (log_k.mean() - np.log(k[1:3]))
    spectrum = np.maximum(k, 1.0) ** -gamma * np.exp(margin)
    return dct_matrix / np.sqrt(spectrum)[:, None]


def _gls(W, A, y):
    """Least squares of y on the columns of A after whitening with W: coefficients and the whitened RSS."""
    coef, *_ = np.linalg.lstsq(W @ A, W @ y, rcond=None)
    r = W @ (y - A @ coef)
    return coef, float(r @ r)


def _f_test(y, base, extra, W=None):
    """F statistic and its degrees of freedom for adding the columns ``extra`` to ``base``, under
    the power-law noise of the fuller model's residual (:func:`_whitener`) unless ``W`` is given;
    the fuller model's coefficients."""
    full = np.column_stack((base, extra))
    if W is None:
        coef, *_ = np.linalg.lstsq(full, y, rcond=None)
        W = _whitener(y - full @ coef)
    coef, rss_full = _gls(W, full, y)
    _, rss_base = _gls(W, base, y)
    dof = y.size - full.shape[1]
    F = (rss_base - rss_full) / extra.shape[1] / max(rss_full / dof, np.finfo(float).tiny)
    return F, dof, coef


def _steps_and_trends(t, y, keep, blocks, sigma, level):
    from scipy.stats import f as fisher

    found = []
    yb = np.array([y[b].mean() for b in blocks])
    tb = np.array([t[b].mean() for b in blocks])
    n_blocks = yb.size
    t0, t1 = t[blocks[0][0]], t[blocks[-1][-1]]
    Z = _time_poly(tb, t0, t1)
    # step: the best boundary j (blocks j.. after the step), at least two blocks on each side, over
    # a quadratic in time
    splits = np.arange(2, n_blocks - 1)
    best = None
    for j in splits:
        H = (np.arange(n_blocks) >= j).astype(float)[:, None]
        F, dof, coef = _f_test(yb, Z, H)
        if best is None or F > best[0]:
            best = (F, dof, j, coef)
    step_col = None
    if best is not None:
        F, dof, j, coef = best
        p_adj = min(1.0, float(fisher.sf(F, 1, dof)) * splits.size)
        t_step = _refine_step(t, y, blocks[j - 1], blocks[j], Z @ coef[:3], tb)
        share = float(np.mean(t[np.concatenate(blocks)] < t_step))
        height = float(coef[3])
        if p_adj <= level["step"] and abs(height) * math.sqrt(share * (1.0 - share)) >= SIZE_FLOOR * sigma:
            step_col = (tb >= t_step).astype(float)
            found.append(
                {
                    "kind": "step",
                    "frequency_hz": None,
                    "regressor": None,
                    "size": abs(height),
                    "signed": height,
                    "time_s": t_step,
                    "statistic": float(F),
                    "p_value": p_adj,
                }
            )
    # trend: a quadratic in time against a constant, the step (if found) in both
    base = np.ones((n_blocks, 1)) if step_col is None else np.column_stack((np.ones(n_blocks), step_col))
    F, dof, coef = _f_test(yb, base, Z[:, 1:])
    p_adj = float(min(1.0, fisher.sf(F, 2, dof)))
    tt = np.linspace(t0, t1, 201)
    drift = _time_poly(tt, t0, t1)[:, 1:] @ coef[-2:]
    drift_blocks = Z[:, 1:] @ coef[-2:]
    if p_adj <= level["trend"] and float(np.std(drift_blocks)) >= SIZE_FLOOR * sigma:
        found.append(
            {
                "kind": "trend",
                "frequency_hz": None,
                "regressor": None,
                "size": float(np.ptp(drift)),
                "signed": float(drift[-1] - drift[0]),
                "span_s": float(t1 - t0),
                "statistic": float(F),
                "p_value": p_adj,
            }
        )
    return found


def _refine_step(t, y, before, after, trend_blocks, tb):
    """The row-level time of a step between two adjacent blocks: the split of their kept rows
    (freed of the fitted trend) that maximises k (n - k) (mean_left - mean_right)^2."""
    rows = np.concatenate((before, after))
    r = y[rows] - np.interp(t[rows], tb, trend_blocks)
    n = r.size
    k = np.arange(1, n)
    c = np.cumsum(r)[:-1]
    left = c / k
    right = (r.sum() - c) / (n - k)
    score = k * (n - k) * (left - right) ** 2
    i = int(np.argmax(score))
    return float(0.5 * (t[rows[i]] + t[rows[i + 1]]))


# --------------------------------------------------------------------------- the spectrum


def _lines(y, runs, dt, sigma, level, max_hz=None):
    """Spectral lines of one channel's residual over its local floor (see the module docstring)."""
    from scipy.stats import f as fisher

    if dt <= 0.0:
        return []
    n_kept = sum(b - a for a, b in runs)
    longest = max((b - a for a, b in runs), default=0)
    nper = 2 ** int(math.floor(math.log2(max(2.0, 2.0 * n_kept / (WELCH_MIN_SEGMENTS + 1)))))
    nper = min(nper, WELCH_MAX_NPERSEG, 2 ** int(math.floor(math.log2(max(longest, 1)))))
    if nper < WELCH_MIN_NPERSEG:
        return []
    step = nper // 2
    starts, per_run = [], []
    for a, b in runs:
        s = list(range(a, b - nper + 1, step))
        starts += s
        if s:
            per_run.append(len(s))
    window = np.hanning(nper + 1)[:-1]  # periodic Hann: exact 50 % overlap-add
    fs = 1.0 / dt
    seg = np.lib.stride_tricks.sliding_window_view(y, nper)[np.array(starts)]
    seg = seg - seg.mean(axis=1, keepdims=True)
    power = np.mean(np.abs(np.fft.rfft(seg * window, axis=1)) ** 2, axis=0) / (fs * np.sum(window**2))
    power[1:-1] *= 2.0  # one-sided
    df = fs / nper
    # Welch's equivalent degrees of freedom: K segments, neighbours correlated by rho1^2
    rho1 = float(np.sum(window[:-step] * window[step:]) / np.sum(window**2))
    k_total = sum(per_run)
    var = sum(k**2 * (1.0 + 2.0 * (1.0 - 1.0 / k) * rho1**2) / k for k in per_run) / k_total**2
    nu = 2.0 / var
    median_bias = (1.0 - 2.0 / (9.0 * nu)) ** 3  # median of chi2(nu) / nu (Wilson-Hilferty)
    n_bins = power.size
    floor, n_nb = _floor(power)
    floor /= median_bias
    tested = np.isfinite(floor) & (floor > 0.0)
    if max_hz is not None:
        tested &= np.arange(n_bins) * df <= max_hz
    n_tests = int(tested.sum())
    if n_tests == 0:
        return []
    ratio = np.where(tested, power / np.where(tested, floor, 1.0), 0.0)
    nu_floor = nu * n_nb * (2.0 / math.pi) * 0.5
    p = np.ones(n_bins)
    p[tested] = fisher.sf(ratio[tested], nu, nu_floor[tested])
    p_adj = np.minimum(1.0, p * n_tests)
    sig = np.flatnonzero(p_adj <= level)
    if sig.size == 0:
        return []
    groups = np.split(sig, np.flatnonzero(np.diff(sig) > GUARD_BINS) + 1)
    peaks = sorted((int(g[np.argmax(power[g])]) for g in groups), key=lambda k: -power[k])
    lines: list[int] = []
    for k in peaks:
        if any(abs(k - q) <= FLOOR_HALF_BINS and power[k] < SIDELOBE_FRACTION * power[q] for q in lines):
            continue  # leakage of a stronger line
        lines.append(k)
    found = []
    for k in lines:
        lo, hi = max(1, k - GUARD_BINS + 1), min(n_bins - 1, k + GUARD_BINS)
        amplitude = math.sqrt(2.0 * max(0.0, float(np.sum(power[lo:hi] - floor[k]))) * df)
        if amplitude / math.sqrt(2.0) < SIZE_FLOOR * sigma:
            continue
        found.append(
            {
                "kind": "spectral_line",
                "frequency_hz": _peak_hz(power, k, df),
                "regressor": None,
                "size": amplitude,
                "statistic": float(ratio[k]),
                "p_value": float(p_adj[k]),
            }
        )
    return sorted(found, key=lambda f: -f["size"])[:MAX_LINES]


def _floor(power):
    """Per bin: the median of its neighbours (symmetric, guard bins left out, never the DC or Nyquist
    bin) and their number; NaN where fewer than MIN_FLOOR_BINS neighbours exist."""
    n_bins = power.size
    floor = np.full(n_bins, np.nan)
    n_nb = np.zeros(n_bins, dtype=int)
    for h in range(GUARD_BINS + (MIN_FLOOR_BINS + 1) // 2, FLOOR_HALF_BINS + 1):
        # bins whose half-width is h: the two edges for h < FLOOR_HALF_BINS, the interior for h = FLOOR_HALF_BINS
        k = np.arange(1, n_bins - 1)
        k = k[np.minimum(np.minimum(k - 1, n_bins - 2 - k), FLOOR_HALF_BINS) == h]
        if k.size == 0:
            continue
        offsets = np.concatenate((np.arange(-h, -GUARD_BINS), np.arange(GUARD_BINS + 1, h + 1)))
        floor[k] = np.median(power[k[:, None] + offsets[None, :]], axis=1)
        n_nb[k] = offsets.size
    return floor, n_nb


def _peak_hz(power, k, df):
    """The peak's frequency, by a parabola through the log power of bins k-1, k, k+1."""
    if 1 <= k < power.size - 1 and np.all(power[k - 1 : k + 2] > 0.0):
        a, b, c = np.log(power[k - 1 : k + 2])
        den = a - 2.0 * b + c
        shift = 0.5 * (a - c) / den if den < 0.0 else 0.0
        return float((k + max(-0.5, min(0.5, shift))) * df)
    return float(k * df)


# --------------------------------------------------------------------------- words


def _unit(c):
    return "rad/s" if c < 3 else "m/s^2"


def _report(c, value_si):
    """A value of channel c in report units, as text."""
    if c < 3:
        return f"{value_si / DEG_PER_H:.3g} deg/h"
    return f"{value_si / MICRO_G:.3g} ug"


def _regressor_cause(name, channel):
    if name in ("omega_sq", "omega2", "omega_squared"):
        return f"an effect proportional to omega^2 on {channel} that no candidate explains"
    if name.startswith("omegadot"):
        return (
            f"an effect proportional to angular acceleration on {channel} (an arm or a delay the model does not hold)"
        )
    if name.startswith("omega"):
        return f"a rate-dependent effect on {channel} (scale-factor nonlinearity, a rate-dependent misalignment)"
    if name.startswith("f_"):
        return f"a specific-force dependence on {channel} (g-sensitivity or nonlinearity beyond the candidates)"
    return f"an effect following {name} on {channel} that no candidate explains"


def _sentence(c, f, t, keep):
    channel = CHANNELS[c]
    kind = f["kind"]
    if kind == "spectral_line":
        return f"{channel}: a line at {f['frequency_hz']:.2f} Hz, amplitude {_report(c, f['size'])}: {_CAUSE[kind]}"
    if kind == "trend":
        return (
            f"{channel}: a drift of {_report(c, f['signed'])} over {f['span_s']:.0f} s (peak to peak "
            f"{_report(c, f['size'])}): {_CAUSE[kind]}"
        )
    if kind == "step":
        return f"{channel}: a step of {_report(c, f['signed'])} at t = {f['time_s']:.3f} s: {_CAUSE[kind]}"
    return (
        f"{channel}: follows {f['regressor']}, {_report(c, f['size'])} RMS: {_regressor_cause(f['regressor'], channel)}"
    )
