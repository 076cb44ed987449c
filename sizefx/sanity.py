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

Why one module of about 720 lines: it is one decision,
the verdict on a record's units (and the rows a streamed record is judged on, chosen for what
(a) and (b) look for). (a), (b) and (c) share the windows and the rest detection, the
unit-hypothesis test :func:`looks_like` and the verdict type :class:`Check`, and
:func:`check_units` chooses (c) only where (b) cannot decide. A quarter of the lines are the
named thresholds, each beside the evidence that set it (rates measured on the real recordings);
split into one module per check, a threshold would sit away from the others it is weighed
against (``GYRO_BAND`` bounds both (b) and (c)). The module imports no other stage and nothing
imports its private helpers, so it can be split later without touching its callers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import earth
from .constants import DEG, GAP_FACTOR, STANDARD_GRAVITY_MPS2
from .errors import UnitsError
from .io.contract import magnitude_problem
from .io.gaps import nominal_period_s
from .io.schema import TELEMETRY_SCHEMA, load_schema, unit_factor
from .rotation import quat_angle_between, rotvec_to_mat

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

# --------------------------------------------------------------------------- windows and rest

#: Window length [s] over which "steady" and "quiet" are judged, and the gravity direction
#: is measured: short enough that a tumbling record (0.7 rad/s) turns only 10 deg within one,
#: long enough to average MEMS noise over 25 samples at 100 Hz.
WINDOW_S = 0.25
#: Fewest samples per window (a slow record gets longer windows).
MIN_WINDOW_SAMPLES = 8
#: Most windows examined; a longer record is sampled evenly (bounded time and memory).
MAX_WINDOWS = 3000
#: A window is steady when every accelerometer axis varies (standard deviation) by less than this
#: fraction of ``|mean f|``. Unit-free, so that a unit mistake cannot hide rest. Measured at rest:
#: BROAD MEMS 0.007, PX4 0.002, the parked ring-laser log 0.018 (quantisation and disturbance);
#: in motion: BROAD 0.1-1, a tumbling table 0.05-0.09, helicopter vibration 0.05-0.07.
REST_STEADINESS = 0.03
#: Quiet gyros: ``|mean omega|`` of a steady window within this factor of the quietest steady
#: windows' (their :data:`REST_GYRO_PERCENTILE`-th percentile). Relative, because the gyro units
#: are under test: rest reads bias plus Earth rate in whatever unit the data are in. A steady
#: window that turns about the vertical (heading sway, a turntable) reads far more.
REST_GYRO_FACTOR = 4.0
REST_GYRO_PERCENTILE = 5.0
#: Rest lasts at least this many windows in a row (1 s): a table or a hand holds a position for
#: seconds, while a tumbling motion passes through a steady, slow moment in a fraction of one.
REST_MIN_WINDOWS = 4

# --------------------------------------------------------------------------- (a) accelerometers

#: ``|f|`` at rest within this factor of normal gravity passes. Uncalibrated MEMS read a few
#: per cent off (imucal raw: 1.054, the PSINS car MEMS: 0.97, PX4: 0.99); a unit mistake is 9.8.
ACCEL_BAND = 1.25
#: The same for a record that never rests (median ``|f|`` of all windows: vehicle accelerations,
#: vibration and centripetal terms add to gravity, by tens of per cent at most).
ACCEL_MOVING_BAND = 1.5

# --------------------------------------------------------------------------- (b) gyros, reference

