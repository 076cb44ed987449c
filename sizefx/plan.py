"""Design a turntable calibration plan from the Fisher information of the calibration model: ``sizefx plan``.

What a calibration can reach is known before anything is recorded. The joint fit
(:func:`sizefx.calibrate.joint_fit`) is a least squares whose design depends only on the motion
(the rates, the angular acceleration, gravity's direction) and whose noise is the accelerometers';
so for a candidate plan the inverse of :func:`sizefx.calibrate.joint.information` on the plan's
noise-free motion is the covariance of the arms, the biases and the tilt the fit will state
(the Cramer-Rao bound, which the fit reaches on white noise: benchmarks/accuracy_calibrate.py).

The plan is the paper's kind (:class:`sizefx.scenarios.TurntablePlan`: each reachable body axis
vertical in turn, the table swinging it through whole positive and negative rotations, dwells
and jerk-limited changes of rate), and the search is over what the table's limits leave free:

- the peak rate and the angular acceleration (fractions of the table's limits);
- the number of rotation cycles per axis (how the time is shared between accelerating, which
  shows the arms through the tangential term, and cruising, which shows them through the
  centripetal term);
- the time per axis: the budget's share (``objective="min-sigma"``: the smallest largest arm
  sigma in the time), or the least that reaches the wanted sigma (``objective="least-time"``).

With a wanted delay sigma (``target_delay_sigma_us``) the plan gains a sway for the
accelerometers' delay, which rotations about vertical axes barely show (gravity stays put in the
body): a level body axis swung harmonically, gravity turning in the body at the sway's rate, as
long as the delay's sigma needs (:func:`_least_sway`).

A plan is a TOML document (``data-schemas/plan-1.json``) that ``sizefx simulate turntable --plan``
runs (and ``sizefx simulate sway --plan``, its sway). Conventions: SI inside; the file and the options in the table's own units (deg/s, deg/s^2,
s, ug/sqrt(Hz), mm).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from . import earth, scenarios
from .calibrate.joint import PARAMS_R, information, unobservable
from .calibrate.records import Record
from .constants import ARCSEC, MAX_PLAN_S, MICRO_G
from .effects import IDEAL, load_effects
from .errors import ConfigError
from .io.plan_file import PLAN_SCHEMA
from .io.schema import check_document
from .simulate import true_motion

__all__ = [
    "TableLimits",
    "PlanRequest",
    "Prediction",
    "PlanDesign",
    "PlanConfig",
    "PlanResult",
    "run",
    "predict",
    "design_plan",
    "plan_document",
    "PlanError",
    "PLAN_SCHEMA",
    "PLAN_RATE_HZ",
    "RATE_FRACTIONS",
    "ACCEL_FRACTIONS",
    "sway_shape",
    "SWAY_MAX_HZ",
    "SWAY_MAX_ANGLE_DEG",
    "SWAY_AXES",
    "MAX_PLAN_S",
    "BLOCK_MAX_S",
    "FINALISTS",
]

#: Rows per second of the plan's motion in the information. The table's changes of rate take 0.5 s
#: or more: on the paper's plan 25, 50 and 12.5 rows a second give the same sigmas to 0.1 %
#: (and the 1600 Hz fit's to 1 %; benchmarks/plan_calibrate.py), 25 at a third of 50's cost.
PLAN_RATE_HZ = 25.0
#: Fractions of the table's rate and acceleration limits tried. More rate is more centripetal
#: signal (as the rate squared); less acceleration leaves more of a cycle accelerating.
RATE_FRACTIONS = (1.0, 0.7)
ACCEL_FRACTIONS = (1.0, 0.5, 0.25)
#: Static lead-ins tried [s]: rest separates the biases and the tilt from the arms, but adds time.
LEAD_IN_S = (10.0, 30.0, 60.0)
#: Cruise at the peak rate, in units of the half cycle's changes of rate and dwells, tried by the
#: least-time search (the budget search tries :data:`CYCLE_CHOICES` instead).
CRUISE_FACTORS = (1.0, 3.0)
#: Rests at each end of a rotation tried [s]. The centripetal term is always positive, so only the
#: contrast of turning with resting separates it (and the arms along their own axis, seen only
#: through it) from the bias; the paper rests 0.5 s.
DWELL_S = (0.5, 3.0, 8.0)
#: Cycles per axis tried when the time is given (more are tried by the least-time search).
CYCLE_CHOICES = (1, 2, 3, 4, 5, 6, 8, 10, 12, 16, 20, 25, 32, 40)
#: The most cycles per axis a plan may have (the simulator's own limit on --cycles).
MAX_CYCLES = 10_000
#: The delay's sway: rate ``A sin(2 pi t / P)`` about a level body axis. Its signal, gravity turning
#: in the body, ``g A tau``, grows with the rate amplitude A alone, so the sway takes all the rate
#: the table allows within its acceleration (``2 pi A / P``) and a swing of at most
#: :data:`SWAY_MAX_ANGLE_DEG` (``A P / 2 pi``), at no more than the paper's :data:`SWAY_MAX_HZ`.
SWAY_MAX_HZ = 1.0
#: Largest swing of the delay's sway [deg] either side of level: a tilting table's usual range,
#: and well inside the Euler angles' single cover.
SWAY_MAX_ANGLE_DEG = 30.0
#: Rest before the sway [s]: the sway record's biases, which its own static part pins down.
SWAY_LEAD_IN_S = 10.0
#: The delay's sway axes: body X swung is a roll, body Y a pitch.
SWAY_AXES = {"X": "roll", "Y": "pitch"}
#: The most sway periods a plan may have.
MAX_SWAY_PERIODS = 100_000
#: Seconds per axis up to which the budget search evaluates every candidate on its whole motion
#: with the fit's bias windows: the paper's plan has 120 s per axis, and a search at its budget
#: evaluates about 750 candidates of that length. With more time per axis a candidate's rotations
#: about each axis are k repetitions of a block of at most this length (the same cycles, k times as
#: many), its information is screened from the block's (:func:`_repeated_sigma`), and only the
#: :data:`FINALISTS` best are evaluated on their whole motion: the search's cost no longer grows
#: with the budget, save for those few (each at most :data:`MAX_PLAN_S` long).
BLOCK_MAX_S = 120.0
#: Screened candidates evaluated on their whole motion with the fit's bias windows, per rest between
#: rotations (:data:`DWELL_S`). The screening carries the windows' cost over from a block shorter
#: than the plan, which states short rests too well (by up to 18 % at a 3000 s budget, against 0.3 %
#: with 3 s rests: the windows of a long plan hold rotations only, a block's hold some rest too);
#: so the best of each rest are evaluated. Measured at 1000 and 3000 s: the best of the 60 and 30
#: best screened candidates, evaluated whole, was the screening's 3rd and 4th.
FINALISTS = 2


class PlanError(ConfigError):
    """A plan the table cannot run, or a request no plan can meet (one line, exit code 2)."""


@dataclass(frozen=True)
class TableLimits:
    """What the table can do: its largest rate and angular acceleration, the body axes it can make
    vertical, and the time it takes to turn the IMU to the next axis and let it settle."""

    max_rate_dps: float = 20.0
    max_accel_dps2: float = 10.0
    axes: str = "XYZ"
    reposition_s: float = 10.0
    settle_s: float = 10.0
    #: body axes the table can swing about while they lie level (X: roll, Y: pitch; "": none), for the delay
    sway_axes: str = ""

    def check(self):
        axes, sway_axes = self.axes.upper(), self.sway_axes.upper()
        if not axes or any(a not in "XYZ" for a in axes) or len(set(axes)) != len(axes):
            raise PlanError(
                f"--vertical-axes '{self.axes}' (the table axes): give the body axes the table can make vertical, each once "
                "(letters X, Y, Z, e.g. XYZ)"
            )
        if any(a not in SWAY_AXES for a in sway_axes) or len(set(sway_axes)) != len(sway_axes):
            raise PlanError(
                f"table sway axes '{self.sway_axes}': give the level body axes the table can swing "
                "about, each once (X for roll, Y for pitch, e.g. XY)"
            )
        for name in ("max_rate_dps", "max_accel_dps2", "reposition_s", "settle_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise PlanError(f"table {name} = {value!r}: give a positive, finite number")
        return replace(self, axes=axes, sway_axes=sway_axes)


@dataclass(frozen=True)
class PlanRequest:
    """``sizefx plan``'s question: the accelerometers' white noise, the table, and either a time
    budget (the best plan in it) or a wanted largest arm sigma (the shortest plan that reaches it).
    ``static_s``: a fixed lead-in at rest (None: the search picks one of :data:`LEAD_IN_S`).
    ``target_delay_sigma_us``: add the shortest sway (within the budget) that determines the
    accelerometers' delay to this sigma; the table must have ``sway_axes``."""

    noise_ug_per_sqrt_hz: float
    table: TableLimits = field(default_factory=TableLimits)
    budget_s: float | None = None
    target_sigma_mm: float | None = None
    static_s: float | None = None
    target_delay_sigma_us: float | None = None

    def check(self):
        if not (math.isfinite(self.noise_ug_per_sqrt_hz) and self.noise_ug_per_sqrt_hz > 0):
            raise PlanError(
                f"noise {self.noise_ug_per_sqrt_hz!r} ug/sqrt(Hz): give the accelerometers' white noise "
                "density, positive and finite"
            )
        if (self.budget_s is None) == (self.target_sigma_mm is None):
            raise PlanError(
                "give either a time budget (--budget-s) or a wanted largest sigma (--target-sigma-mm), one of the two"
            )
        for name in ("budget_s", "target_sigma_mm", "static_s", "target_delay_sigma_us"):
            value = getattr(self, name)
            if value is not None and not (math.isfinite(value) and value > 0):
                raise PlanError(f"{name} = {value!r}: give a positive, finite number")
        if self.budget_s is not None and self.budget_s > MAX_PLAN_S:
            raise PlanError(
                f"--budget-s {self.budget_s:g}: longer than the {MAX_PLAN_S:g} s a plan may take (calibrate reads "
                f"a turntable record whole, at most {MAX_PLAN_S:g} s at 1600 Hz); give at most {MAX_PLAN_S:g} s, "
                "or plan a longer calibration as several records"
            )
        table = self.table.check()
        if self.target_delay_sigma_us is not None and not table.sway_axes:
            raise PlanError(
                f"--delay-sigma-us {self.target_delay_sigma_us:g}: the delay needs a sway about a level "
                "axis, and the table has none; give the axes it can swing about (--sway-axes X, Y or XY)"
            )
        return replace(self, table=table)


