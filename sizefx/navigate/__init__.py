"""Whole-record strapdown navigation: ``sizefx navigate``.

Reads a telemetry file, turns rates into increments (fourth order), sets the
initial state (from ``/reference``, or by alignment), runs the Numba
mechanisation of :mod:`sizefx.kernels.strapdown`, compares with ``/reference``
and writes ``sizefx/navigation/1``.

Alignment (``init="align"``): the record must be stationary over the window.
1. Coarse: TRIAD on the mean specific force (levelling) and the mean angular
   rate (gyrocompassing) against ``-g_n`` and ``omega_ie_n``.
2. Fine: a batch zero-velocity fit. The mechanisation is run over the window from
   the coarse attitude, from three slightly rotated ones, and with a small north
   gyro drift. The resulting velocity histories give the sensitivity of the
   velocity to each parameter. The least-squares correction that brings the
   window's velocity closest to zero is then applied (two iterations). This
   uses the whole nonlinear mechanisation, Earth rate and Schuler coupling
   included. It reaches what the sensors allow: tilt to accelerometer bias / g,
   heading to gyro bias / (Omega_E cos lat).
"""

from __future__ import annotations

import contextlib
import json
import time as _time
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import h5py
import numpy as np

from .. import __version__, earth
from ..compensate import compensate_arrays_increments, sync_accelerometers
from ..correct import correct_imu
from ..effects import EffectModel
from ..constants import METRES_PER_NMI
from ..errors import ConfigError, TelemetryError
from ..io.files import atomic_output
from ..kernels.increments import rates_to_increments
from ..kernels.strapdown import (
    VERTICAL_FREE,
    VERTICAL_HELD,
    VERTICAL_REFERENCE,
    coning_coefficients,
    pack_state,
    strapdown,
)
from ..levers import read_levers
from ..rotation import (
    mat_to_euler,
    mat_to_quat,
    quat_angle_between,
    quat_interp,
    quat_to_mat,
    rotvec_to_mat,
)
from ..io.telemetry import Telemetry, read_telemetry, refuse_gaps

__all__ = ["NavConfig", "NavResult", "navigate", "run", "coarse_alignment", "increments_of"]

VERTICAL_MODES = {"free": VERTICAL_FREE, "held": VERTICAL_HELD, "reference": VERTICAL_REFERENCE}
#: A reference whose position spans less than this [m] is a stationary site: vertical channel held.
STATIONARY_SPAN_M = 1.0
#: Navigation integrates on the uniform grid ``t_first + k dt``; every stamp must lie within this many
#: periods of its grid point. Then each sample is unambiguously the k-th, and treating it as on the grid
#: misplaces it by at most this fraction of a period. Logged stamps jitter: PX4's sensor_combined has
#: steps of 3.94 to 4.84 ms around 4.02 ms and leaves its grid by up to 0.40 periods; a rate change or a
#: lost sample leaves it by more, and grows.
GRID_TOLERANCE = 0.5
#: Why navigation refuses a record with IMU gaps (:func:`sizefx.io.telemetry.refuse_gaps`).
GAPS_WHY = "integrates every sample and cannot bridge a gap (--allow-gaps does not help here)"


@dataclass
class NavConfig:
    subsamples: int = 4  #: sub-samples per navigation interval (1..4)
    vertical: str = "auto"  #: auto | free | held | reference
    init: str = "auto"  #: auto | reference | align
    align_s: float = 300.0  #: alignment window [s] when init is align
    output_rate_hz: float | None = 10.0  #: rate of the written solution (None: every interval)
    allow_gaps: bool = False
    #: navigate only this continuous segment (1-based, between IMU gaps, as sizefx inspect numbers them)
    segment: int | None = None
    levers: str | None = None  #: sizefx/levers/1 file: compensate the size effect before navigating
    #: effect model (sizefx.correct.load_model): correct the IMU errors and the size effect before
    #: navigating (sizefx.correct.correct_imu); not together with ``levers``
    model: EffectModel | None = None
    mode: str = "triad"  #: triad | center (see sizefx.compensate)


