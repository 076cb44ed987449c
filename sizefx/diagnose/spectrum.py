"""The estimates' covariance from a model of the residual's spectrum, block by block.

A weighted least-squares estimate's score is ``s = sum_t H_t w r_t`` over the rows of every
channel. Cut the record into the blocks of the normal equations and write each regressor and the
residual as their block means plus what varies within a block (``H = g_b / n_b + h``, ``r = rbar_b
+ e``): the cross terms vanish, and

    Var(s) = sum_c [ sigma_c^2 (sum_t Hw Hw' - sum_b g_b g_b' / n_b) + G_c' R_c G_c ],

- the first term: what varies within a block, against the residual's variance within blocks
  ``sigma_c^2`` (white at that scale: a block is short against the motion's slow terms);
- the second: the block sums ``G_c [B, P]`` of the weighted regressors against ``R_c [B, B]``, the
  covariance of the residual's block means, from a model of their spectrum fitted to the block
  means' periodogram (:func:`fit_spectrum`): white plus a power law ``A + C (f / f_1)^-alpha``,
  ``alpha`` from 0 (white) through 1 (flicker) to 2 (a random walk).

Each parameter thus takes the noise at the frequencies where its regressor has its energy: a lever
arm's fast regressor is not charged with the slow colour of its channel, a misalignment on a
turntable's long dwells is. The model is fitted over all the block frequencies, so a slow effect the
fit absorbed (the residual's periodogram is low where the regressors are) pulls the fit little.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["BlockNoise", "fit_spectrum", "block_covariance", "spectral_meat", "ALPHAS", "EMBED"]

#: The power-law exponents tried (:func:`fit_spectrum`): white, flicker-like and walk-like colour.
ALPHAS = (0.5, 1.0, 1.5, 2.0)
#: The coloured part is kept only when it raises the likelihood beyond chance: twice the log-likelihood
#: ratio over white noise above the 95 % point of chi-square with 2 degrees of freedom (its level
#: and share; the exponent's choice among :data:`ALPHAS` is not counted).
COLOUR_CHI2 = 5.99
#: The model's autocovariance is formed on a grid this many times the record's span, so that the
#: lowest frequency the record can show (one cycle over its span) is resolved.
EMBED = 8


@dataclass(frozen=True)
class BlockNoise:
    """What the normal equations keep of the residual and the regressors, block by block, for
    :func:`spectral_meat`."""

    G: np.ndarray  #: [6, B, P] per channel, block sums of the weighted regressors ``H w``
    HH: np.ndarray  #: [6, P, P] per channel, ``sum_t (Hw)(Hw)'``
    counts: np.ndarray  #: [B] rows per block
    rbar: np.ndarray  #: [B, 6] the residual's block means (0 where a channel has no rows)
    within: np.ndarray  #: [6] the residual's variance within blocks
    t0: np.ndarray  #: [B] block start times [s]
    block_s: float


def fit_spectrum(x) -> tuple:
    """``(A, C, alpha)``: the spectrum ``A + C (f / f_1)^-alpha`` (per DFT bin of the series, ``f_1``
    its lowest non-zero frequency) of the series ``x [B]`` by Whittle's likelihood over its
    periodogram at ``f_1 .. f_{B/2}``; ``alpha`` from :data:`ALPHAS`, ``A, C >= 0``."""
    x = np.asarray(x, dtype=float)
    x = x - x.mean()
    B = x.size
    k = np.arange(1, B // 2 + 1)
    if k.size < 4:
        return float(np.var(x)), 0.0, 0.0
    power = np.abs(np.fft.rfft(x)[1 : B // 2 + 1]) ** 2 / B
    best = (math.inf, float(power.mean()), 0.0, 0.0)
    mean_I = float(power.mean())
    if not mean_I > 0:
        return 0.0, 0.0, 0.0
    for alpha in ALPHAS:
        shape = k.astype(float) ** -alpha
        # profile over the share of the coloured part: P = s ((1 - u) + u shape / mean(shape))
        for u in np.linspace(0.0, 1.0, 41):
            form = (1.0 - u) + u * shape / shape.mean()
            scale = float(np.mean(power / form))  # the level maximising Whittle's likelihood for this form
            nll = float(np.sum(np.log(scale * form)) + power.size)
            if nll < best[0]:
                best = (nll, scale * (1.0 - u), scale * u / shape.mean(), alpha)
    white_nll = float(power.size * math.log(mean_I) + power.size)
    if 2.0 * (white_nll - best[0]) < COLOUR_CHI2:  # colour no better than chance: white
        return mean_I, 0.0, 0.0
    return best[1], best[2], best[3]


def block_covariance(x, t0, block_s: float) -> np.ndarray:
    """``[B, B]``: the covariance of the block means ``x [B]`` (blocks starting at ``t0`` [s]) under
    the spectrum :func:`fit_spectrum` fits to them, from its autocovariance on a grid of
    :data:`EMBED` times the span (lags between blocks across a gap taken from the times)."""
    A, C, alpha = fit_spectrum(x)
    B = x.size
    M = EMBED * max(B, 2)
    f = np.arange(M // 2 + 1, dtype=float)  # in units of the lowest frequency of the grid
    spec = np.full(f.size, A)
    if C > 0:
        # the record's bins k are the grid's EMBED * k: C k^-alpha at f = EMBED k
        spec[1:] += C * (f[1:] / EMBED) ** -alpha
        spec[0] = spec[1]
    acov = np.fft.irfft(spec, n=M)  # acov[m]: lag of m blocks
    lag = np.abs(np.round((t0[:, None] - t0[None, :]) / block_s)).astype(int)
    return acov[np.minimum(lag, M // 2)]


def spectral_meat(noise: BlockNoise, free) -> np.ndarray:
    """``[f, f]``: the variance of the score of the parameters ``free`` (module docstring)."""
    free = np.asarray(free, dtype=int)
    meat = np.zeros((free.size, free.size))
    for c in range(6):
        n = noise.counts
        inside = n > 0
        if not inside.any():
            continue
        G = noise.G[c][np.ix_(inside, free)]
        if not np.any(G):
            continue
        within = noise.HH[c][np.ix_(free, free)] - (G / n[inside, None]).T @ G
        R = block_covariance(noise.rbar[inside, c], noise.t0[inside], noise.block_s)
        meat += noise.within[c] * within + G.T @ R @ G
    return meat
