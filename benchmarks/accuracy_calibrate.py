"""Figures of the calibration on simulated data: unbiased, honest errors, at the bound.

    python benchmarks/accuracy_calibrate.py [--seeds 100] [--range dev|validation] [--jobs 2] [--variants paper,sway,coloured]
                                            [--skip-reference-rate] [--json out.json] [--record]
    python benchmarks/accuracy_calibrate.py --only checks --record checks   # the single-record checks alone

Monte Carlo of three set-ups, every seed an independent record (only the noise seed varies):

- ``paper``: the paper's plan (rotations about Y, X, Z; 20 deg/s, 10 deg/s^2, 2 min per axis, 1600 Hz),
  the compact geometry plus an offset (100, -50, 20) mm from the table centre, a table tilt of
  10 arcsec (8 north, -6 east), accelerometer biases, white noise 2.96 ug/sqrt(Hz) (2.9e-5 m/s^2/sqrt(Hz))
  and the default bias random walk. Fitted in the increment domain (the default) and, to compare, in
  the rates domain (the gyros' Savitzky-Golay derivative).
- ``sway``: the same record plus a minute of roll and of pitch sway (20 deg/s at 1 Hz), the
  accelerometers 0.5 ms late; the delay estimated too.
- ``coloured``: the paper set-up with a Gauss-Markov part added to the accelerometer noise
  (10 ug/sqrt(Hz) below 0.8 Hz, correlation time 0.2 s): residuals far from white.

Per parameter: the mean of z = (estimate - truth) / stated sigma (target |mean z| <= 0.3), the z RMS
(target 0.8..1.25), the largest |z|, the scatter across seeds over the mean stated sigma, and the
efficiency: the Cramer-Rao bound over the stated sigma and over the scatter (target >= 0.9 on the
paper's plan). Prints a table per set-up; ``--json`` writes every figure.

Then: the paper's per-rotation fit, which ignores the tilt, against the joint fit
on one tilted record; and the paper's plan with a 40-minute roll sway, the sway's reference at
1600 Hz and at 100 Hz, calibrated through ``sizefx.calibrate.run`` (the arms must agree within
0.01 mm).

Last, the single-record checks (``checks``; ``--only checks`` runs them alone, in a few minutes):

- ``noiseless``: the ``paper`` set-up without noise on the paper's plan shortened to 214 s (1600 Hz):
  the arms' largest |estimate - truth| / sigma (sigma at 2.96 ug/sqrt(Hz), from the Fisher
  information) in the increment domain, and in the rates domain with the gyros' 25 ms and a 125 ms
  Savitzky-Golay derivative.
- ``steps``: the ``sway`` set-up on paired seeds (0.5 ms of delay less none, the same noise): the
  delay's difference off 0.5 ms with the rows at the sway's steps in angular acceleration left out
  (the fit's way) and kept.
- ``turntable``: one record of the paper's plan with ``simulate turntable``'s defaults (seed 0),
  calibrated by ``sizefx.calibrate.run``: the pre-flight bound over the fit's sigma per arm, and the
  final horizontal error of navigating the record without and with the calibrated arms (triad).

The seeds are the validation range's (from 1 000 000, ``benchmarks/_validation.py``) unless
``--range dev``: the figures the docs quote come from seeds no change to the fit was tried on.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path

import numpy as np

from sizefx import scenarios
from sizefx.calibrate import PARAMS_R, CalibrateConfig, excitation, joint_fit, per_rotation_fit, prepare
from sizefx.calibrate import joint as joint_module
from sizefx.calibrate import run as calibrate_files
from sizefx.calibrate.joint import information
from sizefx.constants import ARCSEC, MICRO_G
from sizefx.effects import load_effects
from sizefx.io.telemetry import read_telemetry
from sizefx.navigate import NavConfig, navigate
from sizefx.omegadot import savgol
from sizefx.simulate import SimulateConfig, simulate_in_memory
from sizefx.simulate import run as simulate_file

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _measure import add_output_options, emit  # (siblings of this script)
from _validation import RANGES, seeds

OFFSET_M = [0.10, -0.05, 0.02]
TILT_ARCSEC = (8.0, -6.0)
DELAY_S = 0.5e-3
BASE = {
    "lever_arm": {"preset": "compact", "r_vehicle_m": OFFSET_M},
    "level_tilt": {"enabled": True, "north_arcsec": TILT_ARCSEC[0], "east_arcsec": TILT_ARCSEC[1]},
    "accel_bias": {"enabled": True, "bias_ug": [50.0, -30.0, 20.0]},
    "accel_noise": {"enabled": True, "density_ug_per_sqrt_hz": 2.96},
}
VARIANTS = {
    "paper": {},
    "sway": {"accel_delay": {"enabled": True, "tau_s": DELAY_S}},
    "coloured": {
        "accel_noise": {
            "enabled": True,
            "density_ug_per_sqrt_hz": 2.96,
            "markov_density_ug_per_sqrt_hz": 10.0,
            "markov_correlation_s": 0.2,
        }
    },
}
#: Seeds of different set-ups never coincide.
SEED_BASE = {"paper": 0, "sway": 100_000, "coloured": 200_000}


def effects(variant: str):
    return load_effects(overrides={**BASE, **VARIANTS[variant]})


def truth_of(variant: str) -> dict:
    fx = effects(variant)
    out = {f"r_{a}[{c}]": fx.arms_total_m()[i, j] for i, a in enumerate("xyz") for j, c in enumerate("xyz")}
    out["tilt_north"], out["tilt_east"] = TILT_ARCSEC[0] * ARCSEC, TILT_ARCSEC[1] * ARCSEC
    if variant == "sway":
        out["accel_delay"] = DELAY_S
    return out


def one_seed(job):
    """Fit one record: ``{domain: (estimates, sigmas, bounds)}`` over :func:`truth_of`'s names."""
    variant, seed, compare_rates = job
    fx = effects(variant)
    seed = SEED_BASE[variant] + seed
    plan = scenarios.turntable(scenarios.TurntablePlan())[0]
    records = [prepare(simulate_in_memory(plan, fx, form="rates", seed=seed), "turntable")]
    with_delay = variant == "sway"
    if with_delay:
        for k, axis in enumerate(("roll", "pitch")):
            sway = scenarios.sway(scenarios.SwayPlan(axis=axis, amplitudes_dps=(20.0,), static_s=10.0, segment_s=60.0))[
                0
            ]
            records.append(
                prepare(simulate_in_memory(sway, fx, form="rates", seed=seed + 50_000 * (k + 1)), f"sway-{axis}")
            )
    names = list(truth_of(variant))
    out = {}
    domains = {"increments": {}, "rates": {"interval_s": None}} if compare_rates else {"increments": {}}
    for domain, options in domains.items():
        t0 = time.perf_counter()
        res = joint_fit(records, with_delay=with_delay, **options)
        wall = time.perf_counter() - t0
        estimate = dict(zip(PARAMS_R, res.arms.ravel()))
        estimate["tilt_north"], estimate["tilt_east"] = res.tilt_rad
        if with_delay:
            estimate["accel_delay"] = res.delay_s
        index = [res.names.index(n) for n in names]
        sig = np.sqrt(np.diag(res.covariance))
        out[domain] = ([estimate[n] for n in names], sig[index].tolist(), res.bound_sigma[index].tolist(), wall)
    return out