@dataclass
class NavResult:
    time_s: np.ndarray  #: [M] end of each navigation interval
    quat_nb: np.ndarray  #: [M, 4]
    v_n: np.ndarray  #: [M, 3]
    lat_rad: np.ndarray
    lon_rad: np.ndarray
    height_m: np.ndarray
    config: dict
    summary: dict
    #: histories against the reference at errors["time_s"]: horizontal_m, north_m, east_m,
    #: velocity_mps [.., 3], attitude_rad (only where the reference has samples)
    errors: dict | None = None


# --------------------------------------------------------------------------- inputs


def uniform_period_s(t_first: float, t_last: float, n: int) -> float:
    """The sample period of a uniformly sampled record: its span over ``n - 1`` steps.

    Not the median step: stamps like k / 1600 round differently along a long record, and
    the median of the whole record and of its first chunk differ in the 11th digit, which
    a streamed run must not.
    """
    return (float(t_last) - float(t_first)) / (n - 1)


#: Time stamps further than this from the uniform grid [periods] are reported in the summary: the
#: samples are integrated at their grid points, and a user should know by how much they were moved.
JITTER_REPORTED = 0.05


def grid_offsets_periods(time_s, t_first: float, dt: float, first_row: int = 0) -> np.ndarray:
    """How far each stamp lies from its point of the uniform grid ``t_first + k dt`` [periods];
    ``first_row`` is the grid index of ``time_s[0]``."""
    return (np.asarray(time_s) - (t_first + (first_row + np.arange(len(time_s))) * dt)) / dt


def increments_of(tel: Telemetry, dt: float | None = None, first_row: int = 0, *, t_first: float | None = None,
                  row0: int = 0):
    """``(t_end [N'], dtheta [N',3], dvel [N',3], dt, jitter)`` for a record of either form.

    ``dt``: the record's period when ``tel`` is a chunk of it (default: ``tel``'s own span);
    ``first_row``: the row of ``tel``'s first sample counted from the record's first, whose time is
    ``t_first`` (default: ``tel``'s own first); ``row0``: the file row of the record's first sample
    (a segment's), for messages. The stamps must lie on the uniform grid within
    :data:`GRID_TOLERANCE` periods; ``jitter`` is the largest distance of one from it [periods].
    """
    if dt is None:
        dt = uniform_period_s(tel.time_s[0], tel.time_s[-1], tel.n_samples)
    if t_first is None:
        t_first = float(tel.time_s[0]) - first_row * dt
    off_grid = grid_offsets_periods(tel.time_s, t_first, dt, first_row)
    worst = int(np.argmax(np.abs(off_grid)))
    jitter = float(abs(off_grid[worst]))
    if abs(off_grid[worst]) > GRID_TOLERANCE:
        raise TelemetryError(tel.path, "/imu/time", f"sampling is not uniform: the stamp of row {row0 + first_row + worst} "
                                                    f"is {off_grid[worst]:+.3g} periods off the uniform grid of "
                                                    f"{dt:.6g} s; navigation integrates on that grid and accepts "
                                                    f"jitter up to {GRID_TOLERANCE} period (resample the record, "
                                                    "or cut it where the rate changes)")
    if tel.form == "increments":
        return tel.time_s, np.ascontiguousarray(tel.dtheta_rad), np.ascontiguousarray(tel.dvel_mps), dt, jitter
    n = tel.n_samples
    dtheta = np.empty((n - 1, 3))
    dvel = np.empty((n - 1, 3))
    rates_to_increments(np.ascontiguousarray(tel.gyro_rad_s), dt, dtheta)
    rates_to_increments(np.ascontiguousarray(tel.accel_mps2), dt, dvel)
    return tel.time_s[1:], dtheta, dvel, dt, jitter


# --------------------------------------------------------------------------- alignment


