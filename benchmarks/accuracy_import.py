"""Figures of `sizefx import` on the real recordings: the units check of each file, and what they read.

    python benchmarks/accuracy_import.py [--json out.json] [--record]

Each file in ../shared/data/real (or under SIZEFX_REAL_DATA) is imported as docs/import.md shows,
read where it lies, never copied into the repository:

- the units check the import runs on what it writes (``sizefx.sanity.check_units``, as
  ``sizefx inspect`` prints it): specific force against gravity, gyros against the reference
  attitude or the tilts the accelerometers see (docs/telemetry.md's table);
- the PSINS ring-laser log, parked: its mean angular rate against Earth rate, its mean specific
  force against normal gravity at the header's site (docs/import.md);
- imucal's three hand rotations, integrated.

``tests/test_importers.py`` checks that every file passes; this script records the figures.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import tempfile
from pathlib import Path

import numpy as np

from sizefx import earth
from sizefx.constants import OMEGA_EARTH_RAD_S
from sizefx.importers import run_import
from sizefx.io.telemetry import read_telemetry

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _measure import add_output_options, emit  # (a sibling of this script)

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
# the real recordings (read where they lie, never copied) and their import options, as the tests read them
from support import IMUCAL, REAL, REAL_FILES

#: The tilt check's figures as it prints them: "median residual 4.5 % over 5 tilt changes of 75-177 deg"
TILT_DETAIL = re.compile(r"median residual ([\d.]+) % over (\d+) tilt changes of (\d+)-(\d+) deg")


def units_figures(check: dict) -> dict:
    """One dataset's verdict: the ratio, what it rests on, and (a tilt check) its residual and tilts."""
    out = {k: check[k] for k in ("dataset", "verdict", "method", "ratio", "count", "detail")}
    m = TILT_DETAIL.search(check["detail"]) if check["method"] == "tilt" else None
    if m:
        out["tilt_residual_pct"] = float(m.group(1))
        out["tilt_min_deg"], out["tilt_max_deg"] = float(m.group(3)), float(m.group(4))
    return out


def ring_laser(tel) -> dict:
    """Mean angular rate and specific force of the parked log, against Earth rate and normal gravity."""
    dt = tel.sample_period_s
    w = tel.dtheta_rad.mean(axis=0) / dt
    f = tel.dvel_mps.mean(axis=0) / dt
    g = float(earth.gravity_n(tel.site.lat_rad, tel.site.height_m)[2])
    return {
        "earth_rate_read_deg_per_h": float(np.degrees(np.linalg.norm(w)) * 3600),
        "earth_rate_expected_deg_per_h": float(np.degrees(OMEGA_EARTH_RAD_S) * 3600),
        "specific_force_mps2": float(np.linalg.norm(f)),
        "normal_gravity_mps2": g,
        "specific_force_over_gravity_minus_1": float(np.linalg.norm(f) / g - 1.0),
    }


def imucal_rotations(tel) -> list[float]:
    """The three hand rotations (x, y, z), each integrated over its section of the session list [deg]."""
    sections = json.loads((REAL / "imucal" / "example_ferraris_session_list.json").read_text())
    dt = 1 / IMUCAL["rate_hz"]
    return [
        float(np.degrees(tel.gyro_rad_s[sections[key]["start"] : sections[key]["end"], axis].sum() * dt))
        for axis, key in enumerate(("x_rot", "y_rot", "z_rot"))
    ]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_output_options(ap)
    args = ap.parse_args(argv)
    if not REAL.is_dir():
        print(f"real data folder {REAL} not found: put shared/ beside the checkout or set SIZEFX_REAL_DATA")
        return 2
    report = {"files": {}}
    with tempfile.TemporaryDirectory() as tmp:
        for name, (fmt, rel, opts) in REAL_FILES.items():
            h5 = Path(tmp) / f"{name}.h5"
            summary = run_import(fmt, REAL / rel, h5, **opts)
            units = summary["units_check"]
            report["files"][name] = {
                "format": fmt,
                "source": rel,
                "samples": summary["samples"],
                "duration_s": summary["duration_s"],
                "accel": units_figures(units["accel"]),
                "gyro": units_figures(units["gyro"]),
            }
            if name in ("lasergyro", "imucal"):
                tel = read_telemetry(h5, allow_gaps=True)
                if name == "lasergyro":
                    report["ring_laser"] = ring_laser(tel)
                else:
                    report["imucal_rotations_deg"] = imucal_rotations(tel)
    broad = [report["files"][n] for n in REAL_FILES if n.startswith("broad")]
    report["broad"] = {
        "accel_ratio": [b["accel"]["ratio"] for b in broad],
        "gyro_ratio": [b["gyro"]["ratio"] for b in broad],
        "gyro_intervals": [b["gyro"]["count"] for b in broad],
    }
    print("file        specific force / gravity        gyro")
    for name, r in report["files"].items():
        a, g = r["accel"], r["gyro"]
        gyro = f"{g['ratio']:.3f} ({g['method']}, {g['count']})" if g["ratio"] is not None else g["verdict"]
        print(f"  {name:10s}{a['ratio']:.3f} ({a['method']}, {a['count']} windows)       {gyro}")
    rl = report["ring_laser"]
    print(
        f"ring-laser log: |omega| {rl['earth_rate_read_deg_per_h']:.2f} deg/h against Earth rate "
        f"{rl['earth_rate_expected_deg_per_h']:.2f}; |f| / g - 1 = {rl['specific_force_over_gravity_minus_1']:.1e}"
    )
    print("imucal rotations [deg]: " + ", ".join(f"{a:.1f}" for a in report["imucal_rotations_deg"]))
    return emit(report, args, __file__, argv, show=False)


if __name__ == "__main__":
    sys.exit(main())
