"""The loop and the checks around it: :func:`diagnose` turns one record into a :class:`Diagnosis`.

1. **Reference integrity** (:mod:`.integrity`): glitches in ``/reference`` are dropped, the motion
   is split at discontinuities (each segment its own splines), gaps and rate changes reported;
   every finding is a warning.
2. **Predict** the IMU from the reference under the start model (:mod:`.predictor`); the
   **residual** is measured minus predicted on the six channels.
3. **Band** (:mod:`.bandwidth`): without ``bandwidth_hz``, the band where the reference's own
   derivatives are still trustworthy is measured, and the fit is done below it.
4. **Iterate** (Gauss-Newton): select (:func:`sizefx.diagnose.selection.select`) on the
   block-wise normal equations linearised at the current estimate, update, recompute
   prediction and regressors. Rows are weighted per channel (``1 / (sigma_c^2 kappa_c)``,
   sigma from the median absolute deviation, kappa the variance inflation of block means) and
   per row by Huber's weights (iteratively re-weighted least squares, from the second pass on):
   a few bad samples move no estimate by more than a fraction of its standard error.
5. **Judge** what was selected (:func:`_judge`), until nothing changes: an estimate outside its
   grade's range (:mod:`.plausibility`) is rejected with the reason; of two selected effects the
   record cannot tell apart (:func:`sizefx.diagnose.selection.aliased_pairs`) neither is a finding
   (the model keeps their sum as the more common one); an effect explaining under :data:`MIN_SHARE`
   of the structure on its channels is rejected; so is one no longer significant once its errors
   take the random effect of the record's parts in time (a selection must be stable across them). The survivors are refitted with the
   selection fixed, and with the candidates left out that are nearly collinear with one of them
   (:func:`sizefx.diagnose.selection.nuisance_aliases`) fitted beside it, no findings themselves;
   the same checks then judge the findings beside them again.
6. **Errors** (:mod:`.budget`): the covariance the residual's spectrum gives (:mod:`.spectrum`), widened by
   the parts' random effect, plus the resolved aliases', the hidden parameters' (fitted beside the
   findings where they take them up, :func:`sizefx.diagnose.aliases.hidden_fit`) and the band's
   parts; a finding not significant under that error goes to ``not_revealed``.
7. **Out of sample** (:mod:`.holdout`): the gain cross-validated in blocked folds in time.
8. **Name what stays unexplained** (:mod:`.structure`): lines, trends, steps and correlations with
   the motion left in each channel's final residual.
"""

from __future__ import annotations

import functools
import math
import time
from dataclasses import dataclass, field

import numpy as np

from ..io.gaps import nominal_period_s
from ..io.telemetry import Telemetry
from ..sensor_model import SensorParams
from .aliases import (
    hidden_fit,
    hidden_parameters,
    library_normals,
    not_significant,
    resolve,
    separating_motions,
)
from .arms import split_arms
from .bandwidth import choose_bandwidth
from .budget import Parts, error_budget, parts_scatter
from .candidates import CANDIDATES, PRIORITY, columns_between
from .holdout import OutOfSample, cross_validate
from .integrity import check_reference, without_bad_rows
from .naming import name_effect
from .normal import Normal, Rows, normal_equations, solve
from .plausibility import infer_grade, judge, likely_cause, noise_density
from .predictor import Predictor
from .records import NotRevealed, Rejection, ReportWarning, named
from .residual import noise_of, per_sample, predicted, residual_under, rms, white
from .selection import (
    FAMILY_ALPHA,
    Chosen,
    aliased_pairs,
    aliases_outside,
    nuisance_aliases,
    robust_p,
    select,
)
from .structure import unexplained as unexplained_structure
from .theta import CHANNELS, LEVER, PARAMS

__all__ = ["Diagnosis", "diagnose", "MAX_PASSES", "MIN_SHARE"]

