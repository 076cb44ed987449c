"""Validation protocol for sizefx calibrate: random geometries, two disjoint seed ranges.

    python benchmarks/validate_calibrate.py --range dev|validation [--draws 50] [--rate-hz 400]
        [--jobs 2] [--json out.json] [--record [LABEL]]

Each draw is its own unit on the paper's turntable plan (rotations about Y, X, Z; 20 deg/s,
10 deg/s^2, 2 min per axis), fitted by the joint fit as ``sizefx calibrate`` fits it:

- **Geometry**: each accelerometer's arm from the triad point in a random direction, 0-60 mm long;
  the triad point off the table's centre by 0-50 mm in a random direction.
- **Table tilt**: north and east each uniform in -20..20 arcsec.
- **Accelerometers**: biases uniform in -100..100 ug per axis; white noise log-uniform in
  2-10 ug/sqrt(Hz); with probability 1/2 each, a first-order Gauss-Markov part (2-10 ug/sqrt(Hz),
  correlation time 0.05-2 s) and a bias random walk of 2-30 ug/sqrt(h) (else the default 2).

Per arm component and for the tilt: ``z = (estimate - truth) / stated sigma`` over the draws: the
mean (target ``|mean z| <= 0.2``) and RMS (target 0.85-1.2), the 95 % interval's coverage, and a
simulation-based-calibration plot (``--plot``: the PIT ``Phi(z)`` of each truth, uniform when the
errors are right); and the efficiency: the Cramer-Rao bound over the achieved error. The bound
here is computed apart from the fit: the Fisher information of the fit's parameters on the plan's
noise-free motion with the draw's true noise, white, Gauss-Markov and walk as drawn
(:func:`sizefx.plan.predict`, what ``sizefx plan`` computes; the rows whitened by the exact model
of that noise, never by anything measured). The fit's own ``bound_sigma`` (the inverse Fisher
information on its rows with the noise spectrum it measured on its residuals) is shown beside it.
The achieved error is the RMS over the draws of ``(estimate - truth) / bound``: 1 when the fit
reaches the bound, the efficiency its inverse (over all draws, and over the white-only draws).

**Two seed ranges, never mixed**: ``--range dev`` (seeds 0, 1, ...) to tune on, ``--range
validation`` (from :data:`_validation.VALIDATION_FIRST_SEED`) to report only.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from sizefx import scenarios
from sizefx.calibrate import PARAMS_R, joint_fit, prepare
from sizefx.constants import ARCSEC
from sizefx.effects import IDEAL, load_effects
from sizefx.plan import predict
from sizefx.simulate import simulate_in_memory

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _measure import add_output_options, emit  # (siblings of this script)
from _validation import RANGES, plot_pit, run_jobs, seeds

NAMES = [*PARAMS_R, "tilt_north", "tilt_east"]


def _direction(rng, n):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def draw(rng) -> tuple[dict, float]:
    """``(effect overrides, white-noise density [ug/sqrt(Hz)])`` of one draw."""
    arms = _direction(rng, 3) * rng.uniform(0.0, 0.060, (3, 1))
    offset = _direction(rng, 1)[0] * rng.uniform(0.0, 0.050)
    tilt = rng.uniform(-20.0, 20.0, 2)
    density = float(np.exp(rng.uniform(np.log(2.0), np.log(10.0))))
    noise = {"enabled": True, "density_ug_per_sqrt_hz": density}
    if rng.random() < 0.5:
        noise |= {
            "markov_density_ug_per_sqrt_hz": float(np.exp(rng.uniform(np.log(2.0), np.log(10.0)))),
            "markov_correlation_s": float(np.exp(rng.uniform(np.log(0.05), np.log(2.0)))),
        }
    if rng.random() < 0.5:
        noise["bias_rw_ug_per_sqrt_h"] = float(np.exp(rng.uniform(np.log(2.0), np.log(30.0))))
    overrides = {
        "lever_arm": {
            "enabled": True,
            "preset": "none",
            **{f"d_{a}_m": arms[i].tolist() for i, a in enumerate("xyz")},
            "r_vehicle_m": offset.tolist(),
        },
        "level_tilt": {"enabled": True, "north_arcsec": float(tilt[0]), "east_arcsec": float(tilt[1])},
        "accel_bias": {"enabled": True, "bias_ug": rng.uniform(-100.0, 100.0, 3).tolist()},
        "accel_noise": noise,
    }
    return overrides, density


def judge(job) -> dict:
    seed, rate_hz = job
    rng = np.random.default_rng(seed)
    overrides, density = draw(rng)
    fx = load_effects(base=IDEAL, overrides=overrides)
    plan = scenarios.TurntablePlan()
    tel = simulate_in_memory(
        scenarios.turntable(plan)[0], fx, rate_hz=rate_hz, form="rates", seed=int(rng.integers(2**31))
    )
    res = joint_fit([prepare(tel, "turntable")])
    truth = [
        *fx.arms_total_m().ravel(),
        *(np.array([overrides["level_tilt"][k] for k in ("north_arcsec", "east_arcsec")]) * ARCSEC),
    ]
    estimate = [*res.arms.ravel(), *res.tilt_rad]
    index = [res.names.index(n) for n in NAMES]
    sigma = np.sqrt(np.diag(res.covariance))[index]
    fit_bound = res.bound_sigma[index]
    noise = overrides["accel_noise"]
    pred = predict(  # the bound for the draw's true noise: white, Gauss-Markov and walk alike
        plan,
        density,
        markov_ug_per_sqrt_hz=noise.get("markov_density_ug_per_sqrt_hz", 0.0),
        markov_correlation_s=noise.get("markov_correlation_s", 1.0),
        bias_rw_ug_per_sqrt_h=noise.get("bias_rw_ug_per_sqrt_h", 2.0),
    )
    bound = [*pred.sigma_arms_m.ravel(), *pred.sigma_tilt_rad]
    return {
        "seed": seed,
        "density_ug_per_sqrt_hz": density,
        "white": "markov_density_ug_per_sqrt_hz" not in overrides["accel_noise"],
        "arm_lengths_mm": (np.linalg.norm(fx.arms_total_m(), axis=1) * 1e3).tolist(),
        "truth": [float(v) for v in truth],
        "estimate": [float(v) for v in estimate],
        "sigma": sigma.tolist(),
        "bound": [float(v) for v in bound],
        "fit_bound": fit_bound.tolist(),
    }


def summarise(rows: list[dict]) -> dict:
    x, t = np.array([r["estimate"] for r in rows]), np.array([r["truth"] for r in rows])
    s, b, fb = (np.array([r[k] for r in rows]) for k in ("sigma", "bound", "fit_bound"))
    z = (x - t) / s
    white = np.array([r["white"] for r in rows])
    # RMS error in units of the bound (the draw's true noise), over all draws and over those without
    # a Gauss-Markov part
    achieved = np.sqrt(np.mean(((x - t) / b) ** 2, axis=0))
    achieved_white = np.sqrt(np.mean(((x - t) / b)[white] ** 2, axis=0)) if white.any() else np.full(len(NAMES), np.nan)
    per = {}
    for j, n in enumerate(NAMES):
        per[n] = {
            "mean_z": float(z[:, j].mean()),
            "rms_z": float(np.sqrt(np.mean(z[:, j] ** 2))),
            "max_abs_z": float(np.abs(z[:, j]).max()),
            "coverage_95": float(np.mean(np.abs(z[:, j]) <= 1.959964)),
            "sigma_over_bound": float(np.mean(s[:, j] / b[:, j])),
            "fit_bound_over_bound": float(np.mean(fb[:, j] / b[:, j])),
            "efficiency": float(1.0 / achieved[j]),
            "efficiency_white_draws": float(1.0 / achieved_white[j]) if white.any() else None,
        }
    arms = [per[n] for n in PARAMS_R]
    return {
        "draws": len(rows),
        "white_draws": int(white.sum()),
        "seeds": [rows[0]["seed"], rows[-1]["seed"]],
        "parameters": per,
        "arms": {
            "worst_abs_mean_z": max(abs(p["mean_z"]) for p in arms),
            "rms_z_min": min(p["rms_z"] for p in arms),
            "rms_z_max": max(p["rms_z"] for p in arms),
            "coverage_95_min": min(p["coverage_95"] for p in arms),
            "efficiency_min": min(p["efficiency"] for p in arms),
        },
        "targets": {"abs_mean_z": 0.2, "rms_z": [0.85, 1.2], "efficiency": 0.9},
        "rows": rows,
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--range", choices=RANGES, required=True, help="the seed range (see above)")
    ap.add_argument("--draws", type=int, default=50, help="draws from the range's first seeds")
    ap.add_argument("--rate-hz", type=float, default=400.0, help="the records' sample rate")
    ap.add_argument("--jobs", type=int, default=1, help="worker processes")
    ap.add_argument("--plot", type=Path, help="write the simulation-based-calibration histograms here (PNG)")
    add_output_options(ap)
    args = ap.parse_args(argv)
    rows = run_jobs(judge, [(s, args.rate_hz) for s in seeds(args.range, args.draws)], args.jobs)
    summary = summarise(rows)
    print(f"{len(rows)} draws, seeds {summary['seeds'][0]}..{summary['seeds'][1]}, {args.rate_hz:.0f} Hz")
    nan = float("nan")
    print(
        f"  {'parameter':11s} {'mean z':>7s} {'z RMS':>6s} {'max|z|':>6s} {'95 %':>5s} {'sigma/bound':>11s} "
        f"{'fit bound/bound':>15s} {'efficiency':>10s} {'white':>6s}"
    )
    for n, p in summary["parameters"].items():
        print(
            f"  {n:11s} {p['mean_z']:+7.2f} {p['rms_z']:6.2f} {p['max_abs_z']:6.2f} {p['coverage_95']:5.2f} "
            f"{p['sigma_over_bound']:11.3f} {p['fit_bound_over_bound']:15.3f} {p['efficiency']:10.3f} "
            f"{p['efficiency_white_draws'] or nan:6.3f}"
        )
    a = summary["arms"]
    print(
        f"  arms: worst |mean z| {a['worst_abs_mean_z']:.2f} (target <= 0.2), z RMS {a['rms_z_min']:.2f}-"
        f"{a['rms_z_max']:.2f} (target 0.85-1.2), least efficiency {a['efficiency_min']:.2f} (target >= 0.9, "
        f"against the bound for each draw's true noise)"
    )
    code = emit(summary, args, __file__, argv, threads=args.jobs, show=False)
    if args.plot:
        x, t, sig = (np.array([r[k] for r in rows]) for k in ("estimate", "truth", "sigma"))
        z = (x - t) / sig
        plot_pit(dict(zip(NAMES, z.T)), args.plot, f"calibrate, {args.range} range, {len(rows)} draws")
    return code


if __name__ == "__main__":
    sys.exit(main())
