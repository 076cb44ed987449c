"""Physics checks of a record's units: ``sizefx import`` and ``sizefx inspect``,
and ``sizefx simulate`` before it publishes.

A units attribute (or a ``--gyro-units`` option) that says rad/s over data in deg/s makes
every rate 57.3 times too large, and nothing downstream can tell. The magnitudes can:

(a) Specific force at rest. Where the accelerometers are steady and the gyros quiet over a
    short window, ``|f|`` is local gravity (normal gravity at the site from
    :func:`sizefx.earth.gravity_n`, else 9.80665 m/s^2). g stored as m/s^2 reads 1/9.80665
    of it, m/s^2 stored as g 9.80665 times. A record that never rests is judged, with a
    wider band, on the median ``|f|`` of all its windows (a terrestrial vehicle's mean
    specific force is gravity's, give or take its own accelerations).
(b) Gyros against a reference attitude. Over reference intervals that really rotate (a net
    angle of at least :data:`REF_MIN_ANGLE_RAD`, a path short enough that the angle is not
    ambiguous), the integrated gyro vector has the length of the reference rotation angle;
    the median ratio is 57.3 for deg/s read as rad/s, 1/57.3 for the reverse.
(c) Gyros against the tilt the accelerometers see. Without a reference: between two
    quasi-static moments (``|f|`` at its usual value, so ``f`` is ``-g`` in body axes) whose
    gravity directions differ by at least :data:`TILT_MIN_RAD`, the gyros, integrated under
    each unit hypothesis, must carry the first direction onto the second. The hypothesis
    that explains the tilt changes (and that alone) says which unit the data are in.

Nothing here refuses on its own: :func:`check_units` returns what it found (figures, or why a
check could not be made) and :func:`refuse_wrong_units` raises :class:`~sizefx.errors.UnitsError`
for a check whose data look like another unit. When nothing can be decided, nothing is refused.
:func:`implausible` says what ``sizefx inspect`` would refuse by default (the reader's median
magnitudes, then these checks) in a record in memory: ``sizefx simulate`` asks it of what it
writes, on the rows :func:`sample_blocks` keeps of a long record, so that it never publishes a
record inspect refuses.

Work is bounded on any record length: at most :data:`MAX_WINDOWS` windows, :data:`REF_MAX_STARTS`
reference intervals and :data:`TILT_MAX_PAIRS` tilt changes are examined, each reading only its
own rows (the 1.8 h flight at 1600 Hz, 10 M samples, takes about a second).

The package, one concern a module; every name is imported from here:

- :mod:`.thresholds`: the named thresholds of the windows and of the three checks, each beside the
  evidence that set it, kept together because they are weighed against each other
  (:data:`GYRO_BAND` bounds both (b) and (c));
- :mod:`.verdict`: the verdict type :class:`Check` (and :class:`UnitsReport`) and the
  unit-hypothesis test :func:`looks_like` the three checks share;
- :mod:`.windows`: the windows a record is judged on and the rest detection, shared by (a) and (c);
- :mod:`.accel`: check (a); :mod:`.gyro_reference`: check (b); :mod:`.gyro_tilt`: check (c);
- here: the entry points (:func:`check_units`, which chooses (c) only where (b) cannot decide,
  :func:`refuse_wrong_units`, :func:`report_lines`, :func:`implausible`) and the rows a streamed
  record is judged on (:func:`sample_blocks`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import UnitsError
from ..io.contract import magnitude_problem
from ..io.gaps import nominal_period_s
from ..io.schema import TELEMETRY_SCHEMA, load_schema
from ..rotation import quat_angle_between

# what the single module sizefx.sanity held stays importable from here, its helpers too
from .accel import _check_accel, _gravity  # noqa: F401
from .gyro_reference import _check_gyro_reference, _integral, _reference_starts  # noqa: F401
from .gyro_tilt import _angle, _check_gyro_tilt, _tilt_pairs  # noqa: F401
from .thresholds import (  # noqa: F401
    ACCEL_BAND,
    ACCEL_MOVING_BAND,
    GYRO_BAND,
    MAX_WINDOWS,
    MIN_WINDOW_SAMPLES,
    QUASI_STATIC_TOL,
    REF_COARSE_ROWS,
    REF_CONSECUTIVE,
    REF_END_OFFSETS,
    REF_MAX_INTERVAL_S,
    REF_MAX_PATH_RAD,
    REF_MAX_STARTS,
    REF_MIN_ANGLE_RAD,
    REF_MIN_INTERVALS,
    REST_GYRO_FACTOR,
    REST_GYRO_PERCENTILE,
    REST_MIN_WINDOWS,
    REST_STEADINESS,
    TILT_BLOCKS,
    TILT_MATCH,
    TILT_MAX_PAIRS,
    TILT_MIN_PAIRS,
    TILT_MIN_RAD,
    TILT_PAIR_MAX_S,
    TILT_REJECT,
    TILT_SCALE_GRID,
    WINDOW_S,
)
from .verdict import FORM_QUANTITIES, UNITS_OUTSIDE_CONTRACT, Check, UnitsReport, looks_like  # noqa: F401
from .windows import _rates, _runs_at_least, _Windows, _windows  # noqa: F401

__all__ = [
    "Check",
    "UnitsReport",
    "Implausible",
    "check_units",
    "implausible",
    "refuse_wrong_units",
    "looks_like",
    "report_lines",
    "sample_blocks",
    "SAMPLE_ROWS",
]


# --------------------------------------------------------------------------- a streamed record's sample

# These stay beside sample_blocks, which reads them from this module (tests/test_consistent_inputs.py
# narrows SAMPLE_ROWS here, to judge a long flight on its sample).

#: Rows of a record written in chunks (``sizefx simulate``) that :func:`implausible` judges it on:
#: up to this many, the whole record (the verdict ``sizefx inspect`` reaches on the file, from the
#: same rows); beyond, :func:`sample_blocks` spread over it, this many rows in all. 2^18 rows hold
#: 164 s at 1600 Hz (a default tumble whole) and take 24 MiB with a reference at the IMU rate (time,
#: gyro, accel; reference time and attitude), beside the simulator's 100 MiB of chunk work.
SAMPLE_ROWS = 1 << 18
#: A sample block lasts this long [s] where the rows allow: a pair of tilt moments
#: :data:`TILT_PAIR_MAX_S` apart, and many rest runs (:data:`REST_MIN_WINDOWS` windows) and reference
#: intervals (:data:`REF_MAX_INTERVAL_S`) fit in it. At 1600 Hz: 16 blocks of 16 000 rows.
SAMPLE_BLOCK_S = TILT_PAIR_MAX_S
#: ...and there are at least this many, so that a record is judged on more than one stretch of its
#: motion; not more, so that at the top rate (100 kHz) a block still lasts 1.3 s and holds a rest run
#: (:data:`REST_MIN_WINDOWS` windows of :data:`WINDOW_S`): without one, (a) would judge the record in
#: motion, with the wider band, where ``sizefx inspect`` finds it at rest.
SAMPLE_MIN_BLOCKS = 2


# --------------------------------------------------------------------------- entry points


def check_units(tel, *, declared: dict | None = None) -> UnitsReport:
    """Check the magnitudes of ``tel`` (SI as read) against physics; see the module docstring.

    Parameters
    ----------
    tel : sizefx.io.telemetry.Telemetry
        The record, its IMU arrays converted to SI with the declared units.
    declared : dict, optional
        Dataset name -> the units the data were read in (``tel.stored_units`` by default; an
        importer passes what its source declared). Missing names take the contract's SI unit.
    """
    gyro_name, accel_name = load_schema(TELEMETRY_SCHEMA)["forms"][tel.form]["datasets"]
    q_gyro, q_accel = FORM_QUANTITIES[tel.form]
    table = load_schema(TELEMETRY_SCHEMA)["units"]
    declared = {**(tel.stored_units or {}), **(declared or {})}
    d_gyro = declared.get(gyro_name, next(iter(table[q_gyro])))
    d_accel = declared.get(accel_name, next(iter(table[q_accel])))
    period = float(np.median(np.diff(tel.time_s[: 1 << 16])))
    win = _windows(tel, period)
    accel = _check_accel(tel, win, accel_name, d_accel)
    gyro = _check_gyro_reference(tel, period, gyro_name, d_gyro)
    if isinstance(gyro, str):
        reasons = [gyro]
        gyro = _check_gyro_tilt(tel, win, period, gyro_name, d_gyro)
        if isinstance(gyro, str):
            reasons.append(gyro)
            gyro = Check("gyro", gyro_name, d_gyro, "unchecked", "gyro: not checked: " + "; ".join(reasons))
    return UnitsReport(accel, gyro)


def report_lines(doc: dict | None) -> list[str]:
    """What a person is told of the check (its ``UnitsReport.as_dict()``, None when skipped): one
    line per sensor, for ``sizefx import`` and ``sizefx inspect`` alike."""
    if doc is None:
        return ["not checked (--no-units-check)"]
    return [doc["accel"]["detail"], doc["gyro"]["detail"]]


def refuse_wrong_units(report: UnitsReport, path, *, where: dict | None = None, fix=None):
    """Raise :class:`UnitsError` for the first check whose data look like another unit.

    ``where``: dataset -> how to name it in the message (CSV columns, say); ``fix(check)``: how to
    correct it, e.g. ``"import with --gyro-units deg/s"``.
    """
    for check in report.wrong:
        name = (where or {}).get(check.dataset, check.dataset)
        if check.looks_like:
            verdict = f"the data look like {check.looks_like}, not {check.declared}"
        else:
            verdict = f"the data match no unit the contract knows (declared {check.declared})"
        how = fix(check) if fix is not None else None
        raise UnitsError(
            path,
            name,
            f"{check.detail}; {verdict}"
            + (f": {how}" if how else "")
            + " (or pass --no-units-check if you know the data are right)",
        )


@dataclass(frozen=True)
class Implausible:
    """What ``sizefx inspect`` refuses by default in a record's magnitudes (:func:`implausible`)."""

    what: str  #: "accel" or "gyro"
    dataset: str  #: /imu/accel, /imu/dtheta, ...
    detail: str  #: the check's own figures, without the fix for a file's units attribute


