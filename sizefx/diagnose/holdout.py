"""The gain out of sample: does the extended model predict data it was not fitted to?

In sample every parameter freed lowers the residual, whether it is physics or noise; only data the
fit did not see says whether the model generalises. Two checks, both on the fit's rows (its band,
its per-channel weights ``1 / (sigma_c^2 kappa_c)``, :mod:`.fit`):

- :func:`cross_validate`: **blocked folds in time**. The blocks of the normal equations
  (:class:`sizefx.diagnose.normal.Normal`) are cut into :data:`HOLDOUT_FOLDS` contiguous groups;
  each is held out in turn and the selected model refitted on the others: one Gauss-Newton step
  from the final estimate on the normal equations without the fold (the prediction is linear in the
  arms and scale factors, and the step is within a few standard errors). The fold's residual is
  then formed under that estimate, exactly, beside its in-sample residual (under the model fitted
  to the whole record). The selection is not redone per fold: the check asks whether the *selected*
  model's estimates predict data they did not see. A spurious effect, fitted to the other folds'
  noise, predicts nothing on the held-out fold, so its held-out gain is zero or negative.
- :func:`validate_on`: **another record**, the extended model applied as it is (``sizefx diagnose
  A.h5 --validate-on B.h5``), its rows formed in the band ``A`` was fitted in.

Each held-out part yields, per channel, the residual RMS under the start model and under the
extended one, and the relative gain in weighted residual power, ``g = 1 - SS_after / SS_before``.
Whether the gain is positive beyond chance is a one-sided Student t-test of the per-block power
differences ``SS_before - SS_after`` (the blocks of the normal equations, a hundredth of the record:
long enough that the block sandwich takes them as independent, and many enough that folds of
unequal excitation do not hide a gain every fold shows); a model whose held-out gain is not
significantly positive at :data:`OVERFIT_ALPHA` is flagged as overfit. Each effect's own held-out
gain (the model without it, refitted on the same folds, against the model with it) comes from the
blocks' normal equations alone (:func:`_fold_power`, linear about the final estimate).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from ..io.telemetry import Telemetry
from .integrity import check_reference, without_bad_rows
from .normal import Normal, Rows, block_length_s, solve
from .predictor import Predictor
from .residual import residual_under, rms
from .theta import CHANNELS

__all__ = [
    "HeldOut",
    "EffectGain",
    "OutOfSample",
    "cross_validate",
    "validate_on",
    "HOLDOUT_FOLDS",
    "NAVIGATION_WINDOWS",
    "EXTRAPOLATION_RATIO",
    "OVERFIT_ALPHA",
]

#: Contiguous folds of blocked cross-validation: 20 folds of 5 blocks each
#: (:data:`sizefx.diagnose.normal.TARGET_BLOCKS`), each a twentieth of the record and at least
#: 1.25 s (:data:`sizefx.diagnose.normal.MIN_BLOCK_S`): small enough that holding one out rarely
#: takes away what a parameter is seen in (a table plan turns about each axis in one stretch of the
#: record; with five folds a fold held a whole axis), and made of whole blocks, which the block
#: sandwich already takes as independent. Chosen, with :data:`EXTRAPOLATION_RATIO`, on
#: validate_diagnose's development range (five folds flagged 30 of 122 true findings as not
#: generalising, twenty 12); its validation range, never looked at for them, flags 6 of 139.
HOLDOUT_FOLDS = 20
#: Contiguous stretches a record long enough to navigate is navigated over, each with the model
#: fitted without it, and the parts a record validated on is cut into for the table.
NAVIGATION_WINDOWS = 5
#: A fold whose absence multiplies a parameter's variance by more than this (the fold holds over
#: three quarters of what the record shows of it) cannot be predicted from the others: it is
#: reported, but left out of the held-out gain and its test.
EXTRAPOLATION_RATIO = 4.0
#: One-sided level of the t-test that the held-out gain is positive: above it the model, or the
#: effect, is flagged as not shown to generalise (a flag, not a rejection: an effect near its
#: detection limit gains little on a fold, and one test in twenty flags a true effect by chance).
OVERFIT_ALPHA = 0.05


@dataclass(frozen=True)
class HeldOut:
    """One part of the data the model was not fitted to: a fold of the record, or another record."""

    label: str  #: "fold 2 of 20", or "part 2 of 5" of another record
    t0_s: float  #: the part's span [s, IMU clock]
    t1_s: float
    rms_before: dict  #: channel -> residual RMS under the start model (SI), in the fit's band
    rms_after: dict  #: channel -> under the extended model fitted without this part (SI)
    gain: float  #: 1 - SS_after / SS_before, weighted residual power over the six channels
    rms_in_sample: dict | None = None  #: channel -> under the model fitted to all of the record (folds only)
    gain_in_sample: float | None = None
    #: the model vector fitted without this part [NP] (folds)
    theta: np.ndarray | None = field(default=None, repr=False, compare=False)
    #: the other folds determine the model (:data:`EXTRAPOLATION_RATIO`); False: left out of the test
    determined: bool = True

    def as_dict(self) -> dict:
        out: dict = {
            "label": self.label,
            "t0_s": self.t0_s,
            "t1_s": self.t1_s,
            "residual_rms_before": self.rms_before,
            "residual_rms_after": self.rms_after,
            "gain": self.gain,
            "determined": self.determined,
        }
        if self.rms_in_sample is not None:
            out["residual_rms_in_sample"] = self.rms_in_sample
            out["gain_in_sample"] = self.gain_in_sample
        return out


@dataclass(frozen=True)
class EffectGain:
    """One effect's share of the weighted residual power, in sample and on the held-out folds."""

    key: str  #: the effect, as the selection names it (``lever_arm:accel_x``)
    gain_in_sample: float  #: residual power the effect removes, refitted on all of the record, / SS_before
    gain_held_out: float  #: the same on the held-out folds (each model refitted without the fold), pooled
    t: float  #: one-sided t statistic of the per-block held-out gains
    p: float
    generalises: bool  #: p <= OVERFIT_ALPHA

    def as_dict(self) -> dict:
        return {
            "effect": self.key,
            "gain_in_sample": self.gain_in_sample,
            "gain_held_out": self.gain_held_out,
            "t": _number(self.t),
            "p": self.p,
            "generalises": self.generalises,
        }


