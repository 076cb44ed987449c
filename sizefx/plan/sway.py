"""The accelerometers' delay's sway: a level body axis swung harmonically, as fast as the table allows
(:func:`sway_shape`), for the fewest periods whose delay sigma reaches the wanted one
(:func:`_least_sway`); a record of its own, beside the turntable plan's."""

from __future__ import annotations

import math

import numpy as np

from .. import scenarios
from ..constants import MAX_PLAN_S
from .fisher import _fisher, _plan_record, _sigmas
from .request import SWAY_AXES, PlanError, PlanRequest, TableLimits
from .search import _least_count

__all__ = ["sway_shape", "SWAY_MAX_HZ", "SWAY_MAX_ANGLE_DEG", "SWAY_LEAD_IN_S", "MAX_SWAY_PERIODS"]

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
#: The most sway periods a plan may have.
MAX_SWAY_PERIODS = 100_000


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