@dataclass
class Prediction:
    """The standard errors a calibration on a plan will state (the inverse Fisher information)."""

    sigma_arms_m: np.ndarray  #: [3, 3]
    sigma_tilt_rad: np.ndarray  #: [2]
    duration_s: float  #: the turntable's and the sway's records together
    sigma_delay_s: float | None = None  #: with a sway: the accelerometers' delay

    @property
    def max_sigma_mm(self) -> float:
        return float(self.sigma_arms_m.max() * 1e3)


@dataclass
class PlanDesign:
    """The plan chosen, its prediction, and the paper's plan under the same noise and table."""

    plan: scenarios.TurntablePlan
    prediction: Prediction
    request: PlanRequest
    paper: Prediction | None = None
    paper_plan: scenarios.TurntablePlan | None = None
    tried: int = 0
    sway: scenarios.SwayPlan | None = None  #: the delay's sway (a record of its own), if asked for


def _motion_record(traj, name: str) -> Record:
    """A trajectory's noise-free motion as the fit sees it, at :data:`PLAN_RATE_HZ` (true angular acceleration)."""
    t = np.arange(0.0, traj.duration_s, 1.0 / PLAN_RATE_HZ)
    site = traj.evaluate(t[:1])
    motion = true_motion(traj, t, load_effects(base=IDEAL).sensor_params())
    assert motion.mat_nb is not None  # true_motion carries the attitude
    g_n = np.asarray(earth.gravity_n(site.lat_rad[0], site.height_m[0]), dtype=float)
    return Record(name, t, np.zeros((t.size, 3)), motion.omega_ib_b, motion.omegadot_ib_b, motion.mat_nb, g_n)


