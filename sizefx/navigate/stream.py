"""Streaming navigation of a telemetry file: ``sizefx navigate`` on records of any length.

The record is read in chunks of IMU rows (:class:`sizefx.io.telemetry.TelemetryStream`).
Each chunk goes through the same steps as whole-record :func:`sizefx.navigate.navigate`:

1. sync of the accelerometers (``/imu/accel_time``, or the delay of ``--levers``) or the
   effect-model correction (``--model``);
2. rates to increments (fourth order);
3. size-effect compensation (``--levers``);
4. the strapdown kernel, whose state (with its Kahan terms) is carried to the next chunk.

Each chunk is read with :data:`MARGIN` extra rows on both sides, so every filter sees the
same neighbours it sees in a whole-record run: the four-point increment stencil, the edge
rates of the increment-domain compensation, the Savitzky-Golay window of a rates-domain
model correction, and the not-a-knot sync spline, whose dependence on a sample k rows
away decays as (2 - sqrt(3))^k (1e-37 at 64 rows). Results equal the whole-record run to
1e-12 relative (``tests/test_pipeline.py``).

Memory is the chunk, the window of ``/reference`` it spans, and the output rows at
``--output-rate-hz``; the navigation steps themselves are not kept. The output solution
(and the errors against ``/reference``) is held at the output rate; the summary's final
and maximum errors are taken over every navigation step the reference has a sample at,
exactly as in the whole-record run.

While the kernel integrates chunk k on one core, a worker thread reads and prepares
chunk k + 1 on the other (the Numba kernels release the GIL; h5py reads hold it).
"""

from __future__ import annotations

import json
import time as _time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, replace

import numpy as np

from .. import earth
from ..compensate import compensate_arrays_increments, sync_accelerometers
from ..correct import correct_imu
from ..constants import METRES_PER_NMI
from ..errors import ConfigError, TelemetryError
from ..kernels.strapdown import coning_coefficients, pack_state
from ..levers import read_levers
from . import (
    GAPS_WHY,
    VERTICAL_MODES,
    NavConfig,
    NavResult,
    _choose,
    _reference_at,
    _run_kernel,
    increments_of,
    initial_state,
    _segment_config,
    uniform_period_s,
)
from ..rotation import quat_angle_between
from ..io.telemetry import Telemetry, TelemetryStream, refuse_gaps

__all__ = ["CHUNK_SAMPLES", "MARGIN", "navigate_file"]

#: Default IMU rows per chunk (2^20: 24 MiB of rates, a few hundred MiB of working set).
CHUNK_SAMPLES = 1 << 20
#: Extra rows read on each side of a chunk (see the module docstring).
MARGIN = 64
#: Fewest rows read for any chunk: the rates-domain compensation of a model needs 164.
MIN_ROWS = 512


