"""Benchmark: ``sizefx diagnose`` end to end, wall time and peak memory against the record's length.

    python benchmarks/bench_diagnose_memory.py [--durations-s 120 625 1875 3750] [--dir DIR] [--keep DIR]
                                               [--json out.json] [--record]

Writes the two-minute record of ``benchmarks/accuracy_diagnose.py``'s runtime section (a 1600 Hz
tumble, ``--seed 3``, an accelerometer delay and a y-arm off the nominal geometry) at each length
with ``sizefx simulate tumble --duration-s``, then runs ``sizefx diagnose REC --json J`` on each in
a fresh process and reports its wall time, samples per second and peak RSS (measured from a small
intermediate process, :func:`_measure.run_measured`), and the peak's growth per million samples
between consecutive lengths: what the record costs beyond the constant part.

Correctness first: every record must give back the two hidden effects (``lever_arm`` on accel_y
and ``accel_delay``). A 10 s record is diagnosed first as a warm-up (Numba's cached kernels
loaded, the OS's file cache warm); its wall time is reported apart. Timings are reported, never
asserted (the limit, 19.6 s for the two-minute record, is checked by a person).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _measure import add_output_options, emit, run_measured

RATE_HZ = 1600.0
HIDDEN = ["--seed", "3", "--set", "accel_delay.enabled=true", "--set", "lever_arm.d_y_m=[0.003,0.0274,-0.002]"]
EXPECTED = {("lever_arm", "accel_y"), ("accel_delay", None)}


def simulate(exe: Path, path: Path, duration_s: float) -> float:
    started = time.perf_counter()
    run_measured(
        [
            exe,
            "simulate",
            "tumble",
            "-o",
            path,
            "--quiet",
            "--force",
            "--rate-hz",
            RATE_HZ,
            "--duration-s",
            duration_s,
            *HIDDEN,
        ]
    )
    return time.perf_counter() - started


def diagnose(exe: Path, path: Path) -> dict:
    js = path.with_suffix(".json")
    wall, peak_mib = run_measured(
        [exe, "diagnose", path, "--json", js, "--model-out", path.with_suffix(".toml"), "--force"]
    )
    doc = json.loads(js.read_text())
    found = {(e["id"], e.get("channel")) for e in doc["effects"]}
    missing = EXPECTED - found
    assert not missing, (
        f"{path.name}: wrong answer, {sorted(missing, key=str)} not found (found {sorted(found, key=str)})"
    )
    return {
        "samples": doc["samples"],
        "wall_s": round(wall, 2),
        "samples_per_s": round(doc["samples"] / wall),
        "peak_mib": round(peak_mib, 1),
        "found": sorted(f"{i}:{c}" if c else i for i, c in found),
    }


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--durations-s",
        type=float,
        nargs="+",
        default=[120.0, 625.0, 1875.0, 3750.0],
        help="record lengths [s] at 1600 Hz (default: 0.19, 1, 3 and 6 M samples)",
    )
    ap.add_argument("--dir", type=Path, help="where to write the records (default: a temporary folder)")
    ap.add_argument("--keep", type=Path, help="reuse and keep the records in this folder")
    ap.add_argument(
        "--exe",
        type=Path,
        default=Path(sys.executable).with_name("sizefx"),
        help="the sizefx command to measure (default: the one next to this Python)",
    )
    add_output_options(ap)
    args = ap.parse_args(argv)
    exe = args.exe
    with tempfile.TemporaryDirectory(dir=args.dir) as tmp:
        folder = args.keep or Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        warm = folder / "tumble_10s.h5"
        simulate(exe, warm, 10.0)
        warm_wall, _ = run_measured([exe, "diagnose", warm, "--model-out", warm.with_suffix(".toml"), "--force"])
        rows = []
        for duration_s in args.durations_s:
            path = folder / f"tumble_{duration_s:g}s.h5"
            write_s = None
            if not path.exists():
                write_s = round(simulate(exe, path, duration_s), 1)
            row = {"duration_s": duration_s, **diagnose(exe, path), "simulate_s": write_s}
            rows.append(row)
            print(
                f"{row['samples']:>9} samples  {row['wall_s']:7.1f} s  {row['samples_per_s']:>7} samples/s  "
                f"peak {row['peak_mib']:7.1f} MiB",
                file=sys.stderr,
                flush=True,
            )
        for a, b in zip(rows[:-1], rows[1:]):
            b["mib_per_m_samples_since_previous"] = round(
                (b["peak_mib"] - a["peak_mib"]) / ((b["samples"] - a["samples"]) / 1e6), 1
            )
    result = {
        "benchmark": "sizefx diagnose end to end against the record's length (tumble, 1600 Hz)",
        "command": "sizefx diagnose REC --json J",
        "warm_up_10s_wall_s": round(warm_wall, 2),
        "records": rows,
    }
    return emit(result, args, __file__, argv)


if __name__ == "__main__":
    sys.exit(main())