def _plan_record(plan: scenarios.TurntablePlan) -> Record:
    return _motion_record(scenarios.turntable(plan)[0], "plan")


def _sway_record(sway: scenarios.SwayPlan) -> Record:
    return _motion_record(scenarios.sway(sway)[0], "sway")


def _fisher(
    plan: scenarios.TurntablePlan,
    noise_ug_per_sqrt_hz: float,
    bias_window_s="fit",
    sway=None,
    turntable_record=None,
    colour: dict | None = None,
):
    """``(names, Fisher information)`` of the joint fit's parameters on the plan's motion (with the
    delay's sway, a record of its own, and then the delay); the bias windows the fit's (``"fit"``)
    or one bias per channel and record (None: the information is then a sum over the cycles, which
    :func:`_least_cycles` and :func:`_least_sway` use)."""
    windows = {} if bias_window_s == "fit" else {"bias_window_s": bias_window_s}
    records = [_plan_record(plan) if turntable_record is None else turntable_record] + (
        [_sway_record(sway)] if sway is not None else []
    )
    return information(
        records, noise_ug_per_sqrt_hz * MICRO_G, with_delay=sway is not None, **windows, **(colour or {})
    )


def _sigmas(names, fisher, plan_axes: str) -> np.ndarray:
    """Standard errors from a Fisher information, or :class:`PlanError` naming what is unobservable
    (the fit's own test, :func:`sizefx.calibrate.joint.unobservable`)."""
    _, bad = unobservable(fisher, names)
    if bad:
        raise PlanError(
            f"rotations about {', '.join(plan_axes)} leave unobservable: {', '.join(bad)}; the table "
            "must reach at least two body axes (all three for every arm)"
        )
    scale = 1.0 / np.sqrt(np.diag(fisher))
    return np.sqrt(np.diag(np.linalg.inv(fisher * np.outer(scale, scale)))) * scale


def predict(
    plan: scenarios.TurntablePlan,
    noise_ug_per_sqrt_hz: float,
    sway: scenarios.SwayPlan | None = None,
    *,
    markov_ug_per_sqrt_hz: float = 0.0,
    markov_correlation_s: float = 1.0,
    bias_rw_ug_per_sqrt_h: float = 0.0,
) -> Prediction:
    """The arms' and the tilt's (and with ``sway``, the delay's) standard errors a calibration on
    ``plan`` (and the sway's record) will state, the accelerometers' noise white with this density,
    plus, when given, a first-order Gauss-Markov part and a bias random walk (the
    ``accel_noise`` section's ``markov_*`` and ``bias_rw_*``: the Cramer-Rao bound for that noise).
    Raises :class:`PlanError` naming what the plan leaves unobservable."""
    plan.check()
    duration = plan.duration_s
    if sway is not None:
        sway.check()
        duration += sway.duration_s
    colour = {
        "markov_density_mps2_per_sqrt_hz": markov_ug_per_sqrt_hz * MICRO_G,
        "markov_correlation_s": markov_correlation_s,
        "bias_rw_mps2_per_sqrt_s": bias_rw_ug_per_sqrt_h * MICRO_G / 60.0,
    }
    names, fisher = _fisher(plan, noise_ug_per_sqrt_hz, sway=sway, colour=colour)
    sigma = _sigmas(names, fisher, plan.axes)
    tilt = [names.index("tilt_north"), names.index("tilt_east")]
    return Prediction(
        sigma[:9].reshape(3, 3),
        sigma[tilt],
        duration,
        float(sigma[names.index("accel_delay")]) if sway is not None else None,
    )