#: Reference intervals examined at most (evenly spread start rows).
REF_MAX_STARTS = 2000
#: Longest interval [s] (a MEMS bias times the span stays small against the rotation; a
#: 10 Hz reference of a car turning at 10 deg/s reaches the minimum angle).
REF_MAX_INTERVAL_S = 2.0
#: Interval ends tried per start: the next :data:`REF_CONSECUTIVE` rows, then rows spaced
#: geometrically out to :data:`REF_MAX_INTERVAL_S` (a 1600 Hz reference spans 3200 rows).
REF_CONSECUTIVE = 16
REF_END_OFFSETS = 64
#: Most rows of the coarse grid on which the turning stretches of a reference are found.
REF_COARSE_ROWS = 100_000
#: An interval "really rotates" when the reference turns by at least this net angle [rad]:
#: 20 times motion-capture noise (~0.3 deg), and 10 times a 0.5 deg/s MEMS bias over 2 s.
REF_MIN_ANGLE_RAD = 0.1
#: The reference's path (sum of its row-to-row angles) over an interval stays below this [rad],
#: so the net angle is unambiguous (far from pi) and the length of the integrated gyro vector
#: equals it to second order (coning).
REF_MAX_PATH_RAD = 1.0
#: Fewest rotating intervals for a verdict.
REF_MIN_INTERVALS = 10
#: The median ratio (integrated gyro / reference angle) passes within this factor of 1;
#: uncalibrated MEMS scale factors are off by a few per cent, deg/s for rad/s by 57.3.
GYRO_BAND = 1.25

# --------------------------------------------------------------------------- (c) gyros, tilt

#: A window is quasi-static when its ``|mean f|`` is within this fraction of the record's median:
#: then ``f`` is ``-g`` in body axes to within the same angle (3 % ~ 2 deg).
QUASI_STATIC_TOL = 0.03
#: A tilt change counts when the gravity direction moves by at least this [rad] (20 deg):
#: far above the direction's noise (< 1 deg) and a MEMS bias over the pair (removed where the
#: record rests), and large enough that a hypothesis that scales the rotation by 57.3 either way
#: misses it by far.
TILT_MIN_RAD = 20.0 * DEG
#: Longest time between the two moments of a pair [s] (bounds the bias drift and the work).
TILT_PAIR_MAX_S = 10.0
#: Most pairs integrated (evenly chosen among those found).
TILT_MAX_PAIRS = 60
#: Each pair is integrated in this many blocks of summed increments (the rotation per block
#: stays below 0.1 rad for 1 rad/s over 10 s: coning error well below the verdict's tolerance).
TILT_BLOCKS = 128
#: The hypothesis that explains the tilt changes leaves a median residual below this fraction of
#: the tilt change: the raw imucal MEMS leave 4 % (its gyro scale factors are a few per cent off,
#: and a 177 deg flip magnifies them); direction noise, bias and block coning add less...
TILT_MATCH = 0.15
#: ...and every other hypothesis a median residual above this fraction, else no verdict (reading
#: the rotation 57.3 times too small leaves the whole tilt change, 1.0; too large, a random one).
TILT_REJECT = 0.5
#: Fewest tilt changes for a verdict.
TILT_MIN_PAIRS = 3
#: Scale factors tried around the winning hypothesis for the reported ratio (within GYRO_BAND).
TILT_SCALE_GRID = np.exp(np.linspace(-math.log(GYRO_BAND), math.log(GYRO_BAND), 41))

# --------------------------------------------------------------------------- a streamed record's sample

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

#: Units a mistake may leave data in that the contract does not accept (named in messages only):
#: velocity increments integrated from accelerometers that read g.
UNITS_OUTSIDE_CONTRACT = {"velocity": {"g*s": STANDARD_GRAVITY_MPS2}}

FORM_QUANTITIES = {"rates": ("angular_rate", "acceleration"), "increments": ("angle", "velocity")}


@dataclass
class Check:
    """The verdict on one dataset's units."""

    what: str  #: "accel" or "gyro"
    dataset: str  #: the telemetry dataset (/imu/gyro, /imu/dvel, ...)
    declared: str  #: the units the data were read in
    verdict: str  #: "ok", "wrong" (refused), "odd" (disagrees but matches no unit; reported) or "unchecked"
    detail: str  #: the figures, or why no check could be made (no path, no dataset name)
    method: str | None = None  #: "rest", "motion", "reference" or "tilt"
    ratio: float | None = None  #: what the data read (in SI, after the declared units) / what physics says
    count: int = 0  #: windows, intervals or tilt changes behind the ratio
    looks_like: str | None = None  #: the unit the data look like, when not the declared one

    def as_dict(self) -> dict:
        return {
            k: getattr(self, k)
            for k in ("what", "dataset", "declared", "verdict", "method", "ratio", "count", "looks_like", "detail")
        }


