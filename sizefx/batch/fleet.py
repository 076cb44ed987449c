"""Across the records of a batch: the figures side by side, and calibrations of one unit combined.

A campaign calibrates one unit many times; the runs should agree within their standard errors.
:func:`combine_arms` gives the inverse-variance weighted arms with their standard error and the
consistency test (chi^2 per degree of freedom, per component), and names the runs that disagree
(|z| > :data:`DISAGREE_Z` on any component against the combination of the others).
"""

from __future__ import annotations

import numpy as np

__all__ = ["combine_arms", "DISAGREE_Z", "KEY_FIGURES"]

#: A run disagrees with the rest when one of its arm components is this many standard errors
#: (its own and the rest's combined) from the rest's combination: 3.3 sigma is a 0.1 % two-sided
#: chance per component for a consistent run, about 1 % over nine components.
DISAGREE_Z = 3.3

#: The figures the batch report prints per record (the manifest keeps every headline figure).
KEY_FIGURES = {"navigate": ("final_horizontal_error_m", "max_horizontal_error_m", "drift_nmi_per_h"),
               "inspect": ("samples", "duration_s", "sample_rate_hz"),
               "compensate": ("samples",),
               "calibrate": ("accel_delay_s",),
               "diagnose": ("effects", "warnings", "unexplained")}


def _weighted(values, sigmas):
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
    return {"arms_m": mean.tolist(), "sigma_m": sigma.tolist(), "chi2_dof": chi2_dof.tolist(),
            "runs": len(runs), "disagree": disagree}
