"""Benchmark: the navigation kernel on the simulated 1.8 h, 1600 Hz flight (issue 4).

    python benchmarks/bench_navigate.py [--file flight.h5] [--repeat 3] [--json out.json] [--record]

Checks the answer first (ideal flight: final horizontal error < 1 m), then times the
kernel alone on warm JIT code (best of --repeat), reporting the first call (JIT
compile or cache load) apart, samples per second for 1, 2 and 4 sub-samples, the
end-to-end `navigate` wall time, and peak memory.
"""

from __future__ import annotations

import argparse
import resource
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
from _measure import add_output_options, emit  # (a sibling of this script)


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


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--file", type=Path, help="An ideal simulated flight (default: simulate one, ~40 s).")
    ap.add_argument("--repeat", type=int, default=3)
    add_output_options(ap)
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        path = args.file
        if path is None:
            path = Path(tmp) / "flight.h5"
            simulate(SimulateConfig("flight", path, ideal=True))
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
