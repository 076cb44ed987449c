"""The loop and the checks around it: :func:`diagnose` turns one record into a :class:`Diagnosis`.

1. **Reference integrity** (:mod:`.integrity`): glitches in ``/reference`` are dropped, the motion
   is split at discontinuities (each segment its own splines), gaps and rate changes reported;
   every finding is a warning.
2. **Predict** the IMU from the reference under the start model (:mod:`.predictor`); the
   **residual** is measured minus predicted on the six channels.
3. **Band** (:mod:`.bandwidth`): without ``bandwidth_hz``, the band where the reference's own
   derivatives are still trustworthy is measured, and the fit is done below it.
4. **Iterate** (Gauss-Newton, :mod:`.gauss_newton`): select (:func:`sizefx.diagnose.selection.select`) on the
   block-wise normal equations linearised at the current estimate, update, recompute
   prediction and regressors. Rows are weighted per channel (``1 / (sigma_c^2 kappa_c)``,
   sigma from the median absolute deviation, kappa the variance inflation of block means) and
   per row by Huber's weights (iteratively re-weighted least squares, from the second pass on):
   a few bad samples move no estimate by more than a fraction of its standard error.
5. **Judge** what was selected (:mod:`.judging`), until nothing changes: an estimate outside its
   grade's range (:mod:`.plausibility`) is rejected with the reason; of two selected effects the
   record cannot tell apart (:func:`sizefx.diagnose.selection.aliased_pairs`) neither is a finding
   (the model keeps their sum as the more common one); an effect explaining under :data:`MIN_SHARE`
   of the structure on its channels is rejected; so is one no longer significant once its errors
   take the random effect of the record's parts in time (a selection must be stable across them). The survivors are refitted with the
   selection fixed, and with the candidates left out that are nearly collinear with one of them
   (:func:`sizefx.diagnose.selection.nuisance_aliases`) fitted beside it, no findings themselves,
   each step taking their priors about their start values (the direction they share with the
   finding is one the record hardly determines); the same checks then judge the findings beside
   them again.
6. **Errors** (:mod:`.budget`): the covariance the residual's spectrum gives (:mod:`.spectrum`), widened by
   the parts' random effect where they disagree beyond chance, plus the resolved aliases', the hidden parameters' (fitted beside the
   findings where they take them up, :func:`sizefx.diagnose.aliases.hidden_fit`) and the band's
   parts; a finding not significant under that error goes to ``not_revealed`` (:mod:`.not_revealed`
   names what the record cannot reveal, and the motions that would separate each alias).
7. **Out of sample** (:mod:`.holdout`): the gain cross-validated in blocked folds in time.
8. **Name what stays unexplained** (:mod:`.structure`): lines, trends, steps and correlations with
   the motion left in each channel's final residual.
"""

from __future__ import annotations

import functools
import time
from dataclasses import dataclass, field

import numpy as np

from ..io.gaps import nominal_period_s
from ..io.telemetry import Telemetry
from ..sensor_model import SensorParams
from .aliases import hidden_fit, hidden_parameters, not_significant, strongest_hidden, weak_parameters
from .arms import split_arms
from .bandwidth import choose_bandwidth
from .budget import error_budget, parts_scatter
from .candidates import CANDIDATES

# REFIT_PASSES too stays importable from here
from .gauss_newton import MAX_PASSES, REFIT_PASSES, _free, _iterate, normal_beside  # noqa: F401
from .holdout import OutOfSample, cross_validate
from .integrity import check_reference, without_bad_rows
from .judging import MIN_SHARE, _as_reported, _judge, _rejection
from .naming import name_effect
from .normal import Rows
from .not_revealed import _named, _not_revealed, _resolved, _Separation, _undetermined, _with_aliases, _with_left_out
from .plausibility import RANGES, infer_grade, noise_density, prior_sigma
from .predictor import Predictor
from .records import ReportWarning
from .residual import per_sample, predicted, residual_under, rms, white
from .selection import FAMILY_ALPHA, aliases_outside, nuisance_aliases
from .structure import unexplained as unexplained_structure
from .theta import CHANNELS, LEVER, PARAMS

__all__ = ["Diagnosis", "diagnose", "MAX_PASSES", "MIN_SHARE"]

#: With a bandwidth, spectral lines are looked for up to this share of it (:func:`_structure`).
LINE_BAND = 0.5


