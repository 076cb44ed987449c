"""Benchmark: the navigation kernel on the simulated 1.8 h, 1600 Hz flight.

    python benchmarks/bench_navigate.py [--file flight.h5] [--repeat 3] [--json out.json] [--record]
    python benchmarks/bench_navigate.py --against-floor [--file flight.h5] [--repeat 5] [--record floor]

Checks the answer first (ideal flight: final horizontal error < 1 m), then times the
kernel alone on warm JIT code (best of --repeat), reporting the first call (JIT
compile or cache load) apart, samples per second for 1, 2 and 4 sub-samples, the
end-to-end `navigate` wall time, and peak memory.

``--against-floor``: ``sizefx navigate`` of the flight with the paper's high-precision lever arms
against the floor, ``shared/tools/floor_kernel.py`` beside the checkout (a lean single-speed
strapdown loop on the record's increments already in memory; ``SIZEFX_FLOOR_KERNEL`` names
another copy): the floor (its own best of 3, run --repeat times), the navigation in this process
(:func:`sizefx.navigate.run` with an output file, warm JIT, the file in the page cache) and the
whole command in a fresh process (interpreter start, imports and the JIT cache load included, with
its peak memory), interleaved run by run so that all three see the machine alike; medians and
their ratios to the floor's.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from sizefx.io.telemetry import read_telemetry
from sizefx.kernels.strapdown import VERTICAL_REFERENCE, coning_coefficients, pack_state, strapdown
from sizefx.navigate import NavConfig, increments_of, navigate
from sizefx.simulate import SimulateConfig
from sizefx.simulate import run as simulate

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _measure import add_output_options, emit, run_measured  # (a sibling of this script)

#: The floor a navigator's speed is held against (see the module docstring).
FLOOR_KERNEL = Path(
    os.environ.get("SIZEFX_FLOOR_KERNEL", Path(__file__).resolve().parents[2] / "shared" / "tools" / "floor_kernel.py")
)


def time_kernel(dtheta, dvel, dt, n_sub, repeat):
    n = dtheta.shape[0] // n_sub
    outs = [np.empty((n, 4)), np.empty((n, 3)), np.empty(n), np.empty(n), np.empty(n)]
    h_ref, vd_ref = np.full(n, 300.0), np.zeros(n)
    best = np.inf
    for _ in range(repeat):
        state = pack_state([1.0, 0, 0, 0], np.zeros(3), 1.0, 1.0, 300.0)
        t0 = time.perf_counter()
        strapdown(
            dtheta,
            dvel,
            n_sub,
            coning_coefficients(n_sub),
            n_sub * dt,
            state,
            VERTICAL_REFERENCE,
            0.0,
            h_ref,
            vd_ref,
            *outs,
        )
        best = min(best, time.perf_counter() - t0)
    return best


def against_floor(path: Path, tmp: Path, repeat: int) -> dict:
    """``sizefx navigate`` with lever arms, in this process and as a command, against the floor."""
    from sizefx.levers import levers_from_preset, write_levers
    from sizefx.navigate import NavigateConfig
    from sizefx.navigate import run as navigate_run

    if not FLOOR_KERNEL.is_file():
        raise SystemExit(
            f"the floor kernel {FLOOR_KERNEL} is missing: put shared/ beside the checkout or set SIZEFX_FLOOR_KERNEL"
        )
    levers = tmp / "levers.json"
    write_levers(levers, levers_from_preset("high-precision"))
    exe = Path(sys.executable).with_name("sizefx")

    def floor() -> float:
        done = subprocess.run([sys.executable, FLOOR_KERNEL, path], check=True, capture_output=True, text=True)
        return float(done.stdout.split()[-1])

    def in_process() -> float:
        out = tmp / "in-process.h5"
        out.unlink(missing_ok=True)
        t0 = time.perf_counter()
        navigate_run(NavigateConfig(str(path), options=NavConfig(levers=str(levers)), output=str(out)))
        return time.perf_counter() - t0

    def command() -> tuple[float, float]:
        out = tmp / "command.h5"
        out.unlink(missing_ok=True)
        return run_measured([exe, "navigate", path, "--levers", levers, "-o", out, "--quiet"])

    in_process(), command()  # the JIT cache and the page cache, for all that follows
    runs: dict[str, list] = {
        "floor_s": [],
        "navigate_in_process_s": [],
        "navigate_command_s": [],
        "command_peak_mib": [],
    }
    for _ in range(repeat):
        runs["floor_s"].append(floor())
        runs["navigate_in_process_s"].append(in_process())
        wall, peak = command()
        runs["navigate_command_s"].append(wall)
        runs["command_peak_mib"].append(peak)
    med = {k: statistics.median(v) for k, v in runs.items()}
    return {
        "benchmark": "sizefx navigate of the 1.8 h 1600 Hz flight with lever arms against the floor kernel",
        "floor_kernel": str(FLOOR_KERNEL.name),
        "runs": {k: [round(x, 3) for x in v] for k, v in runs.items()},
        "median": {k: round(v, 3) for k, v in med.items()},
        "in_process_over_floor": round(med["navigate_in_process_s"] / med["floor_s"], 2),
        "command_over_floor": round(med["navigate_command_s"] / med["floor_s"], 2),
        "command_start_s": round(med["navigate_command_s"] - med["navigate_in_process_s"], 3),
    }


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--file", type=Path, help="An ideal simulated flight (default: simulate one, ~40 s).")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--against-floor", action="store_true", help="navigate with lever arms against the floor kernel")
    add_output_options(ap)
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        path = args.file
        if path is None:
            path = Path(tmp) / "flight.h5"
            simulate(SimulateConfig("flight", path, ideal=True))
        if args.against_floor:
            return emit(against_floor(path, Path(tmp), args.repeat), args, __file__, argv, threads=2)
        tel = read_telemetry(path)
        # the first call compiles (or loads the cache): timed apart
        t0 = time.perf_counter()
        tiny = np.zeros((8, 3))
        time_kernel(tiny, tiny + [0, 0, -9.8e-3], 1 / 1600, 4, 1)
        first_call_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        res = navigate(tel, NavConfig(subsamples=4))
        navigate_s = time.perf_counter() - t0
        err = res.summary["final_horizontal_error_m"]
        assert err is not None and err < 1.0, f"wrong answer: final horizontal error {err} m"
        _, dtheta, dvel, dt, _ = increments_of(tel)
        result = {
            "benchmark": "navigate kernel, 1.8 h flight at 1600 Hz",
            "samples": int(dtheta.shape[0]),
            "check_final_horizontal_error_m": err,
            "first_call_s": round(first_call_s, 3),
            "navigate_in_memory_s": round(navigate_s, 3),
        }
        for k in (1, 2, 4):
            best = time_kernel(dtheta, dvel, dt, k, args.repeat)
            result[f"kernel_s_subsamples_{k}"] = round(best, 4)
            result[f"samples_per_s_subsamples_{k}"] = round(dtheta.shape[0] / best)
        result["peak_rss_mib"] = round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0, 1)
    return emit(result, args, __file__, argv)


if __name__ == "__main__":
    sys.exit(main())