def sway_shape(table: TableLimits) -> tuple[float, float]:
    """``(rate amplitude [deg/s], period [s])`` of the delay's sway on this table (:data:`SWAY_MAX_HZ`):
    the period where the acceleration's and the swing's limits meet (at least ``1 / SWAY_MAX_HZ``,
    rounded up to 0.1 s), and the largest amplitude both, and the table's rate, allow there."""
    meet = 2 * math.pi * math.sqrt(SWAY_MAX_ANGLE_DEG / table.max_accel_dps2)
    period = math.ceil(max(1.0 / SWAY_MAX_HZ, meet) * 10.0 - 1e-9) / 10.0
    amplitude = min(
        table.max_rate_dps, table.max_accel_dps2 * period / (2 * math.pi), SWAY_MAX_ANGLE_DEG * 2 * math.pi / period
    )
    return math.floor(amplitude * 100.0) / 100.0, period


def _sway(axis: str, amplitude_dps: float, period_s: float, periods: int) -> scenarios.SwayPlan:
    return scenarios.SwayPlan(
        axis=SWAY_AXES[axis],
        amplitudes_dps=(amplitude_dps,),
        frequency_hz=1.0 / period_s,
        static_s=SWAY_LEAD_IN_S,
        segment_s=periods * period_s,
    )


def _least_count(sigma_of, target: float, most: int) -> int | None:
    """The least count k in 1 .. ``most`` with ``sigma_of(k) <= target`` (``sigma_of`` falling in k),
    by doubling then bisection; None when even ``most`` misses it."""
    lo, hi = 0, 1
    while sigma_of(hi) > target:
        if hi >= most:
            return None
        lo, hi = hi, min(most, 2 * hi)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if sigma_of(mid) <= target else (mid, hi)
    return hi


def _least_sway(req: PlanRequest, plan: scenarios.TurntablePlan):
    """The shortest sway (the best of the table's sway axes, :func:`sway_shape`) whose delay sigma,
    with ``plan``'s turntable record, reaches ``req.target_delay_sigma_us``: ``(sway, evaluations)``,
    or ``(None, evaluations)``.

    As :func:`_least_cycles`: with one bias per record the information is ``A + k B`` in the
    periods k, so two evaluations and a bisection find the least k; the fit's bias windows are
    then checked and the sway lengthened until it reaches the sigma."""
    assert req.target_delay_sigma_us is not None  # asked for a sway (design_plan)
    target = req.target_delay_sigma_us * 1e-6
    amplitude, period = sway_shape(req.table)
    turntable = _plan_record(plan)
    best, evals = None, 0
    # the sway is a record of its own, which calibrate reads whole: at most MAX_PLAN_S long
    most = min(MAX_SWAY_PERIODS, int(math.floor((MAX_PLAN_S - SWAY_LEAD_IN_S) / period + 1e-9)))
    for axis in req.table.sway_axes:
        (names, one), (_, two) = (
            _fisher(plan, req.noise_ug_per_sqrt_hz, None, _sway(axis, amplitude, period, k), turntable) for k in (1, 2)
        )
        evals += 2
        step, start, j = two - one, 2 * one - two, names.index("accel_delay")

        def delay_sigma(k, names=names, start=start, step=step, j=j):  # bound now: called in this pass
            try:
                return float(_sigmas(names, start + k * step, plan.axes)[j])
            except np.linalg.LinAlgError:
                return math.inf

        hi = _least_count(delay_sigma, target, most)
        while hi is not None:
            names_w, fisher = _fisher(
                plan, req.noise_ug_per_sqrt_hz, "fit", _sway(axis, amplitude, period, hi), turntable
            )
            evals += 1
            sigma = float(_sigmas(names_w, fisher, plan.axes)[names_w.index("accel_delay")])
            if sigma <= target:
                if best is None or hi < best[1]:
                    best = (_sway(axis, amplitude, period, hi), hi)
                break
            if hi >= most:
                break
            hi = min(most, hi + max(1, math.ceil(hi * ((sigma / target) ** 2 - 1))))
    return (best[0] if best else None), evals


def _spin_s(rate_dps: float, accel_dps2: float, ramp_s: float) -> float:
    """Seconds of one change of rate from rest to the peak (as :meth:`TurntablePlan.check` counts it)."""
    return max(rate_dps / accel_dps2, ramp_s) + ramp_s


