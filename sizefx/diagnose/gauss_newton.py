"""The Gauss-Newton loop of :func:`sizefx.diagnose.fit.diagnose`: select, update, recompute, until settled.

Each pass selects (:func:`sizefx.diagnose.selection.select`) on the block-wise normal equations
linearised at the current estimate, updates the selected parameters, and recomputes the prediction
and the regressors. Rows are weighted per channel (``1 / (sigma_c^2 kappa_c)``, sigma from the median
absolute deviation, kappa the variance inflation of block means) and per row by Huber's weights
(iteratively re-weighted least squares, from the second pass on). A refit with the selection fixed
(:func:`_iterate`'s ``fixed``) runs the same loop without selecting.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from .algebra import with_prior
from .candidates import columns_between
from .normal import Normal, Rows, normal_equations, solve
from .predictor import Predictor
from .residual import noise_of, residual_under
from .selection import select

__all__ = ["MAX_PASSES", "REFIT_PASSES", "normal_beside"]

#: Gauss-Newton passes at most; selection and estimates settle in two or three.
MAX_PASSES = 6
#: Passes at most of a refit with the selection fixed (after judging removed an effect).
REFIT_PASSES = 3


@dataclass
class _State:
    theta: np.ndarray
    chosen: list
    unrevealed: dict
    residual: np.ndarray  #: [m, 6] the rows of the residual at theta
    nrm: Normal
    sigma_c: np.ndarray
    kappa: np.ndarray
    passes: int
    ms_full: np.ndarray  #: [6] the residual's full-band mean square over the usable samples


def normal_beside(pred: Predictor, rows_of: Rows, theta, residual, weighted_by) -> Normal:
    """The normal equations at ``theta`` of the residual's rows ``residual`` there, with the walk and
    the block sums the errors take (:func:`sizefx.diagnose.budget.parts_scatter`), weighted per
    channel and per row as the rows ``weighted_by`` weigh them (:func:`sizefx.diagnose.residual.noise_of`):
    a state's estimate with the parameters fitted beside its model
    (:func:`sizefx.diagnose.aliases.hidden_fit`) at their fitted values, weighted as the state's own
    equations (``weighted_by=state.residual``), from which that step was taken."""
    sigma_c, kappa, row_w = noise_of(rows_of, weighted_by, robust=True)
    cols = columns_between(theta, functools.partial(pred.terms_span, theta), pred.t)
    return normal_equations(rows_of, residual, cols, 1.0 / (sigma_c**2 * kappa), row_w, walk=True)


def _free(chosen):
    return np.array(sorted({j for c in chosen for j in c.active}), dtype=int)


def _iterate(
    pred: Predictor, rows_of: Rows, theta0, theta, log, *, fixed=None, progress=None, start=None, prior=None
) -> _State:
    """Gauss-Newton from ``theta`` with the selection redone each pass (or ``fixed``), until the
    selection and the estimates settle. Returns the final state with the normal equations at the
    final residual (regressors of the last pass: theta has moved by under 1e-3 sigma since).
    ``start``: the residual's rows at ``theta``, when already known. The residual is held as rows
    (``_State.residual``), the regressors are formed span by span.

    ``prior``: {parameter index: standard deviation [SI]}, a Gaussian prior about the start value
    ``theta0`` that the steps take (the estimate is the posterior mode); the state's normal
    equations, from which the errors come, hold none of it. Nearly collinear parameters fitted
    together (:func:`sizefx.diagnose.selection.nuisance_aliases`) have a direction the record hardly
    determines: without their priors a step along it follows the noise as far as it goes, out of
    the range where the prediction is linear in the parameters, and the fit diverges."""
    residual = residual_under(pred, rows_of, theta).rows if start is None else start
    assert residual is not None  # _residual gives rows with rows_of
    first = residual[rows_of.keep]  # white-noise sigma from first differences to start
    sigma_c = np.maximum(np.sqrt(np.mean(np.diff(first, axis=0) ** 2, axis=0) / 2.0), 1e-300)
    kappa, row_w = np.ones(6), None
    history = []
    penalty = math.log(max(int(rows_of.keep.sum()) * 6, 2))
    chosen, unrevealed = list(fixed or []), {}
    # a refit with the selection fixed starts where the last one ended, with a few parameters reset:
    # it settles in two passes, three at most
    for passes in range(1, (MAX_PASSES if fixed is None else REFIT_PASSES) + 1):
        cols = columns_between(theta, functools.partial(pred.terms_span, theta), pred.t)  # span by span
        weights = 1.0 / (sigma_c**2 * kappa)
        nrm = normal_equations(rows_of, residual, cols, weights, row_w)
        offset = theta0 - theta  # a parameter not selected stays at its nominal value
        if fixed is None:
            chosen, unrevealed, steps = select(nrm, offset, penalty)
            log.append(f"pass {passes}: " + ("; ".join(steps) if steps else "nothing selected"))
        free = _free(chosen)
        N, b, yy = nrm.total()
        if prior:
            N, b = with_prior(N, b, offset, prior)
        x, _, cov = solve(N, b, yy, free, offset)
        new = theta0.copy()
        new[free] = theta[free] + x
        sig = np.sqrt(np.abs(np.diag(cov))) if free.size else np.zeros(0)
        step = float(np.max(np.abs(x) / np.maximum(sig, 1e-300))) if free.size else 0.0
        theta = new
        final = residual_under(pred, rows_of, theta)
        residual = final.rows
        assert residual is not None  # _residual gives rows with rows_of
        sigma_c, kappa, row_w = noise_of(rows_of, residual, robust=True)
        history.append(tuple(sorted(c.cand.key for c in chosen)))
        if progress is not None:
            progress(passes, MAX_PASSES)
        if passes >= 2 and history[-1] == history[-2] and step < 1e-3:
            break
    weights = 1.0 / (sigma_c**2 * kappa)
    nrm = normal_equations(rows_of, residual, cols, weights, row_w, walk=True)
    return _State(theta, chosen, unrevealed, residual, nrm, sigma_c, kappa, passes, final.ms_full)
