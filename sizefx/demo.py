"""The demo behind ``sizefx demo``: built-in data through the stages that exist."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .constants import DEG, MICRO_G
from .calibrate import format_report as calibrate_report
from .calibrate import run as calibrate_run
from .inspect import format_summary, summarize
from .levers import write_levers
from .navigate import NavConfig, navigate
from .navigate import format_summary as format_nav_summary
from .simulate import run
from .telemetry import read_telemetry

__all__ = ["run_demo"]


def run_demo(out_dir: Path, *, seed: int = 0):
    """Yield the demo's report line by line (the caller prints)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / "turntable.h5"
    # The demo owns its folder: it replaces its own file from an earlier run.
    summary = run("turntable", path, seed=seed, force=True)
    yield (f"simulated the paper's turntable plan -> {path} ({summary['samples']} samples, "
           f"{summary['file_bytes'] / 2**20:.1f} MiB, {summary['wall_s']:.1f} s)")
    tel = read_telemetry(path)
    yield format_summary(summarize(tel))
    # During a rotation block the two horizontal channels carry no gravity (up
    # to the table's tilt), so their mean is the rectified centripetal term
    # -<omega^2> r_ii: the size effect, visible in the raw data.
    arms = np.asarray(tel.simulation["effects"]["lever_arm"]["r_m"])
    yield "size effect in the raw horizontal accelerometers, mean over each rotation block:"
    for name, t0, t1 in tel.simulation["segments"]:
        if not name.startswith("rotate"):
            continue
        sel = (tel.time_s > t0) & (tel.time_s < t1)
        axis = "XYZ".index(name[-1])
        w2 = np.mean(tel.gyro_rad_s[sel, axis] ** 2)
        cells = []
        for i in range(3):
            if i != axis:
                measured = np.mean(tel.accel_mps2[sel, i])
                cells.append(f"{'xyz'[i]} {measured / MICRO_G:7.1f} ug (-<w^2> r = {-w2 * arms[i][i] / MICRO_G:7.1f})")
        peak = np.max(np.abs(tel.gyro_rad_s[sel, axis])) / DEG
        yield f"  {name} (peak {peak:.1f} deg/s): " + "; ".join(cells)
    # Calibrate the lever arms from the record itself, then navigate without and with compensation.
    cal = calibrate_run([path])
    levers_path = out_dir / "levers.json"
    write_levers(levers_path, cal["levers"], force=True)
    yield "calibration (joint least squares on the same record):"
    yield calibrate_report(cal)
    res = navigate(tel, NavConfig(subsamples=4))
    yield "navigating the record without compensation (initial state from /reference):"
    yield format_nav_summary(path, res)
    res_c = navigate(tel, NavConfig(subsamples=4, levers=str(levers_path), mode="triad"))
    yield f"navigating with the calibrated lever arms ({levers_path}, triad mode):"
    yield format_nav_summary(path, res_c)
    yield (f"size-effect compensation: final horizontal error {res.summary['final_horizontal_error_m']:.2f} m -> "
           f"{res_c.summary['final_horizontal_error_m']:.2f} m over {res.summary['duration_s'] / 60:.1f} min")
    yield "next stages (compare, diagnose, the paper's experiments) are on the issue list."