#: With a bandwidth, spectral lines are looked for up to this share of it (:func:`_structure`).
LINE_BAND = 0.5
#: Gauss-Newton passes at most; selection and estimates settle in two or three.
MAX_PASSES = 6
#: Passes at most of a refit with the selection fixed (after judging removed an effect).
REFIT_PASSES = 3
#: Least share of the structure on its channels (the residual power beyond white noise, without the
#: effect) an accepted effect must explain: below it the effect is a correction of no consequence,
#: more likely a side effect of something else than a finding.
MIN_SHARE = 0.01


@dataclass
class Diagnosis:
    """What :func:`diagnose` found in one record (SI), and what :func:`sizefx.diagnose.run` adds:
    the path of the extended model and the navigation gain."""

    path: str
    effects: list
    unrevealed: list  #: of :class:`~sizefx.diagnose.records.NotRevealed`
    rms_before: dict  #: channel -> SI RMS
    rms_after: dict
    theta_nominal: np.ndarray
    theta: np.ndarray
    sigma_theta: dict
    samples: int
    block: int
    weights_sigma: np.ndarray  #: per-channel noise sigma used in the weights (SI)
    kappa: np.ndarray
    passes: int
    log: list
    wall_s: float
    #: [6] the walk of each channel's bias, sqrt of its intensity (SI per sqrt(s); :mod:`.drift`), 0 where none
    bias_walk: np.ndarray = field(default_factory=lambda: np.zeros(6))
    #: [n, 6] float32 (SI): measured minus predicted per sample, kept for the plots (``keep_series``)
    residual_before: np.ndarray | None = None
    residual_after: np.ndarray | None = None
    t: np.ndarray | None = None
    mask: np.ndarray | None = None
    model_path: str | None = None
    navigation: dict | None = None
    bandwidth_hz: float | None = None
    white_sigma: dict | None = None  #: per channel: the residual's sample-to-sample (first-difference) noise
    rms_full_before: dict | None = None  #: full-band RMS (differs from rms_* when bandwidth_hz is set)
    rms_full_after: dict | None = None
    warnings: list = field(default_factory=list)  #: of :class:`~sizefx.diagnose.records.ReportWarning`
    rejected: list = field(default_factory=list)  #: of :class:`~sizefx.diagnose.records.Rejection`
    unexplained: list = field(default_factory=list)  #: [{"channel", "kind", ..., "sentence"}]
    consistency: dict = field(default_factory=dict)  #: {"parts", "block_s", "parameters": [...]}
    grade: str | None = None
    grade_reason: str = ""
    bandwidth_reason: str = ""  #: how the band was chosen (given, measured, or full band)
    sigma_white: dict = field(default_factory=dict)  #: param -> white-noise standard error (SI), for comparison
    #: [NP, NP] covariance of ``theta`` (SI) with the errors widened as in ``sigma_theta``; zero where fixed
    covariance: np.ndarray | None = None
    #: the arms split at the triad point, with errors (:func:`sizefx.diagnose.arms.split_arms`); None
    #: when no arm was estimated
    geometry: dict | None = None
    #: blocked cross-validation in time (:func:`sizefx.diagnose.holdout.cross_validate`); None when
    #: nothing was estimated
    out_of_sample: OutOfSample | None = None
    #: the extended model on other records (``--validate-on``, :func:`sizefx.diagnose.holdout.validate_on`)
    validated_on: list = field(default_factory=list)


# --------------------------------------------------------------------------- the Gauss-Newton loop


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


def _free(chosen):
    return np.array(sorted({j for c in chosen for j in c.active}), dtype=int)


def _iterate(pred: Predictor, rows_of: Rows, theta0, theta, log, *, fixed=None, progress=None, start=None) -> _State:
    """Gauss-Newton from ``theta`` with the selection redone each pass (or ``fixed``), until the
    selection and the estimates settle. Returns the final state with the normal equations at the
    final residual (regressors of the last pass: theta has moved by under 1e-3 sigma since).
    ``start``: the residual's rows at ``theta``, when already known. The residual is held as rows
    (``_State.residual``), the regressors are formed span by span."""
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


