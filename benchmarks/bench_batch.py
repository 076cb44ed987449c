"""Benchmark: ``sizefx batch navigate`` over a campaign, one worker against all cores (issue 18, item 3).

    python benchmarks/bench_batch.py [--records 8] [--duration-h 1.8] [--file flight.h5] [--repeat 3] [--json out.json] [--record]

Without --file it simulates one flight of --duration-h at 1600 Hz and makes --records copies of it
(a campaign of that flight). The baseline is today's way, one after another: ``sizefx navigate``
once per record, a process each, as a shell loop runs them. Each batch run is ``sizefx batch navigate RECORDS --out DIR --workers N``
as a whole process (Python start-up, the workers' start and their kernels from the cache, every
record, the manifest), ``--redo`` after the first, for N = 1 and N = the cores: wall time, records
and samples per second, the speed-up, the batch process tree's peak memory, and the records' own
peak memory from the manifest; the speed-ups over one after another and over one worker (medians
over ``--repeat`` interleaved runs of each way).
Measured, never asserted (the issue's target: 8 records of the 1.8 h flight at least 1.8 times
faster on 2 cores than one after another).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
from pathlib import Path

import h5py
import numpy as np
from _measure import add_output_options, emit, run_measured

from sizefx.scenarios import FlightPlan
from sizefx.simulate import SimulateConfig
from sizefx.simulate import run as simulate


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--records", type=int, default=8)
    ap.add_argument("--duration-h", type=float, default=1.8)
    ap.add_argument("--file", type=Path, help="A telemetry file to copy (default: simulate a flight).")
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1, help="The parallel run's workers.")
    ap.add_argument(
        "--repeat",
        type=int,
        default=1,
        help="Run each way this many times (interleaved) and report the medians and every run.",
    )
    add_output_options(ap)
    args = ap.parse_args(argv)
    sizefx = Path(sys.executable).with_name("sizefx")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        source = args.file
        if source is None:
            source = tmp / "flight.h5"
            simulate(
                SimulateConfig(
                    "flight",
                    source,
                    plan=FlightPlan(duration_s=args.duration_h * 3600.0, align_s=min(600.0, args.duration_h * 360.0)),
                )
            )
        campaign = tmp / "campaign"
        campaign.mkdir()
        for k in range(args.records):
            shutil.copyfile(source, campaign / f"flight{k:02d}.h5")
        with h5py.File(source) as f:
            samples = int(f["/imu/time"].shape[0])
        # today's way, one after another: a process per record, as a shell loop runs them
        serial_dir = tmp / "serial"
        serial_dir.mkdir()
        loop_walls, loop_peak, batch_walls, runs = [], 0.0, {}, {}
        for _ in range(args.repeat):  # interleaved, so that a slow spell of the machine hits each way alike
            loop_wall = 0.0
            for record in sorted(campaign.iterdir()):
                wall, peak = run_measured(
                    [
                        sizefx,
                        "navigate",
                        record,
                        "-o",
                        serial_dir / f"{record.stem}.nav.h5",
                        "--json",
                        serial_dir / f"{record.stem}.json",
                        "-q",
                        "--force",
                    ]
                )
                loop_wall, loop_peak = loop_wall + wall, max(loop_peak, peak)
            loop_walls.append(loop_wall)
            for workers in (1, args.workers):
                out = tmp / f"out{workers}"
                wall, peak = run_measured(
                    [sizefx, "batch", "navigate", campaign, "--out", out, "--workers", workers, "--redo", "-q"]
                )
                batch_walls.setdefault(workers, []).append(wall)
                manifest = json.loads((out / "manifest.json").read_text())
                ok = sum(e["status"] == "ok" for e in manifest["records"])
                runs[workers] = {
                    "workers": workers,
                    "records_ok": ok,
                    "peak_mib_of_the_batch_process": peak,
                    "record_peak_mib_max": max(e["peak_memory_mib"] for e in manifest["records"]),
                    "record_duration_s": [round(e["duration_s"], 2) for e in manifest["records"]],
                }
        loop_wall = float(np.median(loop_walls))
        for workers, walls in batch_walls.items():
            wall = float(np.median(walls))
            runs[workers].update(
                {
                    "wall_s": wall,
                    "wall_s_each": [round(w, 2) for w in walls],
                    "records_per_s": args.records / wall,
                    "samples_per_s": args.records * samples / wall,
                }
            )
        result = {
            "benchmark": "sizefx batch navigate (issue 18)",
            "records": args.records,
            "samples_per_record": samples,
            "duration_h": samples / 1600.0 / 3600.0,
            "repeat": args.repeat,
            "one_after_another": {
                "wall_s": loop_wall,
                "wall_s_each": [round(w, 2) for w in loop_walls],
                "peak_mib": loop_peak,
                "samples_per_s": args.records * samples / loop_wall,
            },
            "runs": list(runs.values()),
            "speed_up_over_one_after_another": loop_wall / runs[args.workers]["wall_s"],
            "speed_up_over_one_worker": runs[1]["wall_s"] / runs[args.workers]["wall_s"],
            "cores": os.cpu_count(),
        }
    return emit(result, args, __file__, argv, threads=args.workers)


if __name__ == "__main__":
    sys.exit(main())
