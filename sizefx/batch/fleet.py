"""Across the records of a batch: each record's headline figures side by side, and calibrations of
one unit combined. The figures themselves (:func:`headline`, :func:`table_figures`,
:data:`KEY_FIGURES`) are :mod:`sizefx.runs.figures`'s, a chain's as well; their names are imported
here too.

A campaign calibrates one unit many times; the runs should agree within their standard errors.
:func:`combine_arms` gives the inverse-variance weighted arms with their standard error and the
consistency test (chi^2 per degree of freedom, per component), and names the runs that disagree
(|z| > :data:`DISAGREE_Z` on any component against the combination of the others).
"""

from __future__ import annotations

from pathlib import Path

from ..io.files import atomic_output
from ..runs.figures import KEY_FIGURES, headline, table_figures

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
