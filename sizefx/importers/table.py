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
"""

from __future__ import annotations

import io
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..constants import DEG, QUATERNION_NORM_TOLERANCE
from ..errors import SourceError
from ..frames import enu_to_ned, quat_nb_from_enu_body
from ..io.schema import POLE_REASON, TELEMETRY_SCHEMA, allowed_units, load_schema, unit_factor
from ..io.telemetry import Reference, Site, Telemetry
from ..rotation import euler_to_mat, mat_to_quat, quat_to_mat
from . import (
    IMU_RATE_HZ,
    REFERENCE_GRAVITY_ANGLE_MAX_DEG,
    REFERENCE_RATE_HZ,
    median_rate_hz,
    provenance,
    reference_up_angle_deg,
)

TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
FORM_QUANTITIES = {"rates": ("angular_rate", "acceleration"), "increments": ("angle", "velocity")}
#: Units of Euler angles and of latitude and longitude (height is always metres).
ANGLE_UNITS = {"deg": DEG, "rad": 1.0}
REFERENCE_FRAMES = ("ned", "enu")


def _time_units_problem(column: str, option: str, units: str, units_option: str, time_s, rate_range_hz, what: str):
    """What is wrong with the unit of a time column whose stamps (``time_s``, in s after ``units``) imply a
    sample rate outside ``rate_range_hz``, naming the column and the unit option, and the unit that would
    give a plausible rate; None when the rate is plausible (or the stamps do not increase: the time checks
    refuse those)."""
    rate_hz = median_rate_hz(time_s)
    lo, hi = rate_range_hz
    if rate_hz is None or lo <= rate_hz <= hi:
        return None
    read_as = f"in {units}" if units in TIME_UNITS else "as a sample counter"
    found = f"the time column '{column}' ({option}) implies {rate_hz:.3g} Hz {read_as}, outside the {lo:g}..{hi:g} Hz"
    if units not in TIME_UNITS:  # a sample counter: its step, not a unit, sets the rate
        return f"{found} {what}; check --rate-hz (per counter step) or give the column's time unit ({units_option})"
    # the plausible unit nearest the one given (ms before us when s was given)
    given = TIME_UNITS[units]
    plausible = [
        (abs(np.log(factor / given)), unit, rate_hz * given / factor)
        for unit, factor in TIME_UNITS.items()
        if unit != units and lo <= rate_hz * given / factor <= hi
    ]
    if not plausible:
        return f"{found} {what} in any of {', '.join(TIME_UNITS)}; check the column is the time"
    _, unit, rate_then_hz = min(plausible)
    return f"{found} {what}; in {unit} it would be {rate_then_hz:.3g} Hz: give {units_option} {unit}"


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


# --------------------------------------------------------------------------- reading text


@dataclass
class _Table:
    """A delimited text file: its lines and stripped header names."""

    path: Path
    lines: list
    header: list
    delimiter: str

    @classmethod
    def read(cls, path: Path, delimiter: str, what: str = "file") -> _Table:
        try:
            text = Path(path).read_text("utf-8-sig")  # -sig: a spreadsheet's byte-order mark is not a name
        except UnicodeDecodeError:
            raise SourceError(path, f"{what} is not a text file") from None
        lines = text.splitlines()
        header = [h.strip() for h in lines[0].split(delimiter)] if lines else []
        return cls(Path(path), lines, header, delimiter)

    def require(self, names, option_of: dict):
        """Every column of ``names`` is in the header, or an error naming the first missing one and its option."""
        missing = [c for c in names if c not in self.header]
        if missing:
            raise SourceError(
                self.path,
                f"column '{missing[0]}' is not in the header ({option_of[missing[0]]}); "
                f"columns are: {', '.join(self.header)}",
            )

    @staticmethod
    def is_data(line: str) -> bool:
        """What :func:`numpy.loadtxt` reads as a row: not blank once a ``#`` comment is cut."""
        return bool(line.split("#", 1)[0].strip())

    def line_number(self, row: int) -> int:
        """File line (1-based, the header is line 1) of data row ``row``."""
        k = -1
        for number, line in enumerate(self.lines[1:], start=2):
            if self.is_data(line):
                k += 1
                if k == row:
                    return number
        return len(self.lines)

    def numbers(self, names, option_of: dict, *, empty_is_nan: bool = False) -> np.ndarray:
        """Columns ``names`` as float64 ``[rows, len(names)]``; empty cells NaN if ``empty_is_nan``.

        Fast path :func:`numpy.loadtxt`; on failure a line-by-line scan names the bad cell.
        """
        idx = [self.header.index(c) for c in names]
        body = "\n".join(self.lines[1:])
        converters: dict[int | str, Callable[[str], float]] | None = None
        if empty_is_nan:
            converters = {i: (lambda s: float(s) if s.strip() else np.nan) for i in set(idx)}
        try:
            return np.loadtxt(io.StringIO(body), delimiter=self.delimiter, ndmin=2, usecols=idx, converters=converters)
        except ValueError as exc:
            self._raise_bad_cell(names, idx, option_of, empty_is_nan)
            detail = " ".join(str(exc).split())[:100]
            raise SourceError(self.path, f"a data row is not numeric or has too few columns ({detail})") from None

    def _raise_bad_cell(self, names, idx, option_of, empty_is_nan):
        need = max(idx) + 1
        for number, line in enumerate(self.lines[1:], start=2):
            if not self.is_data(line):
                continue
            fields = line.split("#", 1)[0].split(self.delimiter)
            if len(fields) < need:
                raise SourceError(
                    self.path,
                    f"line {number} has {len(fields)} fields, the header {len(self.header)}; "
                    f"column '{names[idx.index(max(idx))]}' is missing there (write empty "
                    "cells with their delimiters)",
                )
            for name, i in zip(names, idx):
                cell = fields[i].strip()
                if not cell:
                    if empty_is_nan:
                        continue
                    raise SourceError(
                        self.path,
                        f"column '{name}' ({option_of[name]}) is empty on line {number}; "
                        "IMU cells must all be filled (give a reference with rows of its "
                        "own in --reference-file)",
                    )
                try:
                    float(cell)
                except ValueError:
                    raise SourceError(
                        self.path,
                        f"column '{name}' ({option_of[name]}) on line {number} holds "
                        f"'{cell[:20]}', which is not numeric",
                    ) from None


