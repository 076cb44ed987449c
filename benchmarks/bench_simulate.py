"""Benchmark: `sizefx simulate flight` throughput and peak memory (run by hand, not in the tests),
and the figures docs/simulate.md gives for the simulator's defaults and refusals.

    python benchmarks/bench_simulate.py --duration-h 1.8 [--form rates|increments] [--skip-flight]
        [--json out.json] [--record]

- the flight: checks the answer before reporting (the file validates, has the expected number of
  samples, and its static lead-in reads normal gravity);
- why the default accelerometer noise density: the formal sigma of the paper's per-rotation least
  squares ``H = [1, omega^2, omegadot]`` (``sizefx.calibrate.per_rotation``) over each axis's
  rotation of the default turntable plan, at the default density;
- what simulate refuses to publish: the extreme settings docs/simulate.md lists, each run as a
  command (as ``tests/test_consistent_inputs.py`` runs them), with the figures its one-line
  refusal gives.
"""

from __future__ import annotations

import argparse
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from sizefx import earth, scenarios
from sizefx.io.telemetry import read_telemetry
from sizefx.simulate import SimulateConfig, run

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _measure import add_output_options, emit  # (a sibling of this script)


def noise_sigma() -> dict:
    """The per-rotation fit's formal sigma of the arms on the default turntable plan (1600 Hz), at the
    default accelerometer white noise: sample sigma N sqrt(rate), times sqrt of the diagonal of
    (H^T H)^-1 over each axis's rotation segment (the lead-in, repositioning and settling left out)."""
    from sizefx.calibrate.records import prepare
    from sizefx.constants import MICRO_G
    from sizefx.effects import load_effects
    from sizefx.simulate import simulate_in_memory

    rate = SimulateConfig.rate_hz
    density = float(load_effects().get("accel_noise", "density_mps2_per_sqrt_hz"))
    sample_sigma = density * np.sqrt(rate)
    traj, _ = scenarios.turntable(scenarios.TurntablePlan())
    rec = prepare(simulate_in_memory(traj, rate_hz=rate))  # ideal sensors: the motion's own omega, omegadot
    axes, own, other, samples = [], [], [], []
    for name, t0, t1 in traj.segments:
        if not name.startswith("rotate "):
            continue
        a = "XYZ".index(name[-1])
        m = (rec.t >= t0) & (rec.t < t1)
        H = np.column_stack([np.ones(m.sum()), rec.omega[m, a] ** 2, rec.omegadot[m, a]])
        cov = np.linalg.inv(H.T @ H)
        axes.append(name[-1])
        samples.append(int(m.sum()))
        own.append(float(sample_sigma * np.sqrt(cov[1, 1]) * 1e3))  # from omega^2: r_i[i]
        other.append(float(sample_sigma * np.sqrt(cov[2, 2]) * 1e3))  # from omegadot: r_i[j]
    return {
        "rate_hz": rate,
        "density_ug_per_sqrt_hz": density / MICRO_G,
        "sample_sigma_mg": sample_sigma / MICRO_G / 1e3,
        "axes": axes,
        "samples_per_axis": samples,
        "sigma_from_omega2_mm": own,
        "sigma_from_omegadot_mm": other,
        # each axis fits two horizontal channels, each an arm component from omega^2 and one from omegadot
        "sigma_mean_mm": float(np.mean(own + other)),
    }


#: The extreme settings of docs/simulate.md, as tests/test_consistent_inputs.py simulates them: the
#: command's arguments after `sizefx simulate`, and the --set values.
TUMBLE = "tumble --duration-s 5 --rate-hz 100 -q".split()
REFUSALS = {
    "contract_limit_5000dps_3m_arms": (
        "turntable --vertical-axes Z --static-s 60 --seconds-per-axis 10 --cycles 1 --peak-rate-dps 5000 "
        "--accel-dps2 1e5 --rate-hz 100 -q".split(),
        ["lever_arm.r_vehicle_m=[3, 0, 0]"],
    ),
    "lever_arm_100m_tumble": (TUMBLE, ["lever_arm.r_vehicle_m=[100, 100, 100]"]),
    "accel_bias_1g_tumble": (TUMBLE, ["accel_bias.enabled=true", "accel_bias.bias_ug=[1e6, 1e6, 1e6]"]),
    "accel_lsb_1mps_tumble": (
        "tumble --duration-s 2 --rate-hz 1600 -q".split(),
        ["quantisation.enabled=true", "quantisation.accel_lsb_m_per_s=1"],
    ),
}
#: The figures a refusal line gives, by the check that refused.
REFUSAL_FIGURES = {
    "contract_reading_si": r"would read (-?[\d.]+) \(SI\)",
    "median_abs_f_si": r"median \|specific force\| is ([\d.]+) in SI",
    "at_rest_mps2": r"reads ([\d.]+) m/s\^2\s+at rest",
    "windows": r"\(median of (\d+) windows\)",
    "times_gravity": r"([\d.]+) times normal gravity",
    "gravity_mps2": r"normal gravity at the site ([\d.]+) m/s\^2",
}