@dataclass(frozen=True)
class OutOfSample:
    """The extended model on data it was not fitted to: per part, pooled, and the test of the gain."""

    kind: str  #: "blocked folds in time" or "other record"
    parts: tuple  #: of :class:`HeldOut`: the folds, or the other record cut in time
    rms_before: dict  #: channel -> over all parts (SI)
    rms_after: dict
    gain: float  #: pooled over the parts: 1 - sum SS_after / sum SS_before
    t: float  #: one-sided t statistic of the per-block gains
    p: float
    overfit: bool  #: the held-out gain is not significantly positive (p > OVERFIT_ALPHA)
    rms_in_sample: dict | None = None  #: folds: the model fitted to all of the record
    gain_in_sample: float | None = None
    effects: tuple = ()  #: of :class:`EffectGain` (folds only)
    record: str | None = None  #: the other record's path
    #: the other record's free-inertial horizontal error, {"duration_s", "before", "after"}
    #: (:func:`sizefx.diagnose.navigation_gain`); None for a record too short to navigate (the folds'
    #: navigation over their windows is the stage's: :class:`~sizefx.diagnose.records.ModelChecks`)
    navigation: dict | None = None
    #: folds: (t0_s, t1_s, theta) of :data:`NAVIGATION_WINDOWS` stretches, each with the model
    #: fitted without it (for the navigation over it)
    windows: tuple = field(default=(), repr=False, compare=False)

    def as_dict(self) -> dict:
        out: dict = {
            "kind": self.kind,
            **({"record": self.record} if self.record is not None else {}),
            "residual_rms_before": self.rms_before,
            "residual_rms_after": self.rms_after,
            "gain": self.gain,
            "t": _number(self.t),
            "p": self.p,
            "overfit": self.overfit,
            "parts_tested": sum(p.determined for p in self.parts),
            "parts": [p.as_dict() for p in self.parts],
        }
        if self.rms_in_sample is not None:
            out["residual_rms_in_sample"] = self.rms_in_sample
            out["gain_in_sample"] = self.gain_in_sample
        if self.effects:
            out["effects"] = [e.as_dict() for e in self.effects]
        if self.navigation is not None:
            out["navigation"] = self.navigation
        return out


