"""Across the records of a batch: each record's headline figures (:func:`headline`, also the
chain's), side by side, and calibrations of one unit combined.

A campaign calibrates one unit many times; the runs should agree within their standard errors.
:func:`combine_arms` gives the inverse-variance weighted arms with their standard error and the
consistency test (chi^2 per degree of freedom, per component), and names the runs that disagree
(|z| > :data:`DISAGREE_Z` on any component against the combination of the others).
"""

from __future__ import annotations

from pathlib import Path

from ..io.files import atomic_output
from ..io.schema import as_json

__all__ = [
    "headline",
    "table_figures",
    "recurring_findings",
    "combine_arms",
    "plot_fleet",
    "DISAGREE_Z",
    "KEY_FIGURES",
    "FLEET_PLOT",
]

#: The figure of the headline figures across the records (``sizefx batch ... --with-plots``).
FLEET_PLOT = "fleet.png"

#: A run disagrees with the rest when one of its arm components is this many standard errors
#: (its own and the rest's combined) from the rest's combination: 3.3 sigma is a 0.1 % two-sided
#: chance per component for a consistent run, about 1 % over nine components.
DISAGREE_Z = 3.3

#: The figures the batch report prints per record (the manifest keeps every headline figure).
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
    """A few figures of a record's result for the manifest and the fleet table: the scalars at the top
    of its JSON, and per stage the ones that matter (navigation error, arms, findings)."""
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


def recurring_findings(entries: list[dict]) -> list[tuple[str, int]]:
    """diagnose's findings (effect and channel) that more than one successful record reports, with
    how many, the most frequent first."""
    counts: dict[str, int] = {}
    for e in entries:
        if e["status"] == "ok":
            for finding in set(e.get("headline", {}).get("effects", [])):
                counts[finding] = counts.get(finding, 0) + 1
    return sorted(((f, n) for f, n in counts.items() if n > 1), key=lambda fn: (-fn[1], fn[0]))


def _weighted(values, sigmas):
    import numpy as np

    w = 1.0 / sigmas**2
    mean = (w * values).sum(axis=0) / w.sum(axis=0)
    return mean, 1.0 / np.sqrt(w.sum(axis=0))


def combine_arms(entries: list[dict]) -> dict | None:
    """The calibrate records' arms combined: ``{"arms_m", "sigma_m", "chi2_dof", "runs", "disagree"}``
    (None with fewer than two successful runs). ``disagree``: ``[(name, largest |z|)]`` of the runs
    whose arms differ from the other runs' combination by more than :data:`DISAGREE_Z`."""
    runs = [e for e in entries if e["status"] == "ok" and "r_x_m" in e.get("headline", {})]
    if len(runs) < 2:
        return None
    import numpy as np  # here: a batch that combines nothing (a re-run of any other stage) never loads it

    r = np.array([[e["headline"][f"r_{a}_m"] for a in "xyz"] for e in runs])  # [n, 3, 3]
    s = np.array([[e["headline"][f"sigma_{a}_m"] for a in "xyz"] for e in runs])
    mean, sigma = _weighted(r, s)
    chi2_dof = (((r - mean) / s) ** 2).sum(axis=0) / (len(runs) - 1)
    disagree = []
    for k, e in enumerate(runs):
        others = [j for j in range(len(runs)) if j != k]
        m, sm = _weighted(r[others], s[others])
        z = np.abs(r[k] - m) / np.sqrt(s[k] ** 2 + sm**2)
        if z.max() > DISAGREE_Z:
            disagree.append((e["name"], float(z.max())))
    return {
        "arms_m": mean.tolist(),
        "sigma_m": sigma.tolist(),
        "chi2_dof": chi2_dof.tolist(),
        "runs": len(runs),
        "disagree": disagree,
    }


def plot_fleet(stage: str, entries: list[dict], path) -> Path | None:
    """One panel per numeric headline figure of :data:`KEY_FIGURES` (for calibrate: the nine arm
    components with their sigma, the runs' combination as a band), records along x in input order;
    the records that failed or were refused are marked. None when there is nothing to draw."""
    from ..compare.plots import pyplot

    ok = [e for e in entries if e["status"] == "ok"]
    names = [e["name"] for e in entries]
    x = {e["name"]: k for k, e in enumerate(entries)}
    panels = []
    if stage == "calibrate" and any("r_x_m" in e["headline"] for e in ok):
        combined = combine_arms(entries)
        for i, a in enumerate("xyz"):
            for j, c in enumerate("xyz"):
                pts = [
                    (x[e["name"]], e["headline"][f"r_{a}_m"][j] * 1e3, e["headline"][f"sigma_{a}_m"][j] * 1e3)
                    for e in ok
                    if "r_x_m" in e["headline"]
                ]
                band = None if combined is None else (combined["arms_m"][i][j] * 1e3, combined["sigma_m"][i][j] * 1e3)
                panels.append((f"r_{a}[{c}] [mm]", pts, band))
    else:
        for key in KEY_FIGURES.get(stage, ()):
            pts = [
                (x[e["name"]], float(e["headline"][key]), 0.0)
                for e in ok
                if isinstance(e["headline"].get(key), (int, float)) and not isinstance(e["headline"][key], bool)
            ]
            if pts:
                panels.append((key, pts, None))
    if not panels:
        return None
    import numpy as np

    plt = pyplot()
    cols = 3 if len(panels) > 3 else 1
    rows = -(-len(panels) // cols)
    fig, axes = plt.subplots(
        rows, cols, figsize=(4.2 * cols + 2, 2.2 * rows + 1), squeeze=False, sharex=True, constrained_layout=True
    )
    fig.suptitle(f"sizefx batch {stage}: {len(ok)} of {len(entries)} records ok")
    for ax, (label, pts, band) in zip(axes.ravel(), panels):
        k, v, s = (np.array(col, dtype=float) for col in zip(*pts))
        ax.errorbar(k, v, yerr=s if s.any() else None, fmt="o", ms=4, capsize=2)
        if band is not None:
            ax.axhspan(band[0] - band[1], band[0] + band[1], alpha=0.25, label="combined +- sigma")
            ax.axhline(band[0], lw=0.8)
        for e in entries:
            if e["status"] != "ok":
                ax.axvline(x[e["name"]], color="tab:red", lw=0.8, ls=":")
        ax.set_ylabel(label, fontsize=8)
        ax.grid(alpha=0.3)
    for ax in axes.ravel()[len(panels) :]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xticks(range(len(names)), names, rotation=60, ha="right", fontsize=7)
    out = Path(path)
    with atomic_output(out, force=True) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return out