def summarise(names, truth, rows) -> dict:
    """Per parameter: the figures of the module's docstring, from the seeds' ``(x, sigma, bound)``."""
    x = np.array([r[0] for r in rows])
    s = np.array([r[1] for r in rows])
    b = np.array([r[2] for r in rows])
    t = np.array([truth[n] for n in names])
    z = (x - t) / s
    scatter = x.std(axis=0, ddof=1)
    out = {}
    for j, n in enumerate(names):
        out[n] = {
            "mean_z": float(z[:, j].mean()),
            "z_rms": float(np.sqrt(np.mean(z[:, j] ** 2))),
            "max_abs_z": float(np.abs(z[:, j]).max()),
            "mean_error": float((x[:, j] - t[j]).mean()),
            "sigma": float(s[:, j].mean()),
            "scatter": float(scatter[j]),
            "bound": float(b[:, j].mean()),
            "scatter_over_sigma": float(scatter[j] / s[:, j].mean()),
            "efficiency_stated": float(b[:, j].mean() / s[:, j].mean()),
            "efficiency_scatter": float(b[:, j].mean() / scatter[j]),
        }
    return out


def headline(table) -> dict:
    """The set-up's figures over all its parameters: the worst of each, and the ranges."""
    rms = [r["z_rms"] for r in table.values()]
    return {
        "worst_abs_mean_z": max(abs(r["mean_z"]) for r in table.values()),
        "z_rms_min": min(rms),
        "z_rms_max": max(rms),
        "z_rms_pooled": float(np.sqrt(np.mean(np.square(rms)))),
        "max_abs_z": max(r["max_abs_z"] for r in table.values()),
        "bound_over_scatter_min": min(r["efficiency_scatter"] for r in table.values()),
        "bound_over_scatter_max": max(r["efficiency_scatter"] for r in table.values()),
        "bound_over_stated_min": min(r["efficiency_stated"] for r in table.values()),
        "bound_over_stated_max": max(r["efficiency_stated"] for r in table.values()),
    }