def _number(x: float) -> float | str:
    """A JSON number, or its name when infinite or undefined (JSON has no inf or nan)."""
    return float(x) if np.isfinite(x) else str(x)


def _t_test(d) -> tuple[float, float]:
    """One-sided t-test that the mean of the per-block gains ``d`` is positive: (t, p)."""
    d = np.asarray(d, dtype=float)
    if d.size < 2:
        return float("nan"), 1.0
    sd = float(np.std(d, ddof=1))
    mean = float(np.mean(d))
    if sd == 0.0:
        return (float("inf"), 0.0) if mean > 0 else (float("-inf") if mean < 0 else 0.0, 1.0)
    t = mean / (sd / np.sqrt(d.size))
    return float(t), float(stats.t.sf(t, d.size - 1))


def _power(rows, sel, weights) -> tuple[float, np.ndarray]:
    """Weighted residual power of the rows ``sel`` and each channel's RMS there."""
    r = rows[sel]
    ms = np.mean(r**2, axis=0) if r.shape[0] else np.zeros(6)
    return float(np.sum(weights * ms) * r.shape[0]), np.sqrt(ms)


def _block_power(rows, sel, block_of_row, blocks: int, weights) -> np.ndarray:
    """Weighted residual power of the rows ``sel``, per block ``[blocks]``."""
    return np.bincount(block_of_row[sel], weights=(rows[sel] ** 2) @ weights, minlength=blocks)


def _fold_power(Ng, bg, yyg, step):
    """Weighted residual power, linear about the final estimate, after ``step`` [NP] (the change of
    every parameter from the final estimate): ``yy - 2 b's + s'Ns``, for one set of normal equations
    or per block (``Ng [B, P, P]``, ``bg [B, P]``, ``yyg [B]``)."""
    return yyg - 2.0 * bg @ step + np.einsum("...i,...ij,j->...", step, Ng, step)


def _step(N, b, yy, free, offset) -> np.ndarray:
    """The full step [NP] from the final estimate: ``free`` refitted, the others held at ``offset``."""
    step = offset.copy()
    x, _, _ = solve(N, b, yy, free, offset)
    step[free] = x
    return step


def _channels(a) -> dict:
    return dict(zip(CHANNELS, np.asarray(a, dtype=float).tolist()))


def _fold_rows(rows_of: Rows, nrm: Normal, g) -> tuple[float, float, np.ndarray]:
    """The span [s] of the blocks ``g`` and the kept rows inside it."""
    t0 = float(nrm.t0[g[0]])
    t1 = float(nrm.t0[g[-1] + 1]) if g[-1] + 1 < nrm.blocks else float(np.inf)
    return t0, t1, rows_of.keep & (rows_of.t >= t0) & (rows_of.t < t1)