@dataclass
class UnitsReport:
    accel: Check
    gyro: Check

    @property
    def wrong(self) -> list[Check]:
        return [c for c in (self.accel, self.gyro) if c.verdict == "wrong"]

    def lines(self) -> list[str]:
        return [c.detail for c in (self.accel, self.gyro)]

    def as_dict(self) -> dict:
        return {"accel": self.accel.as_dict(), "gyro": self.gyro.as_dict()}


def looks_like(quantity: str, declared: str, ratio: float, band: float) -> str | None:
    """The unit the data are in, if not ``declared``: data read as ``declared`` came out ``ratio``
    times the physical value, so they are in the unit whose SI factor is ``factor(declared) / ratio``
    (within ``band``). Units from the contract, then :data:`UNITS_OUTSIDE_CONTRACT`; None if none fits.
    """
    base = unit_factor(quantity, declared)
    if base is None or not ratio > 0 or isinstance(base, list):
        return None
    table = {**load_schema(TELEMETRY_SCHEMA)["units"][quantity], **UNITS_OUTSIDE_CONTRACT.get(quantity, {})}
    best, best_err = None, math.log(band)
    for unit, factor in table.items():
        if isinstance(factor, list) or unit == declared:
            continue
        err = abs(math.log(factor * ratio / base))
        if err <= best_err:
            best, best_err = unit, err
    return best


# --------------------------------------------------------------------------- windows


@dataclass
class _Windows:
    t_center: np.ndarray  #: [W] s
    f_b: np.ndarray  #: [W, 3] mean specific force (SI as read)
    omega_b: np.ndarray  #: [W, 3] mean angular rate (SI as read)
    steadiness: np.ndarray  #: [W] max axis std of f / |mean f|
    rest: np.ndarray  #: [W] bool


def _rates(tel, rows, period):
    """Angular rate and specific force of ``rows`` (an index array), whatever the form."""
    g, a = tel.imu_arrays()
    if tel.form == "rates":
        return g[rows], a[rows]
    return g[rows] / period, a[rows] / period


def _runs_at_least(mask: np.ndarray, joined: np.ndarray, length: int) -> np.ndarray:
    """``mask`` kept only in runs of at least ``length`` consecutive windows (``joined[k]``: window
    k follows window k - 1 without a break)."""
    out = np.zeros_like(mask)
    k = 0
    n = mask.size
    while k < n:
        if not mask[k]:
            k += 1
            continue
        end = k + 1
        while end < n and mask[end] and joined[end]:
            end += 1
        if end - k >= length:
            out[k:end] = True
        k = end
    return out


