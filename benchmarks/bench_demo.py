"""Benchmark: ``sizefx demo`` end to end, wall time and peak memory with the Numba cache warm.

    python benchmarks/bench_demo.py [--repeat 2] [--json out.json] [--record]

The demo is the README's first command. It runs once as a warm-up (Numba compiles its kernels
into the on-disk cache, or loads them), then ``--repeat`` times, each in a fresh process through
the console script next to this Python, in a fresh folder; each run's wall time and peak RSS
(of the demo's process, measured from a small intermediate process) is reported, with the
median and the largest peak. Correctness first: every run must print what the demo finds
(the accelerometer y's arm, the accelerometers' lag) and draw its plots, as CI checks.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _measure import add_output_options, emit, run_measured  # (a sibling of this script)

#: What the demo must print and draw (the checks of .ci/run).
PRINTS = ("accelerometer y sits", "lag the gyros by", "demo finished in")
PLOTS = (
    "fig6_turntable_compensation.png",
    "fig9_sway_position.png",
    "flight_horizontal_error.png",
    "diagnosis/residuals.png",
)


def check(printed: str, folder: Path) -> None:
    """What the demo must have printed and drawn."""
    missing = [p for p in PRINTS if p not in printed] + [p for p in PLOTS if not (folder / p).is_file()]
    assert not missing, f"wrong answer: the demo's output lacks {missing}"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=2, help="measured runs after the warm-up")
    add_output_options(ap)
    args = ap.parse_args(argv)
    exe = Path(sys.executable).with_name("sizefx")
    if not exe.exists():
        print(f"bench_demo: no console script at {exe}; install sizefx into this Python first", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory() as tmp:
        walls, peaks = [], []
        for k in range(args.repeat + 1):  # the first is the warm-up
            folder, printed = Path(tmp) / f"run{k}", Path(tmp) / f"run{k}.txt"
            wall, peak = run_measured([exe, "demo", "--out", folder], stdout=printed)
            check(printed.read_text(), folder)
            walls.append(wall)
            peaks.append(peak)
        warm_up_s = walls.pop(0)
        peaks.pop(0)
    result = {
        "benchmark": "sizefx demo, Numba cache warm",
        "measured_command": "sizefx demo",
        "repeat": args.repeat,
        "warm_up_s": round(warm_up_s, 1),
        "wall_s": round(statistics.median(walls), 1),
        "wall_s_each": [round(w, 1) for w in walls],
        "peak_mib": round(max(peaks), 1),
        "peak_gib": round(max(peaks) / 1024, 2),
        "peak_mib_each": [round(p, 1) for p in peaks],
    }
    return emit(result, args, __file__, argv)


if __name__ == "__main__":
    sys.exit(main())
