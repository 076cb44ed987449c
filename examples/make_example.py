"""Regenerate the example recording of README "Your own recording", bit for bit.

    .venv/bin/python examples/make_example.py            # rewrites examples/tumble_*
    .venv/bin/python examples/make_example.py --out DIR  # writes them into DIR instead

1. Simulates, with the installed ``sizefx`` next to this Python:

       sizefx simulate tumble -o tumble.h5 --rate-hz 100 --reference-rate-hz 50 --seed 0 \\
           --set 'lever_arm.d_y_m=[0.0, 0.0279, 0.0]' \\
           --set accel_delay.enabled=true --set accel_delay.tau_s=0.001

   120 s of heading, pitch and roll sinusoids on a static site (the paper's airfield),
   navigation-grade noise, the high-precision arms except accelerometer y, which sits
   3.0 mm further out than the drawing (27.9 instead of 24.9 mm), and accelerometers
   that lag the gyros by 1 ms.
2. Writes what a user's logger and reference system would: the IMU in its own
   forward-left-up axes (``x, -y, -z`` of body FRD), gyro in deg/s, accelerometers in
   m/s^2, 100 Hz (``tumble_imu.csv``); the reference at 50 Hz in its own file
   (``tumble_reference.csv``) as ROS writes it: quaternion (w, x, y, z) of the sensor
   axes in East-North-Up, ENU velocity, latitude/longitude [deg] and height [m], with a
   three-row occlusion (empty cells) at t = 60.00-60.04 s.
3. Keeps the simulation's truth (``/simulation``, SI, body FRD) in ``tumble_truth.json``,
   so the result of ``calibrate`` and ``diagnose`` can be checked against it.

Printed digits: time exact (multiples of 10 ms); gyro 1e-6 deg/s (rounding noise 3e-7
deg/s against a sample noise of 6e-5 deg/s); accelerometers 1e-6 m/s^2 (0.03 ug rms
against 25 ug); quaternion 1e-9 (2e-9 rad, 0.01 ug of gravity); position 1e-9 deg
(0.1 mm). ``tests/test_own_recording.py`` regenerates the files and compares bytes.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from sizefx.frames import MAT_FRD_FLU, MAT_NED_ENU
from sizefx.io.telemetry import read_telemetry
from sizefx.rotation import mat_to_quat, quat_to_mat

HERE = Path(__file__).resolve().parent
SIMULATE = [
    "simulate",
    "tumble",
    "--rate-hz",
    "100",
    "--reference-rate-hz",
    "50",
    "--seed",
    "0",
    "--set",
    "lever_arm.d_y_m=[0.0, 0.0279, 0.0]",
    "--set",
    "accel_delay.enabled=true",
    "--set",
    "accel_delay.tau_s=0.001",
    "--quiet",
]
#: Reference rows left empty, as a motion-capture occlusion would: t = 60.00, 60.02, 60.04 s.
OCCLUDED_ROWS = slice(3000, 3003)
#: Body FRD = MAT_FRD_FLU @ sensor FLU: the sensor's axes are x forward, y left, z up.
MAT_B_S = MAT_FRD_FLU


def write_csv(path: Path, header: list, columns: list, formats: list, empty_rows=slice(0, 0)):
    """One line per row, ``%``-formatted; the cells of ``empty_rows`` after the time are left empty."""
    table = np.column_stack(columns) + 0.0  # + 0.0 turns -0.0 into 0.0: no "-0.0000" for a zero velocity
    lines = [",".join(header)]
    empty = set(range(table.shape[0])[empty_rows])
    for k, row in enumerate(table):
        cells = [fmt % v for fmt, v in zip(formats, row)]
        if k in empty:
            cells[1:] = [""] * (len(cells) - 1)
        lines.append(",".join(cells))
    path.write_text("\n".join(lines) + "\n", encoding="utf-8", newline="\n")


def main(out: Path):
    sizefx = Path(sys.executable).with_name("sizefx")
    with tempfile.TemporaryDirectory() as tmp:
        h5 = Path(tmp) / "tumble.h5"
        subprocess.run([str(sizefx), *SIMULATE, "-o", str(h5)], check=True, stdout=subprocess.DEVNULL)
        tel = read_telemetry(h5)
    # v_sensor = MAT_B_S.T @ v_body, row by row
    gyro_s_dps = np.degrees(tel.gyro_rad_s @ MAT_B_S)
    accel_s_mps2 = tel.accel_mps2 @ MAT_B_S
    write_csv(
        out / "tumble_imu.csv",
        ["time_s", "gyro_x_dps", "gyro_y_dps", "gyro_z_dps", "accel_x_mps2", "accel_y_mps2", "accel_z_mps2"],
        [tel.time_s, gyro_s_dps, accel_s_mps2],
        ["%.2f"] + ["%.6f"] * 6,
    )
    ref = tel.reference
    # mat_enu_sensor = MAT_ENU_NED @ mat_nb @ mat_b_sensor (MAT_NED_ENU is its own inverse)
    quat_enu_s = mat_to_quat(MAT_NED_ENU.T @ quat_to_mat(ref.quat_nb) @ MAT_B_S)
    quat_enu_s *= np.where(quat_enu_s[:, :1] < 0.0, -1.0, 1.0)  # the same rotation, printed with w >= 0
    v_enu = ref.velocity_n_mps @ MAT_NED_ENU  # ENU components of the NED velocity
    write_csv(
        out / "tumble_reference.csv",
        ["time_s", "qw", "qx", "qy", "qz", "v_east_mps", "v_north_mps", "v_up_mps", "lat_deg", "lon_deg", "height_m"],
        [ref.time_s, quat_enu_s, v_enu, np.degrees(ref.lat_rad), np.degrees(ref.lon_rad), ref.height_m],
        ["%.2f"] + ["%.9f"] * 4 + ["%.4f"] * 3 + ["%.9f"] * 2 + ["%.3f"],
        empty_rows=OCCLUDED_ROWS,
    )
    truth = {
        "made_by": "examples/make_example.py: sizefx " + " ".join(SIMULATE[:-1]),
        "frames": "body FRD, SI (m, s, rad); r_m[i] is the arm of accelerometer i from the rotation centre",
        "simulation": tel.simulation,
    }
    (out / "tumble_truth.json").write_text(json.dumps(truth, indent=1, sort_keys=True) + "\n", encoding="utf-8")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=HERE, help="folder to write into [default: examples/]")
    main(parser.parse_args().out)
