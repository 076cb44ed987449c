"""The one navigation loop: read a chunk, correct it, integrate it, write it.

Every navigation goes through :func:`navigate_source`: a file streamed in chunks of IMU rows
(:func:`navigate_file`, a :class:`sizefx.io.telemetry.TelemetryStream`) and a record in memory
(:func:`navigate`, one chunk of a :class:`MemorySource`) alike. A levers file (``--levers``) or an
effect model (``--model``) is resolved once, before the first chunk, into a
:class:`sizefx.sensor_model.Correction`; each chunk's arrays then go through:

1. the accelerometers synced to the gyros (``/imu/accel_time``, the correction's delay);
2. an effect model's per-channel and gyro errors undone (:meth:`Correction.channels`);
3. rates to increments (fourth order);
4. the lever terms removed on the increments, with edge rates (:meth:`Correction.on_increments`);
5. the strapdown kernel, whose state (with its Kahan terms) is carried to the next chunk;
6. the output rows to the writer (or the result), the errors against ``/reference``.

Each chunk is read with :data:`MARGIN` extra rows on both sides, so every filter sees the
same neighbours it sees in a single-chunk run; results do not depend on the chunk size
(``tests/test_pipeline.py``: to 1e-12 relative, in practice bit for bit).

Memory is the chunk, the window of ``/reference`` it spans, and the output rows at
``output_rate_hz``; the navigation steps themselves are not kept. The summary's final and
maximum errors are taken over every navigation step the reference has a sample at.

While the kernel integrates chunk k on one core, a worker thread reads and prepares
chunk k + 1 on the other (the Numba kernels release the GIL; h5py reads hold it).
"""

from __future__ import annotations

import time as _time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import fields

import numpy as np

from ..errors import ConfigError, TelemetryError
from ..io.telemetry import Telemetry, TelemetryStream, refuse_gaps
from ..kernels.strapdown import coning_coefficients, pack_state
from ..levers import read_levers
from ..omegadot import SAVGOL_WINDOW
from ..sensor_model import Correction
from ..sensor_model.correction import model_correction_record
from ..stage import helper_threads
from ..sync import synced_accel
from .config import CHUNK_SAMPLES, GAPS_WHY, MARGIN, MIN_PLOT_ROWS, MIN_ROWS, VERTICAL_MODES, NavConfig
from .initial import choose, initial_state
from .reference import Errors, MemoryReference, reference_at, vertical_reference_at
from .result import NavResult
from .steps import increments_from, integrate, uniform_period_s

__all__ = ["MemorySource", "navigate", "navigate_file", "navigate_source"]


class MemorySource:
    """A :class:`Telemetry` in memory behind the interface of :class:`TelemetryStream`."""

    def __init__(self, tel: Telemetry):
        self.tel = tel
        self.path = tel.path
        self.form = tel.form
        self.site, self.source = tel.site, tel.source
        self.n_samples = tel.n_samples
        self.gaps, self.segment = tel.gaps, tel.segment
        self.first_row = tel.segment.first_row if tel.segment is not None else 0
        self.reference = MemoryReference(tel.reference) if tel.reference is not None else None
        self._gyro, self._accel = tel.imu_arrays()

    def read(self, k0: int, k1: int):
        ta = None if self.tel.accel_time_s is None else self.tel.accel_time_s[k0:k1]
        return self.tel.time_s[k0:k1], self._gyro[k0:k1], self._accel[k0:k1], ta


def resolve_correction(cfg: NavConfig) -> Correction | None:
    """The levers file or the effect model of ``cfg`` as the run's one :class:`Correction` (None:
    neither), read and checked before any chunk (``cfg`` refused both together when it was made)."""
    if cfg.levers:
        levers = read_levers(cfg.levers)
        return Correction.of_arms(levers.arms_for(cfg.mode), levers.axes, levers.accel_delay_s, cfg.mode, None)
    if cfg.model is None:
        return None
    p = cfg.model.sensor_params()
    # the lever terms' angular acceleration: edge rates of the increments
    described = model_correction_record(cfg.model, p, cfg.mode, "increments")
    return Correction.of_model(p, cfg.mode, described)


