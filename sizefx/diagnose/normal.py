"""The linear algebra under the selection: rows, block-wise normal equations, honest covariances.

One Gauss-Newton pass linearises the prediction at the current estimate; every question the
selection and the checks ask is then answered from weighted normal equations kept **per block**
(contiguous stretches of the record, :func:`block_length_s`), never from the samples again:

- :class:`Rows` turns samples into the rows of the fit (block means, or a zero-phase low-pass
  and decimation with a bandwidth), the same for the residual and every regressor;
- :func:`normal_equations` sums ``H' W H``, ``H' W y`` and ``y' W y`` per block, with per-channel
  weights ``W`` times per-row robust weights (:func:`huber_weights`);
- :func:`solve` fits a parameter set with the others pinned;
- :func:`covariance` gives the white-noise covariance ``N^-1`` and the **cluster-robust
  (block) sandwich** ``N^-1 (sum_b s_b s_b') N^-1`` with the block scores ``s_b = b_b - N_b x``
  (Liang-Zeger / batch means): it holds for heteroskedastic and autocorrelated residuals as long
  as the scores decorrelate within a block, which is why blocks are long (a second or more);
- :func:`wald` tests a group of parameters with that covariance (chi-square with as many degrees
  of freedom as the group has parameters);
- :func:`cv_error`: the cross-validated error over interleaved folds of blocks;
- :func:`excitation`, :func:`canonical_correlation`: what the motion shows of a parameter, and
  how far two groups of parameters can be told apart, noise-free.

:func:`solve`, :func:`wald`, :func:`canonical_correlation` and the sandwich's meat
(:func:`long_run_meat`) are the algebra of the summed matrices, which knows nothing of rows or
blocks: :mod:`.algebra` holds them, and they are imported from here as before.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError
from .algebra import (
    DEGENERATE,
    HAC_MAX_RHO,
    _pinned,
    canonical_correlation,
    hac_lag,
    long_run_meat,
    solve,
    wald,
)
from .drift import NO_DRIFT, TERMS, Drift, basis, intensity
from .spectrum import BlockNoise, haar_splits, levels_for
from .theta import NP, PARAMS

__all__ = [
    "Normal",
    "Rows",
    "block_length_s",
    "block_means",
    "canonical_correlation",
    "covariance",
    "cv_error",
    "excitation",
    "huber_weights",
    "normal_equations",
    "solve",
    "wald",
    "CHUNK_SAMPLES",
    "FILTER_SETTLE",
    "FOLDS",
    "MAX_ROWS",
    "TARGET_BLOCKS",
    "MIN_BLOCK_S",
    "HUBER_K",
    "DEGENERATE",
    "HAC_MAX_RHO",
    "hac_lag",
    "long_run_meat",
    "block_scores",
]

#: Rows kept for the fit after block averaging: a two-minute record at 1600 Hz is fitted sample
#: by sample; longer records are averaged in blocks (y and regressors alike, so the model stays exact).
MAX_ROWS = 250_000
#: Cross-validation folds: interleaved blocks.
FOLDS = 5
#: Blocks the record is cut into for the robust covariance: 100 blocks estimate a variance to
#: +-14 % (sqrt(2/100)), and leave the sandwich well conditioned for the ~20 parameters a rich
#: diagnosis frees. Never shorter than :data:`MIN_BLOCK_S`: scores must decorrelate within a block.
TARGET_BLOCKS = 100
MIN_BLOCK_S = 0.25
#: Samples whose regressors and prediction are formed at once: the Jacobian columns take about
#: 650 bytes per sample and the sensor model's terms 400, so a chunk holds about 35 MiB whatever the
#: record's length (with a bandwidth, plus the low-pass's margins: :meth:`Rows.spans`).
CHUNK_SAMPLES = 32_768
#: What the low-pass's start-up transient may leave at a span's edge, relative to the signal: the
#: spans' rows then equal the whole series' to rounding (its slowest pole to the power of
#: :attr:`Rows.margin`; 2800 samples at 10 Hz in a 1600 Hz record).
FILTER_SETTLE = 1e-18
#: Huber's constant in units of the channel's robust sigma: 3 leaves Gaussian rows untouched
#: (0.3 % of them are down-weighted, by at most a few percent) and caps a glitch's pull.
HUBER_K = 3.0


def block_means(x, L):
    """Means of consecutive blocks of ``L`` rows of ``x`` [n, ...] (a last partial block is dropped)."""
    n = (x.shape[0] // L) * L
    return x[:n].reshape(-1, L, *x.shape[1:]).mean(axis=1)


def block_length_s(span_s: float) -> float:
    """Length of the blocks of the normal equations [s]: :data:`TARGET_BLOCKS` over the span, at least
    :data:`MIN_BLOCK_S`."""
    return max(MIN_BLOCK_S, span_s / TARGET_BLOCKS)


class Rows:
    """How the samples become the rows of the fit, the same for the residual and every regressor.

    Without a bandwidth: means over blocks of ``L`` samples (``L = 1`` for records up to
    :data:`MAX_ROWS` samples). With ``bandwidth_hz``: a zero-phase 4th-order Butterworth
    low-pass (``scipy.signal.sosfiltfilt``), then every ``L``-th sample with ``L`` giving
    2.5 samples per period of the cut-off. A linear filter applied to both sides keeps the
    model exact (``F y = (F H) theta + F e``); it is what a reference differentiated from
    noisy motion capture needs, whose noise grows with frequency. Unusable samples are set
    to zero before filtering and their neighbourhood (three periods of the cut-off) is left out.

    Span by span (:meth:`spans`, :meth:`extended`, :meth:`span_rows`): the rows of the samples
    ``lo:hi`` from the samples :meth:`extended` gives, equal to the whole series' rows there. Block
    means need nothing beyond the span; the low-pass needs :attr:`margin` samples on either side,
    where its start-up transient (the filter's slowest pole, to the power of the margin) has fallen
    below :data:`FILTER_SETTLE`. Only the rows, at most :data:`MAX_ROWS` of them, are ever held.
    """

    def __init__(self, t, mask, dt, bandwidth_hz=None):
        n = t.size
        self.n = n
        self.bandwidth_hz = bandwidth_hz
        self.margin = 0
        if bandwidth_hz is not None:
            from scipy.signal import butter, sos2zpk

            nyquist = 0.5 / dt
            if not 0.0 < bandwidth_hz < 0.8 * nyquist:
                raise ConfigError(
                    f"--bandwidth-hz {bandwidth_hz:g} must lie between 0 and {0.8 * nyquist:g} Hz "
                    f"(0.8 times the Nyquist frequency of this {1 / dt:g} Hz record)"
                )
            self.sos = butter(4, bandwidth_hz / nyquist, output="sos")
            self.L = max(1, math.floor(1.0 / (2.5 * bandwidth_hz * dt)), math.ceil(n / MAX_ROWS))
            pad = max(1, round(3.0 / (bandwidth_hz * dt)))
            # bad[i]: an unusable sample within pad of i (a running window over the mask, at the rows only)
            unusable = np.concatenate([[0], np.cumsum(~np.asarray(mask, dtype=bool))])
            at = np.arange(0, n, self.L)
            bad = unusable[np.minimum(n, at + pad + 1)] - unusable[np.maximum(0, at - pad)] > 0
            self.mask = mask
            keep = ~bad
            self.t = t[:: self.L]
            radius = float(np.max(np.abs(sos2zpk(self.sos)[1])))
            self.margin = min(n, math.ceil(math.log(FILTER_SETTLE) / math.log(radius)))
        else:
            self.L = max(1, math.ceil(n / MAX_ROWS))
            self.mask = mask
            keep = block_means(mask.astype(float), self.L) == 1.0 if self.L > 1 else mask
            self.t = block_means(t, self.L) if self.L > 1 else t
        self.keep = keep
        self.dt = dt * self.L

    def spans(self, step: int | None = None) -> list:
        """``[(lo, hi)]``: consecutive spans of about ``step`` samples (:data:`CHUNK_SAMPLES`; with a
        low-pass at least four margins, so that the margins cost at most half again) covering the
        record, each starting at a multiple of ``L``."""
        step = max(CHUNK_SAMPLES if step is None else step, 4 * self.margin)
        step = max(1, step // self.L) * self.L
        return [(lo, min(self.n, lo + step)) for lo in range(0, self.n, step)]

    def extended(self, lo: int, hi: int) -> tuple:
        """The samples ``[a, b)`` :meth:`span_rows` needs for the rows of ``lo:hi``."""
        return max(0, lo - self.margin), min(self.n, hi + self.margin)

    def span_rows(self, x, a: int, lo: int, hi: int):
        """Rows of the samples ``lo:hi`` (starting at a multiple of ``L``) from ``x`` [b - a, ...], the
        samples :meth:`extended` gives; they are the rows ``lo // L`` on of the whole series."""
        if self.bandwidth_hz is None:
            return block_means(x[lo - a : hi - a], self.L) if self.L > 1 else x[lo - a : hi - a]
        from scipy.signal import sosfiltfilt

        b = a + x.shape[0]
        x = np.where(self.mask[a:b].reshape(-1, *([1] * (x.ndim - 1))), x, 0.0)
        return sosfiltfilt(self.sos, x, axis=0)[lo - a : hi - a : self.L]

    def __call__(self, x):
        """Rows ``[m, ...]`` of a per-sample series ``x [n, ...]`` (all rows; index with ``keep``)."""
        if self.bandwidth_hz is not None:
            from scipy.signal import sosfiltfilt

            x = np.where(self.mask.reshape(-1, *([1] * (x.ndim - 1))), x, 0.0)
            return sosfiltfilt(self.sos, x, axis=0)[:: self.L]
        return block_means(x, self.L) if self.L > 1 else x


@dataclass
class Normal:
    """Weighted normal equations per block of the record; sums over blocks give the whole record."""

    N: np.ndarray  #: [B, P, P]
    b: np.ndarray  #: [B, P]
    yy: np.ndarray  #: [B]
    rows: int
    excitation: np.ndarray  #: [P] RMS of each regressor over its primary channels (SI)
    block_s: float  #: block length [s]
    t0: np.ndarray  #: [B] start time of each block [s]
    drift: Drift = NO_DRIFT  #: the walk of each channel's bias and the regressors' sums against its basis
    noise: BlockNoise | None = None  #: block sums for :func:`sizefx.diagnose.spectrum.spectral_meat`

    @property
    def blocks(self) -> int:
        return self.N.shape[0]

    def total(self) -> tuple[np.ndarray, np.ndarray, float]:
        return self.N.sum(0), self.b.sum(0), float(self.yy.sum())

    def fold(self) -> np.ndarray:
        """Fold of each block (interleaved: block k in fold k mod :data:`FOLDS`)."""
        return np.arange(self.blocks) % FOLDS

    def groups(self, K: int) -> list:
        """``K`` contiguous groups of blocks (index arrays), as equal as the blocks allow."""
        return [g for g in np.array_split(np.arange(self.blocks), K) if g.size]


def huber_weights(u: np.ndarray, k: float = HUBER_K) -> np.ndarray:
    """Huber's weights ``min(1, k / |u|)`` of standardised residuals ``u``."""
    a = np.abs(u)
    return np.where(a > k, k / np.maximum(a, 1e-300), 1.0)


def normal_equations(
    rows_of: Rows, y, cols, weights, row_weights=None, walk: bool = False, blocks_of: Normal | None = None
) -> Normal:
    """The weighted normal equations of the residual on the Jacobian columns ``cols``
    (:func:`sizefx.diagnose.candidates.jacobian_columns`), one set per block; ``weights`` [6] per
    channel, ``row_weights`` [m, 6] per row of :class:`Rows` (robust weights; None: all 1).

    ``y``: the residual's rows ``[m, 6]`` (``rows_of``'s, all of them: ``rows_of(residual)`` of a
    per-sample residual, or built span by span). ``cols`` is the columns' dict for all samples, or a function
    ``(lo, hi) -> dict`` for the samples ``lo:hi``, called span by span (:meth:`Rows.spans`) so that
    only one span of regressors is held at a time.

    ``walk``: measure the walk of each channel's bias (:func:`sizefx.diagnose.drift.intensity`) and
    keep the regressors' sums against the walk's basis (:attr:`Normal.drift`), from which
    :func:`sizefx.diagnose.drift.walk_covariance` gives the error the walk adds to the estimates;
    and keep the block sums :func:`sizefx.diagnose.spectrum.spectral_meat` takes the estimates'
    covariance from (:attr:`Normal.noise`). The final fit's equations are formed so.

    ``blocks_of``: cut the blocks where those equations' blocks start (:attr:`Normal.t0`), so that
    block ``k`` of both holds the same stretch of time (rows before the first start go to the first
    block): the same record in another band, whose first usable row differs by the filter's margin."""
    keep = rows_of.keep
    rows = np.flatnonzero(keep)
    t = rows_of.t[rows]
    span = float(t[-1] - t[0]) if t.size > 1 else 0.0
    block_s = block_length_s(span)
    if blocks_of is not None:
        block_s = blocks_of.block_s
        block = np.maximum(np.searchsorted(blocks_of.t0, t, side="right") - 1, 0)
    else:
        block = np.minimum(np.floor((t - t[0]) / block_s).astype(int), max(0, int(span // block_s) - 1))
    B = int(block.max()) + 1 if block.size else 1
    edges = np.searchsorted(block, np.arange(B + 1))
    full = np.flatnonzero(np.diff(edges) > 0)  # blocks inside a gap hold no rows: not blocks at all
    edges = np.append(edges[full], edges[full[-1] + 1]) if full.size else edges[:2]
    B = max(1, edges.size - 1)
    yb = np.asarray(y)[rows]
    rw = np.ones_like(yb) if row_weights is None else np.asarray(row_weights)[rows]
    block_of = np.repeat(np.arange(B), np.diff(edges))  # block of each kept row
    sumsq = np.zeros(NP)
    count = np.zeros(NP)
    N = np.zeros((B, NP, NP))
    b = np.zeros((B, NP))
    yy = np.zeros(B)
    L = rows_of.L
    cols_of = cols if callable(cols) else (lambda lo, hi: {j: (ch, x[lo:hi]) for j, (ch, x) in cols.items()})
    t0, span_s = (float(t[0]), span) if t.size else (0.0, 0.0)
    walking = list(range(6)) if walk and span_s > 0 else []
    K = TERMS
    # for the spectral covariance (walk): per channel the block sums of the weighted regressors and
    # the splits of each block scale by scale (spectrum.haar_splits); per block the rows and the residual's sums
    g_sum = np.zeros((6, B, NP)) if walk else None
    levels = levels_for(int(np.diff(edges).max())) if walk else 0
    d_sum = np.zeros((6, levels, NP, NP)) if walk else None
    u_sum, u_count = np.zeros((6, levels)), np.zeros((6, levels))
    counts, ysum = np.zeros(B), np.zeros((B, 6))
    block_rows = np.diff(edges)  # rows of each block in the whole record
    waiting: dict = {}  # channel -> (block, weighted regressors, residual) of a block a span ended inside
    jxs: dict = {}  # channel -> the parameters of those regressors
    NU = {c: np.zeros((NP, K)) for c in walking}
    UU = {c: np.zeros((K, K)) for c in walking}
    bU = {c: np.zeros(K) for c in walking}
    for lo, hi in rows_of.spans():
        a, z = np.searchsorted(rows, [lo // L, -(-hi // L)])  # the kept rows inside [lo, hi)
        if z <= a:
            continue
        ea, eb = rows_of.extended(lo, hi)
        cc = cols_of(ea, eb)
        local = rows[a:z] - lo // L
        bl = block_of[a:z]
        ks = np.arange(bl[0], bl[-1] + 1)  # every block between holds rows here: blocks are contiguous
        le = np.searchsorted(bl, np.append(ks, ks[-1] + 1))
        Z = basis(t[a:z], t0, span_s) if walking else None
        if g_sum is not None:
            counts[ks] += np.diff(le)  # rows of each block met so far
            ysum[ks] += np.add.reduceat(yb[a:z], le[:-1], axis=0)
        for c in range(6):
            js = [j for j in range(NP) if c in cc[j][0]]
            if not js:
                continue
            w = weights[c] * rw[a:z, c]
            if c in walking:  # the walk's basis against itself and the residual, on the channels the model acts on
                assert Z is not None
                Zw = Z * w[:, None]
                UU[c] += Zw.T @ Z
                bU[c] += Zw.T @ yb[a:z, c]
            H = rows_of.span_rows(np.column_stack([cc[j][1][:, list(cc[j][0]).index(c)] for j in js]), ea, lo, hi)[
                local
            ]
            for k, j in enumerate(js):
                if not PARAMS[j].primary or c in PARAMS[j].primary:
                    sumsq[j] += H[:, k] @ H[:, k]
                    count[j] += H.shape[0]
            Hw = H * w[:, None]
            G = np.empty((ks.size, len(js), len(js)))  # per block, then one scatter into N per channel
            for i in range(ks.size):
                sl = slice(le[i], le[i + 1])
                G[i] = Hw[sl].T @ H[sl]
            jx = np.asarray(js)  # as ix_ would make it (its stubs do not take an array and a list together)
            N[np.ix_(ks, jx, jx)] += G
            b[np.ix_(ks, jx)] += np.add.reduceat(Hw * yb[a:z, c : c + 1], le[:-1], axis=0)
            yy[ks] += np.add.reduceat(w * yb[a:z, c] ** 2, le[:-1])
            if c in walking:
                NU[c][jx] += Hw.T @ Z
            if g_sum is not None and d_sum is not None:
                g_sum[c][np.ix_(ks, jx)] += np.add.reduceat(Hw, le[:-1], axis=0)
                # each block's splits are taken whole: the rows of a block the span ends inside wait
                # for the next span (the splits then do not depend on where the spans fall)
                X, yc, parts = Hw, yb[a:z, c], le
                if c in waiting:
                    k0, Xw, yw = waiting.pop(c)
                    X, yc = np.concatenate([Xw, X]), np.concatenate([yw, yc])
                    parts = (
                        np.concatenate([[0], le[1:] + Xw.shape[0]])
                        if k0 == ks[0]
                        else np.concatenate([[0], le + Xw.shape[0]])
                    )
                if counts[ks[-1]] < block_rows[ks[-1]]:  # the last block goes on in the next span
                    cut = parts[-2]
                    waiting[c] = (ks[-1], X[cut:], yc[cut:])
                    jxs[c] = jx
                    X, yc, parts = X[:cut], yc[:cut], parts[:-1]
                if parts.size > 1:
                    D, us, uc = haar_splits(X, yc, parts, levels)
                    d_sum[c][:, jx[:, None], jx[None, :]] += D
                    u_sum[c] += us
                    u_count[c] += uc
        del cc
    noise = None
    if g_sum is not None and d_sum is not None:
        for c, (_, X, yc) in waiting.items():  # none unless the last span ended inside a block
            D, us, uc = haar_splits(X, yc, np.array([0, X.shape[0]]), levels)
            d_sum[c][:, jxs[c][:, None], jxs[c][None, :]] += D
            u_sum[c] += us
            u_count[c] += uc
        u = np.divide(u_sum, u_count, out=np.zeros_like(u_sum), where=u_count > 0)
        rbar = ysum / np.maximum(counts, 1.0)[:, None]
        noise = BlockNoise(g_sum, d_sum, u, counts, rbar, t[edges[:-1]] if t.size else np.zeros(B), block_s)
    drift = NO_DRIFT
    if walking:
        walking = [c for c in walking if UU[c].any()]  # the channels the model acts on
        drift = intensity(N.sum(0), b.sum(0), NU, UU, bU, walking, t0, span_s)
    return Normal(
        N,
        b,
        yy,
        int(rows.size) * 6,
        np.sqrt(sumsq / np.maximum(count, 1)),
        block_s,
        t[edges[:-1]] if t.size else np.zeros(B),
        drift,
        noise,
    )


def covariance(nrm: Normal, free, offset, blocks=None):
    """Estimates of ``free`` and two covariances: ``(x, white, robust)``.

    ``white`` is ``N^-1`` (right when the weights are the inverse noise variances and the noise is
    white); ``robust`` the block sandwich ``N^-1 (B/(B-1) sum_b s_b s_b') N^-1`` with the scores
    ``s_b = b_b - N_b x`` of each block at the estimate. ``blocks`` restricts everything to those
    blocks (the consistency check fits groups of blocks alone).
    """
    x, inv, s = block_scores(nrm, free, offset, blocks)
    if s.shape[1] == 0:
        return x, inv, inv
    at = np.arange(s.shape[0]) if blocks is None else np.asarray(blocks, dtype=int)
    return x, inv, inv @ long_run_meat(s, at) @ inv


def block_scores(nrm: Normal, free, offset, blocks=None):
    """``(x, N^-1, s)``: the estimates of ``free``, the inverse of their normal matrix and each
    block's scores ``s_b = b_b - N_b x`` [B, f] at the estimate (as :func:`covariance`); ``s N^-1``
    is each block's share of the estimate's error."""
    free = np.asarray(free, dtype=int)
    Nb, bb, yyb = (nrm.N, nrm.b, nrm.yy) if blocks is None else (nrm.N[blocks], nrm.b[blocks], nrm.yy[blocks])
    N, b, yy = Nb.sum(0), bb.sum(0), float(yyb.sum())
    x, _, inv = solve(N, b, yy, free, offset)
    if free.size == 0:
        return x, inv, np.zeros((Nb.shape[0], 0))
    pinned, c = _pinned(free, offset)
    s = (
        bb[:, free]
        - np.einsum("bij,j->bi", Nb[:, free][:, :, pinned], c)
        - np.einsum("bij,j->bi", Nb[:, free][:, :, free], x)
    )
    return x, inv, s


def cv_error(nrm: Normal, free, offset):
    """Cross-validated weighted squared error of the model with ``free`` estimated: each fold of
    interleaved blocks predicted from the others."""
    free = np.asarray(free, dtype=int)
    N, b, yy = nrm.total()
    pinned, c = _pinned(free, offset)
    fold = nrm.fold()
    err = 0.0
    for k in range(FOLDS):
        sel = fold == k
        if not sel.any():
            continue
        Nk, bk, yyk0 = nrm.N[sel].sum(0), nrm.b[sel].sum(0), float(nrm.yy[sel].sum())
        x, _, _ = solve(N - Nk, b - bk, yy - yyk0, free, offset)
        bf = bk[free] - Nk[np.ix_(free, pinned)] @ c
        yyk = yyk0 - 2.0 * c @ bk[pinned] + c @ Nk[np.ix_(pinned, pinned)] @ c
        err += yyk - 2.0 * x @ bf + x @ Nk[np.ix_(free, free)] @ x
    return float(err)


def excitation(nrm: Normal, free) -> dict:
    """Per parameter of ``free``: its regressor's RMS divided by sqrt(VIF) given the others in ``free``.

    VIF = cov_jj N_jj (1 when the regressor is orthogonal to the others; infinite when
    they explain it). Noise-free: it says what the motion shows, not how well.
    """
    N = nrm.N.sum(0)
    free = np.asarray(free, dtype=int)
    diag = np.diag(N)[free]
    out = {}
    live = diag > 0
    if live.any():
        sub = free[live]
        Nf = N[np.ix_(sub, sub)]
        d = np.sqrt(np.diag(Nf))
        try:
            inv = np.linalg.inv(Nf / np.outer(d, d))
            vif = np.maximum(np.diag(inv), 1.0)
        except np.linalg.LinAlgError:
            vif = np.full(sub.size, np.inf)
        for j, v in zip(sub.tolist(), vif):
            out[j] = float(nrm.excitation[j] / np.sqrt(v)) if np.isfinite(v) and v > 0 else 0.0
    for j in free[~live].tolist():
        out[j] = 0.0
    return out
