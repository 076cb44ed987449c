"""Benchmark: ``sizefx batch navigate`` over a campaign, one worker against all cores.

    python benchmarks/bench_batch.py [--records 8] [--duration-h 1.8] [--file flight.h5] [--repeat 3] [--json out.json] [--record]

Without --file it simulates one flight of --duration-h at 1600 Hz and makes --records copies of it
(a campaign of that flight). The baseline is today's way, one after another: ``sizefx navigate``
once per record, a process each, as a shell loop runs them. Each batch run is ``sizefx batch navigate RECORDS --out DIR --workers N``
as a whole process (Python start-up, the workers' start and their kernels from the cache, every
record, the manifest), ``--redo`` after the first, for N = 1 and N = the cores: wall time, records
and samples per second, the speed-up, the batch process tree's peak memory, and the records' own
peak memory from the manifest; the speed-ups over one after another and over one worker (medians
over ``--repeat`` interleaved runs of each way).
Measured, never asserted (the target: 8 records of the 1.8 h flight at least 1.8 times
faster on 2 cores than one after another).

    python benchmarks/bench_batch.py --scaling [--records 64] [--rate-hz 800] [--workers-list 1,2,4,8,16] [--dask] [--tmp /dev/shm]

The scaling table: ``sizefx batch navigate`` of --records copies of the flight at 1, 2, 4,
8, 16 workers (``--redo``, a whole process each, the Numba cache warmed first), with each run's
speed-up over one worker, records and samples per second, the workers' busy fraction and the
records' mean phase times from the manifest (hash, open and checks, initial state, read, kernels,
write, other, outputs); beside it the machine's own ceiling: N copies of the strapdown kernel at
once, each on its record's increments already in memory, as N processes, each copy's median of
CEILING_PASSES passes (the speed-up N copies allow: memory bandwidth, shared cores, clock); with --dask the same batch on a local Dask cluster
of as many one-thread worker processes as the most workers; and the re-run of the finished batch
(nothing changed) against its run, on all the records and on 4.
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
    ap.add_argument("--scaling", action="store_true", help="The scaling table instead.")
    ap.add_argument("--rate-hz", type=float, default=1600.0, help="The simulated flight's IMU rate.")
    ap.add_argument("--workers-list", default="1,2,4,8,16", help="--scaling: the worker counts.")
    ap.add_argument("--dask", action="store_true", help="--scaling: also on a local Dask cluster.")
    ap.add_argument("--tmp", type=Path, help="Folder for the campaign (default: the system's temporary folder).")
    add_output_options(ap)
    args = ap.parse_args(argv)
    sizefx = Path(sys.executable).with_name("sizefx")
    if args.scaling:
        return emit(scaling(args, sizefx), args, __file__, argv, threads=max(_counts(args.workers_list)))
    with tempfile.TemporaryDirectory(dir=args.tmp) as tmp:
        tmp = Path(tmp)
        source = args.file
        if source is None:
            source = tmp / "flight.h5"
            simulate(
                SimulateConfig(
                    "flight",
                    source,
                    plan=FlightPlan(duration_s=args.duration_h * 3600.0, align_s=min(600.0, args.duration_h * 360.0)),
                    rate_hz=args.rate_hz,
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
            "benchmark": "sizefx batch navigate",
            "records": args.records,
            "samples_per_record": samples,
            "duration_h": samples / args.rate_hz / 3600.0,
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


def _counts(text: str) -> list[int]:
    return [int(x) for x in str(text).split(",") if x.strip()]


def _flight(args, folder: Path) -> Path:
    """The flight the campaign copies: --file, or one simulated at --rate-hz."""
    if args.file is not None:
        return args.file
    path = folder / "flight.h5"
    plan = FlightPlan(duration_s=args.duration_h * 3600.0, align_s=min(600.0, args.duration_h * 360.0))
    simulate(SimulateConfig("flight", path, plan=plan, rate_hz=args.rate_hz))
    return path


def _batch_run(sizefx, campaign: Path, out: Path, workers: int | None, *extra) -> tuple[float, dict]:
    """One ``sizefx batch navigate`` as a whole process: its wall time and the manifest it left."""
    cmd = [sizefx, "batch", "navigate", campaign, "--out", out, "-q", *extra]
    wall, _ = run_measured([*cmd, *(["--workers", workers] if workers else [])])
    return wall, json.loads((out / "manifest.json").read_text())


def _summary(manifest: dict, wall: float) -> dict:
    """A run's figures from its manifest: records ok, records and samples per second, the workers'
    busy fractions (seconds on records over the wall time), the records' mean duration and phases [s]."""
    records = manifest["records"]
    busy: dict[str, float] = {}
    phases: dict[str, float] = {}
    for e in records:
        busy[e.get("worker", "?")] = busy.get(e.get("worker", "?"), 0.0) + e["duration_s"] / wall
        for k, v in (e.get("phases_s") or {}).items():
            phases[k] = phases.get(k, 0.0) + v / len(records)
    return {
        "records_ok": sum(e["status"] == "ok" for e in records),
        "records_per_s": len(records) / wall,
        "samples_per_s": sum(e.get("samples") or 0 for e in records) / wall,
        "workers_seen": len(busy),
        "busy_mean": float(np.mean(list(busy.values()))),
        "busy_min": float(min(busy.values())),
        "record_duration_mean_s": float(np.mean([e["duration_s"] for e in records])),
        "record_peak_mib_max": max(e["peak_memory_mib"] for e in records),
        "phases_mean_s": {k: round(v, 4) for k, v in phases.items()},
    }