def coarse_alignment(f_b, omega_b, lat_rad, h_m) -> np.ndarray:
    """``mat_nb`` from mean specific force and angular rate (TRIAD: gravity trusted, heading from Earth rate)."""
    f_n = -earth.gravity_n(lat_rad, h_m)
    w_n = earth.omega_ie_n(lat_rad)

    def triad(f, w):
        v1 = f / np.linalg.norm(f)
        v2 = np.cross(f, w)
        v2 /= np.linalg.norm(v2)
        return np.column_stack([v1, v2, np.cross(v1, v2)])

    return triad(f_n, w_n) @ triad(np.asarray(f_b), np.asarray(omega_b)).T


def _run_kernel(dtheta, dvel, n_sub, dt, state, mode, h_hold, h_ref, vd_ref):
    n_steps = dtheta.shape[0] // n_sub
    out_q = np.empty((n_steps, 4))
    out_v = np.empty((n_steps, 3))
    out_lat = np.empty(n_steps)
    out_lon = np.empty(n_steps)
    out_h = np.empty(n_steps)
    strapdown(dtheta, dvel, n_sub, coning_coefficients(n_sub), n_sub * dt, state, mode, h_hold,
              h_ref, vd_ref, out_q, out_v, out_lat, out_lon, out_h)
    return out_q, out_v, out_lat, out_lon, out_h


def fine_alignment(dtheta, dvel, dt, mat_nb0, lat, lon, h, n_sub, iterations: int = 2):
    """Refine ``mat_nb0`` so that navigating the (stationary) window gives the least velocity.

    Parameters fitted: the attitude error about north, east and down, and a gyro
    drift about north. Without the drift, a north drift (whose east-velocity
    error grows as t^2) would be absorbed into a wrong roll. A drift about east
    cannot be told from a heading error: that is the gyrocompassing limit,
    heading error = east drift / (Omega_E cos lat).

    Returns ``(mat_nb, north_drift_rad_s)``.
    """
    empty = np.zeros(0)
    mat = mat_nb0
    eps = 1e-5  # rad: small enough for linearity (errors ~ eps^2), large enough against rounding
    eps_drift = 1e-9  # rad/s (0.0002 deg/h): the same order of velocity response over minutes
    drift = 0.0

    def velocities(trial_mat, drift_n):
        bias_b = trial_mat.T @ np.array([drift_n, 0.0, 0.0])  # static: a fixed body vector
        state = pack_state(mat_to_quat(trial_mat), np.zeros(3), lat, lon, h)
        _, v, _, _, _ = _run_kernel(dtheta - bias_b * dt, dvel, n_sub, dt, state, VERTICAL_HELD, h, empty, empty)
        return v[:, :2].ravel()

    for _ in range(iterations):
        base = velocities(mat, drift)
        cols = [(velocities(rotvec_to_mat(eps * np.eye(3)[k]) @ mat, drift) - base) / eps for k in range(3)]
        cols.append((velocities(mat, drift + eps_drift) - base) / eps_drift)
        x, *_ = np.linalg.lstsq(np.column_stack(cols), -base, rcond=None)
        mat = rotvec_to_mat(x[:3]) @ mat
        drift += x[3]
    return mat, drift


# --------------------------------------------------------------------------- the run


def _reference_at(tel: Telemetry, t, attitude: bool = True):
    ref = tel.reference
    out = {"quat_nb": quat_interp(ref.time_s, ref.quat_nb, t)} if attitude else {}
    if ref.has_position:
        out["lat"] = np.interp(t, ref.time_s, ref.lat_rad)
        out["lon"] = np.interp(t, ref.time_s, ref.lon_rad)
        out["h"] = np.interp(t, ref.time_s, ref.height_m)
    if ref.velocity_n_mps is not None:
        out["v_n"] = np.column_stack([np.interp(t, ref.time_s, ref.velocity_n_mps[:, i]) for i in range(3)])
    return out


