"""Benchmark: bounded memory on a long record (72 h at 1600 Hz, about 415 M samples).

    python benchmarks/bench_long_record.py [--hours 72] [--rate-hz 1600] [--dir DIR] [--keep] [--json out.json] [--record]

Writes a static record of --hours at --rate-hz (navigation-grade white noise on Earth
rate and gravity, a 100 Hz reference: 23 GB and 2.3 GB of it for 72 h) with sizefx's own
streaming writer, then runs ``sizefx navigate FILE -o OUT --quiet`` in a fresh process
and reports its wall time and peak memory (measured from a small intermediate process).
The answer is checked: a static unit's free-inertial error stays within the Schuler
bound of its noise. Timings and memory are reported, never asserted.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from sizefx import earth
from sizefx.constants import DEG
from sizefx.io.telemetry import Site, TelemetryWriter

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _measure import add_output_options, emit, run_measured

CHUNK = 1 << 22
ARW_RAD_PER_SQRT_S = 0.00035 * DEG / 60.0  # 0.00035 deg/sqrt(h)
VRW_MPS2_PER_SQRT_HZ = 2.5 * 9.80665e-6  # 2.5 ug/sqrt(Hz)


def write_record(path: Path, hours: float, rate_hz: float, ref_rate_hz: float = 100.0):
    lat, lon, h = 57.9825 * DEG, 55.7089 * DEG, 120.0
    n = int(hours * 3600 * rate_hz) + 1
    n_ref = int(hours * 3600 * ref_rate_hz) + 1
    w_b = earth.omega_ie_n(np.array([lat]))[0]  # level, heading north: body = NED
    f_b = -earth.gravity_n(np.array([lat]), np.array([h]))[0]
    rng = np.random.default_rng(0)
    writer = TelemetryWriter(
        path,
        n_samples=n,
        form="rates",
        n_reference=n_ref,
        reference_position=True,
        reference_velocity=True,
        site=Site(lat, lon, h),
        description=f"static {hours:g} h record for bench_long_record.py",
        force=True,
    )
    with writer as w:
        for k0 in range(0, n, CHUNK):
            k = np.arange(k0, min(n, k0 + CHUNK))
            g = w_b + rng.standard_normal((k.size, 3)) * (ARW_RAD_PER_SQRT_S * np.sqrt(rate_hz))
            a = f_b + rng.standard_normal((k.size, 3)) * (VRW_MPS2_PER_SQRT_HZ * np.sqrt(rate_hz))
            w.write_imu(k / rate_hz, g, a)
        for j0 in range(0, n_ref, CHUNK):
            j = np.arange(j0, min(n_ref, j0 + CHUNK))
            ones = np.ones(j.size)
            w.write_reference(
                j / ref_rate_hz,
                np.tile([1.0, 0.0, 0.0, 0.0], (j.size, 1)),
                lat * ones,
                lon * ones,
                h * ones,
                np.zeros((j.size, 3)),
            )
    return n


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hours", type=float, default=72.0)
    ap.add_argument("--rate-hz", type=float, default=1600.0)
    ap.add_argument("--dir", type=Path, help="Where to write the record (default: a temporary folder).")
    ap.add_argument("--keep", action="store_true", help="Keep the record.")
    add_output_options(ap)
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(dir=args.dir) as tmp:
        path = Path(tmp) / "long.h5"
        t0 = time.perf_counter()
        n = write_record(path, args.hours, args.rate_hz)
        write_s = time.perf_counter() - t0
        exe = Path(sys.executable).with_name("sizefx")
        out = Path(tmp) / "nav.h5"
        js = Path(tmp) / "nav.json"
        wall, peak_mib = run_measured([exe, "navigate", path, "-o", out, "--json", js, "--quiet"])
        summary = json.loads(js.read_text())
        # a static unit: free-inertial error bounded by the Schuler response to its noise (a few km at most
        # over 72 h for these grades); anything larger means a wrong answer, not a slow one
        err = summary["max_horizontal_error_m"]
        assert err is not None and err < 20_000.0, f"wrong answer: max horizontal error {err} m"
        result = {
            "benchmark": "streamed navigate on a long static record",
            "hours": args.hours,
            "rate_hz": args.rate_hz,
            "samples": n,
            "file_gib": round(path.stat().st_size / 2**30, 2),
            "write_record_s": round(write_s, 1),
            "navigate_wall_s": round(wall, 1),
            "navigate_samples_per_s": round(n / wall),
            "navigate_peak_mib": round(peak_mib, 1),
            "check_max_horizontal_error_m": err,
            "output_rows": summary["samples"] // 4 // 40,
        }
        if args.keep:
            kept = (args.dir or Path(".")) / "long.h5"
            path.rename(kept)
            result["record"] = str(kept)
    return emit(result, args, __file__, argv, threads=2)


if __name__ == "__main__":
    sys.exit(main())
