"""The design: the turntable plan that answers a request (:mod:`.search`), with the delay's sway when one
is wanted (:mod:`.sway`), and the paper's plan predicted beside it (:func:`design_plan`)."""

from __future__ import annotations

from dataclasses import replace

from .. import scenarios
from .fisher import predict
from .request import PlanDesign, PlanError, PlanRequest
from .search import _best_in, _shortest
from .sway import _sway_for

__all__ = ["design_plan"]


def design_plan(req: PlanRequest, *, progress=None) -> PlanDesign:
    """The plan that answers ``req`` (see :mod:`sizefx.plan`), with the paper's plan beside it.

    With a wanted delay sigma the sway is designed against the turntable plan (the delay hardly
    depends on which): with a budget, first against the best plan in the whole budget, then the
    turntable plan is designed again in what the sway leaves, and the sway checked on it."""
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