def _shape(req: PlanRequest, shape: tuple, seconds_per_axis: float, cycles: int):
    """The candidate plan of ``shape`` = (rate, acceleration, lead-in, dwell), or None when its
    cycles leave no time at the peak rate."""
    t = req.table
    rate, accel, static_s, dwell_s = shape
    plan = scenarios.TurntablePlan(
        axes=t.axes,
        static_s=static_s,
        seconds_per_axis=float(seconds_per_axis),
        cycles=int(cycles),
        peak_rate_dps=float(rate),
        accel_dps2=float(accel),
        dwell_s=float(dwell_s),
        reposition_s=t.reposition_s,
        settle_s=t.settle_s,
    )
    try:
        plan.check()
    except ConfigError:
        return None
    return plan


def _overhead_s(req: PlanRequest, static_s: float) -> float:
    t = req.table
    return scenarios.TurntablePlan(
        axes=t.axes, static_s=static_s, reposition_s=t.reposition_s, settle_s=t.settle_s
    ).overhead_s


def _shapes(req: PlanRequest) -> list:
    t = req.table
    leads = LEAD_IN_S if req.static_s is None else (req.static_s,)
    return [
        (f_r * t.max_rate_dps, f_a * t.max_accel_dps2, lead, dwell)
        for f_r in RATE_FRACTIONS
        for f_a in ACCEL_FRACTIONS
        for lead in leads
        for dwell in DWELL_S
    ]


def _one_bias_per_channel(fisher: np.ndarray, names: list) -> np.ndarray:
    """``fisher`` with one accelerometer bias per channel instead of one per window and channel (each
    channel's window columns summed: their parameters made one); the other parameters keep their
    order, the three biases come last."""
    groups = [[j] for j, n in enumerate(names) if not n.startswith("bias_")]
    groups += [[j for j, n in enumerate(names) if n.startswith(f"bias_{a} (")] for a in "xyz"]
    merge = np.zeros((len(names), len(groups)))
    for k, columns in enumerate(groups):
        merge[columns, k] = 1.0
    return merge.T @ fisher @ merge


def _arm_sigmas(info: np.ndarray) -> np.ndarray:
    """The arms' standard errors [9] from an information whose first 9 parameters are the arms."""
    scale = 1.0 / np.sqrt(np.diag(info))
    return np.sqrt(np.diag(np.linalg.inv(info * np.outer(scale, scale)))[:9]) * scale[:9]


def _repeated_sigma(req: PlanRequest, block: scenarios.TurntablePlan, repeats: int, fixed: dict) -> float:
    """The largest arm sigma [mm] of ``block`` with its rotations about each axis repeated ``repeats``
    times (the same cycles, ``repeats`` times as many): the screening of a long budget's candidates.

    With one bias per channel the information is a sum over the plan's parts: those outside the
    rotations (the lead-in at rest, the turns between the axes: the same for every candidate with
    this lead-in, kept in ``fixed``) and each axis's identical cycles, so with ``I(k)`` the
    information with the rotations k times, ``I(k) = k I(1) - (k - 1) F`` and ``F = 2 I(1) - I(2)``
    (exact: tests/test_consistent_inputs.py). The fit's bias windows, which straddle the parts, are
    not additive; what they cost each arm is measured on the block (its sigma with the windows over
    its sigma with one bias per channel) and carried over to the repeated plan, whose windows see
    the same cycles. The :data:`FINALISTS` are then evaluated whole."""
    names, fisher = _fisher(block, req.noise_ug_per_sqrt_hz)
    windowed = _sigmas(names, fisher, block.axes)[:9]  # a PlanError naming what the axes leave unobservable
    one = _one_bias_per_channel(fisher, names)
    with np.errstate(invalid="ignore", divide="ignore"):
        try:
            if block.static_s not in fixed:
                twice = replace(block, seconds_per_axis=2 * block.seconds_per_axis, cycles=2 * block.cycles)
                fixed[block.static_s] = 2 * one - _one_bias_per_channel(*_fisher(twice, req.noise_ug_per_sqrt_hz)[::-1])
            repeated = _arm_sigmas(repeats * one - (repeats - 1) * fixed[block.static_s])
            largest = float(np.max(repeated * windowed / _arm_sigmas(one)) * 1e3)
        except np.linalg.LinAlgError:
            return math.inf
    return largest if math.isfinite(largest) else math.inf


