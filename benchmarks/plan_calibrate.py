"""Plans designed by ``sizefx plan``: their predicted sigmas confirmed by simulation.

    python benchmarks/plan_calibrate.py [--seeds 60] [--jobs 2] [--json out.json] [--record] [--only-delay]

1. The paper's plan (YXZ, 5 cycles, 2 min per axis, 20 deg/s, 10 deg/s^2) and its predicted largest
   arm sigma at 2.96 ug/sqrt(Hz) of white noise.
2. The shortest plan that reaches the same largest sigma on the same table, and on a faster table
   (100 deg/s, 50 deg/s^2); the best plan in half the paper's time. Each with its design time.
3. Monte Carlo of the paper's plan and of the designed plan (seeds simulated at 1600 Hz, white
   noise of that density, fitted by ``joint_fit``): per arm component, the scatter across seeds
   against the prediction, and the pooled ratio (target: within 15 %), and the fit's stated sigma
   against the prediction.
4. The delay's sway: the shortest plan to the paper's arm sigma and a 1 us delay sigma on the
   paper's table swinging about X and Y; Monte Carlo of its turntable and sway records with a
   0.5 ms delay, fitted with the delay: the delay's scatter and stated sigma against the prediction,
   its mean z, and the arms' pooled ratio.
"""

from __future__ import annotations

import argparse
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

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _measure import add_output_options, emit  # (a sibling of this script)

NOISE_UG = 2.96
#: The prediction's noise: white, no bias random walk (its 2 ug/sqrt(h) adds ~1 % over these plans).
EFFECTS = {
    "lever_arm": {"preset": "compact", "r_vehicle_m": [0.10, -0.05, 0.02]},
    "accel_noise": {"density_ug_per_sqrt_hz": NOISE_UG, "bias_rw_ug_per_sqrt_h": 0.0},
}


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
    print(
        f"\n{name}: {plan.axes}, {plan.cycles} cycles x {plan.seconds_per_axis:.1f} s at {plan.peak_rate_dps:g} deg/s, "
        f"{plan.accel_dps2:g} deg/s^2, lead-in {plan.static_s:g} s, {plan.duration_s:.0f} s; {seeds} seeds"
    )
    print("  component     predicted   scatter  ratio   stated/predicted")
    for j, n in enumerate(f"r_{a}[{c}]" for a in "xyz" for c in "xyz"):
        print(f"  {n:10s}  {p[j] * 1e3:10.4f} {scatter[j] * 1e3:9.4f}  {ratio[j]:5.2f}   {stated[j] / p[j]:6.3f}")
    se = 1 / np.sqrt(2 * (seeds - 1))
    print(
        f"  pooled scatter / predicted {pooled:.3f} (its own standard error {se / 3:.3f}); per component "
        f"{ratio.min():.2f}..{ratio.max():.2f} (each +- {se:.2f}); stated / predicted "
        f"{(stated / p).min():.3f}..{(stated / p).max():.3f}"
    )
    return {
        "plan": asdict(plan),
        "duration_s": plan.duration_s,
        "predicted_mm": (p * 1e3).tolist(),
        "scatter_mm": (scatter * 1e3).tolist(),
        "ratio": ratio.tolist(),
        "pooled_ratio": pooled,
        "stated_over_predicted": (stated / p).tolist(),
        "seeds": seeds,
    }


DELAY_S = 0.5e-3


def one_delay_seed(job):
    plan_dict, sway_dict, seed = job
    fx = load_effects(overrides={**EFFECTS, "accel_delay": {"enabled": True, "tau_s": DELAY_S}})
    records = [
        prepare(
            simulate_in_memory(
                scenarios.turntable(scenarios.TurntablePlan(**plan_dict))[0], fx, form="rates", seed=seed
            ),
            "turntable",
        ),
        prepare(
            simulate_in_memory(
                scenarios.sway(scenarios.SwayPlan(**sway_dict))[0], fx, form="rates", seed=seed + 1_000_000
            ),
            "sway",
        ),
    ]
    res = joint_fit(records, with_delay=True)
    return (
        (res.arms - fx.arms_total_m()).ravel().tolist(),
        res.sigma_arms.ravel().tolist(),
        res.delay_s - DELAY_S,
        res.sigma_delay_s,
    )


def confirm_delay(design, seeds, jobs, seed0):
    plan, sway, pred = design.plan, design.sway, design.prediction
    with ProcessPoolExecutor(max_workers=jobs) as pool:
        rows = list(pool.map(one_delay_seed, [(asdict(plan), asdict(sway), seed0 + s) for s in range(seeds)]))
    err_arms = np.array([r[0] for r in rows])
    err = np.array([r[2] for r in rows])
    stated = float(np.mean([r[3] for r in rows]))
    scatter = float(err.std(ddof=1))
    arms_ratio = err_arms.std(axis=0, ddof=1) / pred.sigma_arms_m.ravel()
    pooled = float(np.sqrt(np.mean(arms_ratio**2)))
    se = 1 / np.sqrt(2 * (seeds - 1))
    mean_z = float(np.mean(err / np.array([r[3] for r in rows])))
    print(
        f"\ndelay's sway ({sway.axis}, {sway.amplitudes_dps[0]:g} deg/s at {sway.frequency_hz:.4g} Hz for "
        f"{sway.segment_s:g} s) with the plan above; {DELAY_S * 1e3:g} ms delay; {seeds} seeds"
    )
    print(
        f"  delay: predicted {pred.sigma_delay_s * 1e6:.3f} us, scatter {scatter * 1e6:.3f} us (ratio "
        f"{scatter / pred.sigma_delay_s:.3f} +- {se:.2f}), stated / predicted {stated / pred.sigma_delay_s:.3f}, "
        f"mean z {mean_z:+.2f} (+- {1 / np.sqrt(seeds):.2f})"
    )
    print(
        f"  arms: pooled scatter / predicted {pooled:.3f} (+- {se / 3:.3f}); per component "
        f"{arms_ratio.min():.2f}..{arms_ratio.max():.2f}"
    )
    return {
        "plan": asdict(plan),
        "sway": asdict(sway),
        "duration_s": pred.duration_s,
        "predicted_delay_us": pred.sigma_delay_s * 1e6,
        "scatter_delay_us": scatter * 1e6,
        "ratio": scatter / pred.sigma_delay_s,
        "stated_over_predicted": stated / pred.sigma_delay_s,
        "mean_z": mean_z,
        "arms_pooled_ratio": pooled,
        "seeds": seeds,
    }