# --------------------------------------------------------------------------- options


def _columns(path, cols, option: str, n: int, names: str):
    cols = tuple(c.strip() for c in cols)
    if len(cols) != n:
        raise SourceError(
            path,
            f"{option} names {len(cols)} columns ({', '.join(cols)}); give exactly {('three', 'four')[n - 3]}, {names}",
        )
    return cols


def _angle_factor(path, units: str, option: str) -> float:
    if units not in ANGLE_UNITS:
        raise SourceError(path, f"{option} '{units}' are not known; use deg or rad")
    return ANGLE_UNITS[units]


@dataclass
class _ReferenceColumns:
    """The reference options, checked: column names, SI factors and frame."""

    path: Path  #: the file the reference columns are in
    separate: bool  #: in its own file (not the IMU file)
    time: str | None  #: own time column, or None: the IMU's time rows
    time_units: str | None
    quaternion: tuple | None
    euler: tuple | None
    euler_units: str
    velocity: tuple | None
    position: tuple | None
    position_units: str
    frame: str

    def options(self) -> dict:
        """Column name -> the option that named it (for messages)."""
        out = {} if self.time is None else {self.time: "--reference-time"}
        for option, cols in (
            ("--reference-quaternion", self.quaternion),
            ("--reference-euler", self.euler),
            ("--reference-velocity", self.velocity),
            ("--reference-position", self.position),
        ):
            out.update(dict.fromkeys(cols or (), option))
        return out

    def value_columns(self) -> list:
        return [c for cols in (self.quaternion, self.euler, self.velocity, self.position) if cols for c in cols]


