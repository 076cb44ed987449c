"""The search for the turntable plan: over the shapes the table's limits leave free (the rate, the
acceleration, the lead-in, the rests) and the cycles per axis, the plan with the smallest largest arm
sigma in a time budget (:func:`_best_in`), or the shortest plan that reaches a wanted sigma
(:func:`_shortest`)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from .. import scenarios
from ..constants import MAX_PLAN_S
from ..errors import ConfigError
from .fisher import _fisher, _sigmas, predict
from .request import PlanError, PlanRequest

__all__ = [
    "RATE_FRACTIONS",
    "ACCEL_FRACTIONS",
    "LEAD_IN_S",
    "CRUISE_FACTORS",
    "DWELL_S",
    "CYCLE_CHOICES",
    "MAX_CYCLES",
    "BLOCK_MAX_S",
    "FINALISTS",
]

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