def refusals(tmp: Path) -> dict:
    """Each extreme setting run as a command: its exit code, its one line and the figures in it."""
    exe = Path(sys.executable).with_name("sizefx")
    out = {}
    for name, (args, sets) in REFUSALS.items():
        cmd = [str(exe), "simulate", *args, *(x for v in sets for x in ("--set", v)), "-o", str(tmp / "r.h5")]
        done = subprocess.run(cmd, capture_output=True, text=True)
        line = done.stderr.strip().replace(str(tmp / "r.h5"), "r.h5")
        assert done.returncode == 2 and len(line.splitlines()) == 1, (name, done.returncode, line)
        assert not (tmp / "r.h5").exists(), name
        figures = {k: float(m.group(1)) for k, rx in REFUSAL_FIGURES.items() if (m := re.search(rx, line))}
        out[name] = {
            "command": " ".join(["sizefx", "simulate", *args, *(f"--set '{v}'" for v in sets), "-o", "r.h5"]),
            "exit_code": done.returncode,
            "message": line,
            **figures,
        }
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration-h", type=float, default=1.8)
    ap.add_argument("--form", choices=["rates", "increments"], default="rates")
    ap.add_argument("--skip-flight", action="store_true", help="Only the defaults' and refusals' figures.")
    add_output_options(ap)
    args = ap.parse_args(argv)
    result = {"noise_sigma": noise_sigma()}
    ns = result["noise_sigma"]
    print(
        f"per-rotation formal sigma at {ns['density_ug_per_sqrt_hz']:g} ug/sqrt(Hz) (sample sigma "
        f"{ns['sample_sigma_mg']:.3f} mg at {ns['rate_hz']:g} Hz), {ns['samples_per_axis']} samples per axis: "
        f"from omega^2 {max(ns['sigma_from_omega2_mm']):.4f} mm, from omegadot "
        f"{max(ns['sigma_from_omegadot_mm']):.4f} mm, mean {ns['sigma_mean_mm']:.4f} mm"
    )
    with tempfile.TemporaryDirectory() as tmp:
        result["refusals"] = refusals(Path(tmp))
    for name, r in result["refusals"].items():
        print(f"refused: {name}: {r['message'][:160]}...")
    if args.skip_flight:
        return emit(result, args, __file__, argv, show=False)
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "flight.h5"
        t0 = time.perf_counter()
        summary = run(
            SimulateConfig(
                "flight", out, plan=scenarios.FlightPlan(duration_s=args.duration_h * 3600.0), form=args.form, seed=0
            )
        )
        wall = time.perf_counter() - t0
        peak_mib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
        tel = read_telemetry(out)
        expected = int(round(args.duration_h * 3600.0 * 1600.0)) + (1 if args.form == "rates" else 0)
        assert tel.n_samples == expected, (tel.n_samples, expected)
        static = tel.time_s < 100.0
        f = tel.accel_mps2[static] if args.form == "rates" else tel.dvel_mps[static] * 1600.0
        g = earth.gravity_n(tel.site.lat_rad, tel.site.height_m)[2]
        assert abs(np.linalg.norm(f.mean(axis=0)) - g) < 1e-5, "static lead-in does not read gravity"
        result |= {
            "benchmark": "simulate flight",
            "duration_h": args.duration_h,
            "form": args.form,
            "samples": summary.samples,
            "wall_s": round(wall, 2),
            "samples_per_s": round(summary.samples / wall),
            "file_mib": round(summary.file_bytes / 2**20, 1),
            "peak_rss_mib": round(peak_mib, 1),
        }
    return emit(result, args, __file__, argv)


if __name__ == "__main__":
    sys.exit(main())