def _choose(tel: Telemetry, cfg: NavConfig, t_start: float):
    """Initialisation and vertical mode for this record, with the reason."""
    ref = tel.reference
    approximate = bool(tel.source and tel.source.get("reference_is_approximate"))
    covers = ref is not None and ref.time_s[0] <= t_start + 1e-9 and not approximate
    init = cfg.init
    if init == "auto":
        init = "reference" if covers else "align"
    if init == "reference" and not covers:
        raise ConfigError(f"{tel.path}: --init reference needs a /reference that covers the start "
                          f"(t = {t_start:.3f} s) and is not approximate; use --init align")
    vertical = cfg.vertical
    stationary = True
    if ref is not None and ref.has_position:
        r_mer, r_tr = earth.radii_m(ref.lat_rad[0])
        span = max(np.ptp(ref.lat_rad) * r_mer, np.ptp(ref.lon_rad) * r_tr * np.cos(ref.lat_rad[0]),
                   np.ptp(ref.height_m))
        stationary = span < STATIONARY_SPAN_M
    if vertical == "auto":
        if stationary:
            vertical = "held"
        elif ref is not None and ref.has_position:
            vertical = "reference"
        else:
            vertical = "free"
    if vertical == "reference" and (ref is None or not ref.has_position):
        raise ConfigError(f"{tel.path}: --vertical reference needs /reference/position")
    return init, vertical, stationary


def initial_state(path, cfg: NavConfig, init: str, ref0, site, dt: float, n_sub: int, n_increments: int,
                  alignment_window):
    """Start attitude, velocity and position, and the alignment details for the configuration.

    ``ref0``: the reference at the start (:func:`_reference_at`) or None; ``alignment_window(n)``
    returns the first ``n`` angle and velocity increments (whole record or stream alike).
    Returns ``(quat0, v0, (lat0, lon0, h0), details)``.
    """
    if ref0 is not None and "lat" in ref0:
        lat0, lon0, h0 = float(ref0["lat"][0]), float(ref0["lon"][0]), float(ref0["h"][0])
    elif site is not None:
        lat0, lon0, h0 = float(site.lat_rad), float(site.lon_rad), float(site.height_m)
    else:
        raise ConfigError(f"{path}: no start position: the file has neither root latitude/longitude/height "
                          "nor /reference/position; add the site attributes (sizefx import --site-deg)")
    if init == "reference":
        v0 = ref0["v_n"][0] if "v_n" in ref0 else np.zeros(3)
        return ref0["quat_nb"][0], v0, (lat0, lon0, h0), {}
    n_align = int(round(cfg.align_s / dt))
    n_align -= n_align % n_sub
    if n_align < n_sub * 10 or n_align > n_increments:
        raise ConfigError(f"{path}: alignment window of {cfg.align_s} s does not fit a record of "
                          f"{n_increments * dt:.1f} s; choose --align-s")
    dtheta, dvel = alignment_window(n_align)
    f_b = dvel.sum(axis=0) / (n_align * dt)
    w_b = dtheta.sum(axis=0) / (n_align * dt)
    mat_c = coarse_alignment(f_b, w_b, lat0, h0)
    mat_f, drift_n = fine_alignment(dtheta, dvel, dt, mat_c, lat0, lon0, h0, n_sub)
    roll_c, pitch_c, heading_c = mat_to_euler(mat_c)
    roll, pitch, heading = mat_to_euler(mat_f)
    details = {"align_window_s": n_align * dt,
               "coarse_roll_pitch_heading_deg": [float(np.degrees(a)) for a in (roll_c, pitch_c, heading_c % (2 * np.pi))],
               "fine_roll_pitch_heading_deg": [float(np.degrees(a)) for a in (roll, pitch, heading % (2 * np.pi))],
               "mean_specific_force_mps2": f_b.tolist(),
               "north_gyro_drift_deg_per_h": float(np.degrees(drift_n) * 3600.0)}
    return mat_to_quat(mat_f), np.zeros(3), (lat0, lon0, h0), details