def _best_in(req: PlanRequest, budget_s: float, progress, tried: int = 0, sway_s: float = 0.0):
    """The turntable plan with the smallest largest arm sigma in ``budget_s``: ``(plan, prediction, tried)``.

    Up to :data:`BLOCK_MAX_S` per axis every candidate is evaluated on its whole motion; above, the
    candidates are screened (:func:`_repeated_sigma`) and the :data:`FINALISTS` best of each rest
    evaluated."""
    t = req.table
    best = None
    screened: list[tuple[float, int, scenarios.TurntablePlan]] = []
    fixed: dict = {}

    def consider(plan):
        nonlocal best, tried
        pred = predict(plan, req.noise_ug_per_sqrt_hz)
        tried += 1
        if best is None or pred.max_sigma_mm < best[1].max_sigma_mm:
            best = (plan, pred)
        if progress is not None:
            progress(tried)

    for shape in _shapes(req):
        per_axis = (budget_s - _overhead_s(req, shape[2])) / len(t.axes)
        repeats = max(1, math.ceil(per_axis / BLOCK_MAX_S - 1e-9)) if per_axis > 0 else 1
        for cycles in CYCLE_CHOICES if per_axis > 0 else ():
            block = _shape(req, shape, per_axis / repeats, cycles)
            if block is None or cycles * repeats > MAX_CYCLES:
                continue
            if repeats == 1:
                consider(block)
                continue
            whole = replace(block, seconds_per_axis=per_axis, cycles=cycles * repeats)
            screened.append((_repeated_sigma(req, block, repeats, fixed), len(screened), whole))
            tried += 1
            if progress is not None:
                progress(tried)
    for dwell_s in DWELL_S:
        for _, _, whole in sorted(c for c in screened if c[2].dwell_s == dwell_s)[:FINALISTS]:
            consider(whole)
    if best is None:
        leads = LEAD_IN_S if req.static_s is None else (req.static_s,)
        after = f" after the delay's sway ({sway_s:.0f} s)" if sway_s else ""
        raise PlanError(
            f"--budget-s {req.budget_s:g}: too short{after} for one rotation each way about each of "
            f"{len(t.axes)} axes at up to {t.max_rate_dps:g} deg/s and {t.max_accel_dps2:g} deg/s^2, "
            f"with the turns between them ({_overhead_s(req, min(leads)):g} s with the lead-in); "
            "allow more time"
        )
    return best[0], best[1], tried


def _shortest(req: PlanRequest, progress):
    """The shortest turntable plan whose every arm sigma reaches the wanted one: ``(plan, prediction, tried)``.

    Each shape's least cycle count with one bias per channel (:func:`_least_cycles`) is a lower
    bound of its count with the fit's bias windows (more nuisance parameters never make a sigma
    smaller); the shapes are then evaluated with the fit's windows shortest bound first, and a
    shape whose bound is no shorter than the best plan found is not evaluated."""
    bounds: list[tuple[float, int, tuple, float, scenarios.TurntablePlan]] = []
    tried = 0
    for shape in _shapes(req):
        # half a cycle: the changes of rate and the dwells, and cruising CRUISE_FACTORS times as long
        base = 2 * _spin_s(shape[0], shape[1], scenarios.TurntablePlan.ramp_s) + 2 * shape[3]
        for cruise_factor in CRUISE_FACTORS:
            half_s = base * (1.0 + cruise_factor)
            plan, evals = _least_cycles(req, shape, half_s)
            tried += evals
            if plan is not None:
                bounds.append((plan.duration_s, len(bounds), shape, half_s, plan))
            if progress is not None:
                progress(tried)
    best = None
    for bound_s, _, shape, half_s, plan in sorted(bounds):
        if best is not None and bound_s >= best[1].duration_s:
            break
        plan, pred, evals = _lengthened(req, shape, half_s, plan)
        tried += evals
        if plan is not None and (best is None or pred.duration_s < best[1].duration_s):
            best = (plan, pred)
        if progress is not None:
            progress(tried)
    if best is None:
        raise PlanError(
            f"--target-sigma-mm {req.target_sigma_mm:g}: no plan within {MAX_PLAN_S:g} s (the longest calibrate "
            f"reads whole at 1600 Hz) and {MAX_CYCLES} cycles per axis reaches it with "
            f"{req.noise_ug_per_sqrt_hz:g} ug/sqrt(Hz) of noise; allow a larger sigma, or plan several records"
        )
    return best[0], best[1], tried


def _sway_for(req: PlanRequest, plan: scenarios.TurntablePlan):
    """:func:`_least_sway`, or :class:`PlanError` when no sway reaches the wanted delay sigma."""
    sway, evals = _least_sway(req, plan)
    if sway is None:
        amplitude, period = sway_shape(req.table)
        raise PlanError(
            f"--delay-sigma-us {req.target_delay_sigma_us:g}: no sway within {MAX_PLAN_S:g} s (the longest "
            f"calibrate reads whole at 1600 Hz; {amplitude:g} deg/s, {period:g} s periods) reaches it with {req.noise_ug_per_sqrt_hz:g} ug/sqrt(Hz) "
            "of noise; allow a larger sigma"
        )
    return sway, evals


def design_plan(req: PlanRequest, *, progress=None) -> PlanDesign:
    """The plan that answers ``req`` (see the module), with the paper's plan beside it.

    With a wanted delay sigma the sway is designed against the turntable plan (the delay hardly
    depends on which): with a budget, first against the best plan in the whole budget, then the
    turntable plan is designed again in what the sway leaves, and the sway checked on it."""
    req = req.check()
    t = req.table
    sway = None
    if req.budget_s is not None:
        plan, pred, tried = _best_in(req, req.budget_s, progress)
        if req.target_delay_sigma_us is not None:
            sway, evals = _sway_for(req, plan)
            sway_s = sway.duration_s
            plan, pred, tried = _best_in(req, req.budget_s - sway_s, progress, tried + evals, sway_s)
            sway, evals = _sway_for(req, plan)
            tried += evals
            if plan.duration_s + sway.duration_s > req.budget_s + 1e-6:
                raise PlanError(
                    f"--budget-s {req.budget_s:g}: too short for the turntable plan and the delay's sway "
                    f"({sway.duration_s:.0f} s for --delay-sigma-us {req.target_delay_sigma_us:g}); "
                    "allow more time or a larger delay sigma"
                )
    else:
        plan, pred, tried = _shortest(req, progress)
        if req.target_delay_sigma_us is not None:
            sway, evals = _sway_for(req, plan)
            tried += evals
    if sway is not None:
        pred = predict(plan, req.noise_ug_per_sqrt_hz, sway)
    paper_plan = replace(scenarios.TurntablePlan(), reposition_s=t.reposition_s, settle_s=t.settle_s)
    paper = None
    if (
        set(paper_plan.axes) <= set(t.axes)
        and paper_plan.peak_rate_dps <= t.max_rate_dps
        and paper_plan.accel_dps2 <= t.max_accel_dps2
    ):
        paper = predict(paper_plan, req.noise_ug_per_sqrt_hz)
    return PlanDesign(plan, pred, req, paper, paper_plan if paper else None, tried, sway)


