"""The algebra of one set of normal equations, held as matrices: nothing here knows of rows or blocks.

- :func:`solve` fits a parameter set with the others pinned;
- :func:`scaled_pinv`: the pseudo-inverse of a normal matrix or covariance whose parameters come
  in units far apart;
- :func:`hac_lag`, :func:`long_run_meat`: the long-run (Newey-West) covariance of block scores, the
  meat of :func:`sizefx.diagnose.normal.covariance`'s sandwich;
- :func:`wald` tests a group of parameters with a covariance (chi-square with as many degrees
  of freedom as the group has parameters);
- :func:`canonical_correlation`: how far two groups of parameters can be told apart, noise-free.

:mod:`sizefx.diagnose.normal` forms the equations from the record, block by block, and answers
the selection's questions with these.
"""

from __future__ import annotations

import math

import numpy as np

from .theta import NP

__all__ = [
    "solve",
    "with_prior",
    "scaled_pinv",
    "hac_lag",
    "long_run_meat",
    "wald",
    "canonical_correlation",
    "DEGENERATE",
    "HAC_MAX_RHO",
]

#: A regressor that keeps under this share of its energy once others are fitted is degenerate
#: given them (its residual RMS under 3e-5 of its own): :func:`canonical_correlation`'s NaN.
DEGENERATE = 1e-9
#: The largest first-order autocorrelation of block scores :func:`hac_lag` takes (Andrews' 0.97):
#: beyond it the plug-in lag runs to the record's length and the estimate to noise.
HAC_MAX_RHO = 0.97


def _pinned(free, offset):
    pinned = np.setdiff1d(np.arange(NP), free)
    return pinned, offset[pinned]


def _inverse(Nf):
    d = np.sqrt(np.where(np.diag(Nf) > 0, np.diag(Nf), 1.0))
    Ns = Nf / np.outer(d, d)
    try:
        return np.linalg.inv(Ns) / np.outer(d, d)
    except np.linalg.LinAlgError:
        return np.linalg.pinv(Ns) / np.outer(d, d)


def scaled_pinv(A, rcond: float = 1e-12):
    """Pseudo-inverse of the symmetric positive semi-definite ``A`` (a normal matrix or a
    covariance), scaled to a unit diagonal first.

    The parameters' units lie far apart: an arm's variance is of order 1e-7 m^2, a gyro
    g-sensitivity's 1e-17 (rad/s per m/s^2)^2. A plain pseudo-inverse cuts its singular values
    relative to the largest, so it would drop every direction of the small-unit parameters as if the
    record held nothing of them. Scaled, the cut ``rcond`` drops only what is degenerate: directions
    in which the parameters' correlation matrix is singular to that share."""
    A = 0.5 * A + 0.5 * A.T  # halved before the sum: a variance near the float limit must not overflow
    d = np.sqrt(np.where(np.diag(A) > 0, np.diag(A), 1.0))
    return np.linalg.pinv(A / np.outer(d, d), rcond=rcond, hermitian=True) / np.outer(d, d)


def with_prior(N, b, offset, prior: dict):
    """The normal equations ``N``, ``b`` (of a step from the current estimate, ``offset`` the start
    values less it) with a Gaussian prior about the start values, {parameter: standard deviation}:
    ``N + P`` and ``b + P offset``, ``P`` the prior's inverse variances."""
    N, b = N.copy(), b.copy()
    for j, sd in prior.items():
        N[j, j] += 1.0 / sd**2
        b[j] += offset[j] / sd**2
    return N, b


def solve(N, b, yy, free, offset):
    """Fit ``free`` with the other parameters held at ``offset``: (x_free, rss, covariance N^-1)."""
    free = np.asarray(free, dtype=int)
    pinned, c = _pinned(free, offset)
    bf = b[free] - N[np.ix_(free, pinned)] @ c
    yy_ = yy - 2.0 * c @ b[pinned] + c @ N[np.ix_(pinned, pinned)] @ c
    if len(free) == 0:
        return np.zeros(0), yy_, np.zeros((0, 0))
    inv = _inverse(N[np.ix_(free, free)])
    x = inv @ bf
    return x, float(yy_ - bf @ x), inv