def unit(name):
    if name.startswith("r_"):
        return 1e3, "mm"
    if name.startswith("tilt"):
        return 1 / ARCSEC, "arcsec"
    return 1e6, "us"


def print_table(title, table, seeds):
    print(f"\n{title} ({seeds} seeds)")
    print(
        f"  {'parameter':12s} {'mean z':>7s} {'z RMS':>6s} {'max|z|':>6s} {'mean error':>11s} {'sigma':>8s} "
        f"{'scatter':>8s} {'bound':>8s} {'bound/sigma':>11s} {'bound/scatter':>13s}"
    )
    for n, r in table.items():
        k, u = unit(n)
        print(
            f"  {n:12s} {r['mean_z']:+7.2f} {r['z_rms']:6.2f} {r['max_abs_z']:6.2f} {r['mean_error'] * k:+8.4f} "
            f"{u:>2s} {r['sigma'] * k:8.4f} {r['scatter'] * k:8.4f} {r['bound'] * k:8.4f} {r['efficiency_stated']:11.3f} "
            f"{r['efficiency_scatter']:13.3f}"
        )
    worst_mean = max(abs(r["mean_z"]) for r in table.values())
    rms = [r["z_rms"] for r in table.values()]
    eff = min(r["efficiency_stated"] for r in table.values())
    print(
        f"  worst |mean z| {worst_mean:.2f} (target <= 0.3); z RMS {min(rms):.2f}..{max(rms):.2f} (target 0.8..1.25); "
        f"pooled z RMS {np.sqrt(np.mean(np.square(rms))):.2f}; least bound/sigma {eff:.3f}"
    )


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=100)
    ap.add_argument(
        "--range",
        choices=RANGES,
        default="validation",
        help="the seed range: dev (seeds from 0) to try changes on, validation (from 1 000 000) to report",
    )
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--variants", default="paper,sway,coloured")
    ap.add_argument("--no-rates", action="store_true", help="skip the rates-domain comparison on the paper set-up")
    ap.add_argument("--skip-reference-rate", action="store_true", help="leave out the 40-minute sway files")
    ap.add_argument("--only", choices=["checks"], help="run only the single-record checks (the docstring's last list)")
    add_output_options(ap)
    args = ap.parse_args(argv)
    if args.only == "checks":
        out = {"checks": checks(args.jobs)}
        return emit(out, args, __file__, argv, threads=args.jobs, show=False)
    variants = [v for v in args.variants.split(",") if v]
    unknown = set(variants) - set(VARIANTS)
    if unknown:
        ap.error(f"unknown variant(s) {sorted(unknown)}; choose from {', '.join(VARIANTS)}")
    out = {"seeds": args.seeds, "range": args.range, "variants": {}}
    t_start = time.perf_counter()
    for variant in variants:
        names = list(truth_of(variant))
        jobs = [(variant, s, variant == "paper" and not args.no_rates) for s in seeds(args.range, args.seeds)]
        t0 = time.perf_counter()
        with ProcessPoolExecutor(max_workers=max(1, args.jobs)) as pool:
            results = list(pool.map(one_seed, jobs))
        wall = time.perf_counter() - t0
        out["variants"][variant] = {"wall_s": wall}
        for domain in results[0]:
            rows = [r[domain] for r in results]
            table = summarise(names, truth_of(variant), rows)
            fit_s = float(np.median([r[3] for r in rows]))
            out["variants"][variant][domain] = {
                "parameters": table,
                "summary": headline(table),
                "median_fit_s": fit_s,
            }
            print_table(f"{variant}, {domain} domain (median fit {fit_s:.2f} s)", table, args.seeds)
        print(f"  ({variant}: {wall:.0f} s for {args.seeds} seeds with {args.jobs} processes)")
    out["per_rotation"] = per_rotation()
    pr = out["per_rotation"]
    print(
        f"\ntilt 8, -6 arcsec, one record of the paper set-up: joint fit {pr['joint_tilt_arcsec'][0]:.2f}, "
        f"{pr['joint_tilt_arcsec'][1]:.2f} arcsec, arms max |z| {pr['joint_max_abs_z']:.2f}; the paper's per-rotation "
        "fit (ignores the tilt), r_ii - truth [mm]: "
        + ", ".join(f"{k} {v:+.3f}" for k, v in pr["per_rotation_error_mm"].items())
    )
    if not args.skip_reference_rate:
        out["reference_rate"] = rr = reference_rate()
        print(
            f"reference rate: turntable + 40-min roll sway at 1600 Hz, the sway's reference at 100 Hz against "
            f"1600 Hz: arms differ by at most {rr['max_difference_mm']:.5f} mm (sigma {rr['sigma_min_mm']:.4f}"
            f"..{rr['sigma_max_mm']:.4f} mm)"
        )
    out["checks"] = checks(args.jobs)
    print(f"\ntotal {time.perf_counter() - t_start:.0f} s")
    return emit(out, args, __file__, argv, threads=args.jobs, show=False)