def _most_cycles(req: PlanRequest, shape: tuple, half_s: float) -> int:
    """The most cycles (each ``2 half_s`` long) per axis of a plan within :data:`MAX_PLAN_S` and :data:`MAX_CYCLES`."""
    room = MAX_PLAN_S - _overhead_s(req, shape[2])
    return min(MAX_CYCLES, int(math.floor(room / (len(req.table.axes) * 2 * half_s) + 1e-9)))


def _least_cycles(req: PlanRequest, shape: tuple, half_s: float):
    """The fewest cycles (each ``2 half_s`` long) per axis whose plan reaches the wanted sigma with
    one bias per channel: ``(plan, evaluations)``, or ``(None, evaluations)`` when no plan within
    :func:`_most_cycles` does.

    With one bias per channel the information is a sum over identical cycles, ``I(c) = A + c B``
    (``B = I(2) - I(1)``), so two evaluations give every cycle count's sigma and a bisection finds
    the least (:func:`_lengthened` then checks it with the fit's bias windows).
    """
    target = req.target_sigma_mm
    assert target is not None  # the shortest plan is searched for a wanted sigma (design_plan)
    most = _most_cycles(req, shape, half_s)
    plans = [_shape(req, shape, 2 * half_s * c, c) for c in (1, 2)]
    if plans[0] is None or most < 1:
        return None, 0
    (names, one), (_, two) = (_fisher(p, req.noise_ug_per_sqrt_hz, bias_window_s=None) for p in plans)
    step, start = two - one, 2 * one - two

    def largest_mm(c):
        try:
            return float(_sigmas(names, start + c * step, plans[0].axes)[:9].max() * 1e3)
        except np.linalg.LinAlgError:
            return math.inf

    hi = _least_count(largest_mm, target, most)
    return (None if hi is None else _shape(req, shape, 2 * half_s * hi, hi)), 2


def _lengthened(req: PlanRequest, shape: tuple, half_s: float, plan: scenarios.TurntablePlan):
    """``plan`` (from :func:`_least_cycles`) evaluated with the fit's bias windows, which give up a
    little of the information, and lengthened until it reaches the wanted sigma:
    ``(plan, prediction, evaluations)``, or ``(None, None, evaluations)`` past :func:`_most_cycles`."""
    target = req.target_sigma_mm
    assert target is not None  # the shortest plan is searched for a wanted sigma (design_plan)
    most, hi, evals = _most_cycles(req, shape, half_s), plan.cycles, 0
    while True:
        plan = _shape(req, shape, 2 * half_s * hi, hi)
        pred = predict(plan, req.noise_ug_per_sqrt_hz)
        evals += 1
        if pred.max_sigma_mm <= target:
            return plan, pred, evals
        if hi >= most:
            return None, None, evals
        hi = min(most, hi + max(1, math.ceil(hi * ((pred.max_sigma_mm / target) ** 2 - 1))))


def plan_document(design: PlanDesign) -> dict:
    """The ``sizefx/plan/1`` document: what ``sizefx simulate turntable --plan`` (and ``sizefx simulate
    sway --plan``, the delay's sway) runs, with the request and the prediction it was designed with."""
    p, pred, req = design.plan, design.prediction, design.request
    doc = {
        "schema": PLAN_SCHEMA,
        "turntable": {k: v for k, v in asdict(p).items()},
        "designed_for": {
            "noise_ug_per_sqrt_hz": req.noise_ug_per_sqrt_hz,
            "objective": "min-sigma" if req.budget_s is not None else "least-time",
            **({"budget_s": req.budget_s} if req.budget_s is not None else {"target_sigma_mm": req.target_sigma_mm}),
            **({"target_delay_sigma_us": req.target_delay_sigma_us} if req.target_delay_sigma_us is not None else {}),
            "table": asdict(req.table),
        },
        "prediction": {
            "duration_s": pred.duration_s,
            "max_sigma_mm": pred.max_sigma_mm,
            "sigma_mm": (pred.sigma_arms_m * 1e3).tolist(),
            "sigma_tilt_arcsec": (pred.sigma_tilt_rad / ARCSEC).tolist(),
            "arms": PARAMS_R,
            **({"sigma_delay_us": pred.sigma_delay_s * 1e6} if pred.sigma_delay_s is not None else {}),
        },
    }
    if design.sway is not None:
        w = design.sway
        doc["sway"] = {
            "axis": w.axis,
            "amplitude_dps": w.amplitudes_dps[0],
            "frequency_hz": w.frequency_hz,
            "static_s": w.static_s,
            "segment_s": w.segment_s,
        }
    if design.paper is not None:
        doc["paper_plan"] = {"duration_s": design.paper.duration_s, "max_sigma_mm": design.paper.max_sigma_mm}
    check_document(doc, PLAN_SCHEMA)
    return doc


