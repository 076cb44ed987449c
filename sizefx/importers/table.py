"""Generic CSV: a column map and units given by the user.

IMU
    Rates (``gyro``/``accel`` columns) or increments (``dtheta``/``dvel``); units from
    the telemetry contract's tables; time in s, ms, us, ns, or a sample counter
    with ``rate_hz``; an axis map that turns the sensor's axes into body FRD, e.g.
    ``("y", "x", "-z")`` for a right-forward-up sensor. Every IMU cell must be a
    finite number.
Reference (optional)
    Attitude as a quaternion (four columns named in scalar-first order W, X, Y, Z)
    or as roll, pitch, heading (deg or rad); NED velocity [m/s]; latitude,
    longitude (deg or rad) and height [m]. Read from the IMU file or from a
    separate ``reference_file`` with its own time column at its own rate. In the
    IMU file the reference rows are those whose reference cells (or reference
    time cell) are filled, the other cells being empty; at the IMU's time when no
    ``reference_time`` column is named. A reference row with an empty or NaN
    value is a dropout: left out of ``/reference`` (the reader reports the gap)
    and counted in ``/source``.
Frames
    The reference attitude describes the same sensor axes as the IMU columns, so
    the axis map applies to it as well: ``mat_nb = mat_n_sensor @ mat_sensor_b``.
    Its navigation frame is NED, or ENU (``reference_frame="enu"``, as ROS and
    motion-capture systems write it), which applies to the quaternion and the
    velocity and is converted by :mod:`sizefx.frames`. Roll, pitch and heading are
    defined in NED only (``mat_nb = Rz(heading) Ry(pitch) Rx(roll)``) and are
    refused with ENU. The reference is taken to be on the IMU clock.

The importer (:func:`load`, and :func:`axis_matrix`) is here; :mod:`.table_reference` holds its
reference side (the options, rows, checks and ``/reference`` above) and :mod:`.table_common` what it
shares with :mod:`.table_log` (the text table, the time units, the column options).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..constants import DEG
from ..errors import SourceError
from ..io.schema import allowed_units, unit_factor
from ..io.telemetry import Site, Telemetry
from . import (
    IMU_RATE_HZ,
    REFERENCE_GRAVITY_ANGLE_MAX_DEG,  # noqa: F401  (importable here as before; docs/figures.toml names it so)
    provenance,
)

# what the single module table.py held stays importable from here (table_log imports TIME_UNITS,
# _Table and _time_units_problem from it)
from .table_common import TIME_UNITS, _columns, _Table, _time_units_problem
from .table_reference import (  # noqa: F401
    ANGLE_UNITS,
    REFERENCE_FRAMES,
    _angle_factor,
    _build_reference,
    _check_gravity,
    _check_reference_time,
    _describe_reference,
    _reference_columns,
    _reference_provenance,
    _reference_rows,
    _ReferenceColumns,
)

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


# --------------------------------------------------------------------------- the importer


def load(
    path: Path,
    *,
    time: str,
    gyro,
    accel,
    form: str = "rates",
    gyro_units: str = "rad/s",
    accel_units: str = "m/s^2",
    time_units: str = "s",
    rate_hz: float | None = None,
    axes=("x", "y", "z"),
    delimiter: str = ",",
    site_deg=None,
    reference_file=None,
    reference_time: str | None = None,
    reference_time_units: str | None = None,
    reference_quaternion=None,
    reference_euler=None,
    reference_euler_units: str = "deg",
    reference_velocity=None,
    reference_position=None,
    reference_position_units: str = "deg",
    reference_frame: str = "ned",
    keep_invalid: bool = False,
) -> Telemetry:
    """A CSV record (and its reference) as :class:`~sizefx.io.telemetry.Telemetry` in SI, body FRD, NED.

    ``keep_invalid``: keep IMU cells holding NaN or inf (for a caller that drops those rows,
    ``sizefx import --drop-invalid-rows``) instead of refusing the file at the first.

    Column arguments are tuples of header names; see the module docstring for
    the rules and :func:`sizefx.importers.run_import` for writing the result.
    ``reference_time`` defaults to ``time`` in a ``reference_file`` and to the IMU
    rows in the IMU file; ``reference_time_units`` to ``time_units``.
    """
    path = Path(path)
    gyro = _columns(path, gyro, "--gyro", 3, "x,y,z")
    accel = _columns(path, accel, "--accel", 3, "x,y,z")
    if form not in FORM_QUANTITIES:
        raise SourceError(path, f"form '{form}': use rates or increments")
    q_gyro, q_accel = FORM_QUANTITIES[form]
    factors = {}
    for label, quantity, units in (("gyro", q_gyro, gyro_units), ("accel", q_accel, accel_units)):
        factor = unit_factor(quantity, units)
        if factor is None:
            raise SourceError(
                path,
                f"{label} units '{units}' are not known for {form}; use one of {', '.join(allowed_units(quantity))}",
            )
        factors[label] = factor
    if time_units != "samples" and time_units not in TIME_UNITS:
        raise SourceError(path, f"time units '{time_units}': use s, ms, us, ns or samples")
    if time_units == "samples" and not rate_hz:
        raise SourceError(path, "time in samples needs the sample rate (--rate-hz)")
    try:
        mat_b_s = axis_matrix(axes)
    except ValueError as exc:
        raise SourceError(path, str(exc)) from None
    spec = _reference_columns(
        path,
        time=time,
        time_units=time_units,
        reference_file=reference_file,
        reference_time=reference_time,
        reference_time_units=reference_time_units,
        reference_quaternion=reference_quaternion,
        reference_euler=reference_euler,
        reference_euler_units=reference_euler_units,
        reference_velocity=reference_velocity,
        reference_position=reference_position,
        reference_position_units=reference_position_units,
        reference_frame=reference_frame,
    )

    table = _Table.read(path, delimiter)
    wanted = [time, *gyro, *accel]
    option_of = {time: "--time"} | dict.fromkeys(gyro, "--gyro") | dict.fromkeys(accel, "--accel")
    table.require(wanted, option_of)
    if not any(table.is_data(line) for line in table.lines[1:]):
        raise SourceError(path, "has 0 data rows; at least 2 are needed")
    data = table.numbers(wanted, option_of)
    if data.shape[0] < 2:
        raise SourceError(path, f"has {data.shape[0]} data rows; at least 2 are needed")
    bad = ~np.isfinite(data)
    if bad.any() and not keep_invalid:
        row, col = (int(v) for v in np.argwhere(bad)[0])
        raise SourceError(
            path,
            f"column '{wanted[col]}' ({option_of[wanted[col]]}) holds NaN/Inf on line "
            f"{table.line_number(row)}; IMU samples must be finite (cut the record there)",
        )
    t = data[:, 0] / rate_hz if time_units == "samples" else data[:, 0] * TIME_UNITS[time_units]
    problem = _time_units_problem(time, "--time", time_units, "--time-units", t, IMU_RATE_HZ, "of an IMU")
    if problem:
        raise SourceError(path, problem)
    g = data[:, 1:4] * np.asarray(factors["gyro"]) @ mat_b_s.T
    a = data[:, 4:7] * np.asarray(factors["accel"]) @ mat_b_s.T
    site = None
    if site_deg is not None:
        site = Site(site_deg[0] * DEG, site_deg[1] * DEG, float(site_deg[2]))
    description = (
        f"imported from CSV {path.name}: time '{time}' [{time_units}], {form} columns {', '.join(gyro)} "
        f"[{gyro_units}] and {', '.join(accel)} [{accel_units}], body axes = sensor ({', '.join(axes)})"
    )
    source: dict[str, Any] = dict(
        time_column=time,
        time_units=time_units,
        gyro_columns=list(gyro),
        accel_columns=list(accel),
        gyro_units=gyro_units,
        accel_units=accel_units,
        axis_map=list(axes),
    )
    tel = Telemetry(time_s=t, form=form, site=site)
    if form == "rates":
        tel.gyro_rad_s, tel.accel_mps2 = g, a
    else:
        tel.dtheta_rad, tel.dvel_mps = g, a
    if spec is not None:
        ref_table = _Table.read(spec.path, delimiter, "reference file") if spec.separate else table
        ref_t, values, dropouts, rows = _reference_rows(ref_table, spec, None if spec.separate else t)
        _check_reference_time(spec, ref_table, ref_t, rows, t, path, time)
        tel.reference = _build_reference(spec, ref_table, ref_t, values, rows, mat_b_s)
        _check_gravity(spec, tel.reference, t, a, float(np.median(np.diff(t))), form)
        description += "; " + _describe_reference(spec, ref_t.size, dropouts)
        source.update(_reference_provenance(spec, ref_t.size, dropouts))
    tel.description = description
    tel.source = provenance(path, "csv", **source)
    return tel
