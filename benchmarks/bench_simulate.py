"""Benchmark: `sizefx simulate flight` throughput and peak memory (run by hand, not in the tests).

    python benchmarks/bench_simulate.py --duration-h 1.8 [--form rates|increments] [--json out.json] [--record]

Checks the answer before reporting: the file validates, has the expected
number of samples, and its static lead-in reads normal gravity.
"""

from __future__ import annotations

import argparse
import resource
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


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration-h", type=float, default=1.8)
    ap.add_argument("--form", choices=["rates", "increments"], default="rates")
    add_output_options(ap)
    args = ap.parse_args(argv)
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
        result = {
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