def navigate(tel: Telemetry, cfg: NavConfig | None = None) -> NavResult:
    """Navigate a record in memory (see :func:`run` for files)."""
    cfg = cfg or NavConfig()
    started = _time.perf_counter()
    if cfg.levers and cfg.model is not None:
        raise ConfigError("--levers and --model both given: the effect model has its own lever arms "
                          "([lever_arm]); give one of them")
    levers = read_levers(cfg.levers) if cfg.levers else None
    correction = None
    if cfg.model is not None:
        tel = correct_imu(tel, cfg.model, mode=cfg.mode)  # syncs the accelerometers itself
        correction = json.loads(tel.source["correction_json"])
        del correction["effects"]  # in the model file; the configuration names it
    else:
        tel = sync_accelerometers(tel, (levers.accel_delay_s or 0.0) if levers else 0.0)
    t_end, dtheta, dvel, dt, jitter = increments_of(tel)
    if levers:
        dvel = compensate_arrays_increments(dtheta, dvel, dt, levers, cfg.mode)
    n_sub = int(cfg.subsamples)
    coning_coefficients(n_sub)  # validates
    t0 = t_end[0] - dt  # start of the first increment
    init, vertical, stationary = _choose(tel, cfg, t0)
    ref0 = _reference_at(tel, np.array([t0])) if tel.reference is not None else None
    quat0, v0, (lat0, lon0, h0), details = initial_state(
        tel.path, cfg, init, ref0, tel.site, dt, n_sub, dtheta.shape[0], lambda n: (dtheta[:n], dvel[:n]))
    n_steps = dtheta.shape[0] // n_sub
    t_nav = t_end[n_sub - 1:n_steps * n_sub:n_sub]  # the file's own stamps: no accumulated rounding
    h_ref = vd_ref = np.zeros(0)
    if vertical == "reference":
        refs = _reference_at(tel, t_nav, attitude=False)
        h_ref = refs["h"]
        vd_ref = refs["v_n"][:, 2] if "v_n" in refs else -np.gradient(h_ref, t_nav)
    state = pack_state(quat0, v0, lat0, lon0, h0)
    kernel_started = _time.perf_counter()
    q, v, lat, lon, h = _run_kernel(dtheta, dvel, n_sub, dt, state, VERTICAL_MODES[vertical], h0, h_ref, vd_ref)
    kernel_s = _time.perf_counter() - kernel_started
    config = {**asdict(replace(cfg, model=None)), "model": cfg.model.source if cfg.model is not None else None,
              "correction": correction, "init": init, "vertical": vertical, "stationary_reference": stationary,
              "input_form": tel.form, "sample_rate_hz": 1.0 / dt, "nav_rate_hz": 1.0 / (n_sub * dt),
              "dropped_trailing_samples": int(dtheta.shape[0] - n_steps * n_sub),
              "time_jitter_periods": jitter,
              **details}
    result = NavResult(t_nav, q, v, lat, lon, h, config, {})
    result.summary = _summary(tel, result, n_steps * n_sub)
    result.summary["kernel_s"] = kernel_s
    result.summary["wall_s"] = _time.perf_counter() - started
    return result