class _Source:
    """Prepared increments ``[j0, j1)`` of a stream, the same as a whole-record run would give."""

    def __init__(self, st: TelemetryStream, cfg: NavConfig, levers):
        self.st, self.cfg, self.levers = st, cfg, levers
        first, last = st.read(0, 1)[0][0], st.read(st.n_samples - 1, st.n_samples)[0][0]
        self.dt = uniform_period_s(first, last, st.n_samples)  # as navigate.increments_of
        self.t_first = float(first)  # the grid every chunk's stamps are checked against
        self.jitter = 0.0  #: the largest distance of a stamp from the grid [periods], for the configuration
        self.rates = st.form == "rates"
        self.n_increments = st.n_samples - 1 if self.rates else st.n_samples
        self.correction = None  #: what the model corrected (from the first chunk), for the configuration

    def increments(self, j0: int, j1: int):
        st, dt = self.st, self.dt
        extra = 1 if self.rates else 0  # increment j spans rows j and j + 1 of a rates record
        hi = min(st.n_samples, j1 + extra + MARGIN)
        lo = max(0, min(j0 - MARGIN, hi - MIN_ROWS))  # a short last chunk reads more history, not less
        t, g, a, ta = st.read(lo, hi)
        tel = Telemetry(time_s=t, form=st.form, accel_time_s=ta, site=st.site, path=str(st.path), source=st.source)
        if self.rates:
            tel.gyro_rad_s, tel.accel_mps2 = g, a
        else:
            tel.dtheta_rad, tel.dvel_mps = g, a
        if self.cfg.model is not None:
            tel = correct_imu(tel, self.cfg.model, mode=self.cfg.mode)
            if self.correction is None:
                self.correction = json.loads(tel.source["correction_json"])
                del self.correction["effects"]  # in the model file; the configuration names it
        else:
            tel = sync_accelerometers(tel, (self.levers.accel_delay_s or 0.0) if self.levers else 0.0)
        t_end, dtheta, dvel, _, jitter = increments_of(tel, dt=dt, first_row=lo, t_first=self.t_first,
                                                       row0=st.first_row)
        self.jitter = max(self.jitter, jitter)
        if self.levers:
            dvel = compensate_arrays_increments(dtheta, dvel, dt, self.levers, self.cfg.mode)
        keep = slice(j0 - lo, j1 - lo)
        return t_end[keep], np.ascontiguousarray(dtheta[keep]), np.ascontiguousarray(dvel[keep])


class _Errors:
    """Errors against the reference at the navigation steps it has samples at: running final and
    maximum (as :func:`sizefx.navigate._summary`), and the history at the output rows."""

    def __init__(self, st: TelemetryStream, res_dt: float):
        self.ref = st.reference  # a ReferenceStream: windows of it are read chunk by chunk
        self.approximate = bool(st.source and st.source.get("reference_is_approximate"))
        self.sparse = self.ref is not None and self.ref.n > 2 and self.ref.median_step_s > 1.5 * res_dt
        self.res_dt = res_dt
        self.final = {}
        self.max = {"horizontal": None, "attitude": None}
        self.history = {k: [] for k in ("time_s", "north_m", "east_m", "horizontal_m", "velocity_mps",
                                        "attitude_rad")}

    def add(self, t, q, v, lat, lon, out_rows, window):
        """One chunk: navigation steps ``t`` and the reference ``window`` that brackets them."""
        if self.ref is None:
            return
        covered = (t >= self.ref.first_s) & (t <= self.ref.last_s + 1e-9)
        if not covered.any():
            return
        ref_t = window.time_s
        if self.sparse:
            k = np.clip(np.searchsorted(ref_t, t), 1, ref_t.size - 1)
            nearest = np.minimum(np.abs(ref_t[k] - t), np.abs(ref_t[k - 1] - t))
            covered &= nearest < 1e-3 * self.res_dt
        idx = np.flatnonzero(covered)
        if idx.size == 0:
            return
        ref = _reference_at(Telemetry(time_s=np.zeros(1), form="rates", reference=window), t[idx])
        hist = np.isin(idx, out_rows)
        self.history["time_s"].append(t[idx][hist])
        if "lat" in ref:
            r_mer, r_tr = earth.radii_m(ref["lat"])
            dn = (lat[idx] - ref["lat"]) * (r_mer + ref["h"])
            de = (lon[idx] - ref["lon"]) * (r_tr + ref["h"]) * np.cos(ref["lat"])
            horiz = np.hypot(dn, de)
            self.final["horizontal"] = float(horiz[-1])
            self.max["horizontal"] = max(self.max["horizontal"] or 0.0, float(horiz.max()))
            for name, x in (("north_m", dn), ("east_m", de), ("horizontal_m", horiz)):
                self.history[name].append(x[hist])
        if "v_n" in ref:
            dv = v[idx] - ref["v_n"]
            self.final["velocity"] = float(np.linalg.norm(dv[-1]))
            self.history["velocity_mps"].append(dv[hist])
        if not self.approximate:
            att = quat_angle_between(ref["quat_nb"], q[idx])
            self.final["attitude"] = float(att[-1])
            self.max["attitude"] = max(self.max["attitude"] or 0.0, float(att.max()))
            self.history["attitude_rad"].append(att[hist])

    def errors(self):
        if self.ref is None:
            return None
        return {k: np.concatenate(v) for k, v in self.history.items() if v}


