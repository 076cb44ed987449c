"""Do the record's parts agree? Each selected parameter fitted on K contiguous parts alone.

A standard error is a promise about how far the estimate would move on another record of the same
set-up. The record itself holds such records: its K contiguous parts (groups of the blocks of
:class:`sizefx.diagnose.normal.Normal`). :func:`block_consistency` fits the selected parameters on
each part alone and compares the spread of the part estimates with their stated errors:

    chi2_j = sum_k (x_kj - xbar_j)^2 / sigma_kj^2,   dof = K' - 1   (K' parts that determine j)

``sigma_kj`` is the part's white standard error scaled by the whole record's ratio of honest
(block-sandwich) to white error, so that chi2/dof is near 1 when the errors are honest. Beyond
the chi-square point of :data:`CONSISTENCY_LEVEL` the disagreement is no chance (a drifting
sensor, a reference that changes, an effect outside the model): ``factor`` is then sqrt(chi2/dof)
and the parameter is flagged.

The same check runs on parts cut by motion instead of time (:func:`motion_groups`: quartiles of
rotation rate and of translation); the level is shared by the three cuts (Bonferroni). How the
cuts widen an error is :func:`sizefx.diagnose.budget.parts_scatter`' choice (the largest sqrt(chi2/dof)).
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
    "dof", "factor", "inflated"}`` (parameters fewer than two parts determine are left out).

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
        ratio = sigma[j] / white_sigma[j] if white_sigma[j] > 0 else 1.0
        s = ss[:, pos] * ratio
        seen = s <= _SEEN * np.sqrt(K) * sigma[j]
        if seen.sum() < 2:
            continue
        w = 1.0 / s[seen] ** 2
        xbar = float(np.sum(w * xs[seen, pos]) / np.sum(w))
        c2 = float(np.sum(w * (xs[seen, pos] - xbar) ** 2))
        dof = int(seen.sum()) - 1
        bad = c2 > chi2.isf(CONSISTENCY_LEVEL / SPLITS, dof)
        out[j] = {
            "parameter": PARAMS[j].label,
            "effect": PARAMS[j].effect,
            "split": split,
            "chi2_dof": c2 / dof,
            "dof": dof,
            "factor": float(np.sqrt(c2 / dof)) if bad else 1.0,
            "inflated": bool(bad),
        }
    return K, out
