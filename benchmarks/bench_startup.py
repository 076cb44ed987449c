"""Benchmark: how long ``sizefx --help`` and every ``sizefx CMD --help`` take to answer.

    python benchmarks/bench_startup.py [--repeat 7] [--json out.json] [--record]

Each command runs in a fresh process through the installed console script (the one next to
this Python), ``--repeat`` times after one warm-up run; the figure is the median wall time,
with the minimum and maximum, and the peak memory of the slowest command. The target is
under 0.3 s for each on 2 cores. Timings are printed, never asserted; the test suite checks
the cause instead (``tests/test_cli.py``: no numpy, numba, scipy, h5py or matplotlib is
imported for ``--help``).

Before timing, each command must exit 0 and print its usage (a fast failure is not a fast
start).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _measure import add_output_options, emit, run_measured

#: Every command path of the CLI (the group, each command, each scenario and importer).
COMMANDS = (
    [
        [],
        ["calibrate"],
        ["compare"],
        ["compensate"],
        ["demo"],
        ["diagnose"],
        ["import"],
        ["inspect"],
        ["navigate"],
        ["paper"],
        ["simulate"],
    ]
    + [["simulate", s] for s in ("turntable", "sway", "flight", "tumble")]
    + [["import", f] for f in ("broad", "psins-imu", "psins-mat", "csv", "ulog")]
)
TARGET_S = 0.3


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=7, help="timed runs per command (after one warm-up)")
    add_output_options(ap)
    args = ap.parse_args(argv)
    exe = Path(sys.executable).with_name("sizefx")
    if not exe.exists():
        print(f"bench_startup: no console script at {exe}; install sizefx into this Python first", file=sys.stderr)
        return 2
    rows = []
    for path in COMMANDS:
        cmd = [str(exe), *path, "--help"]
        done = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, "COLUMNS": "100"})
        if done.returncode != 0 or "Usage:" not in done.stdout:
            print(f"bench_startup: {' '.join(cmd)} failed: {done.stderr.strip()}", file=sys.stderr)
            return 1
        times = []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            subprocess.run(cmd, check=True, capture_output=True)
            times.append(time.perf_counter() - t0)
        rows.append(
            {
                "command": " ".join(["sizefx", *path, "--help"]),
                "median_s": round(statistics.median(times), 4),
                "min_s": round(min(times), 4),
                "max_s": round(max(times), 4),
            }
        )
    slowest = max(rows, key=lambda r: r["median_s"])
    _, peak_mib = run_measured([exe, *slowest["command"].split()[1:]])
    result = {
        "benchmark": "startup",
        "repeat": args.repeat,
        "target_s": TARGET_S,
        "slowest": slowest["command"],
        "slowest_median_s": slowest["median_s"],
        "slowest_peak_mib": round(peak_mib, 1),
        "fastest_median_s": min(r["median_s"] for r in rows),
        "all_under_target": all(r["median_s"] < TARGET_S for r in rows),
        "commands": rows,
    }
    return emit(result, args, __file__, argv)


if __name__ == "__main__":
    sys.exit(main())