def navigate_file(path, cfg: NavConfig | None = None, *, chunk_samples: int = CHUNK_SAMPLES, progress=None,
                  threads: bool = True, writer=None) -> NavResult:
    """Navigate a telemetry file chunk by chunk; the result holds the output rows only.

    ``progress(done, total)`` is called after each chunk (IMU samples). ``threads``: prepare
    the next chunk in a worker thread while the kernel runs. ``writer`` (a
    :class:`sizefx.navigate.NavigationWriter`) receives the output rows chunk by chunk; the
    result then keeps only the first and the last row (memory stays bounded on any length).
    """
    cfg = cfg or NavConfig()
    started = _time.perf_counter()
    if cfg.levers and cfg.model is not None:
        raise ConfigError("--levers and --model both given: the effect model has its own lever arms "
                          "([lever_arm]); give one of them")
    if chunk_samples < 1000:
        raise ConfigError(f"--chunk-samples {chunk_samples}: use at least 1000")
    levers = read_levers(cfg.levers) if cfg.levers else None
    n_sub = int(cfg.subsamples)
    coning_coefficients(n_sub)  # validates
    with TelemetryStream(path, allow_gaps=cfg.allow_gaps, segment=cfg.segment) as st:
        # before any work: the stream found every gap at open (a segment has none)
        refuse_gaps(st.path, st.gaps, command="navigate", why=GAPS_WHY, bridge=False)
        src = _Source(st, cfg, levers)
        dt = src.dt
        n_steps = src.n_increments // n_sub
        if n_steps < 1:
            raise TelemetryError(st.path, "/imu/time", f"{st.n_samples} samples: too few for one navigation step")
        t_head = st.read(0, min(2, st.n_samples))[0]
        t0 = (t_head[1] if src.rates else t_head[0]) - dt  # start of the first increment
        # the reference is read by time window: a two-row summary decides the initialisation and
        # the vertical channel, and each chunk reads the rows it needs
        shell = Telemetry(time_s=np.array([t0]), form=st.form, site=st.site, source=st.source, path=str(st.path),
                          reference=st.reference.summary() if st.reference is not None else None)
        init, vertical, stationary = _choose(shell, cfg, t0)

        def reference_shell(window):
            return Telemetry(time_s=np.zeros(1), form=st.form, reference=window)

        ref0 = (_reference_at(reference_shell(st.reference.window(t0, t0)), np.array([t0]))
                if st.reference is not None else None)
        quat0, v0, (lat0, lon0, h0), details = initial_state(
            st.path, cfg, init, ref0, st.site, dt, n_sub, src.n_increments, lambda n: src.increments(0, n)[1:])
        state = pack_state(quat0, v0, lat0, lon0, h0)
        mode = VERTICAL_MODES[vertical]
        T = n_sub * dt
        stride = 1
        if cfg.output_rate_hz:
            stride = max(1, int(round(1.0 / (T * cfg.output_rate_hz))))
        chunk = max(n_sub, (int(chunk_samples) // (n_sub * stride)) * n_sub * stride)
        bounds = [(j0, min(j0 + chunk, n_steps * n_sub)) for j0 in range(0, n_steps * n_sub, chunk)]
        out = {k: [] for k in ("t", "q", "v", "lat", "lon", "h")}
        errors = _Errors(st, T)
        kernel_s = 0.0
        step0 = 0
        pool = ThreadPoolExecutor(max_workers=1) if threads and len(bounds) > 1 else None
        try:
            pending = pool.submit(src.increments, *bounds[0]) if pool else None
            for c, (j0, j1) in enumerate(bounds):
                t_end, dtheta, dvel = pending.result() if pool else src.increments(j0, j1)
                if pool and c + 1 < len(bounds):
                    pending = pool.submit(src.increments, *bounds[c + 1])
                steps = (j1 - j0) // n_sub
                t_nav = t_end[n_sub - 1:steps * n_sub:n_sub]
                # the rows of /reference this chunk spans, read once for the vertical channel and the errors
                window = (st.reference.window(float(t_nav[0]), float(t_nav[-1]))
                          if st.reference is not None else None)
                h_ref = vd_ref = np.zeros(0)
                if vertical == "reference":
                    refs = _reference_at(reference_shell(window), t_nav, attitude=False)
                    h_ref = refs["h"]
                    vd_ref = refs["v_n"][:, 2] if "v_n" in refs else -np.gradient(h_ref, t_nav)
                k_started = _time.perf_counter()
                q, v, lat, lon, h = _run_kernel(dtheta, dvel, n_sub, dt, state, mode, h0, h_ref, vd_ref)
                kernel_s += _time.perf_counter() - k_started
                rows = np.flatnonzero((np.arange(step0, step0 + steps) + 1) % stride == 0)
                if writer is not None:
                    writer.append(t_nav[rows], lat[rows], lon[rows], h[rows], v[rows], q[rows])
                for key, x in zip(("t", "q", "v", "lat", "lon", "h"), (t_nav, q, v, lat, lon, h)):
                    if writer is None:
                        out[key].append(x[rows])
                    elif rows.size:  # the first and the latest output row
                        out[key] = out[key][:1] + [x[rows[-1:]]] if out[key] else [x[rows[:1]], x[rows[-1:]]]
                errors.add(t_nav, q, v, lat, lon, rows, window)
                if c == 0:
                    t_first_nav = float(t_nav[0])
                last = (float(t_nav[-1]), float(lat[-1]), float(lon[-1]), float(h[-1]))
                step0 += steps
                if progress is not None:
                    progress(min(st.n_samples, j1 + 1), st.n_samples)
        finally:
            if pool:
                pool.shutdown(wait=True, cancel_futures=True)
        form = st.form
    config = {**asdict(replace(cfg, model=None)), "model": cfg.model.source if cfg.model is not None else None,
              "correction": src.correction, "init": init, "vertical": vertical, "stationary_reference": stationary,
              "input_form": form,
              "sample_rate_hz": 1.0 / dt, "nav_rate_hz": 1.0 / T,
              "dropped_trailing_samples": int(src.n_increments - n_steps * n_sub), "streamed": True,
              "chunk_samples": chunk, "output_stride": stride, "time_jitter_periods": src.jitter, **details,
              **(_segment_config(st.segment) if st.segment is not None else {})}
    res = NavResult(*(np.concatenate(out[k]) for k in ("t", "q", "v", "lat", "lon", "h")), config, {})
    duration = last[0] - t_first_nav + T
    summary = {"samples": int(n_steps * n_sub), "duration_s": duration, "final_horizontal_error_m": None,
               "max_horizontal_error_m": None, "drift_nmi_per_h": None, "final_velocity_error_mps": None,
               "final_attitude_error_deg": None, "max_attitude_error_deg": None,
               "final_latitude_deg": float(np.degrees(last[1])), "final_longitude_deg": float(np.degrees(last[2])),
               "final_height_m": last[3]}
    if "horizontal" in errors.final:
        summary["final_horizontal_error_m"] = errors.final["horizontal"]
        summary["max_horizontal_error_m"] = errors.max["horizontal"]
        summary["drift_nmi_per_h"] = errors.final["horizontal"] / METRES_PER_NMI / (duration / 3600.0)
    if "velocity" in errors.final:
        summary["final_velocity_error_mps"] = errors.final["velocity"]
    if "attitude" in errors.final:
        summary["final_attitude_error_deg"] = float(np.degrees(errors.final["attitude"]))
        summary["max_attitude_error_deg"] = float(np.degrees(errors.max["attitude"]))
    summary["kernel_s"] = kernel_s
    summary["wall_s"] = _time.perf_counter() - started
    res.summary = summary
    res.errors = errors.errors()
    return res