@dataclass(frozen=True)
class Diagnosis:
    """What :func:`diagnose` found in one record (SI), built once when the fit ends. What
    :func:`sizefx.diagnose.run` does with the extended model afterwards (the file it writes, the
    navigation, other records) is :class:`~sizefx.diagnose.records.ModelChecks`, beside it."""

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
    #: [6] the slope of each channel's slow noise (:data:`sizefx.diagnose.drift.SLOPES`): 2 a walk,
    #: 1 flicker, whose ``bias_walk`` is then the walk with the same slowest term over the record
    bias_walk_slope: np.ndarray = field(default_factory=lambda: np.full(6, 2.0))
    #: [n, 6] float32 (SI): measured minus predicted per sample, kept for the plots (``keep_series``)
    residual_before: np.ndarray | None = None
    residual_after: np.ndarray | None = None
    t: np.ndarray | None = None
    mask: np.ndarray | None = None
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
    prior: dict = {}  # the nuisances' priors, which the steps from here on take
    if nuisance:
        log.append(
            "refit with "
            + ", ".join(f"{n.cand.key} (beside {of}, canonical correlation {rho:.3f})" for n, of, rho in nuisance)
        )
        # each nuisance with its prior (a part of the grade): fitted beside a finding it is nearly
        # collinear with, their difference is what the record hardly tells
        prior = {j: prior_sigma(n.cand.id, grade) for n, _, _ in nuisance if n.cand.id in RANGES for j in n.active}
        state = _iterate(
            pred, rows_of, theta0, state.theta, log, fixed=findings + [n for n, _, _ in nuisance], prior=prior
        )
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
    # the parameters the selection hid or left out that still move its estimates (aliases.hidden_fit):
    # those nearly collinear with a finding are fitted beside it, as a nuisance is, with their
    # priors (a part of the grade: plausibility.prior_sigma), or held with them; the weak ones, which
    # the record tells apart from the findings but whose prior could move one by its error, are
    # fitted beside them too. Every one adds to the errors what the record cannot say of it; the weak ones mask no finding
    left_out = _with_left_out(_with_aliases(unrevealed, aliased, outside), chosen)
    skip = {a.key for a in resolved.values()}
    hidden = hidden_parameters(nrm, chosen, left_out, grade, skip=skip)
    weak_hidden = weak_parameters(nrm, chosen, left_out, grade, hidden, skip=skip)
    dx, dh, hidden_cov = hidden_fit(nrm, free, hidden + weak_hidden, grade, offset, prior=prior)
    # the significance test takes the model without the weak ones (estimates and errors), as the
    # selection that tested each finding beside them did
    dx_masking, _, masking_cov = (
        hidden_fit(nrm, free, hidden, grade, offset, prior=prior) if weak_hidden else (dx, dh, hidden_cov)
    )
    theta_masking = theta.copy()
    theta_masking[free] += dx_masking
    ms_full = state.ms_full
    noise_nrm = nrm  # the normal equations the errors' noise is measured on
    weak_idx = [j for _, params, _ in weak_hidden for j in params]
    if dh.size:
        fitted = [(c, params) for c, params, beside in hidden if beside]
        beside_idx = [j for _, params in fitted for j in params] + weak_idx  # dh's layout
        theta = theta.copy()
        theta[free] += dx
        theta[beside_idx] += dh
        after = residual_under(pred, rows_of, theta)
        assert after.rows is not None  # made with rows_of
        residual, ms_full = after.rows, after.ms_full
        # the noise the estimates' errors take (the spectrum, the walk, the parts' scatter) is
        # measured on the residual without what the parameters fitted beside the model explain:
        # their own part of the budget holds that, and left in the residual it was counted again,
        # as colour. On a development-range flight (seed 0) arm components under their excitation
        # floor, 35 mm from the drawing, left 12-23 ug of slow residual in accelerometers x and y,
        # and the level tilt's error was 9.8 times its white one (z 0.27). Weighted as the step
        # above was: the sandwich is that estimator's
        beside_offset = theta0 - theta
        beside_offset[beside_idx] = 0.0  # held where fitted
        noise_nrm = normal_beside(pred, rows_of, theta, residual, weighted_by=state.residual)
        parts = parts_scatter(pred, noise_nrm, free, beside_offset, spectral=True)
        for what, group in (("fitted beside the findings", fitted), ("weak, fitted beside the findings", weak_hidden)):
            if group:
                log.append(
                    f"{what}: " + ", ".join(f"{c[0].key}:{','.join(PARAMS[j].label for j in c[1])}" for c in group)
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
    # the extended model is the start model and its findings: the weak parameters' values are no
    # findings (their part is in the findings' estimates and errors), so they go back to their start
    # values in what is reported and written, and the residual after is that of the model written
    theta_out = theta.copy()
    theta_out[weak_idx] = theta0[weak_idx]
    if weak_idx:
        after = residual_under(pred, rows_of, theta_out)
        assert after.rows is not None  # made with rows_of
        residual, ms_full = after.rows, after.ms_full
    geometry = (
        split_arms(
            theta_out[LEVER].reshape(3, 3), cov[np.ix_(LEVER, LEVER)], SensorParams.from_vector(theta_out).accel_axes()
        )
        if np.intersect1d(free, LEVER).size
        else None
    )
    # the findings: selected, plausible, separable (or resolved by the grade); the rest of the pairs
    # the motion cannot tell apart go to not_revealed, with the motions that would separate them
    alias_keys = {g.cand.key for _, g, _ in aliased} | {k.cand.key for k, _, _ in aliased}
    alias_keys |= {c.cand.key for c, _, _, _ in outside}
    alias_keys |= nuisance_keys | {w[0].cand.key for w in weak}
    reported = [c for c in chosen if c.cand.key not in alias_keys]
    # a finding is significant under the error it is reported with, less the weak parameters' part (the
    # selection tested it beside them), or no finding: a hidden parameter may explain it where its
    # prior allows
    masked = not_significant(nrm, free, reported, theta_masking, theta0, budget, hidden, grade, level, masking_cov)
    # a component whose error is mostly the priors of what the record cannot tell from it is not
    # measured, and a finding its reader cannot tell from its start value is none (judging._as_reported)
    undetermined, shown, lent = _as_reported(budget, [c for c in reported if c.cand.key not in masked], theta, theta0)
    masked |= shown
    log += [f"{key} no finding: {why}" for key, why in masked.items()]
    reported = [c for c in reported if c.cand.key not in masked]
    effects = [
        name_effect(
            c, theta, theta0, sig, shares[c.cand.key], resolved.get(c.cand.key), undetermined.get(c.cand.key, ())
        )
        for c in reported
        if len(undetermined.get(c.cand.key, ())) < len(c.active)
    ]
    effects.sort(key=lambda e: -e.explained_fraction)
    weights = 1.0 / (state.sigma_c**2 * state.kappa)
    separation = _Separation(nrm, free, theta, weights)  # the library's motions formed once, if asked
    unrev = _not_revealed(unrevealed, aliased, outside, nuisance, weak, chosen, separation)
    for c in chosen:
        if c.cand.key in masked:
            unrev = _named(unrev, c.cand, c.active, masked[c.cand.key])
    if undetermined:
        lenders = strongest_hidden(nrm, free, hidden + weak_hidden, grade)
        unrev = _undetermined(unrev, reported, undetermined, lent, sig, lenders, separation, log)
    structure = _structure(pred, rows_of, residual, white_rows, theta_out)
    series_after = residual_under(pred, None, theta_out, series=True).series if keep_series else None  # for the plots
    rms_b, rms_a = rms(rows_of, before.rows), rms(rows_of, residual)
    assert before.rows is not None  # made with rows_of
    out_of_sample = cross_validate(
        pred,
        rows_of,
        nrm,
        theta0,
        theta_out,
        free,
        {c.cand.key: list(c.active) for c in reported},
        weights,
        before.rows,
        residual,
    )
    if out_of_sample is not None:
        # a finding must also predict data it was not fitted to: one whose held-out gain is not
        # positive beyond chance is no finding (in-sample significance leans on the errors, the held-out
        # gain does not); a finding the grade resolved from an alias must too, as the grade rules the
        # alternative out, not a third cause the two may share
        gains = {g.key: g for g in out_of_sample.effects}
        for c in reported:
            alt, g = resolved.get(c.cand.key), gains.get(c.cand.key)
            if g is None or g.generalises:
                continue
            effects = [e for e in effects if (e.id, e.channel) != (c.cand.id, c.cand.channel)]
            held_out = (
                f"removes {100 * g.gain_in_sample:.2f} % of the weighted residual power in sample but "
                f"{100 * g.gain_held_out:.2f} % on held-out folds, not beyond chance (p = {g.p:.2g})"
            )
            if alt is None:
                why = f"significant in sample, but it {held_out}; the extended model carries it"
            else:
                why = (
                    f"indistinguishable from {alt.key} on this motion (canonical correlation {alt.rho:.4f}), which "
                    f"alone would be implausible ({alt.reason}); but it {held_out}, so something else may explain "
                    "what the two share; the extended model carries it"
                )
            unrev = _named(unrev, c.cand, c.active, why)
            log.append(f"{c.cand.key} no finding: it does not generalise (p = {g.p:.2g})")
        warnings += _holdout_warnings(out_of_sample)
    return Diagnosis(
        path=str(tel.path),
        effects=effects,
        unrevealed=unrev,
        rms_before=dict(zip(CHANNELS, rms_b.tolist())),
        rms_after=dict(zip(CHANNELS, rms_a.tolist())),
        theta_nominal=theta0,
        theta=theta_out,
        sigma_theta=sig,
        samples=int(pred.mask.sum()),
        block=rows_of.L,
        bandwidth_hz=bandwidth_hz,
        white_sigma=dict(zip(CHANNELS, white_rows.tolist())),
        rms_full_before=dict(zip(CHANNELS, np.sqrt(before.ms_full).tolist())),
        rms_full_after=dict(zip(CHANNELS, np.sqrt(ms_full).tolist())),
        weights_sigma=state.sigma_c,
        kappa=state.kappa,
        bias_walk=np.sqrt(noise_nrm.drift.q),
        bias_walk_slope=noise_nrm.drift.slope,
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
