"""Benchmark: the sync and angular-acceleration kernels against scipy and their NumPy twins.

    python benchmarks/bench_kernels.py [--samples 2000000] [--repeat 5] [--json out.json] [--record]

The target: at least 30 M samples/s (3 channels) on one core from each of
the accelerometer sync (not-a-knot spline, :mod:`sizefx.kernels.sync`) and the
Savitzky-Golay angular acceleration (:mod:`sizefx.kernels.omegadot`). The data are a
1600 Hz record of --samples rows: gyro stamps on a grid, accelerometer stamps of their
own clock (0.3 ms later, 1 us jitter), rates of a few tones and noise.

Before timing it checks the answers: each kernel against scipy and against its twin
(tests/naive.py, on a short span: the twins are slow), and chunk by chunk against the
whole record. Then, as JSON, for each of

- ``sync_rates`` (``resample_onto``), ``sync_increments`` (``resample_increments``, with
  the median step of both stamp series), ``median_step``, ``savgol``:

the kernel alone (scratch allocated outside), the public function (which allocates),
scipy, and the twin: best-of wall time and CPU time of the process, samples per second
of each, and the peak of the memory the call allocates (tracemalloc, which sees NumPy's
buffers). The first call's time (compiling, or loading Numba's cache) is reported
apart, and a cold compile in a fresh process with an empty cache.

On a shared machine the CPU-time figures are the steadier ones. Timings are measured,
never asserted.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.signal import savgol_filter

# the NumPy twins of the kernels (tests/naive.py); tests/, not the repository root, so that
# `sizefx` is the installed package and not the source tree
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import naive

from sizefx.kernels import sync
from sizefx.kernels.omegadot import savgol_derivative, savgol_weights
from sizefx.omegadot import SAVGOL_ORDER, SAVGOL_WINDOW, savgol, savgol_rows
from sizefx.sync import resample_increments, resample_onto

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _measure import add_output_options, emit, run_measured  # (a sibling of this script)

DT = 1 / 1600
#: the spans the slow references run on (the twins are dense solves or a fit per row)
TWIN_SPLINE_ROWS = 400
TWIN_SAVGOL_ROWS = 2000
SCIPY_ROWS_MAX = 2_000_000


def record(n: int, seed: int = 0):
    """Gyro stamps, accelerometer stamps (their own clock), rates, increments."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * DT
    t_accel = t + 0.3e-3 + rng.normal(0.0, 1e-6, n)
    tones = np.stack([np.sin(2 * np.pi * f * t + p) for f, p in ((0.7, 0.0), (3.1, 1.0), (47.0, 2.0))], axis=1)
    rates = 0.2 * tones + 0.01 * rng.standard_normal((n, 3)) + [0.0, 0.0, 9.81]
    return t, t_accel, np.ascontiguousarray(rates), np.ascontiguousarray(rates * DT)


def measure(fn, *args, repeat=3):
    """Best-of ``repeat``: wall and process CPU seconds; the peak of what one call allocates [MiB]."""
    wall = cpu = np.inf
    for _ in range(repeat):
        w0, c0 = time.perf_counter(), time.process_time()
        fn(*args)
        wall, cpu = min(wall, time.perf_counter() - w0), min(cpu, time.process_time() - c0)
    tracemalloc.start()
    fn(*args)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return wall, cpu, peak / 2**20


def figures(rows, wall, cpu, peak_mib):
    return {
        "rows": int(rows),
        "wall_s": round(wall, 5),
        "cpu_s": round(cpu, 5),
        "samples_per_s": round(rows / wall),
        "cpu_samples_per_s": round(rows / cpu),
        "peak_alloc_mib": round(peak_mib, 2),
    }


def edges(t):
    return np.r_[t[0] - np.median(np.diff(t)), t]


def scipy_increments(incr, t_from, t_to):
    """The sync of increments as it was before the kernels."""
    cum = np.vstack([np.zeros(3), np.cumsum(incr, axis=0)])
    return np.diff(CubicSpline(edges(t_from), cum, axis=0, bc_type="not-a-knot")(edges(t_to)), axis=0)


