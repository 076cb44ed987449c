"""Generic CSV: a column map and units given by the user.

Rates (``gyro``/``accel`` columns) or increments (``dtheta``/``dvel``); units from
the telemetry contract's tables; time in s, ms, us, ns, or a sample counter
with ``rate_hz``; an axis map that turns the sensor's axes into body FRD, e.g.
``("y", "x", "-z")`` for a right-forward-up sensor.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from ..constants import DEG
from ..errors import SourceError
from ..schema import allowed_units, unit_factor
from ..telemetry import Site, Telemetry
from . import provenance

TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
FORM_QUANTITIES = {"rates": ("angular_rate", "acceleration"), "increments": ("angle", "velocity")}


def axis_matrix(spec) -> np.ndarray:
    """Matrix M with ``v_body = M @ v_sensor`` from ``("y", "x", "-z")`` (body x, y, z in sensor axes)."""
    if len(spec) != 3:
        raise ValueError("the axis map names three axes")
    m = np.zeros((3, 3))
    for row, item in enumerate(spec):
        item = item.strip().lower()
        sign = -1.0 if item.startswith("-") else 1.0
        axis = item.lstrip("+-")
        if axis not in ("x", "y", "z"):
            raise ValueError(f"'{item}' is not an axis (x, y, z with an optional minus)")
        m[row, "xyz".index(axis)] = sign
    if not np.isclose(np.linalg.det(m), 1.0):
        raise ValueError(f"axis map {','.join(spec)} is not a rotation (a mirror or a repeated axis)")
    return m


def load(path: Path, *, time: str, gyro, accel, form: str = "rates", gyro_units: str = "rad/s",
         accel_units: str = "m/s^2", time_units: str = "s", rate_hz: float | None = None,
         axes=("x", "y", "z"), delimiter: str = ",", site_deg=None) -> Telemetry:
    for label, cols in (("gyro", gyro), ("accel", accel)):
        if len(cols) != 3:
            raise SourceError(path, f"--{label} names {len(cols)} columns ({', '.join(cols)}); give exactly three, x,y,z")
    if form not in FORM_QUANTITIES:
        raise SourceError(path, f"form '{form}': use rates or increments")
    q_gyro, q_accel = FORM_QUANTITIES[form]
    factors = {}
    for label, quantity, units in (("gyro", q_gyro, gyro_units), ("accel", q_accel, accel_units)):
        factor = unit_factor(quantity, units)
        if factor is None:
            raise SourceError(path, f"{label} units '{units}' are not known for {form}; use one of "
                                    f"{', '.join(allowed_units(quantity))}")
        factors[label] = factor
    if time_units != "samples" and time_units not in TIME_UNITS:
        raise SourceError(path, f"time units '{time_units}': use s, ms, us, ns or samples")
    if time_units == "samples" and not rate_hz:
        raise SourceError(path, "time in samples needs the sample rate (--rate-hz)")
    try:
        mat_b_s = axis_matrix(axes)
    except ValueError as exc:
        raise SourceError(path, str(exc)) from None
    try:
        text = Path(path).read_text("utf-8")
    except UnicodeDecodeError:
        raise SourceError(path, "is not a text file") from None
    lines = text.splitlines()
    header = [h.strip() for h in lines[0].split(delimiter)] if lines else []
    wanted = [time, *gyro, *accel]
    missing = [c for c in wanted if c not in header]
    if missing:
        raise SourceError(path, f"column '{missing[0]}' is not in the header; columns are: {', '.join(header)}")
    if not any(line.strip() for line in lines[1:]):
        raise SourceError(path, "has 0 data rows; at least 2 are needed")
    try:
        table = np.loadtxt(io.StringIO("\n".join(lines[1:])), delimiter=delimiter, ndmin=2,
                           usecols=[header.index(c) for c in wanted])
    except ValueError as exc:
        raise SourceError(path, f"a data row is not numeric or has too few columns ({' '.join(str(exc).split())[:100]})") from None
    if table.shape[0] < 2:
        raise SourceError(path, f"has {table.shape[0]} data rows; at least 2 are needed")
    t = table[:, 0] / rate_hz if time_units == "samples" else table[:, 0] * TIME_UNITS[time_units]
    g = table[:, 1:4] * np.asarray(factors["gyro"]) @ mat_b_s.T
    a = table[:, 4:7] * np.asarray(factors["accel"]) @ mat_b_s.T
    site = None
    if site_deg is not None:
        site = Site(site_deg[0] * DEG, site_deg[1] * DEG, float(site_deg[2]))
    tel = Telemetry(time_s=t, form=form, site=site,
                    description=f"imported from CSV {Path(path).name}: time '{time}' [{time_units}], "
                                f"{form} columns {', '.join(gyro)} [{gyro_units}] and {', '.join(accel)} "
                                f"[{accel_units}], body axes = sensor ({', '.join(axes)})",
                    source=provenance(path, "csv", time_column=time, time_units=time_units,
                                      gyro_columns=list(gyro), accel_columns=list(accel), gyro_units=gyro_units,
                                      accel_units=accel_units, axis_map=list(axes)))
    if form == "rates":
        tel.gyro_rad_s, tel.accel_mps2 = g, a
    else:
        tel.dtheta_rad, tel.dvel_mps = g, a
    return tel
