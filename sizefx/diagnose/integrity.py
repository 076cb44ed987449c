"""Is the record's ``/reference`` whole? Its glitches, discontinuities, gaps and rate changes, found against the IMU.

Method. Each reference step ``k`` (rows ``k`` and ``k+1``) is compared with the IMU over the same
interval (:mod:`.mismatch`): the reference's body-frame attitude increment against the gyros', and,
for a reference with position, its velocity increment against the accelerometers' (with
``velocity_n``), or the velocity from the position difference over each step (positions only).
The mismatch ``e_k`` per step is what this module judges.

The mismatch holds the record's unknown small gyro and accelerometer errors, the reference's delay of a
few ms (``tau * domega``) and the reference's noise, all unknown: the threshold is a robust multiple of the
mismatch's own scale (the median of ``|e|``, globally and over the :data:`LOCAL_STEPS` steps around each,
so that fast parts of the motion do not alarm), with an absolute floor per quantity. Steps above it are
grouped (at most :data:`MAX_GLITCH_ROWS` rows apart); a group across which the cumulative mismatch returns
(the bridge from the row before to the row after, possibly one step wider, is below the threshold) is a
**glitch** and its inner rows go to ``bad_rows``; a single step across which it does not return,
at least :data:`JUMP_FLOOR_FACTOR` floors large, is a **discontinuity** (a re-mount, a frame change),
and the motion is split there (``breaks_s``). Glitches smaller than the floor (a held frame during fast
rotation), bursts of several bad steps and small non-returning steps are left to the robust fit,
unreported. Every step's threshold also allows for what ordinary errors explain over it
(:data:`SCALE_TOLERANCE` of its rotation, :data:`DELAY_TOLERANCE_S` times its change of rate).

Timing: a step longer than :data:`~sizefx.diagnose.reference.REFERENCE_GAP_FACTOR` median periods is a
**gap** (masked by :func:`~sizefx.diagnose.reference.usable_mask`, now also reported); a change of the
running median period by more than :data:`RATE_CHANGE_TOLERANCE` is a **rate change**.

Warnings are dicts ``{"kind", "quantity", "time_s", "size", "unit", "message"}``: ``size`` in SI with
its ``unit`` (rad, m/s, m, s), ``quantity`` one of ``attitude``, ``velocity``, ``position``, ``timing``.
Kinds: ``reference_glitch``, ``reference_discontinuity`` (attitude), ``reference_velocity_glitch``,
``reference_velocity_discontinuity`` (a reference with ``velocity_n``), ``reference_position_glitch``,
``reference_position_discontinuity`` (a reference with position only), ``reference_gap``,
``reference_rate_change``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from scipy.spatial.transform import Rotation

from ..constants import DEG
from ..io.telemetry import Telemetry

# the comparison with the IMU, and its settings, which stay importable from here (LONG_STEP_FACTOR too)
from .mismatch import (  # noqa: F401
    ATTITUDE_FLOOR_RAD,
    DELAY_TOLERANCE_S,
    LONG_STEP_FACTOR,
    POSITION_FLOOR_M,
    SCALE_TOLERANCE,
    VELOCITY_FLOOR_MPS,
    _attitude_mismatch,
    _ImuIntegrals,
    _velocity_mismatch,
)
from .records import ReportWarning
from .reference import REFERENCE_GAP_FACTOR, require_reference

__all__ = [
    "ReferenceCheck",
    "check_reference",
    "without_bad_rows",
    "GLITCH_SIGMAS",
    "LOCAL_SIGMAS",
    "JUMP_FLOOR_FACTOR",
    "SCALE_TOLERANCE",
    "DELAY_TOLERANCE_S",
    "ATTITUDE_FLOOR_RAD",
    "VELOCITY_FLOOR_MPS",
    "POSITION_FLOOR_M",
    "MAX_GLITCH_ROWS",
    "LOCAL_STEPS",
    "RATE_CHANGE_TOLERANCE",
    "RATE_WINDOW_ROWS",
    "MAX_WARNINGS_PER_KIND",
]

#: A step is suspect when its mismatch exceeds this many robust sigmas of the whole record's: the
#: mismatch is near Gaussian in its core but has heavy tails on real records (BROAD 07/09, high-passed:
#: 200-450 of ~51 000 clean steps beyond 10 sigma, the largest at 26-29 sigma during 800 deg/s
#: rotation, which the local scale and the floor cover), and a false discontinuity splits the fit.
GLITCH_SIGMAS = 12.0
#: ... and this many of its block's (a fast part of the motion carries a larger delay term).
LOCAL_SIGMAS = 12.0
#: Steps in the running median of the mismatch's size that gives the local scale: long enough that
#: a glitch's steps do not move it, short enough to follow bursts of fast motion (0.1 s at 285 Hz).
LOCAL_STEPS = 31
#: A step that does not come back splits the motion only when it is this many floors large (1 deg,
#: 0.2 m/s, 2 mm): a re-mount or a frame change is tens of degrees or centimetres, and smaller
#: non-returning steps on clean motion-capture trials (BROAD: 0.3-0.4 deg, 0.5 mm during fast rotation)
#: are noise that the robust fit absorbs, while every split costs a segment's initial conditions.
JUMP_FLOOR_FACTOR = 4.0
#: Most rows a glitch spans: motion capture loses a marker for a sample or a few; longer excursions
#: that come back are rather a disturbance of the motion the IMU saw.
MAX_GLITCH_ROWS = 5
#: Steps in the running median taken off the mismatch (:func:`_high_pass`): more than twice the
#: longest glitch, so that the glitch's own steps cannot move it.
RUNNING_MEDIAN_STEPS = 2 * MAX_GLITCH_ROWS + 3
#: Rows in the running median of the reference period, and the relative change that counts as a
#: new rate: jitter of a few per cent does not move a 25-row median, a new rate moves it at once.
RATE_WINDOW_ROWS = 25
RATE_CHANGE_TOLERANCE = 0.1
#: Most warnings of one kind listed one by one; beyond, one summary warning counts the rest.
MAX_WARNINGS_PER_KIND = 50
#: Median of the norm of a 3-D standard normal vector (chi distribution, 3 degrees of freedom).
CHI3_MEDIAN = 1.5382

_QUANTITY = {  # quantity -> (glitch kind, discontinuity kind, unit, user unit, factor to user unit)
    "attitude": ("reference_glitch", "reference_discontinuity", "rad", "deg", 1.0 / DEG),
    "velocity": ("reference_velocity_glitch", "reference_velocity_discontinuity", "m/s", "m/s", 1.0),
    "position": ("reference_position_glitch", "reference_position_discontinuity", "m", "mm", 1e3),
}


@dataclass
class ReferenceCheck:
    """What :func:`check_reference` found.

    ``warnings``: one :class:`~sizefx.diagnose.records.ReportWarning` per finding (see the module
    docstring), in time order.
    ``bad_rows``: int indices of ``/reference`` rows to drop (isolated glitches), sorted, unique.
    ``breaks_s``: times [s] of discontinuities, midway between the last row before and the first
    row after each jump: :class:`~sizefx.diagnose.reference.ReferenceMotion` splits the motion there.
    """

    warnings: list[ReportWarning] = field(default_factory=list)
    bad_rows: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    breaks_s: tuple[float, ...] = ()


def without_bad_rows(tel: Telemetry, check: ReferenceCheck) -> Telemetry:
    """The record with ``/reference`` minus ``check.bad_rows`` (IMU, site and the rest shared)."""
    if check.bad_rows.size == 0:
        return tel
    ref = tel.reference
    assert ref is not None  # checked by check_reference, which found the bad rows
    keep = np.ones(ref.time_s.size, dtype=bool)
    keep[check.bad_rows] = False
    return replace(
        tel,
        reference=replace(
            ref,
            **{
                k: getattr(ref, k)[keep]
                for k in ("time_s", "quat_nb", "lat_rad", "lon_rad", "height_m", "velocity_n_mps")
                if getattr(ref, k) is not None
            },
        ),
    )


def check_reference(tel: Telemetry) -> ReferenceCheck:
    """Check ``tel.reference`` against the IMU: glitches, discontinuities, gaps, rate changes.

    Vectorised: a two-minute 1600 Hz record with a 200 Hz reference takes a few tenths of a second.
    Steps outside the IMU's span, or across an IMU gap, are not compared.
    """
    ref = require_reference(tel)
    rt = np.asarray(ref.time_s, dtype=float)
    warnings = _timing(rt)
    bad: list[int] = []
    breaks: list[float] = []
    if rt.size >= 3:
        imu = _ImuIntegrals(tel)
        mat_nb = Rotation.from_quat(ref.quat_nb[:, [1, 2, 3, 0]])
        att = _attitude_mismatch(tel, rt, mat_nb, imu)
        findings = [("attitude", *att)]
        if ref.has_position:
            findings.append(_velocity_mismatch(tel, rt, mat_nb, imu))
        for quantity, e, ok, row_of_step, floor, allowance in findings:
            w, b, k = _classify(quantity, e, ok, rt, row_of_step, floor, allowance)
            warnings += w
            bad += b
            breaks += k
    bad_rows = np.unique(np.asarray(bad, dtype=int))
    breaks_s = tuple(sorted(_merge(breaks, float(np.median(np.diff(rt))) * MAX_GLITCH_ROWS))) if breaks else ()
    return ReferenceCheck(warnings=_capped(sorted(warnings, key=_time)), bad_rows=bad_rows, breaks_s=breaks_s)


# --------------------------------------------------------------------------- timing


def _timing(rt: np.ndarray) -> list[ReportWarning]:
    """Gaps (steps over REFERENCE_GAP_FACTOR median periods) and changes of the running median period."""
    out: list[ReportWarning] = []
    if rt.size < 2:
        return out
    steps = np.diff(rt)
    period = float(np.median(steps))
    for g in np.flatnonzero(steps > REFERENCE_GAP_FACTOR * period):
        out.append(
            _warning(
                "reference_gap",
                "timing",
                rt[g],
                steps[g],
                "s",
                f"reference gap at t = {rt[g]:.3f} s: no reference for {steps[g] * 1e3:.1f} ms "
                f"({steps[g] / period:.0f} periods of {period * 1e3:.2f} ms); the IMU samples around "
                "it are masked",
            )
        )
    if steps.size < 2 * RATE_WINDOW_ROWS:
        return out
    level = _running_median(steps, RATE_WINDOW_ROWS)
    # a change: the running median moves by more than the tolerance from one window to the next, and
    # stays (compare the windows before and after, which do not overlap)
    before, after = level[:-RATE_WINDOW_ROWS], level[RATE_WINDOW_ROWS:]
    changed = np.abs(after / before - 1.0) > RATE_CHANGE_TOLERANCE
    k = 0
    while k < changed.size:  # bounded: each pass moves on by at least one window
        if not changed[k]:
            k += 1
            continue
        run = k + int(np.argmax(~changed[k:])) if not changed[k:].all() else changed.size
        centre = (k + run) // 2 + RATE_WINDOW_ROWS  # the step where the new rate begins
        centre = min(centre, rt.size - 1)
        p_old, p_new = float(before[k]), float(after[k])
        out.append(
            _warning(
                "reference_rate_change",
                "timing",
                rt[centre],
                p_new - p_old,
                "s",
                f"reference period changes from {p_old * 1e3:.2f} ms to {p_new * 1e3:.2f} ms at "
                f"t = {rt[centre]:.3f} s; gaps are judged against the median, {period * 1e3:.2f} ms",
            )
        )
        k = run + RATE_WINDOW_ROWS
    return out


# --------------------------------------------------------------------------- glitch or discontinuity


#: Windows whose median is taken at once by :func:`_running_median`: np.median copies its windows
#: (the window's length times the series' size), so a million steps take 64 MiB at most, not 1.5 GB.
_MEDIAN_WINDOWS = 2**16


def _running_median(x: np.ndarray, window: int) -> np.ndarray:
    """Medians of every ``window`` consecutive rows of ``x`` [n, ...] along axis 0 ([n - window + 1, ...]),
    :data:`_MEDIAN_WINDOWS` windows at a time (each window's median is its own: the same numbers)."""
    count = x.shape[0] - window + 1
    out = np.empty((max(0, count), *x.shape[1:]))
    for lo in range(0, count, _MEDIAN_WINDOWS):
        hi = min(count, lo + _MEDIAN_WINDOWS)
        out[lo:hi] = np.median(
            np.lib.stride_tricks.sliding_window_view(x[lo : hi + window - 1], window, axis=0), axis=-1
        )
    return out


def _high_pass(e: np.ndarray) -> np.ndarray:
    """The mismatch minus its running median over :data:`RUNNING_MEDIAN_STEPS` steps (per axis).

    What varies smoothly from step to step (the reference delay's ``tau * domega``, scale factors
    times the increment, biases) goes; a glitch's doublet or a jump's single step, at most
    :data:`MAX_GLITCH_ROWS` steps in a window of more than twice that, does not move the median.
    """
    if e.shape[0] < RUNNING_MEDIAN_STEPS:
        return e
    half = RUNNING_MEDIAN_STEPS // 2
    padded = np.concatenate([np.repeat(e[:1], half, axis=0), e, np.repeat(e[-1:], half, axis=0)])
    med = _running_median(padded, RUNNING_MEDIAN_STEPS)
    return e - med


def _threshold(norm: np.ndarray, ok: np.ndarray, floor: float) -> np.ndarray:
    """Per step: the largest of the floor, GLITCH_SIGMAS robust sigmas of the whole record's
    (high-passed) mismatch, and LOCAL_SIGMAS of the :data:`LOCAL_STEPS` steps around it (a fast
    part of the motion carries more marker noise and timing error; a glitch's one or two steps do
    not move a running median of that many)."""
    valid = norm[ok]
    sigma = float(np.median(valid)) / CHI3_MEDIAN if valid.size else 0.0
    thr = np.full(norm.size, max(floor, GLITCH_SIGMAS * sigma))
    if norm.size >= LOCAL_STEPS:
        half = LOCAL_STEPS // 2
        padded = np.concatenate(
            [
                np.full(half, np.median(valid) if valid.size else 0.0),
                norm,
                np.full(half, np.median(valid) if valid.size else 0.0),
            ]
        )
        local = _running_median(padded, LOCAL_STEPS) / CHI3_MEDIAN
        thr = np.maximum(thr, LOCAL_SIGMAS * local)
    return thr


def _classify(quantity, e, ok, rt, row_of_step, floor, allowance):
    """Glitches and discontinuities of one quantity: (warnings, bad rows, break times).

    ``e`` [n, 3]: the mismatch per step; step ``k`` runs from sample ``k`` to ``k+1`` of the quantity
    (reference rows; for ``position``, step midpoints) and is centred between rows ``row_of_step[k]``
    and ``row_of_step[k] + 1`` (for ``position``: on row ``row_of_step[k] + 1``).
    """
    e = _high_pass(e)
    norm = np.linalg.norm(e, axis=1)
    thr = _threshold(norm, ok, floor) + allowance
    suspect = np.flatnonzero(ok & (norm > thr))
    warnings: list[ReportWarning] = []
    bad: list[int] = []
    breaks: list[float] = []
    if suspect.size == 0:
        return warnings, bad, breaks
    # the cumulative mismatch: a glitch leaves it where it was, a discontinuity moves it
    cum = np.vstack([np.zeros(3), np.cumsum(e, axis=0)])  # cum[k] = sum of the steps before step k
    groups = np.split(suspect, np.flatnonzero(np.diff(suspect) > MAX_GLITCH_ROWS) + 1)
    n = e.shape[0]
    for group in groups:
        s0, s1 = int(group[0]), int(group[-1])
        bridge = None
        # steps s0..s1 must come back; one step more on either side is allowed (a glitch whose other
        # edge fell below the threshold), smallest bridge first
        for lo, hi in ((s0, s1), (s0 - 1, s1), (s0, s1 + 1), (s0 - 1, s1 + 1)):
            if lo < 0 or hi >= n or not 1 <= hi - lo <= MAX_GLITCH_ROWS or not ok[lo : hi + 1].all():
                continue
            if np.linalg.norm(cum[hi + 1] - cum[lo]) <= max(thr[lo], thr[hi]):
                bridge = (lo, hi)
                break
        if bridge is None and s0 == s1 and (s0 == 0 or s0 == n - 1) and quantity != "position":
            rows = [0] if s0 == 0 else [int(row_of_step[s0]) + 1]  # the first or last row off
            w = _glitch(quantity, rt[rows[0]], float(norm[s0]), rows) if norm[s0] >= floor else None
        elif bridge is not None and quantity == "position":
            w = _position(bridge, cum, rt, row_of_step, thr, breaks)
            rows = [] if w is None or w.kind.endswith("discontinuity") else _position_rows(bridge, row_of_step)
        elif bridge is not None:
            lo, hi = bridge
            rows = list(range(int(row_of_step[lo]) + 1, int(row_of_step[hi]) + 1))
            size = float(np.linalg.norm(cum[lo + 1 : hi + 1] - cum[lo], axis=1).max())
            # the excursion, not the steps, is the glitch's size: a held frame during fast rotation makes
            # two large steps but leaves the row only one step's rotation off
            w = _glitch(quantity, rt[rows[0]], size, rows) if size >= floor else None
        else:  # it does not come back
            size = float(np.linalg.norm(cum[s1 + 1] - cum[s0]))
            if quantity == "position" or size < JUMP_FLOOR_FACTOR * floor or s1 > s0:
                # a kink in positions, a step within the noise, or a burst of several bad steps that does
                # not come back (BROAD 21 at 400 deg/s: 0.4-1.1 deg on each of 3-5 steps): no clean jump
                # to split at; for the robust fit
                continue
            k = s0 + int(np.argmax(norm[s0 : s1 + 1]))  # the jump: the largest step of the group
            r = int(row_of_step[k])
            t_break = 0.5 * float(rt[r] + rt[r + 1])
            breaks.append(t_break)
            w = _jump(quantity, t_break, size)
            rows = []
        if w is None:
            continue
        bad += rows
        warnings.append(w)
    return warnings, bad, breaks


def _position_rows(bridge, row_of_step):
    lo, hi = bridge  # bad midpoints lo+1 .. hi; the rows between them are off
    return list(range(int(row_of_step[lo]) + 2, int(row_of_step[hi]) + 1))


def _position(bridge, cum, rt, row_of_step, thr, breaks):
    """A velocity excursion that comes back, from positions: a position glitch if the position comes
    back too, else a position jump (a re-mount), whose break time goes to ``breaks``."""
    lo, hi = bridge
    mids = np.arange(lo + 1, hi + 1)  # the bad midpoints: velocity over rows m -> m+1
    rows_m = row_of_step[lo] + 1 + np.arange(mids.size)
    dt = rt[rows_m + 1] - rt[rows_m]
    offset = np.cumsum((cum[mids] - cum[lo]) * dt[:, None], axis=0)  # position of rows m+1 against the IMU's
    size_max = float(np.linalg.norm(offset, axis=1).max())
    final = float(np.linalg.norm(offset[-1]))
    if final <= max(thr[lo], thr[hi]) * float(np.median(dt)):
        rows = _position_rows(bridge, row_of_step)
        return _glitch("position", rt[rows[0]], size_max, rows) if rows and size_max >= POSITION_FLOOR_M else None
    if final < JUMP_FLOOR_FACTOR * POSITION_FLOOR_M:
        return None  # a step within the noise: for the robust fit
    m = int(np.argmax(np.linalg.norm(cum[mids] - cum[lo], axis=1)))
    t_break = 0.5 * float(rt[rows_m[m]] + rt[rows_m[m] + 1])
    breaks.append(t_break)
    return _jump("position", t_break, final)


def _glitch(quantity, time_s, size, rows) -> ReportWarning:
    kind, _, unit, user_unit, to_user = _QUANTITY[quantity]
    n = len(rows)
    return _warning(
        kind,
        quantity,
        time_s,
        size,
        unit,
        f"reference {quantity} glitch at t = {float(time_s):.3f} s: {size * to_user:.3g} {user_unit} "
        f"away from what the IMU measured for {n} row{'s' if n > 1 else ''} and back; masked",
    )


def _jump(quantity, time_s, size) -> ReportWarning:
    _, kind, unit, user_unit, to_user = _QUANTITY[quantity]
    return _warning(
        kind,
        quantity,
        time_s,
        size,
        unit,
        f"reference {quantity} discontinuity at t = {float(time_s):.3f} s: a {size * to_user:.3g} "
        f"{user_unit} jump that the IMU did not measure (a re-mount or a change of frame); the motion "
        "is split into segments there",
    )


def _merge(times, within_s):
    """Break times closer than ``within_s`` [s] (one jump seen in attitude and position) as one."""
    times = sorted(times)
    out = [times[0]]
    for t in times[1:]:
        if t - out[-1] > within_s:
            out.append(t)
    return out


def _warning(kind, quantity, time_s, size, unit, message) -> ReportWarning:
    return ReportWarning(kind, message, time_s=float(time_s), size=float(size), unit=unit, quantity=quantity)


def _time(w: ReportWarning) -> float:
    assert w.time_s is not None  # every reference warning is at a moment
    return w.time_s


def _capped(warnings: list[ReportWarning]) -> list[ReportWarning]:
    """At most MAX_WARNINGS_PER_KIND of each kind, then one that counts the rest (all still acted on)."""
    out: list[ReportWarning] = []
    seen: dict[str, int] = {}
    for w in warnings:
        seen[w.kind] = seen.get(w.kind, 0) + 1
        if seen[w.kind] <= MAX_WARNINGS_PER_KIND:
            out.append(w)
    for kind, count in seen.items():
        if count > MAX_WARNINGS_PER_KIND:
            rest = [w for w in warnings if w.kind == kind][MAX_WARNINGS_PER_KIND:]
            largest = max(w.size for w in rest if w.size is not None)
            out.append(
                _warning(
                    kind,
                    rest[0].quantity,
                    rest[0].time_s,
                    largest,
                    rest[0].unit,
                    f"{count - MAX_WARNINGS_PER_KIND} more {kind.replace('_', ' ')}s "
                    f"from t = {_time(rest[0]):.3f} s on, not listed one by one (largest "
                    f"{largest:.3g} {rest[0].unit}); all acted on",
                )
            )
    return out
