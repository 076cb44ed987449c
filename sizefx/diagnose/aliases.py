"""Two explanations the record cannot tell apart: resolved by plausibility where one is absurd, and
the motion that would tell them apart.

On a pitch sway at one frequency an accelerometer-x arm shifted along z and an accelerometer-x
scale factor leave the same trace: the arm's tangential term ``r * omega_dot`` and the scale
factor's ``k * f_x`` both follow the pitch angle (``omega_dot = -(2 pi f)^2 theta``,
``f_x = -g sin theta``). The record alone cannot say which it sees. The grade often can: 2.1 mm of
arm is an ordinary assembly tolerance, the equivalent ``r (2 pi f)^2 / g`` = 2 100 ppm is beyond any
navigation-grade accelerometer.

- :func:`alone`: what each member of a pair would be if it alone explained what the pair explains
  (the other held at its start value, the rest of the model refitted), from the normal equations.
- :func:`resolve`: when the finding is plausible for the grade, its alternative alone is not, and
  the finding stays significant whatever the alternative is within its plausible range
  (:func:`significant_within`), the finding stands, with the alternative and its implausible value
  beside it, and an error that holds wherever in that range the alternative really is (a uniform
  distribution over the grade's range, propagated through the pair's normal equations).
- :func:`separating_motions`: for a pair that stays unresolved (or nearly collinear), the motions
  of a small library (:data:`LIBRARY`: sways at two frequencies about each body axis, a turntable
  with each axis vertical in turn, a tumble) that would tell the two apart if recorded as long
  again, with the canonical correlation the pair would then have: computed from the Jacobian of
  the model at the record's estimate on each motion, noise-free.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from ..constants import DEG
from .algebra import scaled_pinv, with_prior
from .normal import Rows, canonical_correlation, covariance, normal_equations, solve
from .plausibility import GRADES, RANGES, judge, prior_sigma
from .selection import ALIAS_CORRELATION, NUISANCE_CORRELATION, honest
from .theta import PARAMS

__all__ = [
    "Alternative",
    "hidden_fit",
    "hidden_parameters",
    "weak_parameters",
    "masked_by_hidden",
    "strongest_hidden",
    "not_significant",
    "hidden_reach",
    "alone",
    "library_normals",
    "resolve",
    "separating_motions",
    "significant_within",
    "LIBRARY",
    "SEPARATED_CORRELATION",
]

#: A pair whose canonical correlation falls under this with a motion added is told apart by it: the
#: correlation from which :func:`sizefx.diagnose.selection.nuisance_aliases` calls two effects nearly
#: collinear (errors 2.3 times those of the orthogonal case at most).
SEPARATED_CORRELATION = 0.9
#: The motions :func:`separating_motions` tries, each a few tens of seconds, noise-free, at
#: :data:`LIBRARY_RATE_HZ`: (what the report calls it, how it is made).
LIBRARY = (
    ("a roll sway at two frequencies (0.5 and 1.3 Hz, about body x)", ("sway", "x")),
    ("a pitch sway at two frequencies (0.5 and 1.3 Hz, about body y)", ("sway", "y")),
    ("a heading sway at two frequencies (0.5 and 1.3 Hz, about body z)", ("sway", "z")),
    ("a turntable with each body axis vertical in turn (rotations at 20 deg/s, static dwells)", ("turntable", "")),
    ("a tumble through all attitudes", ("tumble", "")),
)
LIBRARY_RATE_HZ = 100.0
LIBRARY_S = 40.0


@dataclass(frozen=True)
class Alternative:
    """What a finding could be instead on this motion, and why it is not."""

    key: str  #: the other candidate (``accel_scale_factor:accel_x``)
    parameters: dict  #: label -> its value (report unit) were it alone to explain the data
    unit: str
    reason: str  #: why that value is implausible for the grade
    rho: float  #: the pair's canonical correlation on this motion
    #: label -> how far the finding's parameters could move (``finding_unit``, 1 sigma) with the
    #: alternative anywhere in its plausible range
    sigma_added: dict
    finding_unit: str

    def as_dict(self) -> dict:
        return {
            "effect": self.key,
            "parameters": dict(self.parameters),
            "unit": self.unit,
            "reason": self.reason,
            "canonical_correlation": self.rho,
            "sigma_added": dict(self.sigma_added),
            "sigma_added_unit": self.finding_unit,
        }


def alone(nrm, free, group, theta, theta0) -> np.ndarray:
    """The values (SI, ``theta``'s layout) of the parameters ``group`` were they to explain the data
    with the parameters ``free`` (the rest of the model, ``group`` excluded) refitted and every other
    parameter at its start value: one Gauss-Newton step at ``theta`` on the normal equations ``nrm``."""
    group = np.asarray(group, dtype=int)
    together = np.union1d(np.setdiff1d(np.asarray(free, dtype=int), group), group)
    N, b, yy = nrm.total()
    x, _, _ = solve(N, b, yy, together, theta0 - theta)
    out = theta0.copy()
    out[together] = theta[together] + x
    return out[group]


def _half_range(cand_id: str, count: int, grade: str) -> np.ndarray:
    """Per parameter [SI]: half the width of the grade's plausible range (:data:`RANGES`)."""
    per_unit, _, ranges = RANGES[cand_id]
    return np.full(count, ranges[GRADES.index(grade)] * per_unit)


def _prior(cand_id: str, count: int, grade: str) -> np.ndarray:
    """Per parameter [SI]: the prior standard deviation of a part of the grade
    (:func:`sizefx.diagnose.plausibility.prior_sigma`: its data sheet, else its plausible range)."""
    return np.full(count, prior_sigma(cand_id, grade))


def _shift(nrm, free, alt_idx) -> np.ndarray:
    """[free, alt]: how much the estimates of ``free`` move per unit of the parameters ``alt_idx``
    (not in the model): ``-N_ff^-1 N_fa``."""
    N = nrm.N.sum(0)
    free = np.asarray(free, dtype=int)
    alt = np.asarray(alt_idx, dtype=int)
    return -scaled_pinv(N[np.ix_(free, free)]) @ N[np.ix_(free, alt)]


def _reach(nrm, free, j: int, sd: float, beside=()) -> float:
    """The largest shift of an estimate of ``free`` that parameter ``j`` one prior standard deviation
    ``sd`` from its start value gives, in the estimate's white standard errors (``N_ff^-1``), with the
    parameters ``beside`` (fitted beside ``free``) free to follow: ``j`` also moves ``free`` through
    them."""
    N = nrm.N.sum(0)
    free = np.asarray(free, dtype=int)
    joint = np.concatenate([free, [b for b in beside if b != j and b not in free]]).astype(int)
    sig = np.sqrt(np.abs(np.diag(scaled_pinv(N[np.ix_(free, free)]))))
    S = _shift(nrm, joint, [j])[: free.size, 0]
    return float(np.max(np.abs(S) * sd / np.where(sig > 0, sig, np.inf)))


def _spread(S, sd) -> np.ndarray:
    """``S Sigma S'``: the covariance the shifts ``S`` [k, m] per unit of parameters with standard
    deviations ``sd`` [m] give (``Sigma = diag(sd^2)``)."""
    return S @ np.diag(np.asarray(sd) ** 2) @ S.T


def significant_within(x, cov, S, half) -> float:
    """p-value of the finding's deviation ``x`` [k] from its start value (covariance ``cov`` [k, k])
    with an alternative anywhere in the box ``[-half, half]`` (shifting the finding by ``S a``,
    ``S`` [k, m]): the chi-square of the deviation the alternative leaves at best (box-constrained
    least squares on the whitened deviation), on ``k`` degrees of freedom."""
    from scipy.optimize import lsq_linear
    from scipy.stats import chi2

    W = np.linalg.cholesky(np.linalg.pinv(cov)).T  # W'W = cov^-1
    best = lsq_linear(W @ S, W @ x, bounds=(-half, half))
    return float(chi2.sf(2.0 * best.cost, x.size))


#: A parameter hidden as not excited that could move no finding by this fraction of its white standard
#: error at one prior standard deviation (:func:`_prior`) is left out of :func:`hidden_parameters`: it would add at
#: most 1 % to a variance, and its regressor is often numerical noise (an arm's r_z[z] on a sway about
#: one horizontal axis: 2e-9 s^-2), which no covariance of it can be formed from. Set from that bound,
#: not from the validation protocol.
MIN_REACH = 0.1
#: A parameter the selection left out (not significant, or not excited) that one prior standard
#: deviation from its start value (:func:`_prior`) moves an estimate of the model by this many of its
#: white standard errors is fitted beside the model with that prior, however weakly correlated: held at zero it would bias
#: the estimate by more than its error says (an accelerometer-x scale factor of -12 ppm on a tumble
#: moved the x arm's z component by 0.19 mm, 4.4 sigma: development seed 35). Through the parameters
#: fitted beside the model too (:func:`weak_parameters`): on a flight with rotor vibration an
#: accelerometer delay under its excitation floor moved the arms found by 5 um per 720 us itself and by
#: 1.0 mm with the other arm components free (development seed 0: r_x[z] at -2.6 sigma). One standard
#: error: the size from which a bias changes what a reported error means; not chosen by the
#: validation protocol.
CONSIDER_REACH = 1.0


def hidden_parameters(nrm, chosen, unrevealed: dict, grade: str, skip=()) -> list:
    """``[(candidate, [param], fitted)]``: the parameters the selection hid (``unrevealed``: key -> (candidate,
    hidden parameters, reason)) that may still move the estimates of the model ``chosen`` (its
    :class:`~sizefx.diagnose.selection.Chosen` effects), held at their start values by the fit
    (``skip``: candidate keys already counted, the alternatives of resolved aliases; ``grade``: the
    priors, :func:`sizefx.diagnose.plausibility.prior_sigma`):

    - those hidden because the record cannot tell them from what it selected (a reason
      "indistinguishable ...");
    - those hidden as not excited (their regressor under its floor, :attr:`Param.min_excitation`,
      or measured on some channels only, :attr:`Param.primary`) that the model's findings nearly
      explain together (canonical correlation with all of them of
      :data:`sizefx.diagnose.selection.NUISANCE_CORRELATION` or more, as a candidate left out is
      fitted beside a finding): the floor says the record cannot reveal them, not that they are
      absent, and the findings take them up. A mount about z on a flight that only turns about the
      vertical: the gyros do not show it, the accelerometers see it as a misalignment of x towards
      y (a development-range flight: 140.6 arcsec of mount reported as that misalignment, 140.6 +-
      0.84 against a truth of 0). The y gyro's scale factor on a flight of coordinated turns: the
      pitch rate is the yaw rate times the tangent of the bank, under the floor, and the y gyro's
      misalignment towards z took a true -16 ppm as -1.0 +- 0.1 arcsec (development seed 55).
      These are ``fitted``: what the record says of them moves the estimates (:func:`hidden_fit`),
      as a nuisance's does."""
    out: list = []
    for cand, mine, _, rho in _screen(nrm, chosen, unrevealed, grade, skip):
        if rho is None:  # indistinguishable: held at its start value, its prior in the errors
            out.append((cand, mine, False))
            continue
        # from ALIAS_CORRELATION on, the record cannot tell the parameter from the findings at all:
        # held with its prior as an indistinguishable one is (fitting it would only invert noise)
        held = [j for j in mine if rho[j] >= ALIAS_CORRELATION]
        fitted = [j for j in mine if NUISANCE_CORRELATION <= rho[j] < ALIAS_CORRELATION]
        for group, beside in ((fitted, True), (held, False)):
            if group:
                out.append((cand, group, beside))
    return out


def weak_parameters(nrm, chosen, unrevealed: dict, grade: str, hidden: list, skip=()) -> list:
    """``[(candidate, [param], True)]``: the parameters of ``unrevealed`` (as for
    :func:`hidden_parameters`) the record tells apart from the findings (canonical correlation under
    :data:`sizefx.diagnose.selection.NUISANCE_CORRELATION`) but which one prior standard deviation
    from their start values would move a finding by its own white standard error or more
    (:data:`CONSIDER_REACH`), to be fitted beside the model with that prior (:func:`hidden_fit`),
    furthest reaching first. The reach is taken with the ``hidden`` parameters fitted beside the
    model and the weak ones taken so far free to follow (:func:`_reach`), round by round until a
    round takes none: a parameter may move a finding little by itself and much through another
    fitted beside it.

    One nearly collinear with the model, the ``hidden`` parameters fitted beside it and the weak ones
    taken so far is skipped: two left out together (a bias and a scale factor under constant gravity)
    have no joint covariance, and the first taken stands for both.

    The selection tested each finding against these (it can tell them apart), so they widen the
    errors the findings are reported with but do not mask a finding (:func:`not_significant`)."""
    N = nrm.N.sum(0)
    findings = sorted({j for c in chosen for j in c.active})
    basis = findings + [j for _, params, beside in hidden if beside for j in params]
    # (candidate, parameter, reach with the parameters fitted beside so far), the first round's
    # reach the screen's own
    left = [
        (cand, j, reach[j])
        for cand, mine, reach, rho in _screen(nrm, chosen, unrevealed, grade, skip, beside=basis[len(findings) :])
        if rho is not None
        for j in mine
        if rho[j] < NUISANCE_CORRELATION
    ]
    out: list = []
    while left:
        ranked = sorted((r, k) for k, (_, _, r) in enumerate(left) if r >= CONSIDER_REACH)[::-1]
        if not ranked:
            break
        for _, k in ranked:
            cand, j, _ = left[k]
            if canonical_correlation(N, basis, [j]) < NUISANCE_CORRELATION:
                out.append((cand, [j], True))
                basis.append(j)
        taken = {k for _, k in ranked}
        beside = basis[len(findings) :]
        left = [
            (cand, j, _reach(nrm, findings, j, _prior(cand.id, 1, grade)[0], beside))
            for k, (cand, j, _) in enumerate(left)
            if k not in taken
        ]
    return out


def _screen(nrm, chosen, unrevealed: dict, grade: str, skip, beside=()):
    """Per entry of ``unrevealed`` the model ``chosen`` does not hold already: ``(candidate, its
    parameters, None, None)`` for one hidden as indistinguishable; otherwise ``(candidate, parameters
    that could move a finding by MIN_REACH or more, {param: reach}, {param: canonical correlation with
    the findings})``, the reach with the parameters ``beside`` free to follow (:func:`_reach`)."""
    N = nrm.N.sum(0)
    free = sorted({j for c in chosen for j in c.active})
    for cand, params, reason in unrevealed.values():
        if cand.key in skip or cand.id not in RANGES:
            continue
        mine = [j for j in params if j not in free]
        if reason.startswith("indistinguishable"):
            if mine:
                yield cand, mine, None, None
            continue
        if not free:
            continue
        reach = {j: _reach(nrm, free, j, _prior(cand.id, 1, grade)[0], beside) for j in mine}
        mine = [j for j in mine if reach[j] >= MIN_REACH]
        yield cand, mine, reach, {j: canonical_correlation(N, free, [j]) for j in mine}


def hidden_fit(nrm, free, hidden: list, grade: str, offset, prior=None):
    """The model ``free`` beside the ``hidden`` parameters (:func:`hidden_parameters`), each with the
    prior of a part of the grade about its start value (:func:`sizefx.diagnose.plausibility.prior_sigma`:
    the data-sheet standard deviation, or a spread over the plausible range):
    ``(dx [free], dh [fitted], added [free, free])``: the steps of the estimates and of the hidden
    parameters marked ``fitted``, from the normal equations ``nrm`` (formed at the current
    estimate; ``offset``: the start model minus it), and what all the hidden parameters add to the
    covariance of ``free``.

    With ``S = -N_ff^-1 N_fh`` the shift of the estimates per unit of the hidden ones and ``P`` the
    priors' precisions:

    - a parameter held at its start value (hidden as indistinguishable) may be anywhere its prior
      allows: it adds ``S P^-1 S'``;
    - a ``fitted`` one is estimated beside ``free`` with its prior: with
      ``C = N_hh - N_hf N_ff^-1 N_fh`` what the record still says of it once ``free`` is fitted,
      ``dh = (C + P)^-1 (b_h - N_hf N_ff^-1 b_f + P o_h)`` (``o_h`` its offset: the prior is about
      the start value), ``dx = N_ff^-1 b_f + S dh`` (the joint system's solution, from an estimate
      of ``free`` fitted at other weights too), and it adds ``S (C_r + P)^-1 S'``,
      ``C_r`` the inverse of its block of the covariance of ``free`` and the fitted ones together:
      the white one with each variance scaled up to the long-run sandwich's
      (:func:`sizefx.diagnose.normal.covariance`) where that is larger:
      where the residual is coloured (a bias walk) the weighted normal equations promise far more
      than the record holds.

    ``prior``: {parameter of ``free``: standard deviation}, the priors the fit's steps took (the
    nuisances fitted beside a nearly collinear finding, :func:`sizefx.diagnose.gauss_newton._iterate`):
    the step takes them too, so that it stays the posterior mode the fit converged to (without,
    its ``N_ff^-1 b_f`` undid them along the direction the record hardly determines: thousands of
    arcseconds of mount on a heading sway); the errors take those parameters free.

    A mount about z and the gyros' antisymmetric misalignment are one rotation to a record: with
    the z gyro's misalignment towards x hidden, the x gyro's towards z comes out as their sum, and
    its error, conditional on the hidden one being zero, said nothing of it (a development-range
    tumble: 0.24 +- 0.004 arcsec against a truth of -1.4)."""
    free = np.asarray(free, dtype=int)
    added = np.zeros((free.size, free.size))
    held = [(cand, params) for cand, params, fitted in hidden if not fitted]
    beside = [(cand, params) for cand, params, fitted in hidden if fitted]
    for cand, params in held:
        added += _spread(_shift(nrm, free, params), _prior(cand.id, len(params), grade))
    idx = np.array([j for _, params in beside for j in params], dtype=int)
    if idx.size == 0 or free.size == 0:
        return np.zeros(free.size), np.zeros(idx.size), added
    sd = np.concatenate([_prior(cand.id, len(params), grade) for cand, params in beside])
    P = np.diag(1.0 / sd**2)
    N, b, _ = nrm.total()
    # the step: the joint posterior mode, the fit's own priors in (they are on free's parameters only)
    Ns, bs = with_prior(N, b, offset, prior) if prior else (N, b)
    inv_s = scaled_pinv(Ns[np.ix_(free, free)])
    S_s = -inv_s @ Ns[np.ix_(free, idx)]
    S = _shift(nrm, free, idx) if prior else S_s  # [free, fitted], the errors' (the fit's priors out)
    C_s = Ns[np.ix_(idx, idx)] + Ns[np.ix_(idx, free)] @ S_s
    # the priors are about the start values: from an estimate away from them, they pull back (offset)
    dh = scaled_pinv(C_s + P) @ (bs[idx] + S_s.T @ bs[free] + P @ offset[idx])
    joint = np.concatenate([free, idx])
    order = np.argsort(joint)
    _, white, robust = covariance(nrm, joint[order], offset)
    at = np.searchsorted(joint[order], idx)
    # the white covariance scaled up where the sandwich's diagonal is larger (honest() with the roles
    # swapped): the design's correlations, the colour's widening per parameter. The sandwich's own
    # correlations come from about a hundred blocks over twenty and more parameters; inverted, its
    # block promised more than the white one in some combination: on a development-range flight
    # (seed 10) the y gyro's scale factor and nine others fitted beside the y gyro's misalignment
    # towards z moved it by 1.5 arcsec, charged 0.19 arcsec from the sandwich against 0.57 from white
    V = honest(robust, white)[np.ix_(at, at)]
    # halved before the sum: a weak parameter the record hardly holds has a variance near the float
    # limit; one beyond it says the record holds nothing of it (its prior alone then speaks)
    V = 0.5 * V + 0.5 * V.T
    ok = np.isfinite(V).all(axis=0)
    C_r = np.zeros_like(V)
    C_r[np.ix_(ok, ok)] = scaled_pinv(V[np.ix_(ok, ok)])
    own = inv_s @ bs[free]  # nil where free was fitted at these weights
    return own + S_s @ dh, dh, added + S @ scaled_pinv(C_r + P) @ S.T


def strongest_hidden(nrm, free, hidden: list, grade: str) -> dict:
    """``{param: (candidate, hidden param)}`` for each parameter of ``free``: of the ``hidden``
    parameters (:func:`hidden_parameters`, :func:`weak_parameters`), the one whose prior standard
    deviation (:func:`sizefx.diagnose.plausibility.prior_sigma`) moves its estimate most."""
    free = np.asarray(free, dtype=int)
    pairs = [(cand, j) for cand, params, _ in hidden for j in params]
    if not pairs or free.size == 0:
        return {}
    reach = np.abs(_shift(nrm, free, [j for _, j in pairs])) * np.array([prior_sigma(c.id, grade) for c, _ in pairs])
    return {int(f): pairs[int(k)] for f, k in zip(free.tolist(), reach.argmax(axis=1))}


def masked_by_hidden(x, cov, added, level: float) -> float | None:
    """The p-value of a finding's deviation ``x`` [k] from its start values under its covariance
    ``cov`` [k, k] widened by the hidden parameters' part ``added`` [k, k] (:func:`hidden_fit`) when
    it is beyond ``level``: with the hidden parameters where their priors allow, the record no
    longer shows the finding. None when it stays a finding."""
    from scipy.stats import chi2

    x = np.asarray(x, dtype=float)
    p = float(chi2.sf(x @ scaled_pinv(cov + added) @ x, x.size))
    return p if p > level else None


def hidden_reach(nrm, free, active, cov, hidden: list, grade: str) -> list:
    """The hidden candidates (:func:`hidden_parameters`) that could move the finding with parameters
    ``active`` (covariance ``cov`` [k, k]) by its own standard error or more at one prior standard
    deviation, largest first, as ``candidate key:parameters``."""
    free = np.asarray(free, dtype=int)
    pos = np.searchsorted(free, active)
    sig = np.sqrt(np.abs(np.diag(cov)))
    reach = {}
    for cand, params, _ in hidden:
        S = _shift(nrm, free, params)[pos]
        size = float(np.max(np.abs(S) * _prior(cand.id, len(params), grade) / sig[:, None]))
        reach[cand.key + ":" + ",".join(PARAMS[j].label for j in params)] = size
    return [k for k, v in sorted(reach.items(), key=lambda kv: -kv[1]) if v >= 1.0]


def not_significant(
    nrm, free, reported, theta, theta0, budget, hidden: list, grade: str, level: float, added=None
) -> dict:
    """``{finding key: reason}``: the findings of ``reported`` (:class:`~sizefx.diagnose.selection.Chosen`
    effects of the model ``free``) not significant at the selection's ``level`` under the error they
    are reported with (``budget``: :class:`sizefx.diagnose.budget.ErrorBudget`), every part in but
    that of a resolved alias and of the weak parameters (:func:`masked_by_hidden`): most often a
    ``hidden`` parameter (:func:`hidden_parameters`) could explain them anywhere in its plausible
    range, and the reason names it (:func:`hidden_reach`). ``added`` [free, free]: the ``hidden``
    parameters' part alone (:func:`hidden_fit` of them without the weak ones); the budget's hidden
    part when not given.

    A weak parameter (:func:`weak_parameters`) the record tells apart from the findings: the
    selection tested each finding beside it, so its part widens the error reported and does not
    mask the finding."""
    # a finding resolved from its alias by the grade passed its own test with the alternative anywhere
    # in its range (significant_within): that part is not counted twice
    in_budget = budget.hidden if budget.hidden is not None else np.zeros((free.size, free.size))
    added = in_budget if added is None else added
    cov = budget.covariance() - in_budget - (budget.aliases if budget.aliases is not None else 0.0)
    out = {}
    for c in reported:
        pos = np.searchsorted(free, c.active)
        x = (theta - theta0)[list(c.active)]
        p = masked_by_hidden(x, cov[np.ix_(pos, pos)], added[np.ix_(pos, pos)], level)
        if p is None:
            continue
        which = ", ".join(hidden_reach(nrm, free, c.active, cov[np.ix_(pos, pos)], hidden, grade))
        if which:
            out[c.cand.key] = (
                f"could be {which}, which the record does not reveal: at sizes a part of the grade "
                f"shows it would explain this (p = {p:.2g}); the extended model carries it as {c.cand.key}"
            )
        else:
            out[c.cand.key] = (
                f"not significant once its error takes every part of the budget (p = {p:.2g}); the "
                f"extended model carries it"
            )
    return out


def resolve(nrm, free, finding, alt_cand, alt_idx, theta, theta0, grade, rho, cov, level):
    """``finding`` (a :class:`sizefx.diagnose.selection.Chosen` in the model ``free``) against the
    candidate ``alt_cand`` (its parameters ``alt_idx`` not in the model) the motion cannot tell from
    it: (:class:`Alternative`, covariance [free, free] to add) when the finding is plausible, the
    alternative alone is not, and the finding stays significant at ``level`` (its covariance ``cov``
    [free, free] without the alias) with the alternative anywhere in its plausible range
    (:func:`significant_within`: else a third cause may explain what the two share); None otherwise."""
    if judge(finding.cand.id, theta[list(finding.cand.idx)], grade):
        return None
    free = np.asarray(free, dtype=int)
    rest = np.setdiff1d(free, finding.active)
    values = theta0[list(alt_cand.idx)].copy()
    values[[list(alt_cand.idx).index(j) for j in alt_idx]] = alone(nrm, rest, alt_idx, theta, theta0)
    why = judge(alt_cand.id, values, grade)
    if not why:
        return None
    half = _half_range(alt_cand.id, len(alt_idx), grade)
    S = _shift(nrm, free, alt_idx)
    pos = np.searchsorted(free, finding.active)
    x = (theta - theta0)[list(finding.active)]
    if significant_within(x, cov[np.ix_(pos, pos)], S[pos], half) > level:
        return None
    added_cov = _spread(S, half / np.sqrt(3.0))  # spread evenly over the range
    added = {PARAMS[j].label: float(np.sqrt(added_cov[p, p]) / PARAMS[j].per_unit) for j, p in zip(finding.active, pos)}
    alt = Alternative(
        alt_cand.key,
        {PARAMS[j].label: float(v / PARAMS[j].per_unit) for j, v in zip(alt_cand.idx, values)},
        PARAMS[alt_cand.idx[0]].unit,
        why,
        float(rho),
        added,
        PARAMS[finding.active[0]].unit,
    )
    return alt, added_cov


def _trajectory(kind: str, axis: str):
    from .. import scenarios
    from ..motion import RotationChain, Sinusoids, StaticSite, Trajectory

    if kind == "tumble":
        return scenarios.tumble(LIBRARY_S, freqs_hz=(0.05, 0.083, 0.117))
    if kind == "turntable":
        plan = scenarios.TurntablePlan(
            static_s=2.0, seconds_per_axis=12.0, cycles=1, reposition_s=3.0, settle_s=1.0, accel_dps2=40.0
        )
        return scenarios.turntable(plan)[0]
    lat, lon, h = scenarios.PAPER_AIRFIELD.radians()
    still = Sinusoids([0.0], [0.1], [0.0])
    sway = Sinusoids([5.0 * DEG, 2.0 * DEG], [0.5, 1.3], [0.0, 1.0])
    # z-y-x Euler chain: heading about down, pitch about east, roll about north (body axes at rest)
    profiles = [sway if axis == "z" else still, sway if axis == "y" else still, sway if axis == "x" else still]
    chain = RotationChain([scenarios.E_DOWN, scenarios.E_EAST, scenarios.E_NORTH], profiles)
    return Trajectory(StaticSite(lat, lon, h), chain, LIBRARY_S, name="sway", segments=[("sway", 0.0, LIBRARY_S)])


def library_normals(theta, weights) -> dict:
    """name -> ([NP, NP], rows): the noise-free normal matrix of every parameter on each motion of
    :data:`LIBRARY`, at the model ``theta`` with the per-channel ``weights`` of the record's rows, and
    the number of rows it sums."""
    from ..effects import IDEAL, load_effects
    from ..simulate import simulate_in_memory
    from .candidates import columns_between
    from .predictor import Predictor

    out = {}
    for name, (kind, axis) in LIBRARY:
        tel = simulate_in_memory(_trajectory(kind, axis), load_effects(base=IDEAL), rate_hz=LIBRARY_RATE_HZ, seed=0)
        pred = Predictor(tel)
        rows_of = Rows(pred.t, pred.mask, pred.dt)
        cols = columns_between(theta, functools.partial(pred.terms_span, theta), pred.t)
        nrm = normal_equations(rows_of, np.zeros((rows_of.t.size, 6)), cols, weights)
        out[name] = (nrm.N.sum(0), nrm.rows)
    return out


def separating_motions(N_record, rows_record: int, a, b, rest, normals: dict) -> tuple:
    """``((motion, rho), ...)``: the motions of ``normals`` (:func:`library_normals`) that, recorded
    beside this record (``N_record`` over ``rows_record`` rows) for as long again, would bring the
    canonical correlation of the parameter groups ``a`` and ``b`` (given ``rest``) under
    :data:`SEPARATED_CORRELATION`; best first.

    The record's rows are weighted ``1 / sigma^2`` with ``sigma`` its per-row noise; a motion's rows,
    formed at another rate with the same weights, count as the record's once scaled by the ratio
    of the row counts (white noise: the information per second does not depend on the row rate)."""
    out = []
    for name, (N, rows) in normals.items():
        rho = canonical_correlation(N_record + N * (rows_record / rows), a, b, rest)
        if rho < SEPARATED_CORRELATION:
            out.append((name, float(rho)))
    return tuple(sorted(out, key=lambda m: m[1]))