def per_rotation() -> dict:
    """One record of the paper set-up: the joint fit against the paper's per-rotation fit."""
    fx = effects("paper")
    rec = prepare(simulate_in_memory(scenarios.turntable(scenarios.TurntablePlan())[0], fx, form="rates", seed=11))
    res = joint_fit([rec])
    truth = fx.arms_total_m()
    return {
        "joint_tilt_arcsec": (res.tilt_rad / ARCSEC).tolist(),
        "joint_max_abs_z": float(np.abs((res.arms - truth) / res.sigma_arms).max()),
        "per_rotation_error_mm": {
            f"{r['axis']}/{r['channel']}": (r["r_own"] - truth["xyz".index(r["channel"])]["xyz".index(r["channel"])])
            * 1e3
            for r in per_rotation_fit(rec)
        },
    }


#: The reference-rate study's offset of the table centre.
RR_OFFSET_M = [0.0010, -0.0005, 0.0008]


def reference_rate() -> dict:
    """The same records calibrated with the sway's reference at 1600 Hz and at 100 Hz."""
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        sway_plan = scenarios.SwayPlan(axis="roll")  # 10 min static, then 10, 20, 30 deg/s for 10 min each
        overrides = {"lever_arm": {"r_vehicle_m": RR_OFFSET_M}}
        simulate_file(SimulateConfig("turntable", tmp / "turntable.h5", overrides=overrides, seed=41))
        arms = {}
        for hz in (1600.0, 100.0):
            sway = tmp / f"sway_{int(hz)}.h5"
            simulate_file(
                SimulateConfig("sway", sway, plan=sway_plan, overrides=overrides, seed=42, reference_rate_hz=hz)
            )
            res = calibrate_files(CalibrateConfig((str(tmp / "turntable.h5"), str(sway)))).fit
            arms[hz] = res
    diff = np.abs(arms[100.0].arms - arms[1600.0].arms)
    return {
        "max_difference_mm": float(diff.max() * 1e3),
        "difference_mm": (diff * 1e3).tolist(),
        "sigma_min_mm": float(arms[1600.0].sigma_arms.min() * 1e3),
        "sigma_max_mm": float(arms[1600.0].sigma_arms.max() * 1e3),
    }


#: The paper's plan shortened to 214 s, all nine arms observable (tests/test_calibrate_bound.py's).
SHORT_PLAN = scenarios.TurntablePlan(static_s=20.0, seconds_per_axis=48.0, cycles=2)
#: The wide derivative of the noiseless check: 201 samples, 125 ms at 1600 Hz.
WIDE_WINDOW = 201


def noiseless() -> dict:
    """The arms' bias in sigma on a noiseless record: the increment domain against the rates
    domain's filtered derivatives."""
    quiet = load_effects(overrides={**BASE, "accel_noise": {"enabled": False}, "gyro_noise": {"enabled": False}})
    rec = prepare(simulate_in_memory(scenarios.turntable(SHORT_PLAN)[0], quiet, form="rates", seed=0))
    names, fisher = information([rec], 2.96 * MICRO_G)
    sigma = np.sqrt(np.diag(np.linalg.inv(fisher)))[:9].reshape(3, 3)
    truth = quiet.arms_total_m()
    dt = float(np.median(np.diff(rec.t)))
    wide = replace(rec, omegadot=savgol(rec.omega, dt, window=WIDE_WINDOW))
    fits = {
        "increments": joint_fit([rec]),
        "rates_25ms": joint_fit([rec], interval_s=None),
        "rates_125ms": joint_fit([wide], interval_s=None),
    }
    return {
        "record_s": float(rec.t[-1] - rec.t[0]),
        **{f"max_abs_z_{k}": float(np.abs((r.arms - truth) / sigma).max()) for k, r in fits.items()},
    }


_STEPS = joint_module.steps_in_angular_acceleration


def _no_steps(rec):
    return np.zeros(rec.t.size, dtype=bool)


