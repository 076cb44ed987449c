"""What a design is written as: the ``sizefx/plan/1`` document that ``sizefx simulate`` runs
(:func:`plan_document`) and the lines ``sizefx plan`` prints (:func:`report_lines`)."""

from __future__ import annotations

import math
from dataclasses import asdict

from ..calibrate.joint import PARAMS_R
from ..constants import ARCSEC
from ..io.plan_file import PLAN_SCHEMA
from ..io.schema import check_document
from .request import PlanDesign

__all__ = ["plan_document", "report_lines"]


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
