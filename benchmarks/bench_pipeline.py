"""Benchmark: the whole-flight pipeline, stage by stage and end to end.

    python benchmarks/bench_pipeline.py [--file flight.h5] [--duration-h 1.8] [--json out.json] [--record]

Without --file it simulates a flight of --duration-h at 1600 Hz (the paper's
high-precision arms, navigation-grade noise). Before timing it checks the answers:
each Numba kernel against its NumPy twin (tests/naive.py), and the streamed
navigation against the whole-record one. Then it reports, as JSON:

- per stage on the whole record: read (HDF5, validated), sync (spline, a 0.5 ms
  delay), omegadot (Savitzky-Golay), compensation (rates kernel; increments kernel
  with its edge rates), rates -> increments, navigation kernel, write: wall time
  and samples per second;
- the kernels against their NumPy twins on the same data, as a speed-up ratio;
- the whole-flight path in this process (warm JIT, file in the page cache), best of
  --repeat: the floor (read the IMU rows, rates -> increments, the strapdown kernel;
  no sync, compensation, reference or output), `navigate_file` with the lever arms and
  the output file, and the same on a copy whose accelerometers have their own stamps
  (`/imu/accel_time`, 0.5 ms after the gyros', so every chunk is synced), as ratios;
- end to end: `sizefx navigate FILE --levers L -o OUT` in a fresh process with a
  warm JIT cache, and with a cold one (an empty NUMBA_CACHE_DIR); wall time and the
  child's peak memory against the file's size.

Timings are measured, never asserted. CI runs it on a 20-minute flight
(`--duration-h 0.34`, the shortest the flight plan allows) and prints the figures.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

# the NumPy twins of the kernels (tests/naive.py); tests/, not the repository root, so that
# `sizefx` is the installed package and not the source tree
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import naive

from sizefx.io.navigation import NavigationWriter, write_navigation
from sizefx.io.telemetry import TelemetryStream, read_telemetry
from sizefx.kernels.increments import rates_to_increments
from sizefx.kernels.sizeeffect import (
    compensate_increments,
    compensate_increments_edges,
    compensate_rates,
)
from sizefx.kernels.strapdown import (
    VERTICAL_REFERENCE,
    coning_coefficients,
    pack_state,
    strapdown,
)
from sizefx.levers import levers_from_preset, write_levers
from sizefx.navigate import NavConfig, navigate, navigate_file
from sizefx.navigate.steps import integrate
from sizefx.omegadot import edges_from_increments, savgol
from sizefx.scenarios import FlightPlan
from sizefx.simulate import SimulateConfig
from sizefx.simulate import run as simulate
from sizefx.sync import sync_accelerometers

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _measure import add_output_options, emit, run_measured  # (a sibling of this script)


def timed(fn, *args, repeat=1, **kw):
    best, out = np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn(*args, **kw)
        best = min(best, time.perf_counter() - t0)
    return best, out


def check_kernels():
    """Each kernel against its NumPy twin on 20 000 samples of random motion (tolerances: rounding)."""
    rng = np.random.default_rng(0)
    n, dt = 20_000, 1 / 1600
    rates = rng.standard_normal((n, 3)) * 0.3
    ours = np.empty((n - 1, 3))
    rates_to_increments(rates, dt, ours)
    assert np.allclose(ours, naive.rates_to_increments(rates, dt), rtol=0, atol=1e-15)
    arms, axes = levers_from_preset("high-precision").arms_total, np.eye(3)
    accel, wd = rng.standard_normal((n, 3)), rng.standard_normal((n, 3))
    out = np.empty((n, 3))
    compensate_rates(accel, rates, wd, arms, axes, True, True, out)
    assert np.allclose(out, naive.compensate_rates(accel, rates, wd, arms, axes), rtol=0, atol=1e-12)
    dth = rates[:-1] * dt
    dv = accel[:-1] * dt
    edges = edges_from_increments(dth, dt)
    outi = np.empty_like(dv)
    compensate_increments(dv, dth, edges, dt, arms, axes, True, True, outi)
    assert np.allclose(outi, naive.compensate_increments(dv, dth, edges, dt, arms, axes), rtol=0, atol=1e-14)
    return {"kernels_vs_twins": "agree (rates->increments 1e-15, compensation 1e-12 m/s^2)"}


def twin_ratios(dtheta, dvel, rates, accel, omegadot, dt, levers):
    """Speed-up of each kernel over its NumPy twin, on the first 2^18 samples of the record."""
    m = 1 << 18
    out = {}
    buf = np.empty((m - 1, 3))
    t_k, _ = timed(rates_to_increments, rates[:m], dt, buf, repeat=3)
    t_n, _ = timed(naive.rates_to_increments, rates[:m], dt)
    out["rates_to_increments"] = round(t_n / t_k, 1)
    arms, axes = levers.arms_total, levers.axes
    buf = np.empty((m, 3))
    t_k, _ = timed(compensate_rates, accel[:m], rates[:m], omegadot[:m], arms, axes, True, True, buf, repeat=3)
    t_n, _ = timed(naive.compensate_rates, accel[:m], rates[:m], omegadot[:m], arms, axes)
    out["compensate_rates"] = round(t_n / t_k, 1)
    k = 1 << 14  # the strapdown twin is a Python loop: a shorter span
    state = pack_state([1.0, 0, 0, 0], np.zeros(3), 1.0, 1.0, 300.0)
    outs = [np.empty((k // 4, 4)), np.empty((k // 4, 3)), np.empty(k // 4), np.empty(k // 4), np.empty(k // 4)]
    h_ref, vd = np.full(k // 4, 300.0), np.zeros(k // 4)
    t_k, _ = timed(
        lambda: strapdown(
            dtheta[:k],
            dvel[:k],
            4,
            coning_coefficients(4),
            4 * dt,
            state.copy(),
            VERTICAL_REFERENCE,
            0.0,
            h_ref,
            vd,
            *outs,
        ),
        repeat=3,
    )
    t_n, _ = timed(
        naive.strapdown,
        dtheta[:k],
        dvel[:k],
        4,
        coning_coefficients(4),
        4 * dt,
        [1.0, 0, 0, 0],
        np.zeros(3),
        1.0,
        1.0,
        300.0,
    )
    out["strapdown"] = round(t_n / t_k, 1)
    return out


def stages(path: Path, levers_path: Path, levers):
    """Each stage on the whole record, one after the other (samples per second)."""
    out = {}
    st = TelemetryStream(path)
    n = st.n_samples
    t_read, (_, gyro, accel, _) = timed(st.read, 0, n)
    st.close()
    out["read"] = (t_read, n)
    tel = read_telemetry(path)
    dt = tel.sample_period_s
    t_sync, _ = timed(sync_accelerometers, tel, 5e-4)
    out["sync"] = (t_sync, n)
    t_wd, omegadot = timed(savgol, gyro, dt)
    out["omegadot_savgol"] = (t_wd, n)
    comp = np.empty_like(accel)
    arms = np.ascontiguousarray(levers.arms_total)
    t_c, _ = timed(compensate_rates, accel, gyro, omegadot, arms, levers.axes, True, True, comp, repeat=2)
    out["compensate_rates"] = (t_c, n)
    dtheta, dvel = np.empty((n - 1, 3)), np.empty((n - 1, 3))
    t_i, _ = timed(lambda: (rates_to_increments(gyro, dt, dtheta), rates_to_increments(accel, dt, dvel)), repeat=2)
    out["rates_to_increments"] = (t_i, n)
    fused = np.empty_like(dvel)
    t_ci, _ = timed(compensate_increments_edges, dvel, dtheta, dt, arms, levers.axes, True, True, fused, repeat=3)
    out["compensate_increments_with_edge_rates"] = (t_ci, n)  # the navigation path: omegadot as edge rates
    m = (n - 1) // 4
    state = pack_state([1.0, 0, 0, 0], np.zeros(3), 1.0, 1.0, 300.0)
    outs = [np.empty((m, 4)), np.empty((m, 3)), np.empty(m), np.empty(m), np.empty(m)]
    t_n, _ = timed(
        lambda: strapdown(
            dtheta[: 4 * m],
            dvel[: 4 * m],
            4,
            coning_coefficients(4),
            4 * dt,
            state.copy(),
            VERTICAL_REFERENCE,
            0.0,
            np.full(m, 300.0),
            np.zeros(m),
            *outs,
        ),
        repeat=2,
    )
    out["navigate_kernel"] = (t_n, 4 * m)
    res = navigate_file(path, NavConfig(levers=str(levers_path)))
    with tempfile.TemporaryDirectory() as tmp:
        t_w, _ = timed(write_navigation, Path(tmp) / "nav.h5", res, input_file=path)
    out["write_output_rows"] = (t_w, res.time_s.size)
    ratios = twin_ratios(dtheta, dvel, gyro, accel, omegadot, dt, levers)
    return {k: {"wall_s": round(w, 4), "rows": int(c), "rows_per_s": round(c / w)} for k, (w, c) in out.items()}, ratios


def floor_pass(path: Path, n_sub: int = 4, chunk: int = 1 << 20) -> float:
    """The least any navigation of the record does, one thread: read, increments, kernel. Returns seconds."""
    t0 = time.perf_counter()
    with TelemetryStream(path) as st:
        n = st.n_samples
        dt = (st.read(n - 1, n)[0][0] - st.read(0, 1)[0][0]) / (n - 1)
        state = pack_state([1.0, 0, 0, 0], np.zeros(3), 1.0, 1.0, 300.0)
        for k0 in range(0, n - 1, chunk):
            _, g, a, _ = st.read(k0, min(n, k0 + chunk + 1))
            m = (g.shape[0] - 1) // n_sub * n_sub
            dtheta, dvel = np.empty((g.shape[0] - 1, 3)), np.empty((g.shape[0] - 1, 3))
            rates_to_increments(g, dt, dtheta)
            rates_to_increments(a, dt, dvel)
            integrate(
                dtheta[:m],
                dvel[:m],
                n_sub,
                dt,
                state,
                VERTICAL_REFERENCE,
                0.0,
                np.full(m // n_sub, 300.0),
                np.zeros(m // n_sub),
            )
    return time.perf_counter() - t0


def with_accel_stamps(path: Path, out: Path, late_s: float = 5e-4) -> Path:
    """A copy of ``path`` whose accelerometers carry their own stamps, ``late_s`` after the gyros'."""
    with h5py.File(path) as src, h5py.File(out, "w") as dst:
        for key, value in src.attrs.items():
            dst.attrs[key] = value
        for name in src:
            src.copy(src[name], dst, name=name)
        t = dst["imu/time"]
        stamps = dst["imu"].create_dataset("accel_time", shape=t.shape, dtype="f8", chunks=True)
        stamps.attrs["units"] = t.attrs["units"]
        for k0 in range(0, t.shape[0], 1 << 22):
            stamps[k0 : k0 + (1 << 22)] = t[k0 : k0 + (1 << 22)] + late_s
    return out


