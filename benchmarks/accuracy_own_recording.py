"""Figures of the README's "Your own recording" walk on examples/*.csv, for examples/README.md.

    python benchmarks/accuracy_own_recording.py [--json out.json] [--record]

Runs the walk exactly as README.md writes it (the ```sh commands between its
``own-recording`` markers, as ``tests/test_own_recording.py`` reads them: import csv, inspect,
diagnose, calibrate --delay, navigate without and with the arms, compare), with the installed
``sizefx`` next to this Python, in a temporary folder that links ``examples`` to the
repository's. Every figure is read from what the commands write: diagnose's, calibrate's and
compare's ``--json`` files, the navigation files' ``summary_json``, ``sizefx inspect --json -``
on the imported file (the walk's ``inspect`` prints text), and the import's one-line summary
(``import csv`` has no JSON). Against the example's truth (``examples/tumble_truth.json``).

Beside the walk, four measurements the page quotes, each from the installed ``sizefx``:

- the compensated navigation again with ``--output-rate-hz 0``: its attitude error against the
  reference at every navigation step (slerp between reference samples, as ``navigate`` does),
  where it peaks and its largest outside the occlusion; the same for the walk's 10 Hz
  solutions, where ``compare`` puts its peaks;
- an ideal tumble (``sizefx simulate tumble --ideal``: noise-free sensors at one point, the
  example's rates) navigated as the walk's plain ``navigate``: the navigation's own error;
- ``sizefx calibrate --delay`` on the simulated HDF5 file the CSVs were written from
  (``examples/make_example.py``'s command) against the walk's on the imported CSVs: how much
  the CSV round trip (printed digits, the occlusion left out) moves the arms.

Deterministic: a re-run on the same software gives the same figures.
"""

from __future__ import annotations

import argparse
import json
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

from sizefx.constants import DEG_PER_H, MICRO_G
from sizefx.io.navigation import read_navigation
from sizefx.io.telemetry import read_telemetry
from sizefx.rotation import quat_angle_between, quat_interp

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "examples"))
from make_example import SIMULATE  # noqa: E402  (the example's simulation, as the CSVs were made)
from test_own_recording import (  # noqa: E402  (the walk as the test reads it)
    README,
    check_steps,
    find_step,
    readme_commands,
)

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _measure import add_output_options, emit  # noqa: E402  (a sibling of this script)

SIZEFX = Path(sys.executable).with_name("sizefx")
EXAMPLES = ROOT / "examples"
#: The ideal counterpart of the example: the same scenario and rates, perfect sensors at one point.
IDEAL = ["simulate", "tumble", "--rate-hz", "100", "--reference-rate-hz", "50", "--ideal", "--quiet"]