def _reference_columns(
    path,
    *,
    time,
    time_units,
    reference_file,
    reference_time,
    reference_time_units,
    reference_quaternion,
    reference_euler,
    reference_euler_units,
    reference_velocity,
    reference_position,
    reference_position_units,
    reference_frame,
):
    given = {
        "--reference-file": reference_file,
        "--reference-time": reference_time,
        "--reference-velocity": reference_velocity,
        "--reference-position": reference_position,
    }
    if reference_quaternion is None and reference_euler is None:
        extra = [k for k, v in given.items() if v is not None]
        if extra:
            raise SourceError(
                path,
                f"{extra[0]} needs a reference attitude (--reference-quaternion or "
                "--reference-euler): /reference always holds one",
            )
        return None
    if reference_file is not None:
        ref_path = Path(reference_file)
        if not ref_path.is_file():
            problem = "is a directory; give a file" if ref_path.is_dir() else "does not exist"
            raise SourceError(ref_path, f"reference file (--reference-file) {problem}")
    else:
        ref_path = Path(path)
    if reference_quaternion is not None and reference_euler is not None:
        raise SourceError(ref_path, "give the reference attitude once: --reference-quaternion or --reference-euler")
    frame = str(reference_frame).strip().lower()
    if frame not in REFERENCE_FRAMES:
        raise SourceError(ref_path, f"--reference-frame '{reference_frame}' is not known; use ned or enu")
    if reference_euler is not None and frame != "ned":
        raise SourceError(
            ref_path,
            "--reference-euler: roll, pitch and heading are defined in NED only; give an "
            "ENU attitude as a quaternion (--reference-quaternion)",
        )
    _angle_factor(ref_path, reference_euler_units, "--reference-euler-units")
    _angle_factor(ref_path, reference_position_units, "--reference-position-units")
    # an own time column: always in a separate file, and in the IMU file when named (and not the IMU's own)
    if reference_file is not None and reference_time is None:
        reference_time = time
    own_time = reference_time is not None and (
        reference_file is not None or reference_time != time or reference_time_units is not None
    )
    if own_time:
        if reference_time_units is None:
            if time_units not in TIME_UNITS:
                raise SourceError(
                    ref_path,
                    f"the IMU time is in {time_units}; give the reference's time units "
                    f"(--reference-time-units {', '.join(TIME_UNITS)})",
                )
            reference_time_units = time_units
        if reference_time_units not in TIME_UNITS:
            raise SourceError(
                ref_path, f"--reference-time-units '{reference_time_units}' are not known; use {', '.join(TIME_UNITS)}"
            )
    return _ReferenceColumns(
        path=ref_path,
        separate=reference_file is not None,
        time=reference_time.strip() if own_time else None,
        time_units=reference_time_units if own_time else None,
        quaternion=None
        if reference_quaternion is None
        else _columns(ref_path, reference_quaternion, "--reference-quaternion", 4, "W,X,Y,Z (scalar first)"),
        euler=None
        if reference_euler is None
        else _columns(ref_path, reference_euler, "--reference-euler", 3, "ROLL,PITCH,HEADING"),
        euler_units=reference_euler_units,
        velocity=None
        if reference_velocity is None
        else _columns(ref_path, reference_velocity, "--reference-velocity", 3, "north,east,down (ENU: east,north,up)"),
        position=None
        if reference_position is None
        else _columns(ref_path, reference_position, "--reference-position", 3, "LAT,LON,HEIGHT"),
        position_units=reference_position_units,
        frame=frame,
    )


# --------------------------------------------------------------------------- the reference


def _reference_rows(table: _Table, spec: _ReferenceColumns, imu_time_s):
    """``(time_s [M], values [M, k] in the order of spec.value_columns(), dropouts, data rows kept)``."""
    options = spec.options()
    names = ([spec.time] if spec.time else []) + spec.value_columns()
    table.require(names, options)
    raw = table.numbers(names, options, empty_is_nan=True)
    if spec.time:
        assert spec.time_units is not None  # an own time column always comes with its units (_reference_columns)
        t, values = raw[:, 0] * TIME_UNITS[spec.time_units], raw[:, 1:]
    else:
        t, values = np.asarray(imu_time_s, dtype=float), raw
    finite = np.isfinite(values).all(axis=1) & np.isfinite(t)
    # a row of empty cells is no reference row (the IMU file between reference rows); one partly filled
    # (or with a time stamp but no values) is a dropout
    is_row = np.isfinite(values).any(axis=1) | (np.isfinite(raw[:, 0]) if spec.time else False)
    rows = np.flatnonzero(finite)
    dropouts = int(np.count_nonzero(is_row & ~finite))
    return t[rows], values[rows], dropouts, rows