def hac_lag(scores) -> int:
    """Andrews' (1991) plug-in lag for the Bartlett kernel from AR(1) fits of each score component:
    ``L = 1.1447 (alpha B)^(1/3)``, ``alpha = sum 4 rho^2 s^4 / ((1-rho)^6 (1+rho)^2) / sum s^4 / (1-rho)^4``
    (``s^2`` the AR(1) innovation variance; ``rho`` kept within +-:data:`HAC_MAX_RHO`)."""
    B = scores.shape[0]
    if B < 3:
        return 0
    z = scores / np.maximum(scores.std(axis=0), 1e-300)
    a, b = z[:-1], z[1:]
    rho = np.clip(np.sum(a * b, axis=0) / np.maximum(np.sum(a * a, axis=0), 1e-300), -HAC_MAX_RHO, HAC_MAX_RHO)
    s4 = np.mean((b - rho * a) ** 2, axis=0) ** 2
    num = np.sum(4.0 * rho**2 * s4 / ((1 - rho) ** 6 * (1 + rho) ** 2))
    den = np.sum(s4 / (1 - rho) ** 4)
    alpha = num / den if den > 0 else 0.0
    return int(min(B - 1, math.floor(1.1447 * (alpha * B) ** (1.0 / 3.0))))


def long_run_meat(scores, at=None):
    """The long-run covariance of block scores ``s_b`` [B, f]: ``B/(B-1) sum_l w_l sum_b s_b s_{b+l}'``
    over lags ``l`` of ``-L..L`` with Bartlett weights ``w_l = 1 - |l| / (L + 1)`` (Newey-West), ``L``
    from :func:`hac_lag`.

    Scores a block or more apart stay correlated when the residual's colour outlasts a block (a bias
    walk, flicker noise): their plain sum of squares would under-state the variance. ``at``: the
    blocks' indices in the record, when the scores are those of some of its blocks (a part of the
    record, or blocks gathered by motion); a lag counts blocks of the record, so blocks far apart in
    time never pair."""
    s = np.asarray(scores, dtype=float)
    B = s.shape[0]
    at = np.arange(B) if at is None else np.asarray(at, dtype=int)
    if B > 1 and np.any(np.diff(at) != 1):  # blocks gathered from the record: zeros between them
        full = np.zeros((int(at.max() - at.min()) + 1, s.shape[1]))
        full[at - at.min()] = s
        s = full
    meat = s.T @ s
    lag = hac_lag(s)
    for k in range(1, lag + 1):
        g = s[k:].T @ s[:-k]
        meat = meat + (1.0 - k / (lag + 1.0)) * (g + g.T)
    return meat * (B / max(B - 1, 1))


def wald(x, cov, group) -> float:
    """Wald statistic ``x_g' cov_gg^-1 x_g`` of the parameters at positions ``group`` of ``x``."""
    g = np.asarray(group, dtype=int)
    C = cov[np.ix_(g, g)]
    try:
        return float(x[g] @ np.linalg.solve(C, x[g]))
    except np.linalg.LinAlgError:
        return float(x[g] @ np.linalg.pinv(C) @ x[g])


def canonical_correlation(N: np.ndarray, a, b, rest=()) -> float:
    """Largest canonical correlation between the regressors of parameter groups ``a`` and ``b``
    after both are regressed on the group ``rest``, from the normal matrix ``N`` alone.

    1 means some combination of ``a`` is a combination of ``b`` on this motion: the record cannot
    say which of the two it sees. Computed from the Schur complements of ``rest``. NaN when a
    parameter of either group is degenerate by itself given ``rest`` (keeps under
    :data:`DEGENERATE` of its regressor's energy once ``rest`` is fitted): it is confounded with
    ``rest``, not with the other group, whose correlation with it means nothing.
    """
    a, b, rest = (np.asarray(g, dtype=int) for g in (a, b, rest))
    ab = np.concatenate([a, b])
    S = N[np.ix_(ab, ab)]
    if rest.size:
        S = S - N[np.ix_(ab, rest)] @ _inverse(N[np.ix_(rest, rest)]) @ N[np.ix_(rest, ab)]
    raw = np.diag(N)[ab]
    if np.any(np.diag(S) <= DEGENERATE * np.where(raw > 0, raw, 1.0)):
        return float("nan")
    na = a.size
    Saa, Sbb, Sab = S[:na, :na], S[na:, na:], S[:na, na:]
    try:
        La = np.linalg.cholesky(Saa + 1e-300 * np.eye(na))
        Lb = np.linalg.cholesky(Sbb + 1e-300 * np.eye(b.size))
    except np.linalg.LinAlgError:
        return 1.0  # a group is degenerate by itself on this motion
    M = np.linalg.solve(La, np.linalg.solve(Lb, Sab.T).T)
    return float(min(1.0, np.linalg.svd(M, compute_uv=False).max()))