def _summary(tel: Telemetry, res: NavResult, samples: int) -> dict:
    duration = float(res.time_s[-1] - res.time_s[0] + (res.time_s[1] - res.time_s[0] if res.time_s.size > 1 else 0))
    out = {"samples": int(samples), "duration_s": duration, "final_horizontal_error_m": None,
           "max_horizontal_error_m": None, "drift_nmi_per_h": None, "final_velocity_error_mps": None,
           "final_attitude_error_deg": None, "max_attitude_error_deg": None,
           "final_latitude_deg": float(np.degrees(res.lat_rad[-1])),
           "final_longitude_deg": float(np.degrees(res.lon_rad[-1])), "final_height_m": float(res.height_m[-1])}
    if tel.reference is None:
        return out
    ref_t = tel.reference.time_s
    covered = (res.time_s >= ref_t[0]) & (res.time_s <= ref_t[-1] + 1e-9)
    if ref_t.size > 2 and np.median(np.diff(ref_t)) > 1.5 * np.median(np.diff(res.time_s)):
        # A reference sparser than the solution is compared only where it has samples:
        # interpolating it (e.g. 100 Hz through 32 Hz rotor vibration) would be the error shown.
        k = np.clip(np.searchsorted(ref_t, res.time_s), 1, ref_t.size - 1)
        nearest = np.minimum(np.abs(ref_t[k] - res.time_s), np.abs(ref_t[k - 1] - res.time_s))
        covered &= nearest < 1e-3 * np.median(np.diff(res.time_s))
    idx = np.flatnonzero(covered)
    if idx.size == 0:
        return out
    t = res.time_s[idx]
    ref = _reference_at(tel, t)
    errors = {"time_s": t}
    if "lat" in ref:
        r_mer, r_tr = earth.radii_m(ref["lat"])
        d_north = (res.lat_rad[idx] - ref["lat"]) * (r_mer + ref["h"])
        d_east = (res.lon_rad[idx] - ref["lon"]) * (r_tr + ref["h"]) * np.cos(ref["lat"])
        horiz = np.hypot(d_north, d_east)
        errors.update(north_m=d_north, east_m=d_east, horizontal_m=horiz)
        out["final_horizontal_error_m"] = float(horiz[-1])
        out["max_horizontal_error_m"] = float(horiz.max())
        out["drift_nmi_per_h"] = float(horiz[-1] / METRES_PER_NMI / (duration / 3600.0))
    if "v_n" in ref:
        dv = res.v_n[idx] - ref["v_n"]
        errors["velocity_mps"] = dv
        out["final_velocity_error_mps"] = float(np.linalg.norm(dv[-1]))
    if not (tel.source and tel.source.get("reference_is_approximate")):
        att = quat_angle_between(ref["quat_nb"], res.quat_nb[idx])
        errors["attitude_rad"] = att
        out["final_attitude_error_deg"] = float(np.degrees(att[-1]))
        out["max_attitude_error_deg"] = float(np.degrees(att.max()))
    res.errors = errors
    return out


def _segment_config(seg) -> dict:
    """What the configuration records of the segment navigated."""
    return {"segment_of": seg.of, "segment_rows": [seg.first_row, seg.stop_row],
            "segment_time_s": [seg.start_s, seg.end_s]}


def format_summary(path, res: NavResult) -> str:
    s, c = res.summary, res.config
    lines = [f"{path}: {s['samples']} samples, {s['duration_s']:.1f} s ({s['duration_s'] / 3600:.3f} h), "
             f"{c['subsamples']} sub-samples -> {c['nav_rate_hz']:.6g} Hz navigation, kernel {s['kernel_s']:.2f} s"]
    if c.get("segment"):
        a, b = c["segment_rows"]
        t0, t1 = c["segment_time_s"]
        lines.append(f"  segment {c['segment']} of {c['segment_of']}: rows {a}..{b - 1}, t = {t0:.6f} .. {t1:.6f} s")
    lines.append(f"  initial state from {c['init']}; vertical channel {c['vertical']}")
    if c.get("time_jitter_periods", 0.0) > JITTER_REPORTED:
        lines.append(f"  time stamps up to {c['time_jitter_periods']:.2f} periods off the uniform grid of "
                     f"{1e3 / c['sample_rate_hz']:.4g} ms (logging jitter): each sample was integrated at its "
                     "grid point")
    if c.get("correction"):
        corr = c["correction"]
        lines.append(f"  IMU corrected with the effect model {corr['model']} ({corr['mode']}): "
                     f"{', '.join(corr['corrected']) or 'nothing enabled'}")
    if "fine_roll_pitch_heading_deg" in c:
        r, p, h = c["fine_roll_pitch_heading_deg"]
        lines.append(f"  alignment over {c['align_window_s']:.1f} s: roll {r:.4f} deg, pitch {p:.4f} deg, "
                     f"heading {h:.4f} deg")
    lines.append(f"  final position {s['final_latitude_deg']:.7f} deg N, {s['final_longitude_deg']:.7f} deg E, "
                 f"{s['final_height_m']:.2f} m")
    if s["final_horizontal_error_m"] is not None:
        lines.append(f"  horizontal error: final {s['final_horizontal_error_m']:.4g} m, max "
                     f"{s['max_horizontal_error_m']:.4g} m, drift {s['drift_nmi_per_h']:.4g} nmi/h")
    if s["final_velocity_error_mps"] is not None:
        lines.append(f"  final velocity error {s['final_velocity_error_mps']:.4g} m/s")
    if s["final_attitude_error_deg"] is not None:
        lines.append(f"  attitude error: final {s['final_attitude_error_deg']:.3g} deg, "
                     f"max {s['max_attitude_error_deg']:.3g} deg")
    return "\n".join(lines)


