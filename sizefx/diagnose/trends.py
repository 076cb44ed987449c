"""Steps and trends in a channel's residual: the block tests of :func:`sizefx.diagnose.structure.unexplained`.

Both test the means ``y_b`` of the residual over the time blocks that
:func:`~sizefx.diagnose.structure.unexplained` forms (:data:`~sizefx.diagnose.structure.MIN_BLOCK_S`
or longer, at most :data:`~sizefx.diagnose.structure.MAX_BLOCKS`), the correlations found removed:

- ``step``: the block means are fitted by a quadratic in time plus a step ``H(t - t_j)`` at each
  block boundary with at least two blocks on each side, by generalised least squares under the
  noise model below; the largest F statistic (1 and ``B - 4`` degrees of freedom),
  Bonferroni over the boundaries. The step time is then refined row by row over the two blocks
  at the boundary (the split that maximises ``k (n - k) (mean_left - mean_right)^2``).
  ``size`` = the step height.
- ``trend``: the same block means, a quadratic in time (plus the step, if one was found) against
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
"""

from __future__ import annotations

import functools
import math

import numpy as np

from .kinds import SIZE_FLOOR

__all__ = ["MAX_NOISE_SLOPE", "EXTRAPOLATION_Z"]

#: Steepest power law of the block means' noise spectrum the block tests allow for: 2, a random
#: walk (a bias random walk is sensor noise, not a drift); steeper would let a drift explain itself.
MAX_NOISE_SLOPE = 2.0
#: Standard errors of the fitted noise slope added when the block tests extrapolate the noise
#: spectrum to the two lowest coefficients (where a drift lies): one, so that a flicker whose slope
#: the record measures poorly does not pass for a drift (tests/test_diagnose_structure.py, coloured).
EXTRAPOLATION_Z = 1.0


def _time_poly(t, t0, t1):
    """[1, tau, tau^2] with tau = t scaled to [-1, 1] over [t0, t1] (well conditioned)."""
    tau = (2.0 * (t - t0) / (t1 - t0) - 1.0) if t1 > t0 else np.zeros_like(t)
    return np.column_stack((np.ones_like(t), tau, tau**2))


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
