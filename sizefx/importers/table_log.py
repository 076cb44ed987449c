"""A turntable controller's log: its encoder angles become ``/reference`` beside an IMU record.

A real table logs the angles of its axes (and often their rates) against time, not a body-to-NED
quaternion, and the IMU is recorded by a logger of its own. This importer takes the IMU from a
sizefx record (``imu_record``: what any importer writes, e.g. ``sizefx import csv``) and the
controller's CSV log (SOURCE), and returns the IMU with the reference attitude the log implies,
on the IMU's clock, and the site.

Convention
    The table frame t is level: x along the table's zero direction, ``table_heading_deg`` east
    of north, y to its right, z down. With every angle zero each gimbal frame is the table frame;
    axis k (k = 1 the outer, up to 3 the inner) turns its gimbal about the table axis it names, in
    its parent gimbal's frame, by the encoder angle theta_k in the sense of its sign (``z``: right-handed
    about z; ``-z``: the opposite). The IMU's body axes sit on the inner platform p with the
    mount ``mat_pb = Rz(yaw) Ry(pitch) Rx(roll)`` (``mount_deg``). The attitude, body to NED::

        mat_nb = Rz(psi_t) @ R(a_1, s_1 theta_1) @ R(a_2, s_2 theta_2) @ R(a_3, s_3 theta_3) @ mat_pb

    with psi_t the table heading, a_k the named axis and s_k = +-1 its sign; one or two axes
    leave out the last factors. With z down, a turn of a ``z`` axis by a positive angle turns
    the body clockwise seen from above: its heading increases
    (``tests/test_import_table_log.py::test_a_positive_turn_about_a_down_axis_increases_heading``).
    :func:`sizefx.frames.table_attitude` computes it, with the simulator's gimbal chain
    (:class:`sizefx.motion.RotationChain`).
Angles
    deg, rad or counts (``counts_per_rev`` counts a turn). Each column is unwrapped: a step of
    more than half the wrap period (360 deg, 2 pi rad, ``counter_modulus`` counts, by default a
    turn) is a wrap, so encoders that report one turn and counters that roll over read as
    continuous angles; the log must sample fast enough that no axis turns that far between rows.
    The wraps undone are reported. The table is taken to be level: ``sizefx calibrate`` fits its
    tilt.
Rates
    ``/reference`` holds an attitude only (the telemetry contract has no rate dataset). Rate
    columns, when named, are checked against the angles' derivative (:data:`RATE_SCALE_TOL`).
Checks against the IMU
    Where the table rests, "up" in the log's attitude against the specific force the
    accelerometers read; where it turns, the body rate the chain gives (from the rate columns, or
    the angles' derivative) against the gyros' direction, which catches the sense of a vertical
    axis. More than :data:`OFF_SHARE_MAX` of the rows off by more than 45 deg is refused, and so
    are gyros that turn faster or slower than the log by more than the units check's
    :data:`sizefx.sanity.GYRO_BAND` (median over the turning rows): angles in another unit.
Time
    The log's time [``time_units``] plus ``time_offset_s`` is the IMU's clock: both must share
    one. IMU rows outside the log's span are cut (no attitude is known there), and reported.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..constants import DEG
from ..errors import SourceError
from ..frames import gimbal_axes, table_attitude
from ..io.files import sha256_of
from ..io.schema import TELEMETRY_SCHEMA, load_schema
from ..io.telemetry import Reference, Site, Telemetry, read_telemetry
from ..rotation import euler_to_mat, mat_to_quat
from ..sanity import GYRO_BAND
from . import REFERENCE_GRAVITY_ANGLE_MAX_DEG, REFERENCE_RATE_HZ, provenance
from .table_common import TIME_UNITS, _Table, _time_units_problem

__all__ = ["load", "ANGLE_UNITS", "RATE_UNITS"]

#: Units of the encoder angles and rates, and the SI factor of those that are not counts (a count is
#: 2 pi / ``counts_per_rev`` rad).
ANGLE_UNITS = ("deg", "rad", "counts")
RATE_UNITS = ("deg/s", "rad/s", "counts/s")
RAD_PER_UNIT = {"deg": DEG, "rad": 1.0}
#: The wrap period of an angle column in its own unit (counts: ``counter_modulus``).
WRAP_PERIOD = {"deg": 360.0, "rad": 2.0 * np.pi}
#: A column that wraps holds one turn of values (0..360, -180..180 or 0..N-1 counts); one whose
#: values span more than this many wrap periods and still jumps by more than half of one is not
#: in the unit declared: degrees read as radians span 57 turns, counts read as degrees thousands.
WRAP_SPAN_TURNS = 1.5
#: An axis turns (for the rate checks), and the table turns (for the checks against the IMU; it
#: rests otherwise), faster than this [rad/s]: 1 deg/s, far above the Earth's rate (0.004 deg/s)
#: and a gyro's bias, so that gyros and encoders agree there.
MOVING_RAD_S = 1.0 * DEG
#: Fewest turning rows a rate check needs; with fewer it is skipped (and said so): ten rows keep
#: one glitch from deciding a median or a ratio.
MIN_MOVING_ROWS = 10
#: A rate column passes when the least-squares ratio of its rates to the angles' derivative is
#: within this of 1. A rate in other units is off by 57.3 (rad and deg), 6 (rpm and deg/s) or -1
#: (the other sense); a controller's filtered rate lags the position by a few rows, which lowers
#: the ratio by a few percent at most on the rate profiles of a calibration.
RATE_SCALE_TOL = 0.1
#: Largest angle [deg] between the gyros' rate and the body rate the log gives on a row where the
#: table turns. They agree within a few degrees (gyro noise, the Earth's rate); a sense given wrong
#: is 180 deg off, a mount or an axis misnamed about 90: 45 separates the two, as
#: :data:`sizefx.importers.REFERENCE_GRAVITY_ANGLE_MAX_DEG` does for gravity (checked where the
#: table rests: no centripetal acceleration there). It catches what gravity cannot: the sense of
#: a vertical axis.
GYRO_ANGLE_MAX_DEG = 45.0
#: Largest share of the resting (turning) rows on which the log's attitude (rate) may be off the
#: IMU's by more than those angles. A few rows may be, where the two clocks see a start or a stop a
#: little apart; a sense or a mount given wrong puts a whole stretch off (with one axis held at
#: one angle: a third of the paper's plan), which a median over the record would let through.
OFF_SHARE_MAX = 0.05
#: Log rows turned into attitudes at a time: a block's [rows, 3, 3] matrices take 4.7 MiB each.
CHUNK_ROWS = 1 << 16


# --------------------------------------------------------------------------- options


@dataclass
class _Units:
    """The log's units, checked: SI factors of angle and rate, and the angles' wrap period."""

    angle: str
    angle_rad: float  #: radians per unit of the angle columns
    rate: str
    rate_rad_s: float  #: rad/s per unit of the rate columns
    wrap: float  #: wrap period of the angle columns, in their unit
    counts_per_rev: float | None  #: with counts, the counts in a turn


def _units(path, angle_units, rate_units, counts_per_rev, counter_modulus) -> _Units:
    if angle_units not in ANGLE_UNITS:
        raise SourceError(path, f"--angle-units '{angle_units}' are not known; use {', '.join(ANGLE_UNITS)}")
    rate_units = f"{angle_units}/s" if rate_units is None else rate_units
    if rate_units not in RATE_UNITS:
        raise SourceError(path, f"--rate-units '{rate_units}' are not known; use {', '.join(RATE_UNITS)}")
    counts = "counts" in (angle_units, rate_units.split("/")[0])
    if counts and (counts_per_rev is None or not np.isfinite(counts_per_rev) or counts_per_rev < 2):
        shown = "is missing" if counts_per_rev is None else f"is {counts_per_rev:g}"
        raise SourceError(path, f"encoder counts need the counts per turn: --counts-per-rev {shown} (give N >= 2)")
    if not counts and counts_per_rev is not None:
        raise SourceError(path, "--counts-per-rev applies to --angle-units counts (or --rate-units counts/s) only")
    if counter_modulus is not None and (angle_units != "counts" or not counter_modulus >= 2):
        raise SourceError(
            path, "--counter-modulus (the count at which the counter rolls over, >= 2) needs --angle-units counts"
        )
    cpr = float(counts_per_rev) if counts_per_rev is not None else np.nan  # given exactly when counts are (above)
    per_count = 2.0 * np.pi / cpr
    return _Units(
        angle_units,
        per_count if angle_units == "counts" else RAD_PER_UNIT[angle_units],
        rate_units,
        per_count if rate_units == "counts/s" else RAD_PER_UNIT[rate_units.split("/")[0]],
        float(counter_modulus or cpr) if angle_units == "counts" else WRAP_PERIOD[angle_units],
        cpr if counts else None,
    )


def _column_names(path, names, option: str, n: int):
    names = tuple(str(c).strip() for c in names)
    if len(names) != n:
        raise SourceError(
            path, f"{option} names {len(names)} columns ({', '.join(names)}); --axes names {n}: give one per axis"
        )
    return names


def _site(imu: Telemetry, site_deg, imu_path: Path):
    """The site: ``--site-deg`` (replacing the IMU record's, said so), else the IMU record's."""
    if site_deg is not None:
        site = Site(float(site_deg[0]) * DEG, float(site_deg[1]) * DEG, float(site_deg[2]))
        return site, "--site-deg" + (f" (replaces the site of {imu_path.name})" if imu.site is not None else "")
    if imu.site is None:
        raise SourceError(
            imu_path,
            "holds no site and --site-deg is not given; calibration needs normal gravity at the table: "
            "give --site-deg LAT,LON,H (latitude, longitude [deg], height above the ellipsoid [m])",
        )
    return imu.site, f"from {imu_path.name}"


# --------------------------------------------------------------------------- the log


def _read_log(path: Path, table: _Table, time: str, time_units: str, angles, rates, offset_s: float):
    """``(t [M] s on the IMU clock, angles [M, K], rates [M, K] or None)`` in the log's units, refusing
    empty or NaN cells and time that does not increase (naming the line)."""
    names = [time, *angles, *(rates or ())]
    option_of = {time: "--time"} | dict.fromkeys(angles, "--angles") | dict.fromkeys(rates or (), "--rates")
    table.require(names, option_of)
    raw = table.numbers(names, option_of, empty_is_nan=True)
    if raw.shape[0] < 2:
        raise SourceError(path, f"has {raw.shape[0]} data rows; a table log needs at least 2")
    bad = ~np.isfinite(raw)
    if bad.any():
        row, col = (int(v) for v in np.argwhere(bad)[0])
        raise SourceError(
            path,
            f"column '{names[col]}' ({option_of[names[col]]}) is empty or not finite on line "
            f"{table.line_number(row)}; every cell of a table log must hold a number (cut the log there)",
        )
    t = raw[:, 0] * TIME_UNITS[time_units] + offset_s
    step = np.diff(t)
    if np.any(step <= 0.0):
        k = int(np.flatnonzero(step <= 0.0)[0]) + 1
        raise SourceError(
            path,
            f"time column '{time}' (--time) {'repeats' if step[k - 1] == 0.0 else 'goes back'} on line "
            f"{table.line_number(k)} ({raw[k - 1, 0]:.9g} -> {raw[k, 0]:.9g} {time_units}); sort the log and drop "
            "repeated rows",
        )
    problem = _time_units_problem(time, "--time", time_units, "--time-units", t, REFERENCE_RATE_HZ, "of a table log")
    if problem:
        raise SourceError(path, problem)
    k = len(angles)
    return t, raw[:, 1 : 1 + k], (raw[:, 1 + k :] if rates else None)


def _unwrap(path, table: _Table, t, values, angles, units: _Units):
    """The angle columns [rad], unwrapped, and the wraps undone per column; refuses a column whose
    wraps or rates show it is not in the unit declared."""
    limit_rad_s = load_schema(TELEMETRY_SCHEMA)["sample_limits"]["/imu/gyro"]  # no table turns faster than a gyro reads
    period = units.wrap
    steps = np.diff(values, axis=0)
    wraps = (np.abs(steps) > 0.5 * period).sum(axis=0)
    unit = units.angle
    for k, name in enumerate(angles):
        lo, hi = float(values[:, k].min()), float(values[:, k].max())
        if wraps[k] and hi - lo > WRAP_SPAN_TURNS * period:
            raise SourceError(
                path,
                f"column '{name}' (--angles) jumps by more than half of {period:g} {unit} {wraps[k]} times yet spans "
                f"{lo:g} .. {hi:g} {unit}: more than a turn, so the jumps are not wraps of {unit}; check "
                "--angle-units (counts need --counts-per-rev; a counter that rolls over elsewhere, --counter-modulus)",
            )
    theta = np.unwrap(values, period=period, axis=0) * units.angle_rad
    rate = np.abs(np.diff(theta, axis=0)) / np.diff(t)[:, None]
    row, col = (int(v) for v in np.unravel_index(int(np.argmax(rate)), rate.shape))
    if rate[row, col] > limit_rad_s:
        raise SourceError(
            path,
            f"column '{angles[col]}' (--angles) turns at {rate[row, col] / DEG:.4g} deg/s between lines "
            f"{table.line_number(row)} and {table.line_number(row + 1)} read in {unit}, beyond any "
            f"table (and any gyro: {limit_rad_s / DEG:.0f} deg/s); check --angle-units and --time-units",
        )
    return theta, [int(w) for w in wraps]


def _check_rates(path, theta_rad, rate_rad_s, t, angles, rates, units: _Units) -> list[float | None]:
    """Each rate column against its angle's derivative: the least-squares ratio over the turning rows
    (None where the axis barely turns), refused beyond :data:`RATE_SCALE_TOL`."""
    derivative = np.gradient(theta_rad, t, axis=0)
    ratios: list[float | None] = []
    for k in range(theta_rad.shape[1]):
        d, r = derivative[:, k], rate_rad_s[:, k]
        moving = np.abs(d) > MOVING_RAD_S
        if moving.sum() < MIN_MOVING_ROWS:
            ratios.append(None)
            continue
        ratio = float(np.dot(r[moving], d[moving]) / np.dot(d[moving], d[moving]))
        if not abs(ratio - 1.0) <= RATE_SCALE_TOL:
            raise SourceError(
                path,
                f"column '{rates[k]}' (--rates) reads {ratio:.4g} times the derivative of column '{angles[k]}' "
                f"(--angles) over {int(moving.sum())} turning rows; check --rate-units ({units.rate}) against "
                f"--angle-units ({units.angle}), and that the two columns are one axis's",
            )
        ratios.append(ratio)
    return ratios


# --------------------------------------------------------------------------- against the IMU


def _imu_inside(imu: Telemetry, t_ref, path: Path, imu_path: Path, time: str, time_units: str):
    """The IMU rows within the log's span (a copy of the record cut to them) and how many were cut
    before and after; refuses a log that does not overlap the IMU."""
    t = imu.time_s
    keep = (t >= t_ref[0]) & (t <= t_ref[-1])
    if keep.sum() < 2:
        raise SourceError(
            path,
            f"the log's time '{time}' [{time_units}] (+ --time-offset-s) spans {t_ref[0]:.6g} .. {t_ref[-1]:.6g} s "
            f"and the IMU of {imu_path.name} {t[0]:.6g} .. {t[-1]:.6g} s: they do not overlap; both must be on "
            "one clock (give --time-offset-s, the IMU time at the log's zero, or check --time-units)",
        )
    first, stop = int(np.argmax(keep)), int(t.size - np.argmax(keep[::-1]))
    names = ("gyro_rad_s", "accel_mps2", "dtheta_rad", "dvel_mps", "accel_time_s")
    rows = {k: getattr(imu, k)[first:stop] for k in names if getattr(imu, k) is not None}
    return Telemetry(time_s=t[first:stop], form=imu.form, **rows), first, t.size - stop


def _angle_deg(u, v):
    """Angle [deg] between the rows of ``u`` and ``v`` [n, 3] (0 where either is zero)."""
    norm = np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1)
    cos = np.einsum("ij,ij->i", u, v) / np.where(norm > 0.0, norm, 1.0)
    return np.degrees(np.arccos(np.clip(np.where(norm > 0.0, cos, 1.0), -1.0, 1.0)))


def _check_against_imu(path, imu_path: Path, imu: Telemetry, t_ref, up_b, omega_nb_b) -> list[str]:
    """Refuse an attitude that disagrees with the IMU on a stretch of the log: "up" against the
    specific force where the table rests, the body rate against the gyros where it turns (on more
    than :data:`OFF_SHARE_MAX` of those rows); the lines that say how well they agree. ``up_b``,
    ``omega_nb_b`` [M, 3]: NED up in body axes and the body rate [rad/s] at the log's times ``t_ref``."""
    gyro_like, accel_like = imu.imu_arrays()
    period = imu.sample_period_s
    t_imu, scale = (imu.time_s, 1.0) if imu.form == "rates" else (imu.time_s - 0.5 * period, 1.0 / period)
    inside = (t_ref >= t_imu[0]) & (t_ref <= t_imu[-1])
    t = t_ref[inside]

    def at_log_rows(x):
        return np.column_stack([np.interp(t, t_imu, x[:, k] * scale) for k in range(3)])

    turning = np.linalg.norm(omega_nb_b[inside], axis=1) > MOVING_RAD_S
    resting = ~turning
    checks = "--axes (a minus turns an axis the other way), --mount-deg, --angle-units and --time-offset-s"
    found = []
    if resting.sum() >= MIN_MOVING_ROWS:  # at rest the accelerometers read gravity alone
        off = _angle_deg(at_log_rows(accel_like)[resting], up_b[inside][resting])
        limit = REFERENCE_GRAVITY_ANGLE_MAX_DEG
        what = f"puts 'up' more than {limit:g} deg from the specific force the accelerometers of {imu_path.name} read"
        median = _share_off(path, off, limit, t[resting], "rests", what, checks)
        found.append(
            f"at rest ({resting.sum()} rows): 'up' {median:.2f} deg (median) from the accelerometers' specific force"
        )
    if turning.sum() >= MIN_MOVING_ROWS:
        gyro, omega = at_log_rows(gyro_like)[turning], omega_nb_b[inside][turning]
        ratio = float(np.median(np.linalg.norm(gyro, axis=1) / np.linalg.norm(omega, axis=1)))
        if not 1.0 / GYRO_BAND <= ratio <= GYRO_BAND:  # the gyros' scale against the log's, as sanity's check
            raise SourceError(
                path,
                f"the gyros of {imu_path.name} turn {ratio:.4g} times as fast as the log's angles say (median over "
                f"{turning.sum()} rows where the table turns); check --angle-units, --counts-per-rev and --time-units "
                "(or the gyro units the IMU record was imported with)",
            )
        off = _angle_deg(gyro, omega)
        what = (
            f"turns the body more than {GYRO_ANGLE_MAX_DEG:g} deg away from the axis the gyros of {imu_path.name} read"
        )
        median = _share_off(path, off, GYRO_ANGLE_MAX_DEG, t[turning], "turns", what, checks)
        found.append(
            f"turning ({turning.sum()} rows): the table's rate {median:.2f} deg (median) from the gyros', which turn "
            f"{ratio:.4f} times as fast (median)"
        )
    if not found:
        return [f"not checked against the IMU: the table neither rests nor turns on {MIN_MOVING_ROWS} rows beside it"]
    return found


def _share_off(path, off_deg, limit_deg: float, t, state: str, what: str, checks: str) -> float:
    """Refuse when more than :data:`OFF_SHARE_MAX` of the rows are beyond ``limit_deg``, naming the
    first; the median angle [deg] otherwise."""
    bad = off_deg > limit_deg
    share = float(bad.mean())
    if share > OFF_SHARE_MAX:
        raise SourceError(
            path,
            f"on {share * 100:.0f} % of the {bad.size} rows where the table {state} (the first at t = {t[np.argmax(bad)]:.3f} "
            f"s) the attitude the log gives {what}; check {checks}",
        )
    return float(np.median(off_deg))


# --------------------------------------------------------------------------- the importer


def load(
    path: Path,
    *,
    imu_record,
    axes,
    time: str,
    angles,
    rates=None,
    time_units: str = "s",
    angle_units: str = "deg",
    rate_units: str | None = None,
    counts_per_rev: float | None = None,
    counter_modulus: float | None = None,
    table_heading_deg: float = 0.0,
    mount_deg=(0.0, 0.0, 0.0),
    site_deg=None,
    time_offset_s: float = 0.0,
    delimiter: str = ",",
) -> Telemetry:
    """The IMU of ``imu_record`` with ``/reference`` from the table log ``path`` (module docstring).

    ``axes``: the table's axes, outer to inner, as signed letters (``("z", "-x", "y")``);
    ``angles``, ``rates``: the log's column names, one per axis; ``rate_units`` defaults to the
    angle units per second; ``mount_deg``: roll, pitch, yaw of the IMU's body on the inner platform.
    """
    path, imu_path = Path(path), Path(imu_record)
    try:
        gimbals = gimbal_axes(axes)
    except ValueError as exc:
        raise SourceError(path, f"--axes {','.join(map(str, axes))}: {exc}") from None
    angles = _column_names(path, angles, "--angles", len(gimbals))
    rates = None if rates is None else _column_names(path, rates, "--rates", len(gimbals))
    units = _units(path, angle_units, rate_units, counts_per_rev, counter_modulus)
    if time_units not in TIME_UNITS:
        raise SourceError(path, f"--time-units '{time_units}' are not known; use {', '.join(TIME_UNITS)}")
    for option, value in (("--table-heading-deg", table_heading_deg), ("--time-offset-s", time_offset_s)):
        if not np.isfinite(value):
            raise SourceError(path, f"{option} {value}: give a finite number")
    if len(mount_deg) != 3 or not np.all(np.isfinite(mount_deg)):
        raise SourceError(path, "--mount-deg: give three finite angles, roll,pitch,yaw [deg]")

    # validated as every command reads it (its errors name the record); its gaps are found and declared
    # again by the import, as every importer declares those of its source
    imu = read_telemetry(imu_path, allow_gaps=True)
    site, site_from = _site(imu, site_deg, imu_path)
    table = _Table.read(path, delimiter, "table log")
    t, values, rate_values = _read_log(path, table, time, time_units, angles, rates, float(time_offset_s))
    theta, wraps = _unwrap(path, table, t, values, angles, units)
    cut, before, after = _imu_inside(imu, t, path, imu_path, time, time_units)
    if rate_values is not None:
        rate = rate_values * units.rate_rad_s
        ratios = _check_rates(path, theta, rate, t, angles, rates, units)
    else:
        rate, ratios = np.gradient(theta, t, axis=0), None
    mat_pb = euler_to_mat(*(np.asarray(mount_deg, dtype=float) * DEG))
    quat_nb, omega_nb_b, up_b = np.empty((t.size, 4)), np.empty((t.size, 3)), np.empty((t.size, 3))
    for a in range(0, t.size, CHUNK_ROWS):  # rows are independent: [M, 3, 3] matrices a block at a time
        b = min(a + CHUNK_ROWS, t.size)
        mat_nb, omega_nb_b[a:b] = table_attitude(
            gimbals, theta[a:b], rate[a:b], t[a:b], heading_rad=float(table_heading_deg) * DEG, mat_pb=mat_pb
        )
        quat_nb[a:b], up_b[a:b] = mat_to_quat(mat_nb), -mat_nb[:, 2, :]  # NED up in body axes: -(row 3 of mat_nb)
    checked = _check_against_imu(path, imu_path, cut, t, up_b, omega_nb_b)

    signed = [("-" if s < 0 else "") + a for a, s in gimbals]
    axes_text = ",".join(signed)
    conversion = [
        f"reference: {t.size} rows of {path.name}, attitude only (/reference holds no rate), t = {t[0]:.6g} .. "
        f"{t[-1]:.6g} s on the IMU clock ('{time}' [{time_units}] + {float(time_offset_s):g} s)",
        f"table: axes {axes_text} (outer to inner), zero heading {float(table_heading_deg):g} deg, IMU mount "
        f"roll, pitch, yaw {', '.join(f'{v:g}' for v in mount_deg)} deg; site {site_from}",
        f"angles in {units.angle}: "
        + ", ".join(f"'{a}' {w} wrap{'' if w == 1 else 's'} undone" for a, w in zip(angles, wraps)),
    ]
    if ratios is not None:
        shown = ", ".join("not turning" if r is None else f"{r:.3f}" for r in ratios)
        conversion.append(f"rates [{units.rate}] / the angles' derivative: {shown}")
    conversion += checked
    if before or after:
        conversion.append(f"IMU rows outside the log's span cut: {before} before, {after} after")
    if imu.reference is not None:
        conversion.append(f"the /reference of {imu_path.name} ({imu.reference.time_s.size} rows) is replaced")

    source = dict(
        imu_record=imu_path.name,
        imu_record_sha256=sha256_of(imu_path, mapped=False),
        time_column=time,
        time_units=time_units,
        time_offset_s=float(time_offset_s),
        axes=signed,
        angle_columns=list(angles),
        angle_units=units.angle,
        angle_wraps=wraps,
        table_heading_deg=float(table_heading_deg),
        mount_deg=[float(v) for v in mount_deg],
        conversion=conversion,
    )
    if units.counts_per_rev is not None:
        source["counts_per_rev"] = units.counts_per_rev
    if units.angle == "counts":
        source["counter_modulus"] = float(units.wrap)
    if rates:
        source.update(rate_columns=list(rates), rate_units=units.rate)
    cut.reference, cut.site = Reference(time_s=t, quat_nb=quat_nb), site
    cut.source = provenance(path, "table-log", **source, imu=imu.source)  # where the IMU came from, kept beside
    cut.description = (
        f"IMU of {imu_path.name} with the reference attitude of the table log {path.name} "
        f"(axes {axes_text}, zero heading {float(table_heading_deg):g} deg)"
    )
    return cut
