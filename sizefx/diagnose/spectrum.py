"""The estimates' covariance from a model of the residual's spectrum, scale by scale.

A weighted least-squares estimate's score is ``s = sum_t H_t w r_t`` over the rows of every
channel. Cut the record into the blocks of the normal equations, and each block in halves, each
half in halves again, down to single rows (a Haar multiresolution: the halves of a block part of
``n`` rows are its rows ``floor(p 2^j / n)`` at level ``j``). The score splits exactly into a sum
over the blocks and over every split of a part into two halves ``A`` and ``B``:

    s = sum_b G_b rbar_b + sum_splits d (a - b),    d = (n_B S_A - n_A S_B) / (n_A + n_B),

with ``G_b`` the block sums of the weighted regressors ``Hw`` and ``rbar_b`` the residual's block
means, ``S_A, S_B`` the halves' sums of ``Hw`` and ``a, b`` the residual's means over them. The
terms are taken as uncorrelated, each split's difference of means with the variance its level
shows, ``Var(a - b) = u_j (1/n_A + 1/n_B)`` (``u_j`` the mean of ``(a - b)^2 / (1/n_A + 1/n_B)``
over the level's splits: the residual's variance at that scale, as an Allan variance is), and the
block means with the covariance ``R`` of a model of their spectrum fitted to their periodogram
(:func:`fit_spectrum`: white plus a power law ``A + C (f / f_1)^-alpha``, ``alpha`` from 0.5
through 1 (flicker) to 2 (a random walk), or plus a first-order Gauss-Markov process, flat below its
corner):

    Var(s) = sum_c [ sum_j u_j,c D_j,c + G_c' R_c G_c ],    D_j = sum over level j of d d' (1/n_A + 1/n_B).

For white noise every ``u_j`` is its variance and the sum is the white covariance exactly (the
splits and the block means span the rows). Each parameter takes the noise at the scales where
its regressor varies: a lever arm's fast regressor is not charged with its channel's slow
colour, a misalignment on a turntable's long dwells is. The block means' model is fitted over all
their frequencies, so a slow effect the fit absorbed (the residual is low where the regressors
are) pulls it little. On a channel whose bias walks (:mod:`.drift`), the colour under the walk's
series (:data:`sizefx.diagnose.drift.WALK_BINS`) is the walk's part of the errors and is left out
here, so that no slice of the spectrum is counted twice.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = [
    "BlockNoise",
    "fit_spectrum",
    "block_covariance",
    "haar_splits",
    "levels_for",
    "spectral_meat",
    "ALPHAS",
    "SHAPES",
    "EMBED",
    "COLOUR_CHI2",
]

#: The power-law exponents tried (:func:`fit_spectrum`): white, flicker-like and walk-like colour.
ALPHAS = (0.5, 1.0, 1.5, 2.0)
#: The coloured part is kept only when it raises the likelihood beyond chance: twice the log-likelihood
#: ratio over white noise above the 95 % point of chi-square with 2 degrees of freedom (its level
#: and share; the shape's choice among :data:`SHAPES` is not counted).
COLOUR_CHI2 = 5.99
#: The model's autocovariance is formed on a grid this many times the record's span, so that the
#: frequencies below the lowest the record shows (one cycle over its span) carry the model's power
#: too, as a walk's or flicker's do.
EMBED = 8


@dataclass(frozen=True)
class BlockNoise:
    """What the normal equations keep of the residual and the regressors, scale by scale, for
    :func:`spectral_meat`."""

    G: np.ndarray  #: [6, B, P] per channel, block sums of the weighted regressors ``H w``
    D: np.ndarray  #: [6, J, P, P] per channel and level, the splits' ``sum d d' (1/n_A + 1/n_B)``
    u: np.ndarray  #: [6, J] per channel and level, the residual's variance at that scale (0: no split)
    counts: np.ndarray  #: [B] rows per block
    rbar: np.ndarray  #: [B, 6] the residual's block means (0 where a channel has no rows)
    t0: np.ndarray  #: [B] block start times [s]
    block_s: float


def levels_for(rows_per_block: int) -> int:
    """Levels of splits of a block part of at most ``rows_per_block`` rows down to single rows."""
    return max(0, math.ceil(math.log2(max(rows_per_block, 1))))


def haar_splits(X, y, edges, levels: int):
    """The splits of the parts ``edges[k]:edges[k + 1]`` of the rows (module docstring), level by
    level: ``(D [levels, J, J], usum [levels], ucount [levels])`` for the weighted regressors ``X [m, J]``
    and the residual ``y [m]`` (``u_j = usum / ucount``)."""
    m, J = X.shape
    D, usum, ucount = np.zeros((levels, J, J)), np.zeros(levels), np.zeros(levels)
    sizes = np.diff(edges)
    parts = sizes.size
    seg = np.repeat(np.arange(parts), sizes)
    n = sizes[seg]
    p = np.arange(m) - np.asarray(edges[:-1])[seg]
    Xy = np.column_stack([X, y, np.ones(m)])
    for j in range(1, levels + 1):
        S = 1 << j
        label = seg * S + (p * S) // n  # non-decreasing: parts in order, halves in order within
        starts = np.flatnonzero(np.diff(label, prepend=-1))
        sums = np.zeros((parts * S, J + 2))
        sums[label[starts]] = np.add.reduceat(Xy, starts, axis=0)
        left, right = sums[0::2], sums[1::2]
        nA, nB = left[:, -1], right[:, -1]
        ok = (nA > 0) & (nB > 0)
        if not ok.any():
            continue
        left, right, nA, nB = left[ok], right[ok], nA[ok], nB[ok]
        d = (nB[:, None] * left[:, :J] - nA[:, None] * right[:, :J]) / (nA + nB)[:, None]
        w = 1.0 / nA + 1.0 / nB
        D[j - 1] = (d * w[:, None]).T @ d
        usum[j - 1] = np.sum((left[:, J] / nA - right[:, J] / nB) ** 2 / w)
        ucount[j - 1] = ok.sum()
    return D, usum, ucount


def _shape(shape: tuple, k):
    """The coloured part's shape ``(kind, parameter)`` at bins ``k`` (of the record's periodogram;
    fractional below 1)."""
    kind, param = shape
    k = np.asarray(k, dtype=float)
    if kind == "power":
        return k**-param
    return 1.0 / (1.0 + (k / param) ** 2)  # "knee": a first-order Gauss-Markov process, corner at bin param


#: The coloured parts tried (:func:`fit_spectrum`): power laws ``k^-alpha`` (flicker at 1, a walk at 2)
#: and first-order Gauss-Markov knees ``1 / (1 + (k / k_c)^2)``, flat below their corner bin ``k_c``.
#: A corner below the fourth bin is not tried: the periodogram cannot tell it from a walk, which
#: keeps rising below the record's lowest frequency, and the walk is the safer reading for a slow
#: regressor.
SHAPES = tuple(("power", a) for a in ALPHAS) + tuple(("knee", kc) for kc in (4.0, 8.0, 16.0, 32.0))


def fit_spectrum(x) -> tuple:
    """``(A, C, shape)``: the spectrum ``A + C shape(k)`` (per DFT bin ``k`` of the series) of the
    series ``x [B]`` by Whittle's likelihood over its periodogram at ``k = 1 .. B/2``, the shape from
    :data:`SHAPES`, ``A, C >= 0``; ``C = 0`` (white) unless the colour beats white beyond chance
    (:data:`COLOUR_CHI2`)."""
    x = np.asarray(x, dtype=float)
    x = x - x.mean()
    B = x.size
    k = np.arange(1, B // 2 + 1)
    white = (float(np.var(x)), 0.0, SHAPES[0])
    if k.size < 4:
        return white
    power = np.abs(np.fft.rfft(x)[1 : B // 2 + 1]) ** 2 / B
    mean_power = float(power.mean())
    if not mean_power > 0:
        return (0.0, 0.0, SHAPES[0])
    white_nll = float(power.size * math.log(mean_power) + power.size)
    best = (white_nll, mean_power, 0.0, SHAPES[0])
    for shape in SHAPES:
        form0 = _shape(shape, k)
        scale0 = float(form0.mean())
        # profile over the share of the coloured part: P = s ((1 - u) + u form / mean(form))
        for share in np.linspace(0.0, 1.0, 41)[1:]:
            form = (1.0 - share) + share * form0 / scale0
            level = float(np.mean(power / form))  # the level maximising Whittle's likelihood for this form
            nll = float(np.sum(np.log(level * form)) + power.size)
            if nll < best[0]:
                best = (nll, level * (1.0 - share), level * share / scale0, shape)
    if 2.0 * (white_nll - best[0]) < COLOUR_CHI2:  # colour no better than chance: white
        return (mean_power, 0.0, SHAPES[0])
    return best[1], best[2], best[3]


def block_covariance(x, t0, block_s: float, above: float = 0.0) -> np.ndarray:
    """``[B, B]``: the covariance of the block means ``x [B]`` (blocks starting at ``t0`` [s]) under
    the spectrum :func:`fit_spectrum` fits to them, from its autocovariance on a grid of
    :data:`EMBED` times the span (lags between blocks across a gap taken from the times). ``above``:
    the record's bin under which the coloured part is left out (another model holds it there)."""
    A, C, shape = fit_spectrum(x)
    B = x.size
    M = EMBED * max(B, 2)
    f = np.arange(M // 2 + 1, dtype=float)  # in units of the lowest frequency of the grid
    spec = np.full(f.size, A)
    if C > 0:
        k = f[1:] / EMBED  # the record's bin k is the grid's EMBED k
        spec[1:] += np.where(k >= above, C * _shape(shape, k), 0.0)
        spec[0] = spec[1]
    acov = np.fft.irfft(spec, n=M)  # acov[m]: lag of m blocks
    lag = np.abs(np.round((t0[:, None] - t0[None, :]) / block_s)).astype(int)
    return acov[np.minimum(lag, M // 2)]


def spectral_meat(noise: BlockNoise, free, above=None) -> np.ndarray:
    """``[f, f]``: the variance of the score of the parameters ``free`` (module docstring); ``above``
    ``[6]``: per channel, the record's bin under which its block means' colour is left out (0, or
    None for all: none)."""
    free = np.asarray(free, dtype=int)
    meat = np.zeros((free.size, free.size))
    n = noise.counts
    inside = n > 0
    for c in range(6):
        G = noise.G[c][np.ix_(inside, free)]
        if not np.any(G):
            continue
        R = block_covariance(noise.rbar[inside, c], noise.t0[inside], noise.block_s, 0.0 if above is None else above[c])
        meat += G.T @ R @ G + np.einsum("j,jab->ab", noise.u[c], noise.D[c][:, free][:, :, free])
    return meat