def _windows(tel, period: float) -> _Windows:
    n = tel.n_samples
    width = max(MIN_WINDOW_SAMPLES, int(round(WINDOW_S / period)))
    total = n // width
    if total == 0:
        empty = np.zeros((0, 3))
        return _Windows(np.zeros(0), empty, empty, np.zeros(0), np.zeros(0, bool))
    index = np.arange(total)
    if total > MAX_WINDOWS:  # evenly spread runs of consecutive windows, so that rest can still be seen
        run = 2 * REST_MIN_WINDOWS
        firsts = np.linspace(0, total - run, MAX_WINDOWS // run).round().astype(int)
        index = np.unique((firsts[:, None] + np.arange(run)[None, :]).ravel())
    rows = (index * width)[:, None] + np.arange(width)[None, :]  # [W, width]
    t = tel.time_s
    span = t[rows[:, -1]] - t[rows[:, 0]]
    whole = span <= (width - 1 + GAP_FACTOR - 1.0) * period  # no gap inside
    rows, index = rows[whole], index[whole]
    joined = np.r_[False, np.diff(index) == 1]
    if rows.shape[0] > 1:  # a gap between two windows breaks a run too
        joined[1:] &= t[rows[1:, 0]] - t[rows[:-1, -1]] <= GAP_FACTOR * period
    w, f = _rates(tel, rows, period)  # [W, width, 3]
    f_mean = f.mean(axis=1)
    w_mean = w.mean(axis=1)
    f_norm = np.linalg.norm(f_mean, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        steadiness = f.std(axis=1).max(axis=1) / f_norm
    steady = np.isfinite(steadiness) & (steadiness < REST_STEADINESS)
    rest = np.zeros(rows.shape[0], bool)
    if steady.any():
        w_norm = np.linalg.norm(w_mean, axis=1)
        quiet_level = np.percentile(w_norm[steady], REST_GYRO_PERCENTILE)
        rest = _runs_at_least(steady & (w_norm <= REST_GYRO_FACTOR * quiet_level), joined, REST_MIN_WINDOWS)
    return _Windows(0.5 * (t[rows[:, 0]] + t[rows[:, -1]]), f_mean, w_mean, steadiness, rest)


def _gravity(tel) -> tuple[float, str]:
    """Magnitude of gravity [m/s^2] where the record was made, and how it was known."""
    site = tel.site
    ref = tel.reference
    if site is not None:
        return float(earth.gravity_n(site.lat_rad, site.height_m)[2]), "normal gravity at the site"
    if ref is not None and ref.has_position:
        return float(earth.gravity_n(ref.lat_rad[0], ref.height_m[0])[2]), "normal gravity at the reference position"
    return STANDARD_GRAVITY_MPS2, "standard gravity (no site in the file)"


# --------------------------------------------------------------------------- (a)


def _check_accel(tel, win: _Windows, dataset: str, declared: str) -> Check:
    quantity = FORM_QUANTITIES[tel.form][1]
    g, where = _gravity(tel)
    norms = np.linalg.norm(win.f_b, axis=1)
    if win.rest.any():
        method, band, sel = "rest", ACCEL_BAND, win.rest
        label = "specific force at rest"
    elif norms.size:
        method, band, sel = "motion", ACCEL_MOVING_BAND, np.ones(norms.size, bool)
        label = "specific force (no rest found; median of all windows)"
    else:
        return Check(
            "accel",
            dataset,
            declared,
            "unchecked",
            f"specific force: not checked: the record is shorter than one {WINDOW_S} s window",
        )
    value = float(np.median(norms[sel]))
    count = int(sel.sum())
    ratio = value / g
    figures = (
        f"{label} {value:.4g} m/s^2 against {where} {g:.4f} (ratio {ratio:.3f}, {count} windows of {WINDOW_S:g} s)"
    )
    if 1.0 / band <= ratio <= band:
        return Check("accel", dataset, declared, "ok", figures, method, ratio, count)
    unit = looks_like(quantity, declared, ratio, band)
    state = "at rest" if method == "rest" else "in motion (no rest found)"
    detail = (
        f"reads {value:.4g} m/s^2 {state} after converting from '{declared}' (median of {count} windows), "
        f"{ratio:.4g} times {where} {g:.4f} m/s^2"
    )
    return Check("accel", dataset, declared, "wrong", detail, method, ratio, count, unit)


# --------------------------------------------------------------------------- (b)


def _integral(tel, t_a: float, t_b: float, period: float):
    """Integrated angular rate [3] (SI as read) over ``[t_a, t_b]``, or None across an IMU gap."""
    t = tel.time_s
    g, _ = tel.imu_arrays()
    n = t.size
    k0 = max(0, int(np.searchsorted(t, t_a)) - 1)
    k1 = min(n - 1, int(np.searchsorted(t, t_b)) + 1)
    if k1 - k0 < 1 or t[k0] > t_a or t[k1] < t_b:
        return None
    tt = t[k0 : k1 + 1]
    dt = np.diff(tt)
    if np.any(dt > GAP_FACTOR * period):
        return None
    if tel.form == "rates":
        w = g[k0 : k1 + 1]
        cum = np.vstack([np.zeros(3), np.cumsum(0.5 * (w[1:] + w[:-1]) * dt[:, None], axis=0)])
    else:  # increment k covers (t[k-1], t[k]]
        cum = np.vstack([np.zeros(3), np.cumsum(g[k0 + 1 : k1 + 1], axis=0)])
    return np.array([np.interp(t_b, tt, cum[:, i]) - np.interp(t_a, tt, cum[:, i]) for i in range(3)])


def _reference_starts(q, lo: int, hi: int, far: int) -> np.ndarray:
    """Start rows of the intervals to examine in reference rows ``[lo, hi)``: half spread evenly,
    half in the stretches that turn (a flight turns in a few per cent of its record).

    The stretches are found on a coarse grid of rows ``far`` apart (at most
    :data:`REF_COARSE_ROWS` of them): a cell turns when its two ends differ by
    :data:`REF_MIN_ANGLE_RAD`.
    """
    last = hi - 2
    n_even = min(REF_MAX_STARTS // 2, last - lo + 1)
    even = np.linspace(lo, last, n_even).round().astype(int)
    step = max(far, (hi - lo) // REF_COARSE_ROWS)
    coarse = np.arange(lo, hi, step)
    turning = np.flatnonzero(quat_angle_between(q[coarse[:-1]], q[coarse[1:]]) >= REF_MIN_ANGLE_RAD)
    if turning.size == 0:
        return even
    where = np.linspace(0, turning.size * step - 1, REF_MAX_STARTS - n_even).round().astype(int)
    inside = coarse[turning[where // step]] + where % step
    return np.unique(np.r_[even, np.minimum(inside, last)])


def _check_gyro_reference(tel, period: float, dataset: str, declared: str) -> Check | str:
    """(b); a reason string when no verdict is possible."""
    ref = tel.reference
    if ref is None:
        return "no reference"
    tr, q = ref.time_s, ref.quat_nb
    t = tel.time_s
    lo = int(np.searchsorted(tr, t[0]))
    hi = int(np.searchsorted(tr, t[-1], side="right"))  # rows [lo, hi) inside the IMU span
    if hi - lo < 3:
        return "the reference has too few rows inside the IMU record"
    ref_step = float(np.median(np.diff(tr[lo : min(hi, lo + (1 << 16))])))
    far = max(REF_CONSECUTIVE + 1, int(REF_MAX_INTERVAL_S / ref_step))
    starts = _reference_starts(q, lo, hi, far)
    offsets = np.unique(
        np.r_[
            np.arange(REF_CONSECUTIVE + 1),
            np.geomspace(REF_CONSECUTIVE, far, REF_END_OFFSETS - REF_CONSECUTIVE).round(),
        ]
    ).astype(int)
    idx = np.minimum(starts[:, None] + offsets[None, :], hi - 1)  # [K, E]: interval ends tried
    t_idx = tr[idx]
    step_dt = np.diff(t_idx, axis=1)
    # a reference gap (or the end of the rows) inside an interval ends it
    broken = np.cumsum((step_dt <= 0.0) | (step_dt > GAP_FACTOR * ref_step * np.diff(offsets)[None, :]), axis=1) > 0
    path = np.cumsum(quat_angle_between(q[idx[:, :-1]], q[idx[:, 1:]]), axis=1)
    ok = ~broken & (path <= REF_MAX_PATH_RAD) & (t_idx[:, 1:] - t_idx[:, :1] <= REF_MAX_INTERVAL_S)
    # ok only turns false along a row (path, span and breaks only grow): take the last true end
    n_ok = np.where(ok.all(axis=1), ok.shape[1], np.argmin(ok, axis=1))
    ends = idx[np.arange(starts.size), n_ok]
    has = n_ok > 0
    net = np.zeros(starts.size)
    net[has] = quat_angle_between(q[starts[has]], q[ends[has]])
    use = np.flatnonzero(has & (net >= REF_MIN_ANGLE_RAD))
    if use.size < REF_MIN_INTERVALS:
        return (
            f"the reference rotates by {REF_MIN_ANGLE_RAD:g} rad in only {use.size} intervals "
            f"(needs {REF_MIN_INTERVALS})"
        )
    ratios = []
    for k in use:
        vec = _integral(tel, float(tr[starts[k]]), float(tr[ends[k]]), period)
        if vec is not None:
            ratios.append(float(np.linalg.norm(vec)) / net[k])
    if len(ratios) < REF_MIN_INTERVALS:
        return f"only {len(ratios)} rotating reference intervals have continuous IMU samples"
    ratio = float(np.median(ratios))
    count = len(ratios)
    quantity = FORM_QUANTITIES[tel.form][0]
    if 1.0 / GYRO_BAND <= ratio <= GYRO_BAND:
        return Check(
            "gyro",
            dataset,
            declared,
            "ok",
            f"gyro against the reference attitude: ratio {ratio:.3f} over {count} rotating intervals",
            "reference",
            ratio,
            count,
        )
    unit = looks_like(quantity, declared, ratio, GYRO_BAND)
    detail = (
        f"integrates to {ratio:.4g} times the rotation of the reference attitude "
        f"(median over {count} rotating intervals, read as '{declared}')"
    )
    return Check("gyro", dataset, declared, "wrong" if unit else "odd", detail, "reference", ratio, count, unit)


# --------------------------------------------------------------------------- (c)


def _angle(u, v):
    """Angle [rad] between unit vectors (last axis)."""
    return np.arctan2(np.linalg.norm(np.cross(u, v), axis=-1), np.sum(u * v, axis=-1))


def _tilt_pairs(win: _Windows, gaps_s) -> list[tuple[int, int]]:
    norms = np.linalg.norm(win.f_b, axis=1)
    if norms.size < 2:
        return []
    typical = float(np.median(norms))
    quasi = np.flatnonzero(np.abs(norms / typical - 1.0) <= QUASI_STATIC_TOL)
    u = win.f_b / np.maximum(norms, 1e-300)[:, None]
    tc = win.t_center
    pairs = []
    k = 0
    while k < quasi.size - 1:
        i = quasi[k]
        later = quasi[k + 1 :]
        later = later[tc[later] - tc[i] <= TILT_PAIR_MAX_S]
        moved = later[_angle(u[i], u[later]) >= TILT_MIN_RAD]
        if moved.size == 0:
            k += 1
            continue
        j = int(moved[0])
        if not any(tc[i] <= g < tc[j] for g in gaps_s):
            pairs.append((int(i), j))
        k = int(np.searchsorted(quasi, j))
    if len(pairs) > TILT_MAX_PAIRS:
        pick = np.linspace(0, len(pairs) - 1, TILT_MAX_PAIRS).round().astype(int)
        pairs = [pairs[p] for p in pick]
    return pairs


def _check_gyro_tilt(tel, win: _Windows, period: float, dataset: str, declared: str) -> Check | str:
    """(c); a reason string when no verdict is possible."""
    gaps_s = [g.time_s for g in tel.gaps if g.dataset.startswith("/imu")]
    pairs = _tilt_pairs(win, gaps_s)
    if len(pairs) < TILT_MIN_PAIRS:
        return (
            f"no tilt: the gravity direction moves by {TILT_MIN_RAD / DEG:.0f} deg within "
            f"{TILT_PAIR_MAX_S:g} s {len(pairs)} times (needs {TILT_MIN_PAIRS})"
        )
    quantity = FORM_QUANTITIES[tel.form][0]
    base = unit_factor(quantity, declared)
    table = load_schema(TELEMETRY_SCHEMA)["units"][quantity]
    hypotheses = [declared] + [u for u in table if u != declared]
    # data read as `declared` are (true value) x factor(declared) / factor(u) if they are in u
    scales = np.array([table[u] / base for u in hypotheses])
    candidates = (scales[:, None] * TILT_SCALE_GRID[None, :]).ravel()  # [H * G]
    # The gyro bias read at rest is removed (a raw MEMS reads 0.6 deg/s, 6 deg over 10 s); but a
    # record may only seem to rest (a table turning about the vertical keeps f steady), so each
    # hypothesis is also tried without it, and the better of the two counts.
    biases = [np.zeros(3)] + ([np.median(win.omega_b[win.rest], axis=0)] if win.rest.any() else [])
    t = tel.time_s
    g, _ = tel.imu_arrays()
    norms = np.linalg.norm(win.f_b, axis=1)
    u = win.f_b / norms[:, None]
    u_i = np.array([u[i] for i, _ in pairs])
    u_j = np.array([u[j] for _, j in pairs])
    errors = []
    for bias in biases:
        blocks = np.zeros((len(pairs), TILT_BLOCKS, 3))
        for p, (i, j) in enumerate(pairs):
            r0, r1 = (int(np.searchsorted(t, win.t_center[x])) for x in (i, j))
            if tel.form == "rates":
                incr = (g[r0:r1] - bias) * np.diff(t[r0 : r1 + 1])[:, None]
            else:
                incr = g[r0 + 1 : r1 + 1] - bias * period
            cum = np.vstack([np.zeros(3), np.cumsum(incr, axis=0)])
            edges = np.linspace(0, incr.shape[0], TILT_BLOCKS + 1).round().astype(int)
            blocks[p] = cum[edges[1:]] - cum[edges[:-1]]
        # mat[p, c] maps body vectors at the second moment to body axes at the first
        mat = np.broadcast_to(np.eye(3), (len(pairs), candidates.size, 3, 3)).copy()
        for b in range(TILT_BLOCKS):
            mat = mat @ rotvec_to_mat(candidates[None, :, None] * blocks[:, None, b, :])
        predicted = np.einsum("pcji,pj->pci", mat, u_i)  # gravity fixed in NED: u_j = mat^T u_i
        errors.append(_angle(predicted, u_j[:, None, :]))  # [P, C]
    tilt = _angle(u_i, u_j)  # [P] rad
    # residual as a fraction of the tilt change, median over the pairs: [H, G]
    residual = np.min([np.median(e / tilt[:, None], axis=0) for e in errors], axis=0).reshape(len(hypotheses), -1)
    centre = TILT_SCALE_GRID.size // 2
    at_hypothesis = residual[:, centre]
    best = int(np.argmin(at_hypothesis))
    others = np.delete(at_hypothesis, best)
    count = len(pairs)
    tilts = tilt / DEG
    if at_hypothesis[best] > TILT_MATCH or np.any(others < TILT_REJECT):
        return (
            f"the {count} tilt changes ({min(tilts):.0f}-{max(tilts):.0f} deg) fit no unit clearly (median "
            f"residual / tilt: {', '.join(f'{h} {r:.2f}' for h, r in zip(hypotheses, at_hypothesis))})"
        )
    fitted = scales[best] * TILT_SCALE_GRID[int(np.argmin(residual[best]))]
    ratio = 1.0 / fitted  # data as read / truth, as in (b)
    if best == 0:
        return Check(
            "gyro",
            dataset,
            declared,
            "ok",
            f"gyro against the tilt the accelerometers see: ratio {ratio:.3f}, median residual "
            f"{100 * at_hypothesis[0]:.1f} % over {count} tilt changes of {min(tilts):.0f}-"
            f"{max(tilts):.0f} deg",
            "tilt",
            ratio,
            count,
        )
    detail = (
        f"explains the {count} tilt changes the accelerometers see ({min(tilts):.0f}-{max(tilts):.0f} deg) "
        f"only when read as '{hypotheses[best]}' (median residual {100 * at_hypothesis[best]:.0f} % of the tilt; "
        f"as '{declared}' {100 * at_hypothesis[0]:.0f} %): it integrates to {ratio:.4g} times the tilt"
    )
    return Check("gyro", dataset, declared, "wrong", detail, "tilt", ratio, count, hypotheses[best])


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