def cross_validate(
    pred: Predictor,
    rows_of: Rows,
    nrm: Normal,
    theta0: np.ndarray,
    theta: np.ndarray,
    free: np.ndarray,
    effects: dict,
    weights: np.ndarray,
    before_rows: np.ndarray,
    final_rows: np.ndarray,
    folds: int = HOLDOUT_FOLDS,
) -> OutOfSample | None:
    """Blocked cross-validation in time of the extended model ``theta`` (module docstring).

    ``nrm``: the normal equations at the final estimate; ``free``: the parameters the model
    estimated (findings and the nuisance fitted beside them); ``effects``: {key: parameter indices}
    of the findings whose own held-out gain is reported; ``weights`` [6] the fit's per-channel
    weights; ``before_rows``, ``final_rows``: the residual's rows under the start model and the final
    one. None when nothing was estimated or the record holds too few blocks for the folds."""
    free = np.asarray(free, dtype=int)
    if free.size == 0 or nrm.blocks < 2 * folds:
        return None
    N, b, yy = nrm.total()
    offset = theta0 - theta
    var_all = np.abs(np.diag(solve(N, b, yy, free, offset)[2]))
    block_of_row = np.maximum(np.searchsorted(nrm.t0, rows_of.t, side="right") - 1, 0)
    parts, gains = [], []
    per_effect: dict[str, list] = {k: [] for k in effects}
    pooled = np.zeros((3, 6))  # sums of squares before, held out, in sample, over the folds tested
    counts = 0
    for k, g in enumerate(nrm.groups(folds)):
        Ng, bg, yyg = nrm.N[g].sum(0), nrm.b[g].sum(0), float(nrm.yy[g].sum())
        x, _, cov = solve(N - Ng, b - bg, yy - yyg, free, offset)
        step = offset.copy()
        step[free] = x
        th = theta + step
        # a fold that holds most of what the record shows of a parameter (a table's only turn about
        # one axis) cannot be predicted from the others: that is extrapolation, not generalisation
        determined = bool(np.all(np.abs(np.diag(cov)) <= EXTRAPOLATION_RATIO * var_all))
        t0, t1, sel = _fold_rows(rows_of, nrm, g)
        with pred.uncached():  # a model met once, on a fold of the record
            held = residual_under(pred, rows_of, th, within=(t0, t1 if np.isfinite(t1) else pred.t[-1] + 1.0)).rows
        assert held is not None  # rows_of given
        ss_before, rms_before = _power(before_rows, sel, weights)
        ss_after, rms_after = _power(held, sel, weights)
        ss_in, rms_in = _power(final_rows, sel, weights)
        parts.append(
            HeldOut(
                label=f"fold {k + 1} of {folds}",
                t0_s=t0,
                t1_s=float(min(t1, pred.t[-1])),
                rms_before=_channels(rms_before),
                rms_after=_channels(rms_after),
                gain=1.0 - ss_after / ss_before if ss_before > 0 else 0.0,
                rms_in_sample=_channels(rms_in),
                gain_in_sample=1.0 - ss_in / ss_before if ss_before > 0 else 0.0,
                theta=th,
                determined=determined,
            )
        )
        if not determined:
            continue
        gains.append(
            (
                _block_power(before_rows, sel, block_of_row, nrm.blocks, weights)
                - _block_power(held, sel, block_of_row, nrm.blocks, weights)
            )[g]
        )
        n = int(sel.sum())
        pooled += np.array([rms_before, rms_after, rms_in]) ** 2 * n
        counts += n
        for key, idx in effects.items():  # the effect's own part: the model without it, refitted alike
            without = _step(N - Ng, b - bg, yy - yyg, np.setdiff1d(free, idx), offset)
            per_effect[key].append(
                _fold_power(nrm.N[g], nrm.b[g], nrm.yy[g], without) - _fold_power(nrm.N[g], nrm.b[g], nrm.yy[g], step)
            )
    if not gains:
        return None  # no fold can be predicted from the others
    ss_tested = float(np.sum(weights * pooled[0]))
    ss_all, _ = _power(before_rows, rows_of.keep, weights)
    in_sample = {}
    _, rss_with, _ = solve(N, b, yy, free, offset)
    for key, idx in effects.items():
        _, rss_without, _ = solve(N, b, yy, np.setdiff1d(free, idx), offset)
        in_sample[key] = (rss_without - rss_with) / ss_all if ss_all > 0 else 0.0
    t, p = _t_test(np.concatenate(gains))
    effect_gains = []
    for key, per_fold in per_effect.items():  # pooled over the folds as in sample; tested block by block
        d = np.concatenate(per_fold)
        te, pe = _t_test(d)
        held_out = float(d.sum()) / ss_tested if ss_tested > 0 else 0.0
        effect_gains.append(EffectGain(key, float(in_sample[key]), held_out, te, pe, pe <= OVERFIT_ALPHA))
    rms_pooled = np.sqrt(pooled / max(counts, 1))
    windows = []  # NAVIGATION_WINDOWS stretches, each with the model fitted without it
    for g in nrm.groups(NAVIGATION_WINDOWS):
        Ng, bg, yyg = nrm.N[g].sum(0), nrm.b[g].sum(0), float(nrm.yy[g].sum())
        t0, t1, _ = _fold_rows(rows_of, nrm, g)
        windows.append((t0, float(min(t1, pred.t[-1])), theta + _step(N - Ng, b - bg, yy - yyg, free, offset)))
    return OutOfSample(
        kind="blocked folds in time",
        parts=tuple(parts),
        rms_before=_channels(rms_pooled[0]),
        rms_after=_channels(rms_pooled[1]),
        gain=1.0 - float(np.sum(weights * pooled[1])) / ss_tested if ss_tested > 0 else 0.0,
        t=t,
        p=p,
        overfit=p > OVERFIT_ALPHA,
        rms_in_sample=_channels(rms_pooled[2]),
        gain_in_sample=1.0 - float(np.sum(weights * pooled[2])) / ss_tested if ss_tested > 0 else 0.0,
        effects=tuple(effect_gains),
        windows=tuple(windows),
    )


