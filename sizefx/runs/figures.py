"""What a stage's result contributes to the tables above it: its headline figures (:func:`headline`),
which a chain's run.json (:mod:`sizefx.chain`) and a batch's manifest (:mod:`sizefx.batch`) keep per
step and per record, and of those the few a table prints (:func:`table_figures`: a chain's summary,
a batch's fleet table; :data:`KEY_FIGURES` per stage).
"""

from __future__ import annotations

from ..io.schema import as_json

__all__ = ["headline", "table_figures", "KEY_FIGURES"]

#: The figures a table prints per record or step (a batch's report, a chain's summary; the manifest and
#: run.json keep every headline figure).
KEY_FIGURES = {
    "navigate": ("final_horizontal_error_m", "max_horizontal_error_m", "drift_nmi_per_h"),
    "inspect": ("samples", "duration_s", "sample_rate_hz"),
    "compensate": ("samples",),
    "calibrate": ("accel_delay_s",),
    "diagnose": ("effects", "warnings", "unexplained"),
    "compare": ("a_vs_ref_final_horizontal_m", "b_vs_ref_final_horizontal_m", "a_vs_b_max_horizontal_m"),
    "run": ("plain_final_horizontal_error_m", "compensated_final_horizontal_error_m", "a_vs_b_max_horizontal_m"),
}


def headline(stage: str, doc: dict) -> dict:
    """A few figures of a stage's result (``doc``: its ``to_json()``) for a batch's manifest, a chain's
    run.json and their tables: the scalars at the top of its JSON, and per stage the ones that matter
    (navigation error, arms, findings)."""
    out: dict[str, object] = {k: v for k, v in doc.items() if isinstance(v, (int, float)) and not isinstance(v, bool)}
    if stage == "navigate":
        errors = doc.get("errors") or {}
        out.update({k: v for k, v in errors.items() if isinstance(v, (int, float))})
    elif stage == "calibrate":
        levers = doc.get("levers") or {}
        for axis in "xyz":
            if f"r_{axis}" in levers:
                out[f"r_{axis}_m"] = levers[f"r_{axis}"]
                out[f"sigma_{axis}_m"] = levers.get(f"sigma_{axis}")
        if levers.get("accel_delay_s") is not None:
            out["accel_delay_s"] = levers["accel_delay_s"]
    elif stage == "compare":  # per comparison (A vs REF, B vs REF, A vs B): final and largest distance
        for c in doc.get("comparisons", []):
            key = c["label"].lower().replace(" ", "_")
            for stat in ("final", "max"):
                out[f"{key}_{stat}_horizontal_m"] = (c.get("horizontal_m") or {}).get(stat)
    elif stage == "run":  # a chain: each stage's figures, named after its run (plain, compensated)
        for step in doc.get("steps", []):
            prefix = f"{step['run']}_" if step.get("run") else ""
            out.update(
                {
                    f"{prefix}{k}": v
                    for k, v in step.get("headline", {}).items()
                    if isinstance(v, (int, float)) and not isinstance(v, bool)
                }
            )
    elif stage == "diagnose":
        out["effects"] = sorted(
            f"{e.get('id', '?')}" + (f" {e['channel']}" if e.get("channel") else "") for e in doc.get("effects", [])
        )  # sizefx/diagnosis/2: id and channel
        out["warnings"] = len(doc.get("warnings", []))
        out["unexplained"] = len(doc.get("unexplained", []))
    return as_json(out)


def table_figures(stage: str, head: dict) -> dict:
    """The figures the fleet table prints for one record and spreads across the records: the stage's
    :data:`KEY_FIGURES`, and for calibrate the nine arm components [mm] (``r_x[y]_mm``: the y component
    of the x accelerometer's arm)."""
    out = {k: head[k] for k in KEY_FIGURES.get(stage, ()) if head.get(k) is not None}
    if stage == "calibrate" and "r_x_m" in head:
        for a in "xyz":
            for j, b in enumerate("xyz"):
                out[f"r_{a}[{b}]_mm"] = head[f"r_{a}_m"][j] * 1e3
    return out
