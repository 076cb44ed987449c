"""Do the record's parts agree? Each selected parameter fitted on K contiguous parts alone.

A standard error is a promise about how far the estimate would move on another record of the same
set-up. The record itself holds such records: its K contiguous parts (groups of the blocks of
:class:`sizefx.diagnose.normal.Normal`). :func:`block_consistency` fits the selected parameters on
each part alone and compares the spread of the part estimates with their stated errors:

    chi2_j = sum_k (x_kj - xbar_j)^2 / sigma_kj^2,   dof = K' - 1   (K' parts that determine j)

``sigma_kj`` is the part's white standard error scaled by the whole record's ratio of honest
(long-run sandwich) to white error, so that chi2/dof is near 1 when the errors are honest.

Parts of one record that disagree beyond their noise (a drifting sensor, a reference that changes,
an effect outside the model) have each an effect of their own: a random effect of variance
``tau^2`` (DerSimonian and Laird 1986: ``tau^2 = max(0, (chi2 - dof) / (S1 - S2 / S1))`` with
``S1``, ``S2`` the sums of the parts' weights and of their squares). The whole record's estimate
weighs the parts by their information and carries ``tau^2 S2 / S1^2`` of it: ``factor`` is the
widening of its standard error that this gives, ``sqrt(1 + tau^2 S2 / S1^2 / sigma^2)``, taken only
where the parts disagree beyond chance: chi2 beyond its point at :data:`CONSISTENCY_LEVEL` (shared
by the cuts), where the parameter is flagged too. The estimate ``tau^2`` alone is positive whenever
chi2 exceeds its degrees of freedom, 43 % of the time for parts that agree (7 degrees of freedom),
and would widen an honest error's variance by 21 % on average: the "random effect" of pure noise.
Beyond the point it is positive 0.33 % of the time and adds 0.8 % on average.

The same check runs on parts cut by motion instead of time (:func:`motion_groups`: quartiles of
rotation rate and of translation); the level is shared by the three cuts (Bonferroni). How the
cuts enter an error is :func:`sizefx.diagnose.budget.parts_scatter`' choice.
"""

from __future__ import annotations

import numpy as np
from scipy.stats import chi2

from .normal import Normal, covariance
from .theta import PARAMS

__all__ = ["block_consistency", "motion_groups", "CONSISTENCY_LEVEL", "MOTION_PARTS", "PARTS", "SPLITS"]

#: Parts the record is cut into: 8 give chi2/dof 7 degrees of freedom (99 % point 2.64) while each
#: part of a one-minute record still holds 7.5 s of motion.
PARTS = 8
#: Parts by motion: the blocks sorted by how fast the record turns (|omega|^2), and by how hard it
#: translates (| |f| - g |, specific force beyond gravity), each cut into quartiles. An effect the
#: model lacks shows with the motion that excites it: estimates from the calm and the violent
#: quarter disagree while contiguous parts of similar motion agree.
MOTION_PARTS = 4
#: The cuts of the record the check is run on: in time, by rotation rate, by translation.
SPLITS = 3
#: One-sided level, shared by the cuts, at which the parts' disagreement inflates a standard error.
CONSISTENCY_LEVEL = 0.01
#: A part determines a parameter when its standard error there is within this factor of
#: sqrt(K) times the whole record's (a part that barely sees the parameter says nothing about it).
_SEEN = 5.0


def motion_groups(nrm: Normal, t_s, stat, K: int = MOTION_PARTS) -> list:
    """``K`` groups of blocks by a per-sample motion statistic ``stat`` [n] at times ``t_s`` [n]: the
    blocks with the least of it, the next, ..., the most (quantiles of the block means)."""
    starts = np.searchsorted(t_s, nrm.t0)
    sums = np.add.reduceat(stat, np.minimum(starts, stat.size - 1))
    counts = np.diff(np.append(starts, stat.size)).clip(min=1)
    order = np.argsort(sums / counts, kind="stable")
    return [g for g in np.array_split(order, K) if g.size]


def block_consistency(
    nrm: Normal, free, offset, sigma: dict, white_sigma: dict, groups=None, split: str = "time"
) -> tuple[int, dict]:
    """The number of parts K, and per parameter of ``free``: ``{"parameter", "effect", "split", "chi2_dof",
    "dof", "tau", "factor", "inflated"}`` (``tau`` in report units, 0 and ``factor`` 1 unless
    ``inflated``; parameters fewer than two parts determine are left out).

    ``sigma``, ``white_sigma``: the whole record's honest and white standard errors by parameter.
    ``groups``: the parts as lists of blocks (default :data:`PARTS` contiguous ones); ``split`` names them.
    """
    free = np.asarray(free, dtype=int)
    if groups is None:
        groups = nrm.groups(min(PARTS, nrm.blocks // 2)) if nrm.blocks >= 4 else []
    K = len(groups)
    out: dict[int, dict] = {}
    if K < 2 or free.size == 0:
        return K, out
    per_part = [covariance(nrm, free, offset, blocks=g) for g in groups]
    xs = np.array([x for x, _, _ in per_part])  # [K, free] the estimates of each part
    ss = np.array([np.sqrt(np.abs(np.diag(white))) for _, white, _ in per_part])  # [K, free] their white sigmas
    for pos, j in enumerate(free.tolist()):
        if not 0.0 < sigma[j] < np.inf:
            continue
        ratio = sigma[j] / white_sigma[j] if white_sigma[j] > 0 else 1.0
        s = ss[:, pos] * ratio
        seen = (s > 0) & (s <= _SEEN * np.sqrt(K) * sigma[j])
        if seen.sum() < 2:
            continue
        # in units of the whole record's error: a parameter the record hardly holds has errors near
        # the float limit, whose inverse squares would underflow to nothing
        w = (sigma[j] / s[seen]) ** 2
        x = xs[seen, pos] / sigma[j]
        sw, sw2 = float(np.sum(w)), float(np.sum(w**2))
        xbar = float(np.sum(w * x) / sw)
        c2 = float(np.sum(w * (x - xbar) ** 2))
        dof = int(seen.sum()) - 1
        # DerSimonian-Laird: the variance tau^2 of an effect of each part beyond its own noise, and
        # what it adds to the whole record's estimate, whose parts weigh in by their information;
        # only beyond chance (module docstring)
        inflated = bool(c2 > chi2.isf(CONSISTENCY_LEVEL / SPLITS, dof))
        tau2 = max(0.0, (c2 - dof) / (sw - sw2 / sw)) if inflated else 0.0
        out[j] = {
            "parameter": PARAMS[j].label,
            "effect": PARAMS[j].effect,
            "split": split,
            "chi2_dof": c2 / dof,
            "dof": dof,
            "tau": float(np.sqrt(tau2) * sigma[j] / PARAMS[j].per_unit),
            "factor": float(np.sqrt(1.0 + tau2 * sw2 / sw**2)),
            "inflated": inflated,
        }
    return K, out