def check(t, ta, rates, incr):
    """The answers, before any timing: scipy, the twins, and chunks against the whole."""
    out = {}
    n = min(t.size, 200_000)
    scale = np.abs(rates[:n]).max()
    worst = np.abs(resample_onto(rates[:n], ta[:n], t[:n]) - CubicSpline(ta[:n], rates[:n])(t[:n])).max() / scale
    assert worst < 1e-12, worst
    out["sync_rates_vs_scipy"] = float(worst)
    cum_scale = np.abs(np.cumsum(incr[:n], axis=0)).max()
    worst = np.abs(resample_increments(incr[:n], ta[:n], t[:n]) - scipy_increments(incr[:n], ta[:n], t[:n])).max()
    assert worst / cum_scale < 1e-12, worst / cum_scale
    out["sync_increments_vs_scipy_of_running_sum"] = float(worst / cum_scale)
    sg_scale = 2.0 * savgol_weights(SAVGOL_WINDOW, SAVGOL_ORDER, DT)[0].sum() * np.abs(rates[:n]).max()  # sum|c| max|x|
    worst = (
        np.abs(
            savgol(rates[:n], DT) - savgol_filter(rates[:n], SAVGOL_WINDOW, SAVGOL_ORDER, deriv=1, delta=DT, axis=0)
        ).max()
        / sg_scale
    )
    assert worst < 1e-12, worst
    out["savgol_vs_scipy_of_tap_sum"] = float(worst)
    k = TWIN_SPLINE_ROWS
    worst = np.abs(resample_onto(rates[:k], ta[:k], t[:k]) - naive.spline_not_a_knot(ta[:k], rates[:k], t[:k])).max()
    assert worst / scale < 1e-12
    worst_i = np.abs(resample_increments(incr[:k], ta[:k], t[:k]) - naive.resample_increments(incr[:k], ta[:k], t[:k]))
    assert worst_i.max() / np.abs(np.cumsum(incr[:k], axis=0)).max() < 1e-12
    k = TWIN_SAVGOL_ROWS
    worst_s = np.abs(savgol(rates[:k], DT) - naive.savgol_derivative(rates[:k], DT)).max() / sg_scale
    assert worst_s < 1e-12
    out["twins"] = "agree to 1e-12 (spline on 400 rows, Savitzky-Golay on 2000)"
    # chunk by chunk (64 rows each side for the sync, as sizefx.navigate.loop) against the whole
    n, margin, step = min(t.size, 300_000), 64, 65_536
    whole_sync, whole_sg = resample_onto(rates[:n], ta[:n], t[:n]), savgol(rates[:n], DT)
    sync_diff, sg_equal = 0.0, True
    half = SAVGOL_WINDOW // 2
    for j0 in range(0, n, step):
        j1 = min(n, j0 + step)
        lo, hi = max(0, j0 - margin), min(n, j1 + margin)
        part = resample_onto(rates[lo:hi], ta[lo:hi], t[lo:hi])[j0 - lo : j1 - lo]
        sync_diff = max(sync_diff, float(np.abs(part - whole_sync[j0:j1]).max() / scale))
        lo, hi = max(0, j0 - half), min(n, j1 + half)
        sg_equal &= bool(np.array_equal(savgol_rows(rates[lo:hi], lo, n, j0, j1, DT), whole_sg[j0:j1]))
    assert sync_diff < 1e-15 and sg_equal, (sync_diff, sg_equal)
    out["chunked_vs_whole"] = {"sync_rates_max_relative": sync_diff, "savgol_bit_for_bit": sg_equal}
    return out


def first_calls():
    """The first call of each kernel in this process: compiling, or loading Numba's cache."""
    t, ta, rates, incr = record(64, seed=1)
    out = {}
    for name, fn in (
        ("sync_rates", lambda: resample_onto(rates, ta, t)),
        ("sync_increments", lambda: resample_increments(incr, ta, t)),
        ("savgol", lambda: savgol(rates, DT)),
    ):
        t0 = time.perf_counter()
        fn()
        out[name] = round(time.perf_counter() - t0, 3)
    return out


def cold_compile():
    """All three in a fresh process with an empty Numba cache: compile time and peak memory."""
    code = (
        "import numpy as np; from sizefx.sync import resample_onto, resample_increments; "
        "from sizefx.omegadot import savgol; t = np.arange(64) / 1600; y = np.ones((64, 3)); "
        "resample_onto(y, t + 3e-4, t); resample_increments(y, t + 3e-4, t); savgol(y, 1 / 1600)"
    )
    base = [sys.executable, "-c", "import numpy, scipy, numba, sizefx.sync, sizefx.omegadot"]
    with tempfile.TemporaryDirectory() as tmp:
        env = {**os.environ, "NUMBA_CACHE_DIR": str(Path(tmp) / "cold")}
        imports, _ = run_measured(base, env=env)
        wall, peak = run_measured([sys.executable, "-c", code], env=env)
        warm, _ = run_measured([sys.executable, "-c", code], env=env)
    return {
        "cold_process_s": round(wall, 2),
        "warm_process_s": round(warm, 2),
        "imports_only_s": round(imports, 2),
        "cold_peak_mib": round(peak, 1),
    }