def implausible(tel) -> Implausible | None:
    """What the default checks of ``sizefx inspect`` refuse in the record ``tel`` (SI, in memory),
    or None when they accept its magnitudes.

    The same checks, in inspect's order: the reader's median specific force and angular rate
    (:func:`sizefx.io.contract.magnitude_problem`), then the verdicts of :func:`check_units` that
    :func:`refuse_wrong_units` refuses. A writer calls it on what it writes (``sizefx simulate``,
    on the rows of :func:`sample_blocks`) so that it does not publish a record inspect refuses.
    """
    schema = load_schema(TELEMETRY_SCHEMA)
    gyro_name, accel_name = schema["forms"][tel.form]["datasets"]
    units = {
        name: (tel.stored_units or {}).get(name, next(iter(schema["units"][schema["datasets"][name]["quantity"]])))
        for name in (gyro_name, accel_name)
    }
    gyro, accel = tel.imu_arrays()
    found = magnitude_problem(schema, tel.form, nominal_period_s(tel.time_s), gyro, accel, units)
    if found is not None:
        name, figures, _ = found  # the hint names the units attribute: the caller says its own fix
        return Implausible("accel" if name == accel_name else "gyro", name, figures)
    for check in check_units(tel).wrong:
        return Implausible(check.what, check.dataset, check.detail)
    return None