def run(argv: list, cwd: Path) -> subprocess.CompletedProcess:
    """``sizefx ARGS`` (``argv[0]`` is ``sizefx``) in ``cwd``; a failure stops the benchmark."""
    done = subprocess.run([str(SIZEFX), *argv[1:]], cwd=cwd, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{shlex.join(argv)} -> {done.returncode}: {done.stderr.strip()}")
    return done


def option(argv: list, name: str) -> str:
    return argv[argv.index(name) + 1]


def summary(path: Path) -> dict:
    """A navigation file's summary (``sizefx navigate`` writes it as the root attribute ``summary_json``)."""
    with h5py.File(path, "r") as h5:
        return json.loads(h5.attrs["summary_json"])


def attitude_error(solution: Path, ref, gaps: list) -> dict:
    """The solution's attitude against the reference (slerp between its samples) at the solution's
    rows: the largest, when, and the largest outside the reference's gaps ``[(start, end)]``."""
    sol = read_navigation(solution)
    err = np.degrees(quat_angle_between(quat_interp(ref.time_s, ref.quat_nb, sol.time_s), sol.quat_nb))
    inside = np.zeros(err.size, dtype=bool)
    for start, end in gaps:
        inside |= (sol.time_s > start + 1e-9) & (sol.time_s < end - 1e-9)
    k = int(np.argmax(err))
    return {
        "rows": int(err.size),
        "max_deg": float(err[k]),
        "time_of_max_s": float(sol.time_s[k]),
        "max_in_a_gap": bool(inside[k]),
        "rows_in_gaps": int(inside.sum()),
        "max_outside_gaps_deg": float(err[~inside].max()),
    }


def arms(levers: dict) -> tuple[np.ndarray, np.ndarray]:
    """Calibrate's nine arms and their sigmas [m], rows accelerometer x, y, z."""
    return (
        np.array([levers["r_x"], levers["r_y"], levers["r_z"]]),
        np.array([levers["sigma_x"], levers["sigma_y"], levers["sigma_z"]]),
    )


def walk(tmp: Path) -> dict:
    commands = readme_commands(README.read_text("utf-8"))
    check_steps(commands)
    (tmp / "examples").symlink_to(EXAMPLES, target_is_directory=True)
    done, walls = [], []
    for argv in commands:
        t0 = time.perf_counter()
        done.append((argv, run(argv, tmp)))
        walls.append(time.perf_counter() - t0)
        print(f"  {time.perf_counter() - t0:5.1f} s  {shlex.join(argv)}", file=sys.stderr)
    truth_doc = json.loads((EXAMPLES / "tumble_truth.json").read_text("utf-8"))["simulation"]["effects"]
    truth_r = np.array(truth_doc["lever_arm"]["r_m"])
    truth_tau = truth_doc["accel_delay"]["tau_s"]
    out = {"walk": [shlex.join(a) for a, _ in done], "walk_wall_s": sum(walls)}

    # import csv: its one-line summary (it writes no JSON)
    argv, result = find_step(done, "import csv")
    record = option(argv, "-o")
    out["import"] = {"printed": result.stdout.splitlines()[0]}

    # inspect: the walk's prints text; the same summary as JSON
    info = json.loads(run(["sizefx", "inspect", record, "--json", "-"], tmp).stdout)
    out["inspect"] = {
        "samples": info["samples"],
        "sample_rate_hz": info["sample_rate_hz"],
        "duration_s": info["duration_s"],
        "reference_samples": info["reference"]["samples"],
        "reference_rate_hz": info["reference"]["rate_hz"],
        "gaps": [
            {"dataset": g["dataset"], "time_s": g["time_s"], "duration_ms": g["duration_s"] * 1e3} for g in info["gaps"]
        ],
    }
    gaps = [(g["time_s"], g["time_s"] + g["duration_s"]) for g in info["gaps"]]

    # diagnose --json
    argv, _ = find_step(done, "diagnose")
    report = json.loads((tmp / option(argv, "--json")).read_text())
    found = {(e["id"], e["channel"]): e for e in report["effects"]}
    delay, arm = found[("accel_delay", None)], found[("lever_arm", "accel_y")]
    r_y, s_y = np.array(arm["parameters"]["r_m"]), np.array(arm["sigma"]["r_m"])
    out["diagnose"] = {
        "found": [f"{i}/{c}" if c else i for i, c in found],
        "delay_us": delay["parameters"]["tau_s"] * 1e6,
        "delay_sigma_us": delay["sigma"]["tau_s"] * 1e6,
        "delay_z": (delay["parameters"]["tau_s"] - truth_tau) / delay["sigma"]["tau_s"],
        "arm_y_mm": (r_y * 1e3).tolist(),
        "arm_y_sigma_mm": (s_y * 1e3).tolist(),
        "arm_y_from_nominal_mm": ((r_y - np.array(arm["nominal"]["r_m"])) * 1e3).tolist(),
        "arm_y_abs_z": np.abs((r_y - truth_r[1]) / s_y).tolist(),
        "accel_residual_ug": {
            when: {c[-1]: report[f"residual_rms_{when}"][c] / MICRO_G for c in ("accel_x", "accel_y", "accel_z")}
            for when in ("before", "after")
        },
        "gyro_residual_deg_per_h": {
            when: {c[-1]: report[f"residual_rms_{when}"][c] / DEG_PER_H for c in ("gyro_x", "gyro_y", "gyro_z")}
            for when in ("before", "after")
        },
        "warnings": [w["kind"] for w in report["warnings"]],
    }

    # calibrate --delay --json
    cal_argv, _ = find_step(done, "calibrate")
    levers = json.loads((tmp / option(cal_argv, "--json")).read_text())
    r, s = arms(levers)
    z = np.abs(r - truth_r) / s
    out["calibrate"] = {
        "r_mm": (r * 1e3).tolist(),
        "sigma_mm": (s * 1e3).tolist(),
        "truth_mm": (truth_r * 1e3).tolist(),
        "abs_z": z.tolist(),
        "max_abs_z": float(z.max()),
        "sigma_mm_min": float(s.min() * 1e3),
        "sigma_mm_max": float(s.max() * 1e3),
        "delay_us": levers["accel_delay_s"] * 1e6,
        "delay_sigma_us": levers["sigma_accel_delay_s"] * 1e6,
        "delay_from_truth_us": (levers["accel_delay_s"] - truth_tau) * 1e6,
        "delay_z": (levers["accel_delay_s"] - truth_tau) / levers["sigma_accel_delay_s"],
        "per_rotation_rows": sum(len(v) for v in levers["per_rotation"].values()),
    }

    # navigate, twice: the solutions' summaries
    ref = read_telemetry(tmp / record).reference
    plain_argv, _ = find_step(done, "navigate", lacks="--levers")
    comp_argv, _ = find_step(done, "navigate", has="--levers")
    plain, comp = tmp / option(plain_argv, "-o"), tmp / option(comp_argv, "-o")
    every = comp_argv[: comp_argv.index("-o")] + ["--output-rate-hz", "0", "-o", "every_step.h5"]
    run(every, tmp)
    out["navigate"] = {
        "plain": summary(plain),
        "compensated": summary(comp),
        "compensated_every_step": {"command": shlex.join(every), **attitude_error(tmp / "every_step.h5", ref, gaps)},
        "ideal": ideal(tmp, plain_argv, record),
    }

    # compare --json
    argv, _ = find_step(done, "compare")
    doc = json.loads((tmp / option(argv, "--json")).read_text())
    names = {
        f"{comp.name} vs REF": "compensated_vs_reference",
        f"{plain.name} vs REF": "plain_vs_reference",
        f"{comp.name} vs {plain.name}": "compensated_vs_plain",
    }
    out["compare"] = {}
    for c in doc["comparisons"]:
        label = names[f"{c['a']} vs {'REF' if c['b'] == record else c['b']}"]
        out["compare"][label] = {k: v for k, v in c.items() if k != "label"}
    for name, path in (("compensated_vs_reference", comp), ("plain_vs_reference", plain)):
        out["compare"][name]["attitude_at_the_rows"] = attitude_error(path, ref, gaps)

    out["simulated_vs_imported"] = simulated_vs_imported(tmp, levers, cal_argv, record)
    return out


def ideal(tmp: Path, plain_argv: list, record: str) -> dict:
    """An ideal tumble navigated as the walk's plain ``navigate``: its summary."""
    run(["sizefx", *IDEAL, "-o", "ideal.h5"], tmp)
    argv = [("ideal.h5" if a == record else a) for a in plain_argv]
    argv[argv.index("-o") + 1] = "ideal_nav.h5"
    run(argv, tmp)
    return {
        "simulate": shlex.join(["sizefx", *IDEAL, "-o", "ideal.h5"]),
        "navigate": shlex.join(argv),
        **summary(tmp / "ideal_nav.h5"),
    }


def simulated_vs_imported(tmp: Path, levers: dict, argv: list, record: str) -> dict:
    """The walk's calibrate command on the simulated file the CSVs come from, against the walk's result."""
    run(["sizefx", *SIMULATE, "-o", "simulated.h5"], tmp)
    cal = [("simulated.h5" if a == record else a) for a in argv]
    cal[cal.index("--json") + 1] = "levers_simulated.json"
    run(cal, tmp)
    sim = json.loads((tmp / "levers_simulated.json").read_text())
    (r_csv, _), (r_sim, s_sim) = arms(levers), arms(sim)
    return {
        "simulate": shlex.join(["sizefx", *SIMULATE, "-o", "simulated.h5"]),
        "calibrate": shlex.join(cal),
        "max_arm_difference_mm": float(np.abs(r_csv - r_sim).max() * 1e3),
        "arm_difference_mm": ((r_csv - r_sim) * 1e3).tolist(),
        "sigma_mm_min": float(s_sim.min() * 1e3),
        "sigma_mm_max": float(s_sim.max() * 1e3),
        "delay_difference_us": (levers["accel_delay_s"] - sim["accel_delay_s"]) * 1e6,
    }


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_output_options(ap)
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        figures = walk(Path(tmp))
    d, c, n, m = figures["diagnose"], figures["calibrate"], figures["navigate"], figures["compare"]
    print(
        f"diagnose: delay {d['delay_us']:.2f} +- {d['delay_sigma_us']:.2f} us, "
        f"r_y = {d['arm_y_mm'][1]:.4f} +- {d['arm_y_sigma_mm'][1]:.4f} mm\n"
        f"calibrate: max |z| {c['max_abs_z']:.2f}, sigma {c['sigma_mm_min']:.4f}..{c['sigma_mm_max']:.4f} mm, "
        f"delay {c['delay_us']:.2f} +- {c['delay_sigma_us']:.2f} us\n"
        f"navigate: plain {n['plain']['final_horizontal_error_m']:.4g} m, compensated "
        f"{n['compensated']['final_horizontal_error_m']:.4g} m, ideal {n['ideal']['final_horizontal_error_m']:.4g} m\n"
        f"compare: compensated vs reference {m['compensated_vs_reference']['horizontal_m']['final']:.4g} m\n"
        f"simulated vs imported: arms differ by {figures['simulated_vs_imported']['max_arm_difference_mm']:.2g} mm",
        file=sys.stderr,
    )
    return emit(figures, args, __file__, argv)


if __name__ == "__main__":
    sys.exit(main())