# --------------------------------------------------------------------------- judging the selection


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


def diagnose(
    tel: Telemetry,
    theta_nominal: np.ndarray,
    *,
    bandwidth_hz: float | None = None,
    grade: str | None = None,
    auto_bandwidth: bool = True,
    keep_series: bool = True,
    progress=None,
) -> Diagnosis:
    """Run the steps of the module docstring on one record; ``theta_nominal`` [NP] is the start model.

    ``bandwidth_hz`` fits the residual low-passed at that frequency (see
    :class:`sizefx.diagnose.normal.Rows`); without it the band is measured
    (:func:`sizefx.diagnose.bandwidth.choose_bandwidth`) unless ``auto_bandwidth`` is False.
    ``grade`` (navigation, tactical, industrial) sets the plausible ranges; None infers it from
    the noise. ``keep_series`` keeps the residuals and times for the plots. ``progress(done,
    total)``, when given, is called after each Gauss-Newton pass of the selection.
    """
    started = time.perf_counter()
    check = check_reference(tel)
    warnings = list(check.warnings)
    if check.breaks_s:
        times = ", ".join(f"{b:.3f}" for b in check.breaks_s[:5]) + (" ..." if len(check.breaks_s) > 5 else "")
        warnings.append(
            ReportWarning(
                "segments_share_model",
                f"the reference is split at {len(check.breaks_s)} discontinuit"
                f"{'y' if len(check.breaks_s) == 1 else 'ies'} (t = {times} s) and its segments "
                "are fitted with one model: if the IMU was turned or moved between them (a "
                "re-mount), arms, biases and misalignments differ per segment; diagnose each "
                "segment alone with --from-s/--to-s",
                time_s=float(check.breaks_s[0]),
                size=float(len(check.breaks_s)),
            )
        )
    pred = Predictor(without_bad_rows(tel, check), breaks_s=check.breaks_s)
    theta0 = np.asarray(theta_nominal, dtype=float).copy()
    if bandwidth_hz is not None:
        band_reason = f"given: {bandwidth_hz:g} Hz"
    elif auto_bandwidth:
        finite = (
            per_sample(
                pred,
                lambda lo, hi: (
                    np.isfinite(pred.measured_span(lo, hi)).all(axis=1)
                    & np.isfinite(pred.predict_span(theta0, lo, hi)).all(axis=1)
                ),
            )
            > 0.0
        )
        band = choose_bandwidth(
            pred.t,
            pred.measured_span,
            functools.partial(predicted, pred, theta0),
            pred.mask & finite,
            pred.dt,
            reference_dt_s=nominal_period_s(tel.reference.time_s) if tel.reference is not None else None,
        )
        bandwidth_hz, band_reason = band.bandwidth_hz, band.reason
        del finite
    else:
        band_reason = "full band (not measured)"
    rows_of = Rows(pred.t, pred.mask, pred.dt, bandwidth_hz)
    before = residual_under(pred, rows_of, theta0, series=keep_series)
    log: list = []
    state = _iterate(pred, rows_of, theta0, theta0.copy(), log, progress=progress, start=before.rows)
    if progress is not None and state.passes < MAX_PASSES:
        progress(MAX_PASSES, MAX_PASSES)
    unrevealed = state.unrevealed
    white_rows = white(rows_of, state.residual)
    if grade is None:
        grade, grade_reason = infer_grade(noise_density(pred.measured_span, pred.mask, pred.dt))
    else:
        grade_reason = f"grade {grade}, as given"
    rejected, aliased = [], []
    level = FAMILY_ALPHA / len(CANDIDATES)  # the selection's family-wise level, per candidate
    while True:  # each round removes at least one effect from a finite selection, or ends the loop
        verdict = _judge(pred, rows_of, state, theta0, grade, level, white_rows)
        aliased += verdict.aliased
        for c in state.chosen:
            if c.cand.key in verdict.reasons:
                why, likely, implausible = verdict.reasons[c.cand.key]
                if why is None:  # the pair's other member: the model carries their sum (aliased)
                    continue
                rejected.append(_rejection(c, state.theta, why, likely))
                if implausible:
                    warnings.append(ReportWarning("implausible_estimate", f"{c.cand.key}: {why}; more likely {likely}"))
        if not verdict.reasons:
            break
        kept = [c for c in state.chosen if c.cand.key not in verdict.reasons]
        theta = state.theta.copy()
        for c in state.chosen:
            if c.cand.key in verdict.reasons:
                theta[list(c.cand.idx)] = theta0[list(c.cand.idx)]
        log.append("refit without " + ", ".join(sorted(verdict.reasons)))
        state = _iterate(pred, rows_of, theta0, theta, log, fixed=kept)
    # candidates left out that are nearly collinear with a finding are fitted beside it, so that the
    # finding's error and estimate do not hang on their start values (selection.nuisance_aliases);
    # the findings beside them are judged again, by the same checks
    findings = list(state.chosen)
    rejected_keys = {r.key for r in rejected}
    paired = {c.cand.key for pair in aliased for c in pair[:2]}  # already no findings: their sum is carried
    nuisance = [n for n in nuisance_aliases(state.nrm, state.chosen, skip=rejected_keys) if n[1] not in paired]
    weak: list = []  # findings no longer a finding beside their nuisance: (finding, nuisance, rho, why)
    if nuisance:
        log.append(
            "refit with "
            + ", ".join(f"{n.cand.key} (beside {of}, canonical correlation {rho:.3f})" for n, of, rho in nuisance)
        )
        state = _iterate(pred, rows_of, theta0, state.theta, log, fixed=findings + [n for n, _, _ in nuisance])
        mates: dict = {}  # finding -> its most collinear nuisance and their canonical correlation
        for n, of, rho in nuisance:
            if of not in mates or rho > mates[of][1]:
                mates[of] = (n, rho)
        beside = {n.cand.key for n, _, _ in nuisance}
        verdict = _judge(pred, rows_of, state, theta0, grade, level, white_rows, beside=beside, every_check=True)
        # a finding with no nuisance beside it was judged on nearly this state in the last round
        for c in findings:
            if c.cand.key in verdict.reasons and c.cand.key in mates:
                why = verdict.reasons[c.cand.key][0] or "indistinguishable from another finding"
                weak.append((c, *mates[c.cand.key], why))
    theta, chosen, residual, nrm = state.theta, state.chosen, state.residual, state.nrm
    offset = theta0 - theta
    shares = verdict.shares
    # the pairs the motion cannot tell apart: of those the grade resolves the plausible one is the
    # finding, with its alternative beside it and an error that holds wherever the alternative is
    # in its plausible range (aliases.resolve); the others go to not_revealed
    alias_keys = {g.cand.key for _, g, _ in aliased} | {k.cand.key for k, _, _ in aliased}
    nuisance_keys = {n.cand.key for n, _, _ in nuisance}
    outside = [
        (chosen[i], cand, seen, rho)
        for i, cand, seen, rho in aliases_outside(nrm, chosen, offset, level)
        if chosen[i].cand.key not in alias_keys | nuisance_keys  # a nuisance is no finding to begin with
    ]
    free = _free(chosen)
    # the errors reported take the residual's spectrum at each regressor's frequencies (budget.py)
    parts = parts_scatter(pred, nrm, free, offset, spectral=True)
    resolved, alias_cov = _resolved(nrm, free, aliased, outside, theta, theta0, grade, level, parts, log)
    # the parameters hidden from the selection that still move its estimates (aliases.hidden_fit):
    # those nearly collinear with a finding are fitted beside it, as a nuisance is, with their
    # plausible ranges as priors; every one adds to the errors what the record cannot say of it
    hidden = hidden_parameters(
        nrm, chosen, _with_aliases(unrevealed, aliased, outside), grade, skip={a.key for a in resolved.values()}
    )
    dx, dh, hidden_cov = hidden_fit(nrm, free, hidden, grade, offset)
    ms_full = state.ms_full
    if dh.size:
        fitted = [(c, params) for c, params, beside in hidden if beside]
        theta = theta.copy()
        theta[free] += dx
        theta[[j for _, params in fitted for j in params]] += dh
        after = residual_under(pred, rows_of, theta)
        assert after.rows is not None  # made with rows_of
        residual, ms_full = after.rows, after.ms_full
        log.append(
            "fitted beside the findings: "
            + ", ".join(f"{c.key}:{','.join(PARAMS[j].label for j in params)}" for c, params in fitted)
        )
    aliased = [a for a in aliased if a[0].cand.key not in resolved]
    outside = [o for o in outside if o[0].cand.key not in resolved]
    budget = error_budget(
        pred,
        rows_of,
        nrm,
        theta,
        chosen,
        theta0,
        grade,
        parts=parts,
        aliases=alias_cov if alias_cov.any() else None,
        hidden=hidden_cov if hidden_cov.any() else None,
    )
    cov = np.zeros((theta.size, theta.size))
    cov[np.ix_(free, free)] = budget.covariance()
    sig, sig_white = budget.sigma(), budget.sigma_white()
    warnings += budget.warnings()
    geometry = (
        split_arms(theta[LEVER].reshape(3, 3), cov[np.ix_(LEVER, LEVER)], SensorParams.from_vector(theta).accel_axes())
        if np.intersect1d(free, LEVER).size
        else None
    )
    # the findings: selected, plausible, separable (or resolved by the grade); the rest of the pairs
    # the motion cannot tell apart go to not_revealed, with the motions that would separate them
    alias_keys = {g.cand.key for _, g, _ in aliased} | {k.cand.key for k, _, _ in aliased}
    alias_keys |= {c.cand.key for c, _, _, _ in outside}
    alias_keys |= nuisance_keys | {w[0].cand.key for w in weak}
    reported = [c for c in chosen if c.cand.key not in alias_keys]
    # a finding is significant under the error it is reported with, or no finding: a hidden parameter
    # may explain it anywhere in its plausible range
    masked = not_significant(nrm, free, reported, theta, theta0, budget, hidden, grade, level)
    log += [f"{key} no finding: {why}" for key, why in masked.items()]
    reported = [c for c in reported if c.cand.key not in masked]
    effects = [
        name_effect(c, theta, theta0, sig, shares[c.cand.key], alternative=resolved.get(c.cand.key)) for c in reported
    ]
    effects.sort(key=lambda e: -e.explained_fraction)
    weights = 1.0 / (state.sigma_c**2 * state.kappa)
    unrev = _not_revealed(unrevealed, aliased, outside, nuisance, weak, chosen, free, nrm, theta, weights)
    for c in chosen:
        if c.cand.key in masked:
            unrev = _named(unrev, c.cand, c.active, masked[c.cand.key])
    structure = _structure(pred, rows_of, residual, white_rows, theta)
    series_after = residual_under(pred, None, theta, series=True).series if keep_series else None  # for the plots
    rms_b, rms_a = rms(rows_of, before.rows), rms(rows_of, residual)
    assert before.rows is not None  # made with rows_of
    out_of_sample = cross_validate(
        pred,
        rows_of,
        nrm,
        theta0,
        theta,
        free,
        {c.cand.key: list(c.active) for c in reported},
        weights,
        before.rows,
        residual,
    )
    if out_of_sample is not None:
        # a finding the grade resolved from an alias must also predict held-out data: the grade rules
        # the alternative out, not a third cause the two may share
        gains = {g.key: g for g in out_of_sample.effects}
        for c in reported:
            alt, g = resolved.get(c.cand.key), gains.get(c.cand.key)
            if alt is None or g is None or g.generalises:
                continue
            effects = [e for e in effects if (e.id, e.channel) != (c.cand.id, c.cand.channel)]
            unrev = _named(
                unrev,
                c.cand,
                c.active,
                f"indistinguishable from {alt.key} on this motion (canonical correlation {alt.rho:.4f}), which alone "
                f"would be implausible ({alt.reason}); but it does not predict held-out data beyond chance "
                f"(p = {g.p:.2g}), so something else may explain what the two share; the extended model carries it",
            )
            log.append(f"{c.cand.key} not kept against {alt.key}: it does not generalise (p = {g.p:.2g})")
        warnings += _holdout_warnings(out_of_sample)
    return Diagnosis(
        path=str(tel.path),
        effects=effects,
        unrevealed=unrev,
        rms_before=dict(zip(CHANNELS, rms_b.tolist())),
        rms_after=dict(zip(CHANNELS, rms_a.tolist())),
        theta_nominal=theta0,
        theta=theta,
        sigma_theta=sig,
        samples=int(pred.mask.sum()),
        block=rows_of.L,
        bandwidth_hz=bandwidth_hz,
        white_sigma=dict(zip(CHANNELS, white_rows.tolist())),
        rms_full_before=dict(zip(CHANNELS, np.sqrt(before.ms_full).tolist())),
        rms_full_after=dict(zip(CHANNELS, np.sqrt(ms_full).tolist())),
        weights_sigma=state.sigma_c,
        kappa=state.kappa,
        bias_walk=np.sqrt(state.nrm.drift.q),
        passes=state.passes,
        log=log,
        wall_s=time.perf_counter() - started,
        residual_before=before.series,
        residual_after=series_after,
        t=pred.t if keep_series else None,
        mask=pred.mask if keep_series else None,
        warnings=warnings,
        rejected=rejected,
        unexplained=structure,
        consistency=budget.consistency(nrm.block_s),
        grade=grade,
        grade_reason=grade_reason,
        bandwidth_reason=band_reason,
        sigma_white=sig_white,
        covariance=cov,
        geometry=geometry,
        out_of_sample=out_of_sample,
    )