def designed(label, req):
    t0 = time.perf_counter()
    d = design_plan(req)
    wall = time.perf_counter() - t0
    p = d.plan
    print(
        f"{label}: {p.axes}, {p.cycles} cycles x {p.seconds_per_axis:.1f} s at {p.peak_rate_dps:g} deg/s, "
        f"{p.accel_dps2:g} deg/s^2, dwell {p.dwell_s:g} s, lead-in {p.static_s:g} s: {d.prediction.duration_s:.0f} s, "
        f"largest sigma {d.prediction.max_sigma_mm:.4f} mm ({d.tried} plans, designed in {wall:.1f} s)"
    )
    return d, wall


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=60)
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    add_output_options(ap)
    ap.add_argument("--only-delay", action="store_true", help="confirm only the delay's sway (item 4)")
    args = ap.parse_args(argv)
    t_start = time.perf_counter()
    paper = scenarios.TurntablePlan()
    paper_pred = predict(paper, NOISE_UG)
    target = paper_pred.max_sigma_mm
    print(f"paper's plan: {paper.duration_s:.0f} s, largest predicted sigma {target:.4f} mm at {NOISE_UG} ug/sqrt(Hz)")
    out = {
        "noise_ug_per_sqrt_hz": NOISE_UG,
        "paper": {"duration_s": paper.duration_s, "max_sigma_mm": target},
        "designs": {},
        "confirm": {},
    }
    if not args.only_delay:
        same_table, t1 = designed(
            "shortest plan to the paper's sigma, paper's table (20 deg/s, 10 deg/s^2)",
            PlanRequest(NOISE_UG, TableLimits(), target_sigma_mm=target),
        )
        fast_table, t2 = designed(
            "shortest plan to the paper's sigma, 100 deg/s, 50 deg/s^2 table",
            PlanRequest(NOISE_UG, TableLimits(100.0, 50.0), target_sigma_mm=target),
        )
        half, t3 = designed(
            "best plan in half the paper's time, paper's table",
            PlanRequest(NOISE_UG, TableLimits(), budget_s=paper.duration_s / 2),
        )
        same_time, t5 = designed(
            "best plan in the paper's time, paper's table",
            PlanRequest(NOISE_UG, TableLimits(), budget_s=paper.duration_s),
        )
        out["designs"] = {
            k: {
                "plan": asdict(d.plan),
                "duration_s": d.prediction.duration_s,
                "max_sigma_mm": d.prediction.max_sigma_mm,
                "design_s": w,
                "plans_evaluated": d.tried,
                "shorter_than_paper": 1 - d.prediction.duration_s / paper.duration_s,
                "sigma_below_paper": 1 - d.prediction.max_sigma_mm / target,
            }
            for k, (d, w) in {
                "paper_table": (same_table, t1),
                "fast_table": (fast_table, t2),
                "half_time": (half, t3),
                "paper_time": (same_time, t5),
            }.items()
        }
        for k, d in (("paper_table", same_table), ("fast_table", fast_table)):
            print(
                f"  {k}: {d.prediction.duration_s:.0f} s against the paper's {paper.duration_s:.0f} s "
                f"({1 - d.prediction.duration_s / paper.duration_s:.0%} shorter)"
            )
    with_delay, t4 = designed(
        "shortest plan to the paper's sigma and a 1 us delay sigma, paper's table swinging about X and Y",
        PlanRequest(NOISE_UG, TableLimits(sway_axes="XY"), target_sigma_mm=target, target_delay_sigma_us=1.0),
    )
    w = with_delay.sway
    print(
        f"  delay sway: {w.axis} at {w.amplitudes_dps[0]:g} deg/s, {w.frequency_hz:.4g} Hz for {w.segment_s:g} s "
        f"after {w.static_s:g} s; predicted delay sigma {with_delay.prediction.sigma_delay_s * 1e6:.3f} us; "
        f"{with_delay.prediction.duration_s:.0f} s in all"
    )
    out["designs"]["with_delay"] = {
        "plan": asdict(with_delay.plan),
        "sway": asdict(w),
        "duration_s": with_delay.prediction.duration_s,
        "sigma_delay_us": with_delay.prediction.sigma_delay_s * 1e6,
        "design_s": t4,
        "plans_evaluated": with_delay.tried,
    }
    if not args.only_delay:
        out["confirm"]["paper"] = confirm("paper's plan", paper, args.seeds, args.jobs, 300_000)
        out["confirm"]["designed"] = confirm(
            "designed plan (fast table)", fast_table.plan, args.seeds, args.jobs, 400_000
        )
    out["confirm"]["delay"] = confirm_delay(with_delay, args.seeds, args.jobs, 500_000)
    print(f"\ntotal {time.perf_counter() - t_start:.0f} s")
    return emit(out, args, __file__, argv, threads=args.jobs, show=False)


if __name__ == "__main__":
    sys.exit(main())