def _check_reference_time(spec: _ReferenceColumns, table: _Table, t, rows, imu_t, imu_path: Path, time: str):
    """At least two rows, strictly increasing, overlapping the IMU's span."""
    path = spec.path
    time_label = f"column '{spec.time}' (--reference-time)" if spec.time else "the IMU time (reference rows)"
    if t.shape[0] < 2:
        raise SourceError(
            path,
            f"the reference has {t.shape[0]} row(s) with every column filled "
            f"({', '.join(spec.value_columns())}); at least 2 are needed",
        )
    step = np.diff(t)
    if np.any(step <= 0.0):
        k = int(np.flatnonzero(step <= 0.0)[0]) + 1
        what = "repeats" if step[k - 1] == 0.0 else "goes back"
        raise SourceError(
            path,
            f"reference time {time_label} {what} on line {table.line_number(int(rows[k]))} "
            f"({t[k - 1]:.6f} s -> {t[k]:.6f} s); sort it and drop repeated rows",
        )
    if spec.time:
        assert spec.time_units is not None  # an own time column always has its units (_reference_columns)
        problem = _time_units_problem(
            spec.time,
            "--reference-time",
            spec.time_units,
            "--reference-time-units",
            t,
            REFERENCE_RATE_HZ,
            "of a reference",
        )
        if problem:
            raise SourceError(path, problem)
    if t[-1] < imu_t[0] or t[0] > imu_t[-1]:
        column = f"'{spec.time}' [{spec.time_units}]" if spec.time else "(the IMU time)"
        raise SourceError(
            path,
            f"reference time {column} spans {t[0]:.6g} .. {t[-1]:.6g} s and the IMU "
            f"time '{time}' in {imu_path.name} spans {imu_t[0]:.6g} .. {imu_t[-1]:.6g} s: "
            "they do not overlap; both must be on the IMU clock (check --reference-time-units)",
        )


def _build_reference(spec: _ReferenceColumns, table: _Table, t, values, rows, mat_b_s) -> Reference:
    """/reference in NED and body FRD from the kept rows (``values`` in ``spec.value_columns()`` order)."""
    path = spec.path
    k = 0
    cols = {}
    for key in ("quaternion", "euler", "velocity", "position"):
        names = getattr(spec, key)
        if names:
            cols[key] = values[:, k : k + len(names)]
            k += len(names)
    if spec.quaternion:
        q = cols["quaternion"]
        err = np.abs(np.linalg.norm(q, axis=1) - 1.0)
        if err.max() > QUATERNION_NORM_TOLERANCE:
            j = int(np.argmax(err))
            raise SourceError(
                path,
                f"columns {','.join(spec.quaternion)} (--reference-quaternion) on line "
                f"{table.line_number(int(rows[j]))} have |q| = {np.linalg.norm(q[j]):.9g}; a unit "
                f"quaternion is needed (|q| - 1 within {QUATERNION_NORM_TOLERANCE:g}): check the "
                "columns are named in scalar-first order W,X,Y,Z, and normalise them",
            )
        q = q / np.linalg.norm(q, axis=1, keepdims=True)
        if spec.frame == "enu":
            quat_nb = quat_nb_from_enu_body(q, mat_b_s.T)
        else:  # mat_nb = mat_n_sensor @ mat_sensor_b: the sensor axes' attitude, turned into body FRD
            quat_nb = mat_to_quat(quat_to_mat(q) @ mat_b_s.T)
    else:
        angles = cols["euler"] * ANGLE_UNITS[spec.euler_units]
        quat_nb = mat_to_quat(euler_to_mat(angles[:, 0], angles[:, 1], angles[:, 2]) @ mat_b_s.T)
    ref = Reference(time_s=t, quat_nb=quat_nb)
    if spec.velocity:
        v = cols["velocity"]
        ref.velocity_n_mps = enu_to_ned(v) if spec.frame == "enu" else v
    if spec.position:
        pos = cols["position"]
        factor = ANGLE_UNITS[spec.position_units]
        bad = np.flatnonzero(np.abs(pos[:, 0] * factor) > np.pi / 2)
        if bad.size:
            j = int(bad[0])
            raise SourceError(
                path,
                f"column '{spec.position[0]}' (--reference-position) on line "
                f"{table.line_number(int(rows[j]))} holds latitude {pos[j, 0]:g} "
                f"{spec.position_units}, outside +-90 deg; is it latitude, in "
                "--reference-position-units?",
            )
        lat_max_deg = load_schema(TELEMETRY_SCHEMA)["root_attributes"]["latitude_deg"]["max"]
        polar = np.flatnonzero(np.abs(pos[:, 0] * factor) > lat_max_deg * DEG)
        if polar.size:
            j = int(polar[0])
            raise SourceError(
                path,
                f"column '{spec.position[0]}' (--reference-position) on line "
                f"{table.line_number(int(rows[j]))} holds latitude {pos[j, 0]:g} {spec.position_units}, "
                f"outside [-{lat_max_deg:g}, {lat_max_deg:g}] deg ({POLE_REASON}); cut the record where "
                "it comes that close to the pole",
            )
        ref.lat_rad, ref.lon_rad, ref.height_m = pos[:, 0] * factor, pos[:, 1] * factor, pos[:, 2].copy()
    return ref


