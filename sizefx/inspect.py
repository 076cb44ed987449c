"""What a telemetry file holds: ``sizefx inspect``."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .constants import ARCSEC, MICRO_G, PPM
from .schema import TELEMETRY_SCHEMA
from .telemetry import Telemetry, read_telemetry

__all__ = ["summarize", "format_summary", "inspect_file"]


def _effects_found(sim: dict) -> list[str]:
    """One line per enabled effect, in user units."""
    fx = sim.get("effects", {})
    lines = []

    def on(name):
        return fx.get(name, {}).get("enabled", False)

    if on("lever_arm"):
        r = np.asarray(fx["lever_arm"]["r_m"]) * 1e3
        lines.append("lever_arm: r_x, r_y, r_z [mm] = " + "; ".join(
            "(" + ", ".join(f"{v:.2f}" for v in row) + ")" for row in r))
    if on("accel_delay"):
        lines.append(f"accel_delay: {fx['accel_delay']['tau_s'] * 1e6:.1f} us")
    if on("reference_delay"):
        lines.append(f"reference_delay: {fx['reference_delay']['tau_s'] * 1e6:.1f} us")
    if on("level_tilt"):
        lines.append(f"level_tilt: north {fx['level_tilt']['north_rad'] / ARCSEC:.2f} arcsec, "
                     f"east {fx['level_tilt']['east_rad'] / ARCSEC:.2f} arcsec")
    if on("accel_bias"):
        lines.append("accel_bias [ug]: " + ", ".join(f"{v / MICRO_G:.1f}" for v in fx["accel_bias"]["bias_mps2"]))
    for name in ("accel_scale_factor", "gyro_scale_factor"):
        if on(name):
            lines.append(f"{name} [ppm]: " + ", ".join(f"{v / PPM:.1f}" for v in fx[name]["scale_factor"]))
    for name in ("accel_misalignment", "gyro_misalignment"):
        if on(name):
            m = np.asarray(fx[name]["angles_rad"]) / ARCSEC
            lines.append(f"{name} [arcsec]: " + "; ".join(", ".join(f"{v:.1f}" for v in row) for row in m))
    if on("accel_quadratic"):
        lines.append("accel_quadratic [ug/g^2]: " + ", ".join(
            f"{v * 9.80665 / MICRO_G:.2f}" for v in fx["accel_quadratic"]["k2_per_mps2"]))
    if on("gyro_bias"):
        lines.append("gyro_bias [deg/h]: " + ", ".join(f"{np.degrees(v) * 3600:.4f}" for v in fx["gyro_bias"]["bias_rad_s"]))
    if on("gyro_g_sensitivity"):
        lines.append("gyro_g_sensitivity: on")
    if on("gyro_noise"):
        g = fx["gyro_noise"]
        lines.append(f"gyro_noise: ARW {np.degrees(g['arw_rad_per_sqrt_s']) * 60:.5f} deg/sqrt(h), "
                     f"RRW {np.degrees(g['rrw_rad_s_per_sqrt_s']) * 3600 * 60:.5f} deg/h/sqrt(h)")
    if on("accel_noise"):
        a = fx["accel_noise"]
        lines.append(f"accel_noise: {a['density_mps2_per_sqrt_hz'] / MICRO_G:.2f} ug/sqrt(Hz), "
                     f"bias RW {a['bias_rw_mps2_per_sqrt_s'] * 60 / MICRO_G:.2f} ug/sqrt(h)")
    if on("quantisation"):
        lines.append("quantisation: on")
    return lines


def summarize(tel: Telemetry) -> dict:
    """A JSON-ready description of a validated record."""
    ref = tel.reference
    out = {
        "path": tel.path,
        "schema": TELEMETRY_SCHEMA,
        "form": tel.form,
        "samples": tel.n_samples,
        "sample_rate_hz": tel.sample_rate_hz,
        "duration_s": tel.duration_s,
        "start_s": float(tel.time_s[0]),
        "stored_units": tel.stored_units,
        "stored_dtypes": tel.stored_dtypes,
        "accel_time": tel.accel_time_s is not None,
        "gaps": [{"dataset": g.dataset, "row": g.index, "time_s": g.time_s, "duration_s": g.duration_s}
                 for g in tel.gaps],
        "site": None if tel.site is None else {
            "latitude_deg": float(np.degrees(tel.site.lat_rad)), "longitude_deg": float(np.degrees(tel.site.lon_rad)),
            "height_m": float(tel.site.height_m)},
        "reference": None if ref is None else {
            "samples": int(ref.time_s.shape[0]),
            "rate_hz": float(1.0 / np.median(np.diff(ref.time_s))),
            "position": ref.has_position, "velocity": ref.velocity_n_mps is not None},
        "description": tel.description,
        "simulation": None,
    }
    if tel.simulation is not None:
        sim = tel.simulation
        out["simulation"] = {"scenario": sim.get("scenario"), "seed": sim.get("seed"),
                             "effects": _effects_found(sim), "segments": sim.get("segments", [])}
    return out


def format_summary(s: dict) -> str:
    """The text ``sizefx inspect`` prints."""
    lines = [f"{s['path']}: valid {s['schema']}",
             f"  IMU       {s['samples']} samples of {s['form']}, {s['sample_rate_hz']:.6g} Hz, "
             f"{s['duration_s']:.3f} s ({s['duration_s'] / 3600:.3f} h) from t = {s['start_s']:.6g} s",
             "  units     " + ", ".join(f"{k} [{v}] {s['stored_dtypes'][k]}" for k, v in s["stored_units"].items())]
    if s["accel_time"]:
        lines.append("  accel     separate time stamps (/imu/accel_time)")
    if s["gaps"]:
        g = s["gaps"][0]
        lines.append(f"  gaps      {len(s['gaps'])}, the first in {g['dataset']} at row {g['row']} "
                     f"(t = {g['time_s']:.6f} s, {g['duration_s'] * 1e3:.4g} ms)")
    else:
        lines.append("  gaps      none")
    if s["site"]:
        st = s["site"]
        lines.append(f"  site      {st['latitude_deg']:.6f} deg N, {st['longitude_deg']:.6f} deg E, {st['height_m']:.1f} m")
    if s["reference"]:
        r = s["reference"]
        extra = " + ".join(k for k in ("position", "velocity") if r[k])
        lines.append(f"  reference {r['samples']} samples at {r['rate_hz']:.6g} Hz: attitude"
                     + (f" + {extra}" if extra else ""))
    else:
        lines.append("  reference none")
    if s["simulation"]:
        sim = s["simulation"]
        lines.append(f"  simulated {sim['scenario']}, seed {sim['seed']}")
        for seg in sim["segments"]:
            lines.append(f"    {seg[1]:9.1f} .. {seg[2]:9.1f} s  {seg[0]}")
        lines.append("  effects   " + ("none" if not sim["effects"] else sim["effects"][0]))
        lines.extend(f"            {e}" for e in sim["effects"][1:])
    if s["description"]:
        lines.append(f"  about     {s['description']}")
    return "\n".join(lines)


def inspect_file(path, *, allow_gaps: bool = False) -> dict:
    return summarize(read_telemetry(Path(path), allow_gaps=allow_gaps))