def throughput(t, ta, rates, incr, repeat):
    n = t.size
    res = {}
    ns = min(n, SCIPY_ROWS_MAX)
    k_sp, k_sg = TWIN_SPLINE_ROWS, TWIN_SAVGOL_ROWS
    # sync of rates: the kernel with its scratch, the public function, scipy, the twin
    inv_h, u, d, out = np.empty(n - 1), np.empty(n), np.empty((n, 3)), np.empty((n, 3))
    res["sync_rates"] = {
        "kernel": figures(n, *measure(sync.resample, ta, rates, t, inv_h, u, d, out, repeat=repeat)),
        "resample_onto": figures(n, *measure(resample_onto, rates, ta, t, repeat=repeat)),
        "scipy_CubicSpline": figures(ns, *measure(lambda: CubicSpline(ta[:ns], rates[:ns])(t[:ns]), repeat=2)),
        "twin": figures(k_sp, *measure(naive.spline_not_a_knot, ta[:k_sp], rates[:k_sp], t[:k_sp], repeat=1)),
    }
    # sync of increments: the kernel on ready edges; the public function adds the two medians
    e, g = edges(ta), edges(t)
    inv_h, u, d = np.empty(n), np.empty(n + 1), np.empty((n + 1, 3))
    res["sync_increments"] = {
        "kernel": figures(n, *measure(sync.resample_increments, e, incr, g, inv_h, u, d, out, repeat=repeat)),
        "resample_increments": figures(n, *measure(resample_increments, incr, ta, t, repeat=repeat)),
        "scipy_CubicSpline_of_cumsum": figures(ns, *measure(scipy_increments, incr[:ns], ta[:ns], t[:ns], repeat=2)),
        "twin": figures(k_sp, *measure(naive.resample_increments, incr[:k_sp], ta[:k_sp], t[:k_sp], repeat=1)),
    }
    res["median_step"] = {
        "kernel": figures(n, *measure(sync.median_step, ta, repeat=repeat)),
        "numpy_median_of_diff": figures(n, *measure(lambda: np.median(np.diff(ta)), repeat=2)),
    }
    taps, head, tail = savgol_weights(SAVGOL_WINDOW, SAVGOL_ORDER, DT)
    res["savgol"] = {
        "kernel": figures(n, *measure(savgol_derivative, rates, 0, n, 0, n, taps, head, tail, out, repeat=repeat)),
        "savgol": figures(n, *measure(savgol, rates, DT, repeat=repeat)),
        "scipy_savgol_filter": figures(
            ns, *measure(savgol_filter, rates[:ns], SAVGOL_WINDOW, SAVGOL_ORDER, 1, DT, 0, "interp", repeat=2)
        ),
        "twin": figures(k_sg, *measure(naive.savgol_derivative, rates[:k_sg], DT, repeat=1)),
    }
    for entry in res.values():
        kern = entry["kernel"]["cpu_samples_per_s"]
        entry["kernel_over"] = {
            name: round(kern / f["cpu_samples_per_s"], 1) for name, f in entry.items() if name != "kernel"
        }
    return res


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=2_000_000, help="Rows of the record (1600 Hz, 3 channels).")
    ap.add_argument("--repeat", type=int, default=5, help="Timed calls of each kernel (the best counts).")
    add_output_options(ap)
    args = ap.parse_args(argv)
    if args.samples < 2 * TWIN_SAVGOL_ROWS:
        ap.error(f"--samples: at least {2 * TWIN_SAVGOL_ROWS}")
    result = {
        "benchmark": "sync and angular-acceleration kernels",
        "target_samples_per_s": 30_000_000,
        "samples": args.samples,
        "channels": 3,
    }
    result["first_call_s"] = first_calls()
    t, ta, rates, incr = record(args.samples)
    result["checks"] = check(t, ta, rates, incr)
    result["throughput"] = throughput(t, ta, rates, incr, args.repeat)
    result["jit"] = cold_compile()
    return emit(result, args, __file__, argv)


if __name__ == "__main__":
    sys.exit(main())
