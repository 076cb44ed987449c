"""Which effects the residual supports: weighted normal equations and forward selection.

One Gauss-Newton pass's selection, linearised at the current estimate, with parameters not
selected pinned at their nominal values:

- :class:`Rows` turns samples into the rows of the fit (block means, or a zero-phase low-pass
  and decimation with ``--bandwidth-hz``), the same for the residual and every regressor;
- :func:`normal_equations` sums the weighted normal equations per cross-validation fold
  (interleaved one-second blocks), and each regressor's RMS (its excitation);
- :func:`select` is the forward selection. A candidate enters only when (a) it lowers the
  weighted residual by more than the Bayesian information criterion's ``k ln(n)`` (for one
  parameter 3.7 sigma at 1e6 rows, 3.45 sigma at 1.5e5; a false alarm rate near 2e-4 per
  candidate and step on white noise) and (b) it lowers the five-fold cross-validated error
  (:func:`cv_error`). Of the candidates that pass, the one that improves the criterion most
  enters, unless a more common effect (:data:`sizefx.diagnose.candidates.PRIORITY`) scores within
  one parameter's penalty of it;
- :func:`revealed` removes, before a candidate is scored, the parameters the motion does not
  excite: their regressor's RMS, divided by the square root of its variance inflation factor
  given the effects already selected (:func:`excitation`), is under ``Param.min_excitation``.
  :func:`why_hidden` says why, in words.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError
from .candidates import CANDIDATES, PRIORITY, Candidate
from .theta import NP, PARAMS

__all__ = ["Chosen", "Normal", "Rows", "block_means", "cv_error", "excitation", "normal_equations", "revealed",
           "select", "sigmas", "solve", "why_hidden", "FOLDS", "FOLD_BLOCK_S", "MAX_ROWS"]

#: Rows kept for the fit after block averaging: a two-minute record at 1600 Hz is fitted sample
#: by sample; longer records are averaged in blocks (y and regressors alike, so the model stays exact).
MAX_ROWS = 250_000
#: Cross-validation: folds and the length of the interleaved blocks [s].
FOLDS = 5
FOLD_BLOCK_S = 1.0


@dataclass
class Normal:
    """Weighted normal equations per fold: sums over folds give the whole record."""

    N: np.ndarray  #: [F, P, P]
    b: np.ndarray  #: [F, P]
    yy: np.ndarray  #: [F]
    rows: int
    excitation: np.ndarray  #: [P] RMS of each regressor over its primary channels (SI)

    def total(self):
        return self.N.sum(0), self.b.sum(0), float(self.yy.sum())


def block_means(x, L):
    """Means of consecutive blocks of ``L`` rows of ``x`` [n, ...] (a last partial block is dropped)."""
    n = (x.shape[0] // L) * L
    return x[:n].reshape(-1, L, *x.shape[1:]).mean(axis=1)


class Rows:
    """How the samples become the rows of the fit, the same for the residual and every regressor.

    Without a bandwidth: means over blocks of ``L`` samples (``L = 1`` for records up to
    :data:`MAX_ROWS` samples). With ``bandwidth_hz``: a zero-phase 4th-order Butterworth
    low-pass (``scipy.signal.sosfiltfilt``), then every ``L``-th sample with ``L`` giving
    2.5 samples per period of the cut-off. A linear filter applied to both sides keeps the
    model exact (``F y = (F H) theta + F e``); it is what a reference differentiated from
    noisy motion capture needs, whose noise grows with frequency. Unusable samples are set
    to zero before filtering and their neighbourhood (three periods of the cut-off) is left out.
    """

    def __init__(self, t, mask, dt, bandwidth_hz=None):
        n = t.size
        self.bandwidth_hz = bandwidth_hz
        if bandwidth_hz is not None:
            from scipy.signal import butter

            nyquist = 0.5 / dt
            if not 0.0 < bandwidth_hz < 0.8 * nyquist:
                raise ConfigError(f"--bandwidth-hz {bandwidth_hz:g} must lie between 0 and {0.8 * nyquist:g} Hz "
                                  f"(0.8 times the Nyquist frequency of this {1 / dt:g} Hz record)")
            self.sos = butter(4, bandwidth_hz / nyquist, output="sos")
            self.L = max(1, math.floor(1.0 / (2.5 * bandwidth_hz * dt)), math.ceil(n / MAX_ROWS))
            pad = max(1, round(3.0 / (bandwidth_hz * dt)))
            bad = np.convolve((~mask).astype(float), np.ones(2 * pad + 1), mode="same") > 0
            self.mask = mask
            keep = ~bad[::self.L]
            self.t = t[::self.L]
        else:
            self.L = max(1, math.ceil(n / MAX_ROWS))
            self.mask = mask
            keep = block_means(mask.astype(float), self.L) == 1.0 if self.L > 1 else mask
            self.t = block_means(t, self.L) if self.L > 1 else t
        self.keep = keep
        self.dt = dt * self.L

    def __call__(self, x):
        """Rows ``[m, ...]`` of a per-sample series ``x [n, ...]`` (all rows; index with ``keep``)."""
        if self.bandwidth_hz is not None:
            from scipy.signal import sosfiltfilt

            x = np.where(self.mask.reshape(-1, *([1] * (x.ndim - 1))), x, 0.0)
            return sosfiltfilt(self.sos, x, axis=0)[::self.L]
        return block_means(x, self.L) if self.L > 1 else x


def normal_equations(rows_of: Rows, y, cols, weights) -> Normal:
    """The weighted normal equations of the residual ``y`` [n, 6] on the Jacobian columns ``cols``
    (:func:`sizefx.diagnose.candidates.jacobian_columns`), one set per fold; ``weights`` [6] per channel."""
    keep = rows_of.keep
    t = rows_of.t[keep]
    span = float(t[-1] - t[0]) if t.size > 1 else 0.0
    block = max(min(FOLD_BLOCK_S, span / (2 * FOLDS)), rows_of.dt)  # 1 s, shorter for records under 10 s
    fold = (np.floor((t - t[0]) / block).astype(int)) % FOLDS  # interleaved folds
    order = np.argsort(fold, kind="stable")  # rows grouped by fold: slices instead of masks
    edges = np.searchsorted(fold[order], np.arange(FOLDS + 1))
    rows = np.flatnonzero(keep)[order]

    def prep(x):
        return rows_of(x)[rows]

    yb = prep(y)
    sumsq = np.zeros(NP)
    count = np.zeros(NP)
    N = np.zeros((FOLDS, NP, NP))
    b = np.zeros((FOLDS, NP))
    yy = np.zeros(FOLDS)
    for c in range(6):
        js = [j for j in range(NP) if c in cols[j][0]]
        if not js:
            continue
        H = prep(np.column_stack([cols[j][1][:, list(cols[j][0]).index(c)] for j in js]))
        for k, j in enumerate(js):
            if not PARAMS[j].primary or c in PARAMS[j].primary:
                sumsq[j] += H[:, k] @ H[:, k]
                count[j] += H.shape[0]
        w = weights[c]
        for k in range(FOLDS):
            Hk, yk = H[edges[k]:edges[k + 1]], yb[edges[k]:edges[k + 1], c]
            N[k][np.ix_(js, js)] += w * (Hk.T @ Hk)
            b[k][js] += w * (Hk.T @ yk)
            yy[k] += w * (yk @ yk)
    return Normal(N, b, yy, int(keep.sum()) * 6, np.sqrt(sumsq / np.maximum(count, 1)))


def solve(N, b, yy, free, offset):
    """Fit ``free`` with the other parameters held at ``offset``: (x_free, rss, covariance)."""
    pinned = np.setdiff1d(np.arange(NP), free)
    c = offset[pinned]
    bf = b[free] - N[np.ix_(free, pinned)] @ c
    yy_ = yy - 2.0 * c @ b[pinned] + c @ N[np.ix_(pinned, pinned)] @ c
    if len(free) == 0:
        return np.zeros(0), yy_, np.zeros((0, 0))
    Nf = N[np.ix_(free, free)]
    d = np.sqrt(np.where(np.diag(Nf) > 0, np.diag(Nf), 1.0))
    Ns = Nf / np.outer(d, d)
    try:
        inv = np.linalg.inv(Ns) / np.outer(d, d)
    except np.linalg.LinAlgError:
        inv = np.linalg.pinv(Ns) / np.outer(d, d)
    x = inv @ bf
    return x, float(yy_ - bf @ x), inv


def cv_error(nrm: Normal, free, offset):
    """Five-fold cross-validated weighted squared error of the model with ``free`` estimated."""
    N, b, yy = nrm.total()
    pinned = np.setdiff1d(np.arange(NP), free)
    c = offset[pinned]
    err = 0.0
    for k in range(FOLDS):
        x, _, _ = solve(N - nrm.N[k], b - nrm.b[k], yy - nrm.yy[k], free, offset)
        Nk, bk = nrm.N[k], nrm.b[k]
        bf = bk[free] - Nk[np.ix_(free, pinned)] @ c
        yyk = nrm.yy[k] - 2.0 * c @ bk[pinned] + c @ Nk[np.ix_(pinned, pinned)] @ c
        err += yyk - 2.0 * x @ bf + x @ Nk[np.ix_(free, free)] @ x
    return float(err)


@dataclass
class Chosen:
    """A candidate the selection took, split into what the record reveals and what it cannot."""

    cand: Candidate
    active: tuple  #: the parameters of the candidate the record reveals
    hidden: tuple  #: those it cannot


def select(nrm: Normal, offset, penalty):
    """Forward selection. Returns (chosen, unrevealed {key: (candidate, hidden params, reason)}, log)."""
    N, b, yy = nrm.total()
    chosen: list[Chosen] = []
    log = []

    def free_of(ch):
        return np.array(sorted({j for c in ch for j in c.active}), dtype=int)

    _, rss, _ = solve(N, b, yy, free_of(chosen), offset)
    cv = cv_error(nrm, free_of(chosen), offset)
    while True:
        scored = []
        for cand in CANDIDATES:
            if any(c.cand == cand for c in chosen):
                continue
            active, hidden = revealed(nrm, free_of(chosen), cand)
            if not active:
                continue
            trial = chosen + [Chosen(cand, tuple(active), tuple(hidden))]
            _, rss_new, _ = solve(N, b, yy, free_of(trial), offset)
            gain = rss - rss_new
            score = gain - penalty * len(active)  # the criterion's improvement: fewer parameters win ties
            if score > 0:
                scored.append((score, PRIORITY.index(cand.id), gain, trial, rss_new))
        if not scored:
            break
        # The best score wins unless a more common effect (PRIORITY) scores within one parameter's
        # penalty of it: near-collinear candidates (a z bias and a z scale factor under constant
        # gravity) are then explained the ordinary way, and the other is named as indistinguishable.
        top = max(s[0] for s in scored)
        score, _, gain, trial, rss_new = min((s for s in scored if s[0] >= top - penalty), key=lambda s: s[1])
        best = (gain, trial, rss_new, score)
        cv_new = cv_error(nrm, free_of(best[1]), offset)
        if cv_new >= cv:
            log.append(f"{best[1][-1].cand.key}: passes the information criterion but not cross-validation")
            break
        chosen, rss, cv = best[1], best[2], cv_new
        log.append(f"{chosen[-1].cand.key}: chi2 gain {best[0]:.1f} (threshold {penalty * len(chosen[-1].active):.1f})")
    unrevealed = {}
    free = free_of(chosen)
    for cand in CANDIDATES:
        mine = [c for c in chosen if c.cand == cand]
        if mine:
            if mine[0].hidden:
                unrevealed[cand.key] = (cand, mine[0].hidden, why_hidden(nrm, cand, mine[0].hidden, chosen))
            continue
        active, hidden = revealed(nrm, free, cand)
        if hidden:
            unrevealed[cand.key] = (cand, tuple(hidden), why_hidden(nrm, cand, hidden, chosen))
    return chosen, unrevealed, log


def sigmas(N, b, yy, free, offset):
    """Standard errors ``{param: sigma}`` of the parameters ``free`` (SI)."""
    _, _, cov = solve(N, b, yy, free, offset)
    return dict(zip(free.tolist(), np.sqrt(np.abs(np.diag(cov)))))


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


def revealed(nrm: Normal, free, cand):
    """Split the candidate's parameters into those the record reveals (jointly with ``free``) and the rest."""
    active = list(cand.idx)
    while active:
        trial = np.array(sorted(set(free.tolist()) | set(active)), dtype=int)
        ex = excitation(nrm, trial)
        worst = min(active, key=lambda j: ex[j] / PARAMS[j].min_excitation)
        if ex[worst] >= PARAMS[worst].min_excitation:
            break
        active.remove(worst)
    return active, [j for j in cand.idx if j not in active]


def why_hidden(nrm: Normal, cand, hidden, chosen):
    """Plain reason a parameter set cannot be revealed: the motion, or confusion with a selected effect."""
    alone = excitation(nrm, np.array(hidden, dtype=int))
    if any(alone[j] < PARAMS[j].min_excitation for j in hidden):
        return "the motion in this record does not excite it"
    culprits = []
    for c in chosen:
        if c.cand == cand:
            continue
        rest = [o for o in chosen if o is not c and o.cand != cand]
        trial = np.array(sorted({j for o in rest for j in o.active} | set(hidden)), dtype=int)
        ex = excitation(nrm, trial)
        if all(ex[j] >= PARAMS[j].min_excitation for j in hidden):
            culprits.append(c.cand.key)
    if culprits:
        return "indistinguishable in this record from " + " or ".join(culprits)
    if not [c for c in chosen if c.cand != cand]:
        return "its components cannot be told apart from each other in this record"
    return "indistinguishable in this record from the effects found together"