def whole_flight(path: Path, levers_path: Path, repeat: int) -> dict:
    """The whole-flight path in this process, best of ``repeat``: floor, with levers, with own stamps."""

    def navigate_to_file(p):
        with tempfile.TemporaryDirectory() as tmp:
            writer = NavigationWriter(Path(tmp) / "nav.h5", input_file=p)
            res = navigate_file(p, NavConfig(levers=str(levers_path)), writer=writer)
            writer.close(res.config, res.summary)

    out = {"floor_s": min(floor_pass(path) for _ in range(repeat))}
    out["levers_s"] = timed(navigate_to_file, path, repeat=repeat)[0]
    with tempfile.TemporaryDirectory() as tmp:
        stamped = with_accel_stamps(path, Path(tmp) / "stamped.h5")
        navigate_to_file(stamped)  # the page cache, as for the others
        out["levers_accel_time_s"] = timed(navigate_to_file, stamped, repeat=repeat)[0]
    out = {k: round(v, 3) for k, v in out.items()}
    out["levers_over_floor"] = round(out["levers_s"] / out["floor_s"], 2)
    out["accel_time_over_common_clock"] = round(out["levers_accel_time_s"] / out["levers_s"], 2)
    return out


def end_to_end(path: Path, levers_path: Path, cold: bool):
    exe = Path(sys.executable).with_name("sizefx")
    env = dict(os.environ)
    with tempfile.TemporaryDirectory() as tmp:
        if cold:
            env["NUMBA_CACHE_DIR"] = str(Path(tmp) / "numba-cache")
        wall, peak_mib = run_measured(
            [exe, "navigate", path, "--levers", levers_path, "-o", Path(tmp) / "o.h5", "--quiet"], env=env
        )
    return {"wall_s": round(wall, 3), "peak_mib": round(peak_mib, 1)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--file", type=Path, help="A telemetry file (default: simulate a flight).")
    ap.add_argument("--duration-h", type=float, default=1.8, help="Flight length when simulating [h].")
    ap.add_argument("--repeat", type=int, default=3, help="Runs of each whole-flight figure (the best is kept).")
    add_output_options(ap)
    args = ap.parse_args(argv)
    result = {"benchmark": "whole-flight pipeline"}
    result.update(check_kernels())
    with tempfile.TemporaryDirectory() as tmp:
        path = args.file
        if path is None:
            path = Path(tmp) / "flight.h5"
            simulate(
                SimulateConfig(
                    "flight",
                    path,
                    plan=FlightPlan(
                        duration_s=args.duration_h * 3600.0, align_s=min(600.0, args.duration_h * 3600.0 / 10)
                    ),
                )
            )
        levers = levers_from_preset("high-precision")
        levers_path = Path(tmp) / "levers.json"
        write_levers(levers_path, levers)
        # the answer first: streamed equals whole on this record
        cfg = NavConfig(levers=str(levers_path))
        whole = navigate(read_telemetry(path), cfg)
        streamed = navigate_file(path, cfg)
        stride = streamed.config["output_stride"]
        worst = 0.0
        for name in ("quat_nb", "v_n", "lat_rad", "lon_rad", "height_m"):
            a, b = getattr(whole, name)[stride - 1 :: stride], getattr(streamed, name)
            worst = max(worst, float(np.abs(a - b).max() / np.abs(a).max()))
        assert worst <= 1e-12, f"streamed differs from whole by {worst:.3g} relative"
        result["check_streamed_vs_whole_max_relative"] = worst
        result["check_final_horizontal_error_m"] = streamed.summary["final_horizontal_error_m"]
        del whole
        st = TelemetryStream(path)
        result["samples"] = st.n_samples
        st.close()
        result["file_mib"] = round(path.stat().st_size / 2**20, 1)
        result["stages"], result["kernel_over_numpy_twin"] = stages(path, levers_path, levers)
        result["whole_flight_in_process"] = whole_flight(path, levers_path, args.repeat)
        result["end_to_end_warm"] = end_to_end(path, levers_path, cold=False)
        result["end_to_end_cold_jit"] = end_to_end(path, levers_path, cold=True)
        result["peak_over_file_size"] = round(result["end_to_end_warm"]["peak_mib"] / result["file_mib"], 2)
    return emit(result, args, __file__, argv, threads=2)


if __name__ == "__main__":
    sys.exit(main())