def report_lines(design: PlanDesign) -> list[str]:
    """What ``sizefx plan`` prints."""
    p, pred, req = design.plan, design.prediction, design.request
    goal = (
        f"the smallest largest arm sigma in {req.budget_s:g} s"
        if req.budget_s is not None
        else f"the shortest plan with every arm sigma <= {req.target_sigma_mm:g} mm"
    )
    if req.target_delay_sigma_us is not None:
        goal += f" and the delay's <= {req.target_delay_sigma_us:g} us"
    lines = [
        f"plan for {goal}; noise {req.noise_ug_per_sqrt_hz:g} ug/sqrt(Hz); table up to "
        f"{req.table.max_rate_dps:g} deg/s, {req.table.max_accel_dps2:g} deg/s^2, axes {req.table.axes} "
        f"({design.tried} plans evaluated)",
        f"  axes {p.axes}: {p.cycles} cycles in {p.seconds_per_axis:.1f} s per axis at {p.peak_rate_dps:g} deg/s, "
        f"{p.accel_dps2:g} deg/s^2, resting {p.dwell_s:g} s between rotations; lead-in {p.static_s:g} s; "
        f"{p.duration_s:.0f} s" + (" in all" if design.sway is None else ""),
        "  predicted sigma [mm] (rows r_x, r_y, r_z; columns x, y, z):",
    ]
    for i, a in enumerate("xyz"):
        lines.append(f"    r_{a}  " + " ".join(f"{v * 1e3:8.4f}" for v in pred.sigma_arms_m[i]))
    lines.append(
        f"  largest {pred.max_sigma_mm:.4f} mm; tilt sigma {pred.sigma_tilt_rad[0] / ARCSEC:.3f}, "
        f"{pred.sigma_tilt_rad[1] / ARCSEC:.3f} arcsec"
    )
    if design.sway is not None:
        w = design.sway
        assert pred.sigma_delay_s is not None  # predicted with the sway (design_plan)
        lines.append(
            f"  delay sway, a record of its own: {w.axis} at {w.amplitudes_dps[0]:g} deg/s, {w.frequency_hz:.4g} Hz "
            f"(+-{w.amplitudes_dps[0] / (2 * math.pi * w.frequency_hz):.1f} deg) for {w.segment_s:g} s after "
            f"{w.static_s:g} s at rest; delay sigma {pred.sigma_delay_s * 1e6:.3f} us "
            f"(wanted {req.target_delay_sigma_us:g}); {w.duration_s:.0f} s of the {pred.duration_s:.0f} s"
        )
    if design.paper is not None:
        assert design.paper_plan is not None  # given with the paper's prediction (design_plan)
        lines.append(
            f"  the paper's plan ({design.paper_plan.axes}, {design.paper_plan.cycles} cycles, "
            f"{design.paper_plan.seconds_per_axis:g} s per axis): {design.paper.duration_s:.0f} s, largest "
            f"sigma {design.paper.max_sigma_mm:.4f} mm"
        )
    return lines


@dataclass(frozen=True)
class PlanConfig:
    """``sizefx plan``: the request and the plan file to write (``-o``, ``sizefx/plan/1``)."""

    request: PlanRequest
    output: str | None = None
    force: bool = False

    def inputs(self) -> dict:
        return {}

    def outputs(self) -> dict:
        return {"-o": self.output}


@dataclass
class PlanResult:
    """The plan designed (:attr:`design`) and the file written (:attr:`written`)."""

    design: PlanDesign
    written: dict = field(default_factory=dict)

    def report(self) -> str:
        lines = report_lines(self.design)
        if "-o" in self.written:
            lines.append(f"plan -> {self.written['-o']}")
        return "\n".join(lines)

    def to_json(self) -> dict:
        return {"plan": plan_document(self.design), "written": dict(self.written)}


def run(config: PlanConfig, *, progress=None) -> PlanResult:
    """The ``plan`` stage: the request checked, the output's pre-flight, the search, the file."""
    from .io.toml import write_toml
    from .stage import preflight

    request = config.request.check()
    preflight(inputs=config.inputs(), outputs=config.outputs(), force=config.force)
    out = PlanResult(design_plan(request, progress=progress))
    if config.output:
        write_toml(
            config.output,
            plan_document(out.design),
            force=config.force,
            header="sizefx plan: a turntable calibration plan\n"
            "run it with: sizefx simulate turntable --plan THIS_FILE -o turntable.h5"
            + (
                "\nand its delay sway with: sizefx simulate sway --plan THIS_FILE -o sway.h5"
                if out.design.sway is not None
                else ""
            ),
        )
        out.written["-o"] = str(config.output)
    return out