def _holdout_warnings(cv: OutOfSample) -> list:
    """A model, or a finding, whose gain on the held-out folds is not positive beyond chance."""
    out = []
    if cv.overfit:
        assert cv.gain_in_sample is not None  # folds carry the in-sample figure
        out.append(
            ReportWarning(
                "overfit",
                f"the extended model removes {100 * cv.gain_in_sample:.1f} % of the weighted residual "
                f"power in sample but {100 * cv.gain:.1f} % on held-out folds (p = {cv.p:.2g}): it does not "
                "predict data it was not fitted to better than the start model",
                size=cv.gain,
            )
        )
    for e in cv.effects:
        if not e.generalises and not cv.overfit:
            out.append(
                ReportWarning(
                    "not_generalising",
                    f"{e.key}: removes {100 * e.gain_in_sample:.2f} % of the weighted residual power "
                    f"in sample, {100 * e.gain_held_out:.2f} % on held-out folds (p = {e.p:.2g}): not shown "
                    "to predict data it was not fitted to",
                    size=e.gain_held_out,
                )
            )
    return out


def _structure(pred: Predictor, rows_of: Rows, residual, white_rows, theta):
    """The final residual's structure per channel (:func:`sizefx.diagnose.structure.unexplained`),
    with the motion's rates, omega^2, angular accelerations and specific force as regressors.

    The regressors are the reference's motion alone (the gyros' true rates and the specific force at
    the reference point under the extended model, :func:`sizefx.diagnose.predictor.predict_readings`'
    ``at_gyro``), never the measured readings nor the predicted accelerometers (whose lever terms use
    the measured gyros): the residual carries the IMU's noise, and regressed on anything that carries
    it too, it would "follow" it by construction. They are formed span by span, as rows
    (``residual``: the rows of the final residual)."""
    names = [f"omega_{a}" for a in "xyz"] + ["omega_sq"] + [f"omegadot_{a}" for a in "xyz"] + [f"f_{a}" for a in "xyz"]
    rows = np.zeros((rows_of.t.size, len(names)))
    n, L = pred.n, rows_of.L
    for lo, hi in rows_of.spans():
        a, b = rows_of.extended(lo, hi)
        ga, gb = max(0, a - 1), min(n, b + 1)  # one sample more each side for the rate's gradient
        at = pred.terms_span(theta, ga, gb)["at_gyro"]
        w, f = at.omega_ib_b, at.f_b
        wd = np.gradient(w, pred.t[ga:gb], axis=0)
        x = np.column_stack([w, np.sum(w**2, axis=1), wd, f])[a - ga : b - ga]
        r = rows_of.span_rows(x, a, lo, hi)
        rows[lo // L : lo // L + r.shape[0]] = r
    regressors = {k: rows[:, i] for i, k in enumerate(names)}
    # with a low-pass, the reference's rising noise times the filter's falling response makes a bump
    # near the cut-off that is no line: lines are looked for only where the filter passes
    # (a 4th-order Butterworth is down 0.1 dB at half its cut-off)
    max_line_hz = None if rows_of.bandwidth_hz is None else LINE_BAND * rows_of.bandwidth_hz
    return unexplained_structure(rows_of.t, residual, rows_of.keep, regressors, white_rows, max_line_hz=max_line_hz)


def _with_aliases(unrevealed: dict, aliased, outside) -> dict:
    """The selection's ``unrevealed`` (key -> (candidate, parameters, reason)) and the other half of
    each pair the record cannot tell apart: the effect of a selected pair the model does not keep
    (``aliased``: (kept, gone, rho)) and the candidate left out that a selected effect is no finding
    beside (``outside``). Held at their start values, they move what is estimated beside them (the
    antisymmetric gyro misalignment of one axis and a mount, dropped as a pair on a turntable, went
    whole into the other axis's misalignment: 86 sigma off on a development-range turntable, seed
    206), so :func:`sizefx.diagnose.aliases.hidden_parameters` counts them: fitted beside the model
    with their plausible ranges as priors, so that the record still pins what it can of the pair."""
    out = dict(unrevealed)
    counted = {j for _, params, _ in unrevealed.values() for j in params}
    gone = [(g.cand, tuple(g.active)) for _, g, _ in aliased] + [(cand, tuple(seen)) for _, cand, seen, _ in outside]
    for cand, params in gone:
        params = tuple(j for j in params if j not in counted)  # a pair's half may also be another's outside
        if params:
            counted.update(params)
            out[f"{cand.key} (alias)"] = (cand, params, "left out beside a selected effect nearly collinear with it")
    return out


def _resolved(nrm, free, aliased, outside, theta, theta0, grade, level, parts: Parts, log):
    """The findings the grade resolves from their aliases (:func:`sizefx.diagnose.aliases.resolve`):
    ``({finding key: Alternative}, the budget's aliases part [free, free])``. ``aliased``: selected
    pairs, the first kept; ``outside``: a selected effect and a candidate left out; ``parts``: the
    errors' sandwich and the parts' factors, against which a finding must stay significant."""
    resolved: dict = {}
    alias_cov = np.zeros((free.size, free.size))
    factors = np.array([parts.factors.get(j, 1.0) for j in free.tolist()])
    widened = parts.sandwich * np.outer(factors, factors)
    pairs = [(keep, gone.cand, gone.active, rho) for keep, gone, rho in aliased]
    pairs += [(c, cand, seen, rho) for c, cand, seen, rho in outside]
    for finding, alt, seen, rho in pairs:
        if finding.cand.key in resolved:
            continue
        got = resolve(nrm, free, finding, alt, seen, theta, theta0, grade, rho, widened, level)
        if got is not None:
            resolved[finding.cand.key] = got[0]
            alias_cov += got[1]
            log.append(f"{finding.cand.key} kept against {alt.key}: {got[0].reason}")
    return resolved, alias_cov


def _not_revealed(unrevealed, aliased, outside, nuisance, weak, chosen, free, nrm, theta, weights) -> list:
    """What the record cannot reveal, as :class:`~sizefx.diagnose.records.NotRevealed` entries: the
    parameters the motion does not excite (``unrevealed``, from the selection); the pairs it cannot
    tell apart (``aliased``: both selected, the model carrying their sum as the first; ``outside``:
    a selected effect and a candidate left out); the candidates fitted beside a finding
    (``nuisance``) and the findings no longer one beside them (``weak``). Each alias names the
    motions that would separate it (:func:`sizefx.diagnose.aliases.separating_motions`, the
    library's normal matrices formed once, at the model ``theta`` with the record's ``weights``)."""
    unrev = [
        NotRevealed(cand.id, cand.channel, tuple(PARAMS[j].label for j in hidden), reason)
        for cand, hidden, reason in unrevealed.values()
    ]
    normals: dict = {}
    N_record = nrm.N.sum(0)

    def separated_by(a, b):
        if not normals:
            normals.update(library_normals(theta, weights))
        rest = np.setdiff1d(free, np.union1d(np.asarray(a, dtype=int), np.asarray(b, dtype=int)))
        return separating_motions(N_record, nrm.rows, list(a), list(b), rest, normals)

    for keep, gone, rho in aliased:
        motions = separated_by(keep.active, gone.active)
        for me, other in ((keep, gone), (gone, keep)):
            unrev = _named(
                unrev,
                me.cand,
                me.active,
                f"indistinguishable from {other.cand.key} on this motion (canonical correlation {rho:.4f}); "
                f"the extended model carries their sum as {keep.cand.key}",
                motions,
            )
    for c, cand, seen, rho in outside:
        motions = separated_by(c.active, seen)
        for me, other, params in ((c.cand, cand.key, c.active), (cand, c.cand.key, cand.idx)):
            if any((u.id, u.channel) == (me.id, me.channel) and "on this motion" in u.reason for u in unrev):
                continue
            unrev = _named(
                unrev,
                me,
                params,
                f"indistinguishable from {other} on this motion (canonical correlation {rho:.4f}); "
                f"the extended model carries it as {c.cand.key}",
                motions,
            )
    finding_of = {c.cand.key: c for c in chosen}
    for n, of, rho in nuisance:
        unrev = _named(
            unrev,
            n.cand,
            n.active,
            f"nearly indistinguishable from {of} on this motion (canonical correlation {rho:.4f}): fitted "
            f"beside it, so that {of}'s estimate and error do not assume it absent; not a finding of its own",
            separated_by(n.active, finding_of[of].active),
        )
    for c, n, rho, why in weak:
        unrev = _named(
            unrev,
            c.cand,
            c.active,
            f"nearly indistinguishable from {n.cand.key} on this motion (canonical correlation {rho:.4f}): "
            f"fitted together, it is no longer a finding ({why}); the extended model carries both",
            separated_by(c.active, n.active),
        )
    return unrev


def _named(unrev: list, cand, params, reason: str, separated_by=()) -> list:
    """``unrev`` with the candidate's parameters ``params`` (indices into theta) named for ``reason``
    (:func:`sizefx.diagnose.records.named`), and the motions that would separate it."""
    return named(
        unrev, NotRevealed(cand.id, cand.channel, tuple(PARAMS[j].label for j in params), reason, tuple(separated_by))
    )
