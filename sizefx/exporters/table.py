"""CSV: the IMU rows as the CSV importer reads them back (``sizefx import csv``).

One header line, then one row per sample: ``time_s`` [s, on the record's clock], then
``gyro_x, gyro_y, gyro_z`` [rad/s] and ``accel_x, accel_y, accel_z`` [m/s^2] (increments:
``dtheta_*`` [rad] and ``dvel_*`` [m/s]), body FRD, with 17 significant digits, so that the
import reads back the very same float64 values. The report gives the ``sizefx import csv``
command that does it.
"""

from __future__ import annotations

import shlex
from pathlib import Path

import numpy as np

from ..io.files import atomic_output
from . import ExportDetails, refuse_separate_accel_stamps

__all__ = ["write", "COLUMNS", "UNITS", "ROWS_PER_WRITE"]

#: Column names by form: time, the three gyro-like and the three accel-like columns.
COLUMNS = {
    "rates": ("time_s", ("gyro_x", "gyro_y", "gyro_z"), ("accel_x", "accel_y", "accel_z")),
    "increments": ("time_s", ("dtheta_x", "dtheta_y", "dtheta_z"), ("dvel_x", "dvel_y", "dvel_z")),
}
#: The units of the gyro-like and accel-like columns by form, as ``sizefx import csv`` names them.
UNITS = {"rates": ("rad/s", "m/s^2"), "increments": ("rad", "m/s")}
#: Rows formatted and written at a time (memory: the text of that many rows).
ROWS_PER_WRITE = 1 << 16
#: Characters of one row at most: 7 numbers of 17 digits, sign, point, exponent and a comma.
ROW_CHARS = 7 * 25


def _reimport_command(tel, output: Path) -> str:
    time, gyro, accel = COLUMNS[tel.form]
    g_units, a_units = UNITS[tel.form]
    record = output.with_suffix(".h5")
    if tel.path is not None and record.resolve() == Path(tel.path).resolve():
        record = output.with_name(output.stem + "-imported.h5")
    args = ["sizefx", "import", "csv", str(output), "-o", str(record), "--time", time]
    args += ["--gyro", ",".join(gyro), "--accel", ",".join(accel)]
    if tel.form == "increments":
        args += ["--form", "increments", "--gyro-units", g_units, "--accel-units", a_units]
    if tel.site is not None:
        site = (np.degrees(tel.site.lat_rad), np.degrees(tel.site.lon_rad), tel.site.height_m)
        args += ["--site-deg", ",".join(f"{float(v):.12g}" for v in site)]  # 1e-10 deg: 0.01 mm
    return shlex.join(args)


def write(tel, output: Path, *, force: bool = False, inputs=()) -> ExportDetails:
    """Write the IMU rows of ``tel`` (body FRD, SI) as CSV to ``output``, atomically."""
    refuse_separate_accel_stamps(tel, "a CSV row")
    time, gyro, accel = COLUMNS[tel.form]
    g_units, a_units = UNITS[tel.form]
    gyro_like, accel_like = tel.imu_arrays()
    n = tel.n_samples
    with atomic_output(output, inputs=inputs, force=force, expected_bytes=n * ROW_CHARS) as tmp:
        with open(tmp, "w", encoding="utf-8", newline="\n") as fh:
            fh.write(",".join((time, *gyro, *accel)) + "\n")
            for k0 in range(0, n, ROWS_PER_WRITE):
                rows = slice(k0, min(n, k0 + ROWS_PER_WRITE))
                block = np.column_stack([tel.time_s[rows], gyro_like[rows], accel_like[rows]])
                np.savetxt(fh, block, fmt="%.17g", delimiter=",")
    return ExportDetails(
        lines=[
            f"columns: {time} [s], {', '.join(gyro)} [{g_units}], {', '.join(accel)} [{a_units}], body FRD "
            "(x forward, y right, z down)",
        ],
        reimport=_reimport_command(tel, output),
    )