class _Prepared:
    """Increments ``[j0, j1)`` of a source, synced, corrected and compensated: steps 1-4."""

    def __init__(self, src, cfg: NavConfig, correction: Correction | None):
        self.src, self.cfg, self.corr = src, cfg, correction
        first, last = src.read(0, 1)[0][0], src.read(src.n_samples - 1, src.n_samples)[0][0]
        self.dt = uniform_period_s(first, last, src.n_samples)
        self.t_first = float(first)  # the grid every chunk's stamps are checked against
        self.jitter = 0.0  #: the largest distance of a stamp from the grid [periods], for the configuration
        self.rates = src.form == "rates"
        self.n_increments = src.n_samples - 1 if self.rates else src.n_samples
        if (
            correction is not None
            and correction.params is not None
            and self.rates
            and src.n_samples < 4 * SAVGOL_WINDOW
        ):
            raise ConfigError(
                f"{src.path}: {src.n_samples} samples; correcting rates with a model needs at least {4 * SAVGOL_WINDOW}"
            )

    def increments(self, j0: int, j1: int):
        src, dt = self.src, self.dt
        extra = 1 if self.rates else 0  # increment j spans rows j and j + 1 of a rates record
        hi = min(src.n_samples, j1 + extra + MARGIN)
        lo = max(0, min(j0 - MARGIN, hi - MIN_ROWS))  # a short last chunk reads more history, not less
        t, g, a, ta = src.read(lo, hi)
        corr = self.corr
        if corr is None:
            a = synced_accel(t, a, ta, 0.0, src.form)  # the accelerometers' own stamps, if any
        else:
            a = corr.synced(t, a, ta, src.form)
            g, a = corr.channels(g, a, form=src.form, dt=dt, time_s=t)
        t_end, dtheta, dvel, _, jitter = increments_from(
            t, g, a, src.form, dt, lo, t_first=self.t_first, row0=src.first_row, path=src.path
        )
        self.jitter = max(self.jitter, jitter)
        if corr is not None:
            dvel = corr.on_increments(dtheta, dvel, dt)
        keep = slice(j0 - lo, j1 - lo)
        return t_end[keep], np.ascontiguousarray(dtheta[keep]), np.ascontiguousarray(dvel[keep])


