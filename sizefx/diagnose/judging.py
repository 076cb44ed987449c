"""The checks on a selection (:func:`_judge`): which selected effects are findings.

In order, the later ones only when the earlier pass: plausible for the grade, separable from the
other selected effects, of consequence (:data:`MIN_SHARE` of the structure on its channels), and
stable across the record's parts. :func:`sizefx.diagnose.fit.diagnose` refits without what they
reject until nothing changes, and judges the findings again beside the candidates fitted with them.
Once the errors are made, the last checks (:func:`_as_reported`): which components the record does
not measure, and which findings are not significant under the error they are reported with.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2

from .algebra import wald
from .budget import UNDETERMINED_SHARE, Parts, parts_scatter
from .candidates import PRIORITY
from .gauss_newton import _free, _State
from .normal import Rows
from .plausibility import judge, likely_cause
from .predictor import Predictor
from .records import Rejection
from .residual import residual_under, rms
from .selection import FAMILY_ALPHA, Chosen, aliased_pairs, robust_p
from .theta import PARAMS

__all__ = ["MIN_SHARE", "not_significant_as_reported"]

#: Least share of the structure on its channels (the residual power beyond white noise, without the
#: effect) an accepted effect must explain: below it the effect is a correction of no consequence,
#: more likely a side effect of something else than a finding.
MIN_SHARE = 0.01


def _channels_of(pred, rows_of, theta, theta0, c, residual, sigma_c):
    """The residual's rows without effect ``c`` and the channels it acts on: where its contribution, in units
    of each channel's noise, is at least a tenth of its largest (the tilt acts on the gyros too,
    through Earth rate, but 1e5 times less)."""
    without = theta.copy()
    without[list(c.active)] = theta0[list(c.active)]
    r_wo = residual_under(pred, rows_of, without).rows
    size = rms(rows_of, r_wo - residual) / sigma_c
    chans = np.flatnonzero(size >= 0.1 * size.max()) if size.max() > 0 else np.arange(6)
    return r_wo, chans


def _share(rows_of, r_wo, residual, weights, chans, noise_power):
    """Share of the structure on ``chans`` (weighted residual power without the effect, minus the white
    noise's) that the effect removes: in [0, 1] by construction."""
    p_wo = float(np.sum(weights[chans] * rms(rows_of, r_wo)[chans] ** 2))
    p_with = float(np.sum(weights[chans] * rms(rows_of, residual)[chans] ** 2))
    gain = max(0.0, p_wo - p_with)
    structure = max(p_wo - float(np.sum(weights[chans] * noise_power[chans])), gain)
    return gain / structure if structure > 0 else 0.0


def _rejection(c: Chosen, theta, reason, likely=None) -> Rejection:
    return Rejection(
        c.cand.id,
        c.cand.channel,
        {PARAMS[j].label: float(theta[j] / PARAMS[j].per_unit) for j in c.cand.idx},
        PARAMS[c.cand.idx[0]].unit,
        reason,
        likely,
    )


@dataclass
class _Verdict:
    """One round of the checks on a selection (:func:`_judge`)."""

    #: key -> (reason, likely cause, implausible) of each effect that is no finding; reason None for
    #: the member of an aliased pair the model keeps
    reasons: dict
    aliased: list  #: (kept, gone, rho): selected pairs the motion cannot tell apart
    shares: dict  #: key -> share of the structure on its channels the effect explains
    parts: Parts | None  #: the parts' scatter of this state, when the checks got that far


def _judge(
    pred: Predictor, rows_of: Rows, state: _State, theta0, grade, level, white_rows, beside=(), every_check=False
) -> _Verdict:
    """The checks on the selection ``state.chosen`` but the keys ``beside`` (candidates fitted beside
    the findings, no findings themselves), in order, the later ones only when the earlier pass
    (unless ``every_check``):

    1. plausible for the grade (:func:`sizefx.diagnose.plausibility.judge`): an implausible value says
       the reference or the model is wrong, not the sensor;
    2. separable from the other selected effects (:func:`sizefx.diagnose.selection.aliased_pairs`):
       of a pair the motion cannot tell apart neither is a finding, the model keeps their sum as the
       more common one (:data:`sizefx.diagnose.candidates.PRIORITY`);
    3. of consequence: it explains at least :data:`MIN_SHARE` of the structure on its channels;
    4. stable across the record's parts: still significant with the errors widened by their random effect
       (:func:`sizefx.diagnose.budget.parts_scatter`).
    """
    judged = {c.cand.key for c in state.chosen} - set(beside)
    reasons: dict = {}
    aliased: list = []
    shares: dict = {}
    parts = None
    offset = theta0 - state.theta
    for c in state.chosen:
        why = judge(c.cand.id, state.theta[list(c.cand.idx)], grade) if c.cand.key in judged else None
        if why:
            reasons[c.cand.key] = (why, likely_cause(c.cand.id), True)
    if not reasons or every_check:
        for i, k, rho in aliased_pairs(state.nrm, state.chosen, offset, level):
            a, b = state.chosen[i], state.chosen[k]
            if not {a.cand.key, b.cand.key} <= judged:
                continue  # a finding and what is fitted beside it: alike by construction
            keep, gone = (a, b) if PRIORITY.index(a.cand.id) <= PRIORITY.index(b.cand.id) else (b, a)
            if keep.cand.key in reasons or gone.cand.key in reasons:
                continue
            reasons[gone.cand.key] = (
                (None, None, False) if not every_check else (f"indistinguishable from {keep.cand.key}", None, False)
            )
            aliased.append((keep, gone, rho))
    if not reasons or every_check:
        weights = 1.0 / (state.sigma_c**2 * state.kappa)
        for c in state.chosen:
            if c.cand.key not in judged:
                continue
            r_wo, chans = _channels_of(pred, rows_of, state.theta, theta0, c, state.residual, state.sigma_c)
            share = shares[c.cand.key] = _share(rows_of, r_wo, state.residual, weights, chans, white_rows**2)
            if share < MIN_SHARE and c.cand.key not in reasons:
                reasons[c.cand.key] = (
                    f"explains {100 * share:.2f} % of the structure on its channels, under the "
                    f"{100 * MIN_SHARE:g} % a finding needs",
                    "a side effect of another effect or of the noise's colour",
                    False,
                )
    if not reasons or every_check:
        parts = parts_scatter(pred, state.nrm, _free(state.chosen), offset)
        for i, c in enumerate(state.chosen):
            if c.cand.key not in judged or c.cand.key in reasons:
                continue
            p = robust_p(state.nrm, state.chosen, offset, which=i, factors=parts.factors)
            if p > level:
                reasons[c.cand.key] = (
                    f"not significant (p = {p:.2g}) once its errors take the scatter of the record's parts",
                    "the noise's colour or an effect that changes along the record",
                    False,
                )
    return _Verdict(reasons, aliased, shares, parts)


def not_significant_as_reported(free, reported, theta, theta0, cov, unmeasured: dict, level: float) -> dict:
    """``{finding key: reason}``: the findings of ``reported`` whose reported values (``theta``, the
    parameters fitted beside them in) do not differ from their start values ``theta0`` at ``level``
    under the error they are reported with (``cov`` [free, free], every part in), over the
    parameters the record measures (``unmeasured``: key -> those it does not).

    :func:`sizefx.diagnose.aliases.not_significant` tests the model without the weak parameters;
    fitted beside it, they move the estimate and widen its error, and a finding within its reported
    error of zero is no finding to its reader (a development-range flight: an accelerometer delay
    of -373 +- 390 us, against a truth of 0)."""
    out = {}
    for c in reported:
        params = [j for j in c.active if j not in unmeasured.get(c.cand.key, ())]
        if not params:
            continue
        pos = np.searchsorted(free, params)
        x = (theta - theta0)[params]
        p = float(chi2.sf(wald(x, cov[np.ix_(pos, pos)], np.arange(len(params))), len(params)))
        if p > level:
            out[c.cand.key] = (
                f"not significant under the error it is reported with (p = {p:.2g}, every part of the budget "
                "in); the extended model carries it"
            )
    return out


def _as_reported(budget, reported, theta, theta0) -> tuple:
    """The last checks on the findings ``reported``, under the errors of ``budget``
    (:class:`sizefx.diagnose.budget.ErrorBudget`) at the values ``theta`` they are reported with:
    ``(undetermined {finding key: parameters}, not shown {finding key: reason}, {parameter: share
    of its variance the hidden parameters' part makes up})``.

    - a parameter nine tenths or more of whose variance is the hidden parameters' priors
      (:data:`sizefx.diagnose.budget.UNDETERMINED_SHARE`) and whose value lies within that error of
      its start value (two-sided p above :data:`sizefx.diagnose.selection.FAMILY_ALPHA`) is not
      measured: named in ``not_revealed``, the estimate carried by the extended model; a finding
      with none of its parameters measured is no finding. One whose value stands out of such an
      error is measured all the same: a mount of 30 arcsec at +-0.2 arcsec, all of it a reference
      delay's prior, beside a record's own 0.008 (``tests/test_reference_mount.py``);
    - a finding whose measured parameters do not differ from their start values ``theta0`` under
      the error reported, every part in, at the family's level for it alone
      (:data:`sizefx.diagnose.selection.FAMILY_ALPHA`: the selection has taken it, and this asks only
      whether its reader sees it apart from its start value), is no finding
      (:func:`not_significant_as_reported`)."""
    free = budget.free
    lent = dict(zip(free.tolist(), budget.borrowed().tolist()))
    sigma = budget.sigma()
    p = {j: float(chi2.sf(((theta[j] - theta0[j]) / sigma[j]) ** 2, 1)) if sigma[j] > 0 else 1.0 for j in sigma}
    undetermined = {
        c.cand.key: [j for j in c.active if lent[j] >= UNDETERMINED_SHARE and p[j] > FAMILY_ALPHA] for c in reported
    }
    undetermined = {k: v for k, v in undetermined.items() if v}
    shown = not_significant_as_reported(free, reported, theta, theta0, budget.covariance(), undetermined, FAMILY_ALPHA)
    return {k: v for k, v in undetermined.items() if k not in shown}, shown, lent