def _delay(job):
    """The ``sway`` set-up's delay estimate at ``tau`` on seed ``seed``, the rows at steps in
    angular acceleration left out (the fit's way) or kept."""
    tau, seed, keep_steps = job
    joint_module.steps_in_angular_acceleration = _no_steps if keep_steps else _STEPS  # a worker runs either
    fx = load_effects(overrides={**BASE, "accel_delay": {"enabled": tau > 0, "tau_s": tau}})
    plan = scenarios.turntable(scenarios.TurntablePlan())[0]
    records = [prepare(simulate_in_memory(plan, fx, form="rates", seed=seed), "turntable")]
    for k, axis in enumerate(("roll", "pitch")):
        sway = scenarios.sway(scenarios.SwayPlan(axis=axis, amplitudes_dps=(20.0,), static_s=10.0, segment_s=60.0))[0]
        records.append(prepare(simulate_in_memory(sway, fx, form="rates", seed=seed + 50_000 * (k + 1)), axis))
    res = joint_fit(records, with_delay=True)
    return res.delay_s, res.left_out_steps, res.left_out_s


def steps(jobs: int, seeds=(0, 1)) -> dict:
    """Paired seeds: 0.5 ms of delay less none, the same noise, with the steps' rows left out and kept."""
    grid = [(tau, SEED_BASE["sway"] + s, keep) for keep in (False, True) for s in seeds for tau in (DELAY_S, 0.0)]
    with ProcessPoolExecutor(max_workers=max(1, jobs)) as pool:
        got = dict(zip(grid, pool.map(_delay, grid)))
    out = {"seeds": len(seeds)}
    for keep, name in ((False, "left_out"), (True, "kept")):
        pairs = [
            got[(DELAY_S, SEED_BASE["sway"] + s, keep)][0] - got[(0.0, SEED_BASE["sway"] + s, keep)][0] for s in seeds
        ]
        out[f"{name}_error_us"] = [(d - DELAY_S) * 1e6 for d in pairs]
    out["left_out_steps"], out["left_out_s"] = got[(DELAY_S, SEED_BASE["sway"] + seeds[0], False)][1:]
    return out


def turntable_record() -> dict:
    """One ``simulate turntable`` record with the defaults: the pre-flight bound against the fit's
    sigma, and navigation without and with the calibrated arms."""
    with tempfile.TemporaryDirectory() as tmp:
        path, levers = Path(tmp) / "turntable.h5", Path(tmp) / "levers.json"
        simulate_file(SimulateConfig("turntable", path, seed=0))
        fit = calibrate_files(CalibrateConfig((str(path),), json_path=str(levers))).fit
        exc = excitation(path)
        bound = np.array(
            [np.sqrt(np.diag(np.linalg.inv(exc.arm_information[i] / exc.noise_mps2[i] ** 2))) for i in range(3)]
        )
        tel = read_telemetry(path)
        final = {
            mode: float(navigate(tel, cfg).errors["horizontal_m"][-1])
            for mode, cfg in (("none", NavConfig()), ("triad", NavConfig(levers=str(levers), mode="triad")))
        }
    ratio = bound / fit.sigma_arms
    return {
        "duration_s": float(tel.time_s[-1] - tel.time_s[0]),
        "preflight_over_fit_sigma_min": float(ratio.min()),
        "preflight_over_fit_sigma_max": float(ratio.max()),
        "final_horizontal_error_m": final,
    }


def checks(jobs: int) -> dict:
    t0 = time.perf_counter()
    out = {"noiseless": noiseless()}
    n = out["noiseless"]
    print(
        f"\nnoiseless, {n['record_s']:.0f} s: arms' largest |z| increments {n['max_abs_z_increments']:.4f}, "
        f"rates 25 ms {n['max_abs_z_rates_25ms']:.2f}, 125 ms {n['max_abs_z_rates_125ms']:.2f}",
        flush=True,
    )
    out["steps"] = st = steps(jobs)
    print(
        f"paired seeds, delay less 0.5 ms [us]: steps left out {st['left_out_error_us']}, kept {st['kept_error_us']} "
        f"({st['left_out_steps']} steps, {st['left_out_s']:.2f} s left out)",
        flush=True,
    )
    out["turntable"] = tt = turntable_record()
    print(
        f"turntable: pre-flight bound / fit sigma {tt['preflight_over_fit_sigma_min']:.3f}.."
        f"{tt['preflight_over_fit_sigma_max']:.3f}; final horizontal error {tt['final_horizontal_error_m']}",
        flush=True,
    )
    out["wall_s"] = time.perf_counter() - t0
    return out


if __name__ == "__main__":
    sys.exit(main())