def _check_gravity(spec: _ReferenceColumns, ref: Reference, t, accel_like, period_s: float, form: str):
    """Refuse a reference whose attitude puts "up" far from where the accelerometers see it."""
    angle_deg = reference_up_angle_deg(ref, t, accel_like, period_s, form)
    if angle_deg is not None and angle_deg > REFERENCE_GRAVITY_ANGLE_MAX_DEG:
        attitude = "--reference-quaternion (order W,X,Y,Z)" if spec.quaternion else "--reference-euler"
        raise SourceError(
            spec.path,
            f"the reference attitude puts 'up' {angle_deg:.0f} deg (median) from the "
            "specific force the accelerometers read; at rest they agree. Check --axes (the "
            f"reference describes the sensor axes too), --reference-frame ({spec.frame}) "
            f"and {attitude}",
        )


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
    source = provenance(
        path,
        "csv",
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
    tel.source = source
    return tel


def _describe_reference(spec: _ReferenceColumns, n_rows: int, dropouts: int) -> str:
    where = f"reference file {spec.path.name}" if spec.separate else "the same file"
    time = f"time '{spec.time}' [{spec.time_units}]" if spec.time else "the IMU time"
    frame = "ENU, converted to NED" if spec.frame == "enu" else "NED"
    parts = [f"reference from {where} at {time}"]
    if spec.quaternion:
        parts.append(f"quaternion {','.join(spec.quaternion)} (scalar first, sensor axes to {frame})")
    else:
        assert spec.euler is not None  # the attitude is a quaternion or Euler angles (_reference_columns)
        parts.append(f"roll, pitch, heading {','.join(spec.euler)} [{spec.euler_units}] (sensor axes, NED)")
    if spec.velocity:
        parts.append(f"velocity {','.join(spec.velocity)} [m/s, {frame}]")
    if spec.position:
        u = spec.position_units
        parts.append(f"position {','.join(spec.position)} [{u}, {u}, m]")
    parts.append(f"{n_rows} rows, {dropouts} rows with empty or NaN cells left out")
    return ", ".join(parts)


def _reference_provenance(spec: _ReferenceColumns, n_rows: int, dropouts: int) -> dict:
    out = {
        "reference_frame": spec.frame,
        "reference_rows": n_rows,
        "reference_dropout_rows": dropouts,
        "reference_time_column": spec.time or "(IMU time)",
    }
    if spec.separate:
        out["reference_file"] = spec.path.name
        out["reference_sha256"] = provenance(spec.path, "csv")["sha256"]
    if spec.time:
        out["reference_time_units"] = spec.time_units
    if spec.quaternion:
        out["reference_quaternion_columns"] = list(spec.quaternion)
    else:
        assert spec.euler is not None  # the attitude is a quaternion or Euler angles (_reference_columns)
        out["reference_euler_columns"] = list(spec.euler)
        out["reference_euler_units"] = spec.euler_units
    if spec.velocity:
        out["reference_velocity_columns"] = list(spec.velocity)
    if spec.position:
        out["reference_position_columns"] = list(spec.position)
        out["reference_position_units"] = spec.position_units
    return out