#: Times each copy of the ceiling runs the kernel over its record once every copy is ready; the copy's
#: median is its time (one pass of 0.2 s moved the 16-copy ceiling from 6.6 to 9.8 between two runs).
CEILING_PASSES = 5


def _kernel_copy(path: str, barrier, queue) -> None:
    """One copy of the ceiling: the record's increments into memory and the kernel loaded, then, when
    every copy is ready, the strapdown kernel over them :data:`CEILING_PASSES` times; the median pass."""
    import time

    from sizefx.kernels.modes import VERTICAL_FREE
    from sizefx.kernels.strapdown import pack_state
    from sizefx.navigate.steps import integrate

    with h5py.File(path, "r") as f:
        t = f["imu/time"][:2]
        dt = float(t[1] - t[0])
        dtheta = np.ascontiguousarray(f["imu/gyro"][...] * dt)
        dvel = np.ascontiguousarray(f["imu/accel"][...] * dt)
        lat0, h0 = np.radians(float(f.attrs["latitude_deg"])), float(f.attrs["height_m"])
    n_sub = 4
    n = (dtheta.shape[0] // n_sub) * n_sub
    none = np.zeros(0)

    def once(m):
        state = pack_state([1.0, 0.0, 0.0, 0.0], np.zeros(3), lat0, 0.0, h0)
        return integrate(dtheta[:m], dvel[:m], n_sub, dt, state, VERTICAL_FREE, h0, none, none)

    once(n_sub * 16)  # the kernel from the cache (or compiled), outside the timing
    barrier.wait()
    passes = []
    for _ in range(CEILING_PASSES):
        t0 = time.perf_counter()
        once(n)
        passes.append(time.perf_counter() - t0)
    queue.put(float(np.median(passes)))


def ceiling(record: Path, copies: list[int]) -> list[dict]:
    """The machine's own scaling: N copies of the strapdown kernel at once, as N processes, each on the
    record's increments in memory; per N the mean and slowest of the copies' median kernel times and
    the speed-up N copies give over one (N times one copy's time over the slowest)."""
    import multiprocessing

    ctx = multiprocessing.get_context("spawn")
    rows = []
    for n in copies:
        barrier, queue = ctx.Barrier(n), ctx.Queue()
        procs = [ctx.Process(target=_kernel_copy, args=(str(record), barrier, queue)) for _ in range(n)]
        for p in procs:
            p.start()
        times = [queue.get() for _ in procs]
        for p in procs:
            p.join()
        rows.append({"copies": n, "kernel_s_mean": float(np.mean(times)), "kernel_s_max": float(max(times))})
    one = rows[0]["kernel_s_max"] if rows and rows[0]["copies"] == 1 else None
    for row in rows:
        row["speed_up"] = row["copies"] * one / row["kernel_s_max"] if one else None
    return rows


def scaling(args, sizefx: Path) -> dict:
    """The scaling table of ``sizefx batch navigate`` (the module's docstring)."""
    counts = _counts(args.workers_list)
    with tempfile.TemporaryDirectory(dir=args.tmp) as tmp:
        tmp = Path(tmp)
        source = _flight(args, tmp)
        with h5py.File(source) as f:
            samples = int(f["/imu/time"].shape[0])
        campaign, small = tmp / "campaign", tmp / "small"
        campaign.mkdir()
        small.mkdir()
        for k in range(args.records):
            shutil.copyfile(source, campaign / f"flight{k:02d}.h5")
        for k in range(min(4, args.records)):
            shutil.copyfile(source, small / f"flight{k:02d}.h5")
        # the Numba cache warm, and the records in the page cache, before anything is timed
        run_measured([sizefx, "navigate", source, "--json", tmp / "warm.json", "-q", "--force"])
        _batch_run(sizefx, campaign, tmp / "warm", max(counts), "--redo")
        runs = []
        for workers in counts:
            out = tmp / f"out{workers}"
            wall, manifest = _batch_run(sizefx, campaign, out, workers, "--redo")
            runs.append({"workers": workers, "wall_s": wall, **_summary(manifest, wall)})
            print(f"{workers} workers: {wall:.2f} s", file=sys.stderr, flush=True)
        base = next((r["wall_s"] for r in runs if r["workers"] == 1), None)
        for r in runs:
            r["speed_up_over_one_worker"] = base / r["wall_s"] if base else None
        result = {
            "benchmark": "sizefx batch navigate scaling",
            "records": args.records,
            "samples_per_record": samples,
            "rate_hz": args.rate_hz,
            "duration_h": samples / args.rate_hz / 3600.0,
            "cores_usable": len(os.sched_getaffinity(0)),
            "runs": runs,
            "ceiling": ceiling(source, counts),
        }
        # a re-run of a finished batch, nothing changed: every record skipped
        most = max(counts)
        rerun, _ = _batch_run(sizefx, campaign, tmp / f"out{most}", most)
        small_run, _ = _batch_run(sizefx, small, tmp / "small_out", None)
        small_rerun, _ = _batch_run(sizefx, small, tmp / "small_out", None)
        result["rerun"] = [
            {"records": args.records, "workers": most, "run_s": runs[-1]["wall_s"], "rerun_s": rerun},
            {"records": min(4, args.records), "workers": None, "run_s": small_run, "rerun_s": small_rerun},
        ]
        for r in result["rerun"]:
            r["ratio"] = r["rerun_s"] / r["run_s"]
        if args.dask:
            result["dask"] = _dask(sizefx, campaign, tmp / "dask_out", most, runs[-1]["wall_s"])
    return result


def _dask(sizefx: Path, campaign: Path, out: Path, workers: int, local_wall: float) -> dict:
    """The batch on a local Dask cluster of ``workers`` one-thread worker processes, started and warmed
    before the timing (a cluster serves many batches)."""
    from distributed import LocalCluster

    with LocalCluster(
        n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None, scheduler_port=0
    ) as cluster:
        address = cluster.scheduler_address
        _batch_run(sizefx, campaign, out, None, "--redo", "--scheduler", address)  # the workers' kernels warm
        wall, manifest = _batch_run(sizefx, campaign, out, None, "--redo", "--scheduler", address)
    return {"workers": workers, "wall_s": wall, "over_local_workers": wall / local_wall, **_summary(manifest, wall)}


if __name__ == "__main__":
    sys.exit(main())
