"""Issue 17, item 4: plans designed by ``sizefx plan``, their predicted sigmas confirmed by simulation.

    python benchmarks/plan_calibrate.py [--seeds 60] [--jobs 2] [--json out.json]

1. The paper's plan (YXZ, 5 cycles, 2 min per axis, 20 deg/s, 10 deg/s^2) and its predicted largest
   arm sigma at 2.96 ug/sqrt(Hz) of white noise.
2. The shortest plan that reaches the same largest sigma on the same table, and on a faster table
   (100 deg/s, 50 deg/s^2); the best plan in half the paper's time. Each with its design time.
3. Monte Carlo of the paper's plan and of the designed plan (seeds simulated at 1600 Hz, white
   noise of that density, fitted by ``joint_fit``): per arm component, the scatter across seeds
   against the prediction, and the pooled ratio (target: within 15 %), and the fit's stated sigma
   against the prediction.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict
from pathlib import Path

import numpy as np

from sizefx import scenarios
from sizefx.calibrate import joint_fit, prepare
from sizefx.effects import load_effects
from sizefx.plan import PlanRequest, TableLimits, design_plan, predict
from sizefx.simulate import simulate_in_memory

NOISE_UG = 2.96
#: The prediction's noise: white, no bias random walk (its 2 ug/sqrt(h) adds ~1 % over these plans).
EFFECTS = {"lever_arm": {"preset": "compact", "r_vehicle_m": [0.10, -0.05, 0.02]},
           "accel_noise": {"density_ug_per_sqrt_hz": NOISE_UG, "bias_rw_ug_per_sqrt_h": 0.0}}


def one_seed(job):
    plan_dict, seed = job
    plan = scenarios.TurntablePlan(**plan_dict)
    fx = load_effects(overrides=EFFECTS)
    res = joint_fit([prepare(simulate_in_memory(scenarios.turntable(plan)[0], fx, form="rates", seed=seed))])
    return (res.arms - fx.arms_total_m()).ravel().tolist(), res.sigma_arms.ravel().tolist()


def confirm(name, plan, seeds, jobs, seed0):
    pred = predict(plan, NOISE_UG)
    with ProcessPoolExecutor(max_workers=jobs) as pool:
        rows = list(pool.map(one_seed, [(asdict(plan), seed0 + s) for s in range(seeds)]))
    err = np.array([r[0] for r in rows])
    stated = np.array([r[1] for r in rows]).mean(axis=0)
    p = pred.sigma_arms_m.ravel()
    scatter = err.std(axis=0, ddof=1)
    ratio = scatter / p
    pooled = float(np.sqrt(np.mean(ratio**2)))
    print(f"\n{name}: {plan.axes}, {plan.cycles} cycles x {plan.seconds_per_axis:.1f} s at {plan.peak_rate_dps:g} deg/s, "
          f"{plan.accel_dps2:g} deg/s^2, lead-in {plan.static_s:g} s, {plan.duration_s:.0f} s; {seeds} seeds")
    print("  component     predicted   scatter  ratio   stated/predicted")
    for j, n in enumerate(f"r_{a}[{c}]" for a in "xyz" for c in "xyz"):
        print(f"  {n:10s}  {p[j] * 1e3:10.4f} {scatter[j] * 1e3:9.4f}  {ratio[j]:5.2f}   {stated[j] / p[j]:6.3f}")
    se = 1 / np.sqrt(2 * (seeds - 1))
    print(f"  pooled scatter / predicted {pooled:.3f} (its own standard error {se / 3:.3f}); per component "
          f"{ratio.min():.2f}..{ratio.max():.2f} (each +- {se:.2f}); stated / predicted "
          f"{(stated / p).min():.3f}..{(stated / p).max():.3f}")
    return {"plan": asdict(plan), "duration_s": plan.duration_s, "predicted_mm": (p * 1e3).tolist(),
            "scatter_mm": (scatter * 1e3).tolist(), "ratio": ratio.tolist(), "pooled_ratio": pooled,
            "stated_over_predicted": (stated / p).tolist(), "seeds": seeds}


def designed(label, req):
    t0 = time.perf_counter()
    d = design_plan(req)
    wall = time.perf_counter() - t0
    p = d.plan
    print(f"{label}: {p.axes}, {p.cycles} cycles x {p.seconds_per_axis:.1f} s at {p.peak_rate_dps:g} deg/s, "
          f"{p.accel_dps2:g} deg/s^2, dwell {p.dwell_s:g} s, lead-in {p.static_s:g} s: {d.prediction.duration_s:.0f} s, "
          f"largest sigma {d.prediction.max_sigma_mm:.4f} mm ({d.tried} plans, designed in {wall:.1f} s)")
    return d, wall


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=60)
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--json", type=Path)
    args = ap.parse_args(argv)
    t_start = time.perf_counter()
    paper = scenarios.TurntablePlan()
    paper_pred = predict(paper, NOISE_UG)
    target = paper_pred.max_sigma_mm
    print(f"paper's plan: {paper.duration_s:.0f} s, largest predicted sigma {target:.4f} mm at {NOISE_UG} ug/sqrt(Hz)")
    same_table, t1 = designed("shortest plan to the paper's sigma, paper's table (20 deg/s, 10 deg/s^2)",
                              PlanRequest(NOISE_UG, TableLimits(), target_sigma_mm=target))
    fast_table, t2 = designed("shortest plan to the paper's sigma, 100 deg/s, 50 deg/s^2 table",
                              PlanRequest(NOISE_UG, TableLimits(100.0, 50.0), target_sigma_mm=target))
    half, t3 = designed("best plan in half the paper's time, paper's table",
                        PlanRequest(NOISE_UG, TableLimits(), budget_s=paper.duration_s / 2))
    out = {"noise_ug_per_sqrt_hz": NOISE_UG, "paper": {"duration_s": paper.duration_s, "max_sigma_mm": target},
           "designs": {k: {"plan": asdict(d.plan), "duration_s": d.prediction.duration_s,
                           "max_sigma_mm": d.prediction.max_sigma_mm, "design_s": w, "plans_evaluated": d.tried}
                       for k, (d, w) in {"paper_table": (same_table, t1), "fast_table": (fast_table, t2),
                                         "half_time": (half, t3)}.items()}}
    for k, d in (("paper_table", same_table), ("fast_table", fast_table)):
        print(f"  {k}: {d.prediction.duration_s:.0f} s against the paper's {paper.duration_s:.0f} s "
              f"({1 - d.prediction.duration_s / paper.duration_s:.0%} shorter)")
    out["confirm"] = {"paper": confirm("paper's plan", paper, args.seeds, args.jobs, 300_000),
                      "designed": confirm("designed plan (fast table)", fast_table.plan, args.seeds, args.jobs, 400_000)}
    print(f"\ntotal {time.perf_counter() - t_start:.0f} s")
    if args.json:
        args.json.write_text(json.dumps(out, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
