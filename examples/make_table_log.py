"""A real turntable's two logs, made by the simulator: the IMU logger's CSV and the table controller's.

    .venv/bin/python examples/make_table_log.py --out run/                     # examples/table_plan.toml
    .venv/bin/python examples/make_table_log.py --out run/ --plan plan.toml    # a plan of sizefx plan

docs/howto/calibrate-a-real-turntable.md runs ``sizefx import csv``, ``sizefx import table-log``
and ``sizefx calibrate`` on what this writes into the folder:

``imu.csv``
    The IMU logger: ``time_s``, gyro ``gx_dps, gy_dps, gz_dps`` [deg/s], accelerometers
    ``ax_mps2, ay_mps2, az_mps2`` [m/s^2], body axes (x forward, y right, z down), at the
    simulated rate (200 Hz). Printed to 1e-6 deg/s and 1e-6 m/s^2, below the noise.
``table_log.csv``
    The table controller, at 100 Hz on the same clock: ``time_ms``, then per axis, outer to inner,
    ``pos{k}_deg`` and ``rate{k}_dps``. The table is the simulator's (``sizefx.scenarios.turntable``:
    outer axis down, middle north, inner east when all read zero, its zero pointing north); as many
    controllers do, the outer axis counts its angle anticlockwise seen from above (``--axes -z,x,y``)
    and reports it within 0..360 deg, wrapping. Printed to 1e-9 deg.
``simulated.h5``
    The simulation itself, with its truth in ``/simulation`` (``sizefx calibrate`` on it gives the
    arms to compare with).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from sizefx import scenarios
from sizefx.io.plan_file import read_plan_document
from sizefx.io.telemetry import read_telemetry
from sizefx.simulate import SimulateConfig, run

HERE = Path(__file__).resolve().parent
IMU_RATE_HZ = 200.0
LOG_RATE_HZ = 100.0
SEED = 0


def write_csv(path: Path, header: list, columns: list, formats: list) -> None:
    """One line per row, ``%``-formatted (``+ 0.0`` turns -0.0 into 0.0)."""
    table = np.column_stack(columns) + 0.0
    lines = [",".join(header)] + [",".join(f % v for f, v in zip(formats, row)) for row in table]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8", newline="\n")


def main(out: Path, plan_path: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    sim = out / "simulated.h5"
    run(SimulateConfig("turntable", sim, plan_path=str(plan_path), rate_hz=IMU_RATE_HZ, seed=SEED, force=True))
    tel = read_telemetry(sim)
    write_csv(
        out / "imu.csv",
        ["time_s", "gx_dps", "gy_dps", "gz_dps", "ax_mps2", "ay_mps2", "az_mps2"],
        [tel.time_s, np.degrees(tel.gyro_rad_s), tel.accel_mps2],
        ["%.3f"] + ["%.6f"] * 6,
    )
    # the gimbal angles the simulated table turned through: its rotation chain's profiles
    plan = scenarios.TurntablePlan(**read_plan_document(plan_path)["turntable"])
    traj, _ = scenarios.turntable(plan)
    t = np.arange(0.0, traj.duration_s + 0.5 / LOG_RATE_HZ, 1.0 / LOG_RATE_HZ)
    pos_deg, rate_dps = [], []
    for k, profile in enumerate(traj.attitude.profiles):
        theta, rate, _ = profile.evaluate(t)
        sense = -1.0 if k == 0 else 1.0  # the outer axis counts anticlockwise seen from above
        pos_deg.append(np.degrees(sense * theta) % 360.0 if k == 0 else np.degrees(theta))
        rate_dps.append(np.degrees(sense * rate))
    columns = [np.round(t * 1e3)]
    for p, r in zip(pos_deg, rate_dps):
        columns += [p, r]
    write_csv(
        out / "table_log.csv",
        ["time_ms", "pos1_deg", "rate1_dps", "pos2_deg", "rate2_dps", "pos3_deg", "rate3_dps"],
        columns,
        ["%.0f"] + ["%.9f"] * 6,
    )


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help="folder to write into")
    parser.add_argument("--plan", type=Path, default=HERE / "table_plan.toml", help="a sizefx/plan/1 file")
    args = parser.parse_args()
    main(args.out, args.plan)