def validate_on(
    tel: Telemetry,
    theta0: np.ndarray,
    theta: np.ndarray,
    bandwidth_hz: float | None,
    weights: np.ndarray,
    parts: int = NAVIGATION_WINDOWS,
    navigation: dict | None = None,
) -> OutOfSample:
    """The extended model ``theta`` on another record ``tel``, against the start model ``theta0``.

    The record's reference is checked as diagnose checks it (glitches dropped, the motion split at
    jumps); its rows are formed in ``bandwidth_hz`` (the band the model was fitted in) and cut into
    ``parts`` contiguous parts of equal time for the t-test; ``weights`` [6]: the fit's per-channel
    weights, so that the gain is measured as the fit measured it. ``navigation``: the record's
    navigation before and after, when it was navigated."""
    check = check_reference(tel)
    pred = Predictor(without_bad_rows(tel, check), breaks_s=check.breaks_s)
    rows_of = Rows(pred.t, pred.mask, pred.dt, bandwidth_hz)
    before = residual_under(pred, rows_of, theta0).rows
    after = residual_under(pred, rows_of, theta).rows
    assert before is not None and after is not None  # rows_of given
    kept_t = rows_of.t[rows_of.keep]
    span = float(kept_t[-1] - kept_t[0])
    block_s = block_length_s(span)
    blocks = max(1, int(span // block_s))
    block_of_row = np.clip(np.floor((rows_of.t - kept_t[0]) / block_s).astype(int), 0, blocks - 1)
    d = _block_power(before, rows_of.keep, block_of_row, blocks, weights) - _block_power(
        after, rows_of.keep, block_of_row, blocks, weights
    )
    edges = np.linspace(kept_t[0], kept_t[-1], parts + 1)
    edges[-1] = np.nextafter(edges[-1], np.inf)
    held = []
    for k in range(parts):
        sel = rows_of.keep & (rows_of.t >= edges[k]) & (rows_of.t < edges[k + 1])
        ss_b, rms_b = _power(before, sel, weights)
        ss_a, rms_a = _power(after, sel, weights)
        held.append(
            HeldOut(
                label=f"part {k + 1} of {parts}",
                t0_s=float(edges[k]),
                t1_s=float(min(edges[k + 1], kept_t[-1])),
                rms_before=_channels(rms_b),
                rms_after=_channels(rms_a),
                gain=1.0 - ss_a / ss_b if ss_b > 0 else 0.0,
            )
        )
    ss_b, _ = _power(before, rows_of.keep, weights)
    ss_a, _ = _power(after, rows_of.keep, weights)
    t, p = _t_test(d[np.bincount(block_of_row[rows_of.keep], minlength=blocks) > 0])
    return OutOfSample(
        kind="other record",
        parts=tuple(held),
        rms_before=_channels(rms(rows_of, before)),
        rms_after=_channels(rms(rows_of, after)),
        gain=1.0 - ss_a / ss_b if ss_b > 0 else 0.0,
        t=t,
        p=p,
        overfit=p > OVERFIT_ALPHA,
        record=str(tel.path),
        navigation=navigation,
    )
