"""The reference side of the CSV importer (:mod:`sizefx.importers.table`): the reference options
checked (columns, units, frame, the file they are in), its rows read from the IMU file or its own, its
time checked against the IMU's, ``/reference`` in NED and body FRD built from them and checked against
the gravity the accelerometers see, and how the import describes it (description, ``/source``)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..constants import DEG, QUATERNION_NORM_TOLERANCE
from ..errors import SourceError
from ..frames import enu_to_ned, quat_nb_from_enu_body
from ..io.files import sha256_of
from ..io.schema import POLE_REASON, TELEMETRY_SCHEMA, load_schema
from ..io.telemetry import Reference
from ..rotation import euler_to_mat, mat_to_quat, quat_to_mat
from . import REFERENCE_GRAVITY_ANGLE_MAX_DEG, REFERENCE_RATE_HZ, reference_up_angle_deg
from .table_common import TIME_UNITS, _columns, _Table, _time_units_problem

__all__ = ["ANGLE_UNITS", "REFERENCE_FRAMES"]

#: Units of Euler angles and of latitude and longitude (height is always metres).
ANGLE_UNITS = {"deg": DEG, "rad": 1.0}
REFERENCE_FRAMES = ("ned", "enu")


# --------------------------------------------------------------------------- options


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


# --------------------------------------------------------------------------- described


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
        out["reference_sha256"] = sha256_of(spec.path, mapped=False)  # this command's own process
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