def sample_blocks(n_samples: int, rate_hz: float, reference=None) -> list[tuple[int, int]]:
    """Rows ``[(first, stop), ...]`` of a record of ``n_samples`` rows at ``rate_hz`` that a writer
    streaming it keeps for :func:`implausible`: the whole record up to :data:`SAMPLE_ROWS` rows,
    else blocks of :data:`SAMPLE_BLOCK_S` each (shorter above 6.4 kHz: at least
    :data:`SAMPLE_MIN_BLOCKS` blocks), :data:`SAMPLE_ROWS` rows in all, in row order; the checks
    treat the breaks between blocks as gaps.

    ``reference(time_s) -> quat_nb``: the record's reference attitude at any time [s] from its
    start (a simulator knows it before it writes a row). Check (b) looks for the stretches where
    the reference turns, which evenly spread blocks miss (the 1.8 h flight turns by
    :data:`REF_MIN_ANGLE_RAD` within 2 s in 9 of its 3240 cells); so half the blocks go to them,
    found as (b) finds them (:func:`_reference_starts`: cells of :data:`REF_MAX_INTERVAL_S`, at
    most :data:`REF_COARSE_ROWS` of them, whose ends differ by :data:`REF_MIN_ANGLE_RAD`), and half
    are spread evenly (the first at the start and, when there are two, the last at the end), where
    rest and the typical magnitudes are.
    """
    if n_samples <= SAMPLE_ROWS:
        return [(0, n_samples)]
    length = min(
        max(MIN_WINDOW_SAMPLES * REST_MIN_WINDOWS, math.ceil(SAMPLE_BLOCK_S * rate_hz)),
        SAMPLE_ROWS // SAMPLE_MIN_BLOCKS,
    )
    count = SAMPLE_ROWS // length
    centres = np.zeros(0)
    if reference is not None:  # cells as (b)'s coarse grid: at most REF_COARSE_ROWS of them
        cell_s = max(REF_MAX_INTERVAL_S, n_samples / rate_hz / REF_COARSE_ROWS)
        q = reference(np.arange(0.0, n_samples / rate_hz, cell_s))
        turning = np.flatnonzero(quat_angle_between(q[:-1], q[1:]) >= REF_MIN_ANGLE_RAD)
        if turning.size:
            pick = turning[np.linspace(0, turning.size - 1, min(turning.size, count // 2)).round().astype(int)]
            centres = (np.unique(pick) + 0.5) * cell_s * rate_hz  # rows
    even = np.linspace(0, n_samples - length, count - centres.size).round()
    starts = np.sort(np.r_[even, np.clip(centres - length / 2, 0, n_samples - length).round()]).astype(int)
    blocks: list[tuple[int, int]] = []
    for k in starts:  # overlapping blocks are merged (fewer rows, never more)
        if blocks and k <= blocks[-1][1]:
            blocks[-1] = (blocks[-1][0], int(k) + length)
        else:
            blocks.append((int(k), int(k) + length))
    return blocks