def navigate_source(
    src,
    cfg: NavConfig,
    *,
    chunk_samples: int = CHUNK_SAMPLES,
    progress=None,
    threads: bool = True,
    writer=None,
    decimate: bool = True,
    outputs: tuple = (),
) -> NavResult:
    """Navigate ``src`` (a :class:`TelemetryStream` or a :class:`MemorySource`) chunk by chunk.

    ``decimate``: keep only the rows at ``cfg.output_rate_hz`` (a file's run) or every
    navigation step (a record in memory; the writer decimates). ``writer`` (a
    :class:`sizefx.io.navigation.NavigationWriter`) receives the output rows chunk by chunk;
    the result then keeps only the first and the last row (memory stays bounded on any length).
    ``progress(done, total)`` is called after each chunk (IMU samples). ``outputs``: the options
    whose outputs the caller will write from the result (``"-o"``, implied by ``writer``, and
    ``"--plot"``): one that would hold nothing is refused before any work (:func:`refuse_empty_outputs`).
    """
    started = _time.perf_counter()
    correction = resolve_correction(cfg)
    n_sub = int(cfg.subsamples)
    coning_coefficients(n_sub)  # validates
    # before any work: a stream found every gap at open (a segment has none)
    refuse_gaps(src.path, src.gaps, command="navigate", why=GAPS_WHY, bridge=False)
    prep = _Prepared(src, cfg, correction)
    dt = prep.dt
    n_steps = prep.n_increments // n_sub
    if n_steps < 1:
        raise TelemetryError(src.path, "/imu/time", f"{src.n_samples} samples: too few for one navigation step")
    t_head = src.read(0, min(2, src.n_samples))[0]
    t0 = (t_head[1] if prep.rates else t_head[0]) - dt  # start of the first increment
    # the reference is read by time window: a summary decides the initialisation and the vertical
    # channel, and each chunk reads the rows it needs
    approximate = src.source is not None and src.source.reference_is_approximate
    ref = src.reference
    init, vertical, stationary = choose(src.path, ref.summary() if ref is not None else None, approximate, cfg, t0)
    ref0 = reference_at(ref.window(t0, t0), np.array([t0])) if ref is not None else None
    quat0, v0, (lat0, lon0, h0), details = initial_state(
        src.path, cfg, init, ref0, src.site, dt, n_sub, prep.n_increments, lambda n: prep.increments(0, n)[1:]
    )
    state = pack_state(quat0, v0, lat0, lon0, h0)
    mode = VERTICAL_MODES[vertical]
    T = n_sub * dt
    stride = output_stride(cfg, T) if decimate else 1
    # a decimated run's result holds the output rows alone: none of them is refused even without -o
    refuse_empty_outputs(src, cfg, (*outputs, "-o") if writer is not None or decimate else outputs, n_steps, T)
    chunk = max(n_sub, (int(chunk_samples) // (n_sub * stride)) * n_sub * stride)
    bounds = [(j0, min(j0 + chunk, n_steps * n_sub)) for j0 in range(0, n_steps * n_sub, chunk)]
    out: dict[str, list[np.ndarray]] = {k: [] for k in ("t", "q", "v", "lat", "lon", "h")}
    errors = Errors(ref, approximate, T)
    kernel_s = read_s = write_s = 0.0
    loop_started = _time.perf_counter()
    step0 = 0
    pool = ThreadPoolExecutor(max_workers=1) if threads and len(bounds) > 1 else None
    try:
        pending = pool.submit(prep.increments, *bounds[0]) if pool else None
        for c, (j0, j1) in enumerate(bounds):
            r_started = _time.perf_counter()
            t_end, dtheta, dvel = pending.result() if pending is not None else prep.increments(j0, j1)
            read_s += _time.perf_counter() - r_started
            if pool and c + 1 < len(bounds):
                pending = pool.submit(prep.increments, *bounds[c + 1])
            steps = (j1 - j0) // n_sub
            t_nav = t_end[n_sub - 1 : steps * n_sub : n_sub]  # the file's own stamps: no accumulated rounding
            # the rows of /reference this chunk spans, read once for the vertical channel and the errors
            window = ref.window(float(t_nav[0]), float(t_nav[-1])) if ref is not None else None
            h_ref = vd_ref = np.zeros(0)
            if vertical == "reference":
                assert window is not None  # choose() holds the vertical channel only to a reference
                h_ref, vd_ref = vertical_reference_at(window, t_nav)
                vd_ref = -np.gradient(h_ref, t_nav) if vd_ref is None else vd_ref
            k_started = _time.perf_counter()
            q, v, lat, lon, h = integrate(dtheta, dvel, n_sub, dt, state, mode, h0, h_ref, vd_ref)
            kernel_s += _time.perf_counter() - k_started
            # the steps whose running count (step0 + i + 1) is a multiple of the stride
            rows = np.arange((-step0 - 1) % stride, steps, stride)
            if writer is not None:
                w_started = _time.perf_counter()
                writer.append(t_nav[rows], lat[rows], lon[rows], h[rows], v[rows], q[rows])
                write_s += _time.perf_counter() - w_started
            for key, x in zip(("t", "q", "v", "lat", "lon", "h"), (t_nav, q, v, lat, lon, h)):
                if writer is None:
                    out[key].append(x[rows] if stride > 1 else x)
                elif rows.size:  # the first and the latest output row
                    out[key] = out[key][:1] + [x[rows[-1:]]] if out[key] else [x[rows[:1]], x[rows[-1:]]]
            errors.add(t_nav, q, v, lat, lon, rows, window)
            if c == 0:
                t_first_nav = float(t_nav[0])
            last = (float(t_nav[-1]), float(lat[-1]), float(lon[-1]), float(h[-1]))
            step0 += steps
            if progress is not None:
                progress(min(src.n_samples, j1 + 1), src.n_samples)
    finally:
        if pool:
            pool.shutdown(wait=True, cancel_futures=True)
    config = {
        # the options as given, the effect model by its source (the model itself is in the correction)
        **{
            f.name: cfg.model.source if f.name == "model" and cfg.model is not None else getattr(cfg, f.name)
            for f in fields(cfg)
        },
        "correction": correction.described if correction is not None else None,
        "init": init,
        "vertical": vertical,
        "stationary_reference": stationary,
        "input_form": src.form,
        "sample_rate_hz": 1.0 / dt,
        "nav_rate_hz": 1.0 / T,
        "dropped_trailing_samples": int(prep.n_increments - n_steps * n_sub),
        "streamed": decimate,
        "chunk_samples": chunk,
        "output_stride": stride,
        "time_jitter_periods": prep.jitter,
        **details,
        **(segment_config(src.segment) if src.segment is not None else {}),
    }
    t_out, q_out, v_out, lat_out, lon_out, h_out = (np.concatenate(out[k]) for k in ("t", "q", "v", "lat", "lon", "h"))
    duration = last[0] - t_first_nav + T
    wall_s = _time.perf_counter() - started
    summary = {
        "samples": int(n_steps * n_sub),
        "duration_s": duration,
        **errors.figures(duration),
        "final_latitude_deg": float(np.degrees(last[1])),
        "final_longitude_deg": float(np.degrees(last[2])),
        "final_height_m": last[3],
        "kernel_s": kernel_s,
        "wall_s": wall_s,
    }
    phases_s = {
        "initial": loop_started - started,
        "read": read_s,
        "kernels": kernel_s,
        "write": write_s,
        "other": wall_s - (loop_started - started) - read_s - kernel_s - write_s,
    }
    return NavResult(
        t_out,
        q_out,
        v_out,
        lat_out,
        lon_out,
        h_out,
        config,
        summary,
        errors=errors.errors(),
        path=None if src.path is None else str(src.path),
        phases_s=phases_s,
    )


def output_stride(cfg: NavConfig, step_s: float) -> int:
    """Navigation steps per output row at ``cfg.output_rate_hz`` (1: every step), as the solution's
    writers decimate (:func:`sizefx.io.navigation.write_navigation` by the same rule)."""
    return max(1, int(round(1.0 / (step_s * cfg.output_rate_hz)))) if cfg.output_rate_hz else 1


def refuse_empty_outputs(src, cfg: NavConfig, outputs, n_steps: int, step_s: float) -> None:
    """Refuse, before any work, an output of ``outputs`` that would hold nothing: ``-o`` without one row
    at ``--output-rate-hz`` (a record shorter than one output interval), ``--plot`` without
    ``/reference/position`` to plot the error against or with fewer than :data:`MIN_PLOT_ROWS` rows."""
    if "--plot" in outputs and (src.reference is None or not src.reference.has_position):
        raise TelemetryError(
            src.path,
            "/reference/position",
            "is missing: --plot draws the position error against it; leave out --plot (the summary "
            "reports what the reference allows)",
        )
    stride = output_stride(cfg, step_s)
    rows = n_steps // stride
    for option, what, need in (("-o", "the solution", 1), ("--plot", "the error plot", MIN_PLOT_ROWS)):
        if option not in outputs or rows >= need:
            continue
        found = f"{src.n_samples} samples give {n_steps} navigation step{'s' * (n_steps != 1)} of {step_s:.3g} s"
        if stride > 1:
            found += f", {rows} output row{'s' * (rows != 1)} at --output-rate-hz {cfg.output_rate_hz:g}"
        fix = (
            "give --output-rate-hz 0 (a row per navigation step) or a longer record"
            if stride > 1 and n_steps >= need
            else "give a longer record"
        )
        raise TelemetryError(
            src.path, "/imu/time", f"{found}; {what} ({option}) needs at least {need} row{'s' * (need != 1)}: {fix}"
        )


def segment_config(seg) -> dict:
    """What the configuration records of the segment navigated."""
    return {
        "segment_of": seg.of,
        "segment_rows": [seg.first_row, seg.stop_row],
        "segment_time_s": [seg.start_s, seg.end_s],
    }


def navigate(tel: Telemetry, cfg: NavConfig | None = None, *, outputs: tuple = ()) -> NavResult:
    """Navigate a record in memory: the loop with one chunk; the result keeps every navigation step.
    ``outputs``: as :func:`navigate_source`'s."""
    src = MemorySource(tel)
    return navigate_source(
        src, cfg or NavConfig(), chunk_samples=max(src.n_samples, 1), threads=False, decimate=False, outputs=outputs
    )


def navigate_file(
    path,
    cfg: NavConfig | None = None,
    *,
    chunk_samples: int = CHUNK_SAMPLES,
    progress=None,
    threads: bool | None = None,
    writer=None,
    outputs: tuple = (),
) -> NavResult:
    """Navigate a telemetry file chunk by chunk; the result holds the output rows only. ``outputs``: as
    :func:`navigate_source`'s.

    ``threads``: prepare the next chunk in a helper thread while the kernel runs (default: unless
    this process is a batch worker beside others that fill the cores, :func:`sizefx.stage.helper_threads`).
    """
    cfg = cfg or NavConfig()
    threads = helper_threads() if threads is None else threads
    if chunk_samples < 1000:
        raise ConfigError(f"--chunk-samples {chunk_samples}: use at least 1000")
    with TelemetryStream(path, allow_gaps=cfg.allow_gaps, segment=cfg.segment) as st:
        return navigate_source(
            st, cfg, chunk_samples=chunk_samples, progress=progress, threads=threads, writer=writer, outputs=outputs
        )