def write_navigation(path, res: NavResult, *, input_file, force: bool = False):
    """Write ``sizefx/navigation/1`` atomically, decimated to ``output_rate_hz``."""
    rate = res.config.get("output_rate_hz")
    stride = 1
    if rate and not res.config.get("streamed"):  # a streamed result holds the output rows already
        stride = max(1, int(round(res.config["nav_rate_hz"] / rate)))
    sel = slice(stride - 1, None, stride)
    roll, pitch, heading = mat_to_euler(quat_to_mat(res.quat_nb[sel]))
    with atomic_output(path, inputs=[input_file], force=force) as tmp, h5py.File(tmp, "w") as h5:
        h5.attrs["schema"] = "sizefx/navigation/1"
        h5.attrs["input_file"] = str(input_file)
        h5.attrs["configuration_json"] = json.dumps(res.config, default=float)
        h5.attrs["summary_json"] = json.dumps(res.summary, default=float)
        h5.attrs["sizefx_version"] = __version__
        h5.create_dataset("time", data=res.time_s[sel]).attrs["units"] = "s"
        h5.create_dataset("position", data=np.column_stack([np.degrees(res.lat_rad[sel]), np.degrees(res.lon_rad[sel]),
                                                            res.height_m[sel]])).attrs["units"] = "deg,deg,m"
        h5.create_dataset("velocity", data=res.v_n[sel]).attrs["units"] = "m/s"
        h5.create_dataset("quaternion", data=res.quat_nb[sel]).attrs["units"] = "1"
        h5.create_dataset("euler", data=np.column_stack([np.degrees(roll), np.degrees(pitch),
                                                         np.degrees(heading) % 360.0])).attrs["units"] = "deg"


class NavigationWriter:
    """``sizefx/navigation/1`` written row block by row block, atomically (a streamed run's output).

    The rows go to resizable datasets of a temporary file; :meth:`close` adds the
    configuration and summary and renames it into place, :meth:`abort` removes it.
    """

    def __init__(self, path, *, input_file, force: bool = False):
        self._ctx = atomic_output(path, inputs=[input_file], force=force)
        tmp = self._ctx.__enter__()
        try:
            self.h5 = h5py.File(tmp, "w")
            self.h5.attrs["schema"] = "sizefx/navigation/1"
            self.h5.attrs["input_file"] = str(input_file)
            self.h5.attrs["sizefx_version"] = __version__
            self._sets = {}
            for name, width, units in (("time", None, "s"), ("position", 3, "deg,deg,m"), ("velocity", 3, "m/s"),
                                       ("quaternion", 4, "1"), ("euler", 3, "deg")):
                shape, maxshape = ((0,), (None,)) if width is None else ((0, width), (None, width))
                chunks = (1 << 14,) if width is None else (1 << 14, width)
                dset = self.h5.create_dataset(name, shape=shape, maxshape=maxshape, chunks=chunks, dtype="f8")
                dset.attrs["units"] = units
                self._sets[name] = dset
        except BaseException as exc:
            self._ctx.__exit__(type(exc), exc, exc.__traceback__)
            raise
        self.rows = 0

    def append(self, time_s, lat_rad, lon_rad, height_m, v_n, quat_nb):
        if len(time_s) == 0:
            return
        roll, pitch, heading = mat_to_euler(quat_to_mat(quat_nb))
        block = {"time": time_s,
                 "position": np.column_stack([np.degrees(lat_rad), np.degrees(lon_rad), height_m]),
                 "velocity": v_n, "quaternion": quat_nb,
                 "euler": np.column_stack([np.degrees(roll), np.degrees(pitch), np.degrees(heading) % 360.0])}
        n0, n1 = self.rows, self.rows + len(time_s)
        for name, data in block.items():
            dset = self._sets[name]
            dset.resize(n1, axis=0)
            dset[n0:n1] = data
        self.rows = n1

    def close(self, config: dict, summary: dict):
        self.h5.attrs["configuration_json"] = json.dumps(config, default=float)
        self.h5.attrs["summary_json"] = json.dumps(summary, default=float)
        self.h5.close()
        self._ctx.__exit__(None, None, None)

    def abort(self, exc: BaseException):
        self.h5.close()
        with contextlib.suppress(type(exc)):
            self._ctx.__exit__(type(exc), exc, exc.__traceback__)


