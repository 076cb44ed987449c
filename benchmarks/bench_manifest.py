"""Benchmark: a batch's bookkeeping per record, from 100 records to a million.

    python benchmarks/bench_manifest.py [--records 100 10000 100000 1000000] [--json FILE] [--record]

What a batch does for each record besides running its stage, on the store a batch folder keeps
(:class:`sizefx.batch.manifest.Manifest`, ``manifest.sqlite``), with entries the size of a
navigate record's (outputs, hashes, headline figures):

- ``record_us``: keep a finished record's entry (checked against the contract, one committed row);
- ``lookup_us``: a resume's look-up of a record's previous entry;
- ``export_s``: ``manifest.json`` written from the store when the batch ends (once per batch);
- ``peak_mib``: the process's peak resident memory after the largest size.

And end to end (``--batch-records``): ``sizefx batch inspect`` over that many copies of one tiny
record (40 s at 100 Hz) on 2 workers, in a fresh process, its wall time per record, then the
re-run that finds every record unchanged. Before the store, the whole manifest was validated and
rewritten after every record: 16 ms per record at 200 records and 37 ms at 800.

The promise: the cost per record does not grow with the batch (``record_us`` and ``lookup_us``
flat from 100 to 1e6 records, the batch's wall time per record flat). Figures are printed, never
asserted.
"""

from __future__ import annotations

import argparse
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _measure import add_output_options, emit

from sizefx.batch.manifest import Manifest, canonical_options


def _entry(k: int, folder: str) -> dict:
    name = f"flight{k:07d}"
    digest = f"{k:064x}"
    return {
        "input": f"/campaign/flights/{name}.h5",
        "name": name,
        "sha256": digest,
        "options": canonical_options({"sub_samples": 4}),
        "outputs": {
            "output": {"path": f"{folder}/{name}.nav.h5", "bytes": 123456789, "sha256": digest},
            "json_path": {"path": f"{folder}/{name}.navigate.json", "bytes": 2345, "sha256": digest},
        },
        "status": "ok",
        "reason": None,
        "duration_s": 2.5,
        "peak_memory_mib": 512.0,
        "headline": {"final_horizontal_error_m": 1.5, "max_horizontal_error_m": 1.6, "drift_nmi_per_h": 0.02},
    }


def measure(n: int) -> dict:
    options = canonical_options({"sub_samples": 4})
    with tempfile.TemporaryDirectory() as tmp:
        store = Manifest(tmp, "navigate").open_for_writing(options)
        t0 = time.perf_counter()
        for k in range(n):
            store.record(_entry(k, tmp), options)
        record_s = time.perf_counter() - t0
        probes = range(0, n, max(1, n // 1000))
        t0 = time.perf_counter()
        for k in probes:
            assert store.entry(f"/campaign/flights/flight{k:07d}.h5") is not None
        lookup_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        path = store.export(options)
        export_s = time.perf_counter() - t0
        size = path.stat().st_size
        store.close()
    return {
        "records": n,
        "record_us": round(record_s / n * 1e6, 1),
        "lookup_us": round(lookup_s / len(probes) * 1e6, 1),
        "export_s": round(export_s, 3),
        "manifest_json_mib": round(size / 2**20, 1),
        "peak_mib": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0, 0),
    }


def batch_end_to_end(n: int, workers: int = 2) -> dict:
    """``sizefx batch inspect`` over ``n`` copies of one tiny record, and its re-run."""
    from sizefx.scenarios import TurntablePlan
    from sizefx.simulate import SimulateConfig
    from sizefx.simulate import run as simulate

    sizefx = str(Path(sys.executable).parent / "sizefx")
    with tempfile.TemporaryDirectory() as tmp:
        records = Path(tmp) / "records"
        records.mkdir()
        one = Path(tmp) / "one.h5"
        plan = TurntablePlan(axes="Z", static_s=5.0, seconds_per_axis=24.0, cycles=1, settle_s=5.0)
        simulate(SimulateConfig("turntable", str(one), plan=plan, rate_hz=100.0, seed=0))
        for k in range(n):
            shutil.copyfile(one, records / f"r{k:06d}.h5")
        cmd = [sizefx, "batch", "inspect", str(records), "--out", str(Path(tmp) / "out"), "--workers", str(workers)]
        cmd.append("--json-progress")
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        first = time.perf_counter() - t0
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        again = time.perf_counter() - t0
    return {
        "records": n,
        "workers": workers,
        "wall_s": round(first, 2),
        "ms_per_record": round(first / n * 1e3, 2),
        "rerun_wall_s": round(again, 2),
        "rerun_ms_per_record": round(again / n * 1e3, 2),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--records", type=int, nargs="+", default=[100, 10_000, 100_000, 1_000_000])
    ap.add_argument("--batch-records", type=int, nargs="*", default=[200, 800, 3200])
    add_output_options(ap)
    args = ap.parse_args(argv)
    rows, batches = [], []
    for n in args.records:
        rows.append(measure(n))
        print(rows[-1], file=sys.stderr)
    for n in args.batch_records:
        batches.append(batch_end_to_end(n))
        print(batches[-1], file=sys.stderr)
    # the end-to-end batches run 2 workers: the load they make is theirs, not other programs'
    return emit({"sizes": rows, "batches": batches}, args, __file__, argv, threads=2 if batches else 1)


if __name__ == "__main__":
    sys.exit(main())
