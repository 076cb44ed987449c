"""What a telemetry file holds: ``sizefx inspect``.

The stage (:mod:`sizefx.stage`): :class:`InspectConfig` -> :func:`run` -> :class:`InspectResult`,
whose ``report()`` is the text the command prints and ``to_json()`` what ``--json FILE`` writes.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from .configs.inspect import InspectConfig
from .constants import ARCSEC, MICRO_G, PPM, SECONDS_PER_HOUR, SQRT_SECONDS_PER_HOUR, STANDARD_GRAVITY_MPS2
from .io.documents import write_json
from .io.schema import TELEMETRY_SCHEMA, allowed_units
from .io.telemetry import Telemetry, imu_segments, read_telemetry
from .sanity import report_lines

__all__ = ["InspectConfig", "InspectResult", "run", "summarize", "format_summary", "inspect_file"]

#: Segments listed one per line in the text summary (all of them are in --json FILE).
SEGMENTS_SHOWN = 12


def _effects_found(sim: dict) -> list[str]:
    """One line per enabled effect, in user units."""
    fx = sim.get("effects", {})
    lines = []

    def on(name):
        return fx.get(name, {}).get("enabled", False)

    if on("lever_arm"):
        r = np.asarray(fx["lever_arm"]["r_m"]) * 1e3
        lines.append(
            "lever_arm: r_x, r_y, r_z [mm] = " + "; ".join("(" + ", ".join(f"{v:.2f}" for v in row) + ")" for row in r)
        )
    if on("accel_delay"):
        lines.append(f"accel_delay: {fx['accel_delay']['tau_s'] * 1e6:.1f} us")
    if on("reference_delay"):
        lines.append(f"reference_delay: {fx['reference_delay']['tau_s'] * 1e6:.1f} us")
    if on("level_tilt"):
        lines.append(
            f"level_tilt: north {fx['level_tilt']['north_rad'] / ARCSEC:.2f} arcsec, "
            f"east {fx['level_tilt']['east_rad'] / ARCSEC:.2f} arcsec"
        )
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
        lines.append(
            "accel_quadratic [ug/g^2]: "
            + ", ".join(f"{v * STANDARD_GRAVITY_MPS2 / MICRO_G:.2f}" for v in fx["accel_quadratic"]["k2_per_mps2"])
        )
    if on("gyro_bias"):
        lines.append(
            "gyro_bias [deg/h]: "
            + ", ".join(f"{np.degrees(v) * SECONDS_PER_HOUR:.4f}" for v in fx["gyro_bias"]["bias_rad_s"])
        )
    if on("gyro_g_sensitivity"):
        lines.append("gyro_g_sensitivity: on")
    if on("gyro_noise"):
        g = fx["gyro_noise"]
        lines.append(
            f"gyro_noise: ARW {np.degrees(g['arw_rad_per_sqrt_s']) * SQRT_SECONDS_PER_HOUR:.5f} deg/sqrt(h), "
            f"RRW {np.degrees(g['rrw_rad_s_per_sqrt_s']) * SECONDS_PER_HOUR * SQRT_SECONDS_PER_HOUR:.5f} deg/h/sqrt(h)"
        )
    if on("accel_noise"):
        a = fx["accel_noise"]
        lines.append(
            f"accel_noise: {a['density_mps2_per_sqrt_hz'] / MICRO_G:.2f} ug/sqrt(Hz), "
            f"bias RW {a['bias_rw_mps2_per_sqrt_s'] * 60 / MICRO_G:.2f} ug/sqrt(h)"
            + (
                f", Gauss-Markov {a['markov_density_mps2_per_sqrt_hz'] / MICRO_G:.2f} ug/sqrt(Hz) over "
                f"{a['markov_correlation_s'] * 1e3:.1f} ms"
                if a.get("markov_density_mps2_per_sqrt_hz")
                else ""
            )
        )
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
        "gaps": [
            {
                "dataset": g.dataset,
                "row": g.index,
                "time_s": g.time_s,
                "duration_s": g.duration_s,
                "declared": g.declared,
            }
            for g in tel.gaps
        ],
        "segments": [
            {
                "number": seg.number,
                "first_row": seg.first_row,
                "samples": seg.samples,
                "start_s": seg.start_s,
                "end_s": seg.end_s,
            }
            for seg in imu_segments(tel.n_samples, tel.gaps, tel.time_s.__getitem__)
        ],
        "units_check": None,
        "site": None
        if tel.site is None
        else {
            "latitude_deg": float(np.degrees(tel.site.lat_rad)),
            "longitude_deg": float(np.degrees(tel.site.lon_rad)),
            "height_m": float(tel.site.height_m),
        },
        "reference": None
        if ref is None
        else {
            "samples": int(ref.time_s.shape[0]),
            "rate_hz": float(1.0 / np.median(np.diff(ref.time_s))),
            "position": ref.has_position,
            "velocity": ref.velocity_n_mps is not None,
        },
        "description": tel.description,
        "simulation": None,
    }
    if tel.simulation is not None:
        sim = tel.simulation
        out["simulation"] = {
            "scenario": sim.get("scenario"),
            "seed": sim.get("seed"),
            "effects": _effects_found(sim),
            "segments": sim.get("segments", []),
        }
    return out


def format_summary(s: dict) -> str:
    """The text ``sizefx inspect`` prints."""
    lines = [
        f"{s['path']}: valid {s['schema']}",
        f"  IMU       {s['samples']} samples of {s['form']}, {s['sample_rate_hz']:.6g} Hz, "
        f"{s['duration_s']:.3f} s ({s['duration_s'] / SECONDS_PER_HOUR:.3f} h) from t = {s['start_s']:.6g} s",
        "  units     " + ", ".join(f"{k} [{v}] {s['stored_dtypes'][k]}" for k, v in s["stored_units"].items()),
    ]
    if s["accel_time"]:
        lines.append("  accel     separate time stamps (/imu/accel_time)")
    checked = report_lines(s.get("units_check"))
    lines.append(f"  checked   {'units ' if s.get('units_check') is None else ''}{checked[0]}")
    lines.extend(f"            {line}" for line in checked[1:])
    imu = [g for g in s["gaps"] if g["dataset"].startswith("/imu")]
    ref = [g for g in s["gaps"] if not g["dataset"].startswith("/imu")]
    if imu:
        declared = sum(g["declared"] for g in imu)
        state = (
            "declared in /imu/gaps"
            if declared == len(imu)
            else "undeclared, accepted with --allow-gaps"
            if declared == 0
            else f"{declared} declared in /imu/gaps, {len(imu) - declared} accepted with --allow-gaps"
        )
        first = imu[0]
        big = max(imu, key=lambda g: g["duration_s"])
        lines.append(
            f"  gaps      {len(imu)} in the IMU time stamps ({state}); the first at row {first['row']} "
            f"(t = {first['time_s']:.6f} s, {first['duration_s'] * 1e3:.4g} ms), the longest at row "
            f"{big['row']} (t = {big['time_s']:.6f} s, {big['duration_s'] * 1e3:.4g} ms)"
        )
        segs = s["segments"]
        lines.append(f"  segments  {len(segs)} continuous (--segment K of navigate, compensate, diagnose):")
        for seg in segs[:SEGMENTS_SHOWN]:
            last = seg["first_row"] + seg["samples"] - 1
            lines.append(
                f"    {seg['number']:4d}  rows {seg['first_row']:>9d}..{last:<9d} {seg['samples']:9d} sample{'s' if seg['samples'] != 1 else ' '}  "
                f"t = {seg['start_s']:.6f} .. {seg['end_s']:.6f} s ({seg['end_s'] - seg['start_s']:.3f} s)"
            )
        if len(segs) > SEGMENTS_SHOWN:
            lines.append(f"          ... and {len(segs) - SEGMENTS_SHOWN} more (--json FILE lists them all)")
    else:
        lines.append("  gaps      none")
    if ref:
        g = ref[0]
        longest = max(ref, key=lambda x: x["duration_s"])
        lines.append(
            f"  dropouts  {len(ref)} in {g['dataset']} at row {g['row']} (t = {g['time_s']:.6f} s, "
            f"{g['duration_s'] * 1e3:.4g} ms)"
            + ("" if len(ref) == 1 else f" first; the longest {longest['duration_s'] * 1e3:.4g} ms")
            + " (accepted: the reference is only compared)"
        )
    if s["site"]:
        st = s["site"]
        lines.append(
            f"  site      {st['latitude_deg']:.6f} deg N, {st['longitude_deg']:.6f} deg E, {st['height_m']:.1f} m"
        )
    if s["reference"]:
        r = s["reference"]
        extra = " + ".join(k for k in ("position", "velocity") if r[k])
        lines.append(
            f"  reference {r['samples']} samples at {r['rate_hz']:.6g} Hz: attitude" + (f" + {extra}" if extra else "")
        )
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


def _units_fix(check) -> str:
    """How to correct a file whose data look like another unit (for the one-line error)."""
    quantity = {"gyro": ("angular_rate", "angle"), "accel": ("acceleration", "velocity")}[check.what]
    from .sanity import UNITS_OUTSIDE_CONTRACT

    if any(check.looks_like in allowed_units(q) for q in quantity):
        return f"set its units attribute to '{check.looks_like}'"
    for q in quantity:
        if check.looks_like in UNITS_OUTSIDE_CONTRACT.get(q, {}):
            return f"multiply {check.dataset} by {UNITS_OUTSIDE_CONTRACT[q][check.looks_like]:g} to make it {check.declared}"
    return f"check the units attribute of {check.dataset}"


@dataclass
class InspectResult:
    """What a valid record holds: the fields of :func:`summarize` (``to_json()`` is what ``--json`` writes)."""

    path: str
    schema: str
    form: str
    samples: int
    sample_rate_hz: float
    duration_s: float
    start_s: float
    stored_units: dict
    stored_dtypes: dict
    accel_time: bool
    gaps: list  #: every gap: dataset, row, time_s, duration_s, declared
    segments: list  #: the continuous IMU segments: number, first_row, samples, start_s, end_s
    units_check: dict | None  #: :meth:`sizefx.sanity.UnitsReport.as_dict`, None when not checked
    site: dict | None
    reference: dict | None
    description: str
    simulation: dict | None

    def to_json(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)}

    def report(self) -> str:
        """The text ``sizefx inspect`` prints."""
        return format_summary(self.to_json())


def run(config: InspectConfig, *, progress=None) -> InspectResult:
    """Validate ``config.file`` and describe it; with ``check_units`` (default) also check its units
    against physics (:mod:`sizefx.sanity`) and refuse data that look like another unit. With a
    ``json_path`` other than ``"-"`` the summary is written there (atomically, never over an input).

    Pre-flight first (:func:`sizefx.stage.preflight`: the file exists). ``progress`` is accepted
    for the shape every stage shares and not called: the reader validates the whole record in
    one pass.
    """
    from .sanity import check_units as units_of
    from .sanity import refuse_wrong_units
    from .stage import preflight

    preflight(inputs=config.inputs(), outputs=config.outputs(), force=config.force)
    path = Path(config.file)
    tel = read_telemetry(path, allow_gaps=config.allow_gaps, check_plausibility=config.check_units)
    summary = summarize(tel)
    if config.check_units:
        report = units_of(tel)
        refuse_wrong_units(report, path, fix=_units_fix)
        summary["units_check"] = report.as_dict()
    result = InspectResult(**summary)
    if config.json_path not in (None, "-"):
        write_json(config.json_path, result.to_json(), inputs=[path], force=config.force)
    return result


def inspect_file(path, *, allow_gaps: bool = False, check_units: bool = True) -> dict:
    """``run(InspectConfig(path, allow_gaps, check_units)).to_json()``: the call scripts made before the
    stage shape; kept so they keep working."""
    return run(InspectConfig(path, allow_gaps=allow_gaps, check_units=check_units)).to_json()