def plot_errors(res: NavResult, png, title: str):
    """Horizontal (and north, east) error against the reference versus time, PNG."""
    try:
        import matplotlib
    except ImportError:
        raise ConfigError("plots need matplotlib: pip install 'sizefx[plots]'") from None

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if res.errors is None or "horizontal_m" not in res.errors:
        raise ConfigError("no reference position to plot errors against")
    t_min = (res.errors["time_s"] - res.time_s[0]) / 60.0
    fig, ax = plt.subplots(figsize=(9, 4.5), constrained_layout=True)
    ax.plot(t_min, res.errors["horizontal_m"], label="horizontal")
    ax.plot(t_min, res.errors["north_m"], lw=0.8, label="north")
    ax.plot(t_min, res.errors["east_m"], lw=0.8, label="east")
    ax.set_xlabel("time since start [min]")
    ax.set_ylabel("position error [m]")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend()
    with atomic_output(png, force=True) as tmp:  # the caller checked the path (and --force)
        fig.savefig(tmp, dpi=120, format="png")
    plt.close(fig)


def run(path, cfg: NavConfig | None = None, *, output=None, json_path=None, plot=None, force: bool = False,
        chunk_samples: int | None = None, progress=None):
    """Entry point of ``sizefx navigate``: returns the result; writes what was asked.

    The file is streamed in chunks (:func:`sizefx.navigate.stream.navigate_file`, identical results,
    memory bounded by the chunk); ``chunk_samples=0`` reads it whole and navigates in memory.
    """
    from ..io.files import check_output_path
    from .stream import CHUNK_SAMPLES, navigate_file

    cfg = cfg or NavConfig()
    for out in (output, json_path, plot):
        if out:
            check_output_path(out, inputs=[path], force=force)  # before the work: folder exists, no silent replace
    if chunk_samples == 0:
        tel = read_telemetry(path, allow_gaps=cfg.allow_gaps, segment=cfg.segment)
        refuse_gaps(path, tel.gaps, command="navigate", why=GAPS_WHY, bridge=False)
        res = navigate(tel, cfg)
        if tel.segment is not None:
            res.config.update(_segment_config(tel.segment))
    else:
        writer = NavigationWriter(output, input_file=path, force=force) if output else None
        try:
            res = navigate_file(path, cfg, chunk_samples=chunk_samples or CHUNK_SAMPLES, progress=progress,
                                writer=writer)
        except BaseException as exc:
            if writer is not None:
                writer.abort(exc)
            raise
        if writer is not None:
            writer.close(res.config, res.summary)
            output = None  # written
    if output:
        write_navigation(output, res, input_file=path, force=force)
    if json_path:
        with atomic_output(json_path, inputs=[path], force=force) as tmp:
            Path(tmp).write_text(json.dumps({**res.summary, "configuration": res.config}, indent=2, default=float))
    if plot:
        plot_errors(res, plot, f"{Path(path).name}: free-inertial position error")
    return res
