"""Figures of sizefx diagnose (issue 6) on simulated and real data, as text and JSON.

    python benchmarks/accuracy_diagnose.py [--seeds 5] [--fp-seeds 50] [--json out.json]

1. Recovery: each effect hidden alone in a 60 s, 400 Hz tumble record (navigation-grade
   noise), over several seeds: found in how many, and the z-scores of its parameters
   (estimate - truth) / sigma: their RMS should be near 1 and none beyond 3.
2. False positives: records with only noise and biases (30 s, 200 Hz): how many report
   anything besides biases.
3. Runtime: ``sizefx diagnose`` end to end (process start, read, fit, model and report)
   on a two-minute 1600 Hz record, wall time and peak memory of the child process.
4. Real data: BROAD trials 07 and 21 at 10 Hz bandwidth: arms, clock offsets, their
   difference between trials, and the residual gain.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from sizefx import diagnose as D
from sizefx import scenarios
from sizefx.effects import IDEAL, load_effects
from sizefx.simulate import simulate_in_memory

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_diagnose import BASE, HIDDEN, NOMINAL  # noqa: E402  (the same sizes as the tests)

REAL = Path(os.environ.get("SIZEFX_REAL_DATA", Path(__file__).resolve().parents[2] / "shared" / "data" / "real"))


def make(hidden, seed, rate_hz=400.0, duration_s=60.0):
    overrides = {k: dict(v) for k, v in BASE.items()}
    for name, values in hidden.items():
        overrides.setdefault(name, {}).update(values)
    fx = load_effects(base=IDEAL, overrides=overrides)
    tel = simulate_in_memory(scenarios.tumble(duration_s), fx, rate_hz=rate_hz, form="rates", seed=seed)
    return tel, D.theta_from_model(fx)


def recovery(seeds):
    out = {}
    for effect, values in HIDDEN.items():
        zs, found, extra = [], 0, 0
        for seed in range(seeds):
            tel, truth = make({effect: values}, 1000 + seed)
            d = D.diagnose(tel, NOMINAL, keep_series=False)
            ids = {e.id for e in d.effects}
            found += effect in ids
            extra += bool(ids - {effect})
            zs += [(d.theta[j] - truth[j]) / d.sigma_theta[j] for j, p in enumerate(D.PARAMS)
                   if p.effect == effect and j in d.sigma_theta]
        z = np.array(zs)
        out[effect] = {"found": found, "records": seeds, "other_effects_reported": extra, "parameters": int(z.size),
                       "rms_z": float(np.sqrt(np.mean(z**2))), "max_abs_z": float(np.abs(z).max())}
        print(f"  {effect:20s} found {found}/{seeds}, others {extra}, z RMS {out[effect]['rms_z']:.2f}, "
              f"max |z| {out[effect]['max_abs_z']:.2f} over {z.size}", flush=True)
    return out


def false_positives(seeds):
    biases = {"accel_bias": HIDDEN["accel_bias"], "gyro_bias": HIDDEN["gyro_bias"]}
    records = []
    for seed in range(seeds):
        tel, _ = make(biases, 5000 + seed, rate_hz=200.0, duration_s=30.0)
        d = D.diagnose(tel, NOMINAL, keep_series=False)
        extra = sorted({f"{e.id}:{e.channel}" for e in d.effects if e.id not in ("accel_bias", "gyro_bias")})
        if extra:
            records.append({"seed": 5000 + seed, "extra": extra})
    rate = len(records) / seeds
    print(f"  {len(records)} of {seeds} noise-and-bias records report something else ({100 * rate:.1f} %): {records}")
    return {"records": seeds, "with_false_positive": len(records), "rate": rate, "cases": records}


def runtime():
    with tempfile.TemporaryDirectory() as tmp:
        rec = Path(tmp) / "tumble.h5"
        exe = Path(sys.executable).with_name("sizefx")
        subprocess.run([str(exe), "simulate", "tumble", "-o", str(rec), "--quiet", "--seed", "3",
                        "--set", "accel_delay.enabled=true", "--set", "lever_arm.d_y_m=[0.003,0.0274,-0.002]"],
                       check=True, capture_output=True)
        started = time.perf_counter()
        done = subprocess.run([str(exe), "diagnose", str(rec), "--json", str(Path(tmp) / "d.json")],
                              check=True, capture_output=True, text=True)
        wall = time.perf_counter() - started
        peak_mib = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
        doc = json.loads((Path(tmp) / "d.json").read_text())
    print(f"  two-minute 1600 Hz record ({doc['samples']} samples): {wall:.1f} s wall, peak {peak_mib:.0f} MiB; "
          f"found {[e['id'] for e in doc['effects']]}")
    return {"samples": doc["samples"], "wall_s": wall, "peak_mib": peak_mib,
            "found": [e["id"] for e in doc["effects"]], "report_first_lines": done.stdout.splitlines()[:4]}


def broad():
    if not REAL.is_dir():
        print(f"  real data folder {REAL} not found: skipped")
        return None
    from sizefx.importers import run_import

    out = {}
    with tempfile.TemporaryDirectory() as tmp:
        for trial, name in (("07", "07_undisturbed_fast_rotation_B.mat"), ("21", "21_undisturbed_fast_combined.mat")):
            h5 = Path(tmp) / f"{trial}.h5"
            run_import("broad", REAL / "broad" / name, h5)
            res = D.run(D.DiagnoseConfig(h5, nominal="none", bandwidth_hz=10.0, navigation=False,
                                         model_out=Path(tmp) / f"{trial}.toml"))
            d, doc = res.diagnosis, res.to_json()
            s = d.sigma_theta
            out[trial] = {
                "arms_mm": (d.theta[D.LEVER] * 1e3).reshape(3, 3).round(3).tolist(),
                "sigma_arms_mm": [[round(s[j] * 1e3, 3) for j in D.LEVER[3 * i:3 * i + 3]] for i in range(3)],
                "accel_delay_us": round(d.theta[D.TAU_A] * 1e6, 1), "sigma_accel_delay_us": round(s[D.TAU_A] * 1e6, 1),
                "reference_delay_us": round(d.theta[D.TAU_R] * 1e6, 1),
                "sigma_reference_delay_us": round(s[D.TAU_R] * 1e6, 1),
                "effects": [f"{e.id}:{e.channel}" if e.channel else e.id for e in d.effects],
                "rms_before": doc["residual_rms_before"], "rms_after": doc["residual_rms_after"],
                "wall_s": d.wall_s}
    a07, a21 = np.array(out["07"]["arms_mm"]), np.array(out["21"]["arms_mm"])
    out["difference"] = {"arms_max_mm": float(np.abs(a07 - a21).max()),
                         "accel_delay_us": abs(out["07"]["accel_delay_us"] - out["21"]["accel_delay_us"]),
                         "reference_delay_us": abs(out["07"]["reference_delay_us"] - out["21"]["reference_delay_us"])}
    for trial in ("07", "21"):
        o = out[trial]
        gains = {c: 100 * (1 - o["rms_after"][c] / o["rms_before"][c]) for c in D.CHANNELS}
        print(f"  trial {trial}: arms [mm] {o['arms_mm']}, accel delay {o['accel_delay_us']} +- "
              f"{o['sigma_accel_delay_us']} us, reference delay {o['reference_delay_us']} +- "
              f"{o['sigma_reference_delay_us']} us; residual below 10 Hz lower by "
              + ", ".join(f"{c} {g:.0f} %" for c, g in gains.items()))
    print(f"  trials differ by: arms {out['difference']['arms_max_mm']:.2f} mm (max component), accel delay "
          f"{out['difference']['accel_delay_us']:.0f} us, reference delay {out['difference']['reference_delay_us']:.0f} us")
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5, help="records per effect in the recovery table")
    ap.add_argument("--fp-seeds", type=int, default=50, help="noise-and-bias records for the false-positive rate")
    ap.add_argument("--json", type=Path)
    args = ap.parse_args(argv)
    out = {}
    print("recovery (tumble 60 s, 400 Hz):")
    out["recovery"] = recovery(args.seeds)
    print("false positives (noise and biases, 30 s, 200 Hz):")
    out["false_positives"] = false_positives(args.fp_seeds)
    print("runtime:")
    out["runtime"] = runtime()
    print("BROAD (real):")
    out["broad"] = broad()
    if args.json:
        args.json.write_text(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
