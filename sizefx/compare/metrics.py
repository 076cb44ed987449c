"""The figures of ``sizefx compare``: track A against track B, arrays in, a :class:`Comparison` out.

:func:`compare` puts B on A's time stamps inside the overlap of both spans (linear
interpolation of position and velocity, slerp of attitude) and takes every difference as
A minus B: the horizontal distance and its along/cross-track parts
(:mod:`sizefx.compare.geodesy`), the drift rate, height, velocity and attitude differences,
and their statistics (final, RMS, maximum) in the ``sizefx/comparison/1`` layout. No file
access here: :mod:`sizefx.compare.read` makes the tracks, :mod:`sizefx.compare.report` the
text and JSON.

Attitude differences compare each solution's ``q_nb`` in its own local NED frame, as the
navigation error reports of ``sizefx navigate`` do (the two local frames differ by
distance / Earth radius: 0.009 deg per km of separation).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..constants import METRES_PER_NMI, SECONDS_PER_HOUR
from ..errors import TelemetryError
from ..rotation import mat_to_euler, quat_conjugate, quat_interp, quat_multiply, quat_to_mat
from .geodesy import MIN_GROUND_SPEED_MPS, along_cross_track_m, horizontal_offset_m, velocity_from_position
from .read import Track

__all__ = ["MIN_OVERLAP_SAMPLES", "SPARSE_FACTOR", "TIME_SLACK_S", "Comparison", "compare"]

#: Slack [s] on the ends of the time overlap: stamps of the same instant written by different
#: programs (k / rate against a running sum of steps) differ by float64 rounding, about 1e-12 s
#: after an hour; a microsecond is far below any sample period the contracts allow (<= 100 kHz).
TIME_SLACK_S = 1e-6

#: Minimum number of A's samples inside the overlap: a difference history needs a start and an end.
MIN_OVERLAP_SAMPLES = 2

#: B is "sparser" than A when its median step exceeds A's by this factor; its interpolation
#: between samples then shows in the differences, and the report says so.
SPARSE_FACTOR = 1.5

# --------------------------------------------------------------------------- attitude


def _wrap_pi(angle_rad):
    """Angles wrapped to [-pi, pi)."""
    return (np.asarray(angle_rad) + np.pi) % (2.0 * np.pi) - np.pi


def _rotation_angle_rad(q_a, q_b):
    """Angle [rad] of ``q_a q_b^-1`` (the rotation taking B's attitude to A's, in NED), in [0, pi]."""
    rel = quat_multiply(q_a, quat_conjugate(q_b))
    return 2.0 * np.arctan2(np.linalg.norm(rel[:, 1:], axis=1), np.abs(rel[:, 0]))


# --------------------------------------------------------------------------- statistics


def _num(x):
    """A float for JSON, None for NaN (or None)."""
    if x is None:
        return None
    x = float(x)
    return x if np.isfinite(x) else None


def _signed_stats(x) -> dict:
    """final, rms, max_abs of a signed history over its defined (finite) samples; final None if undefined."""
    x = np.asarray(x, dtype=float)
    ok = np.isfinite(x)
    if not ok.any():
        return {"final": None, "rms": None, "max_abs": None}
    return {"final": _num(x[-1]), "rms": _num(np.sqrt(np.mean(x[ok] ** 2))), "max_abs": _num(np.abs(x[ok]).max())}


def _magnitude_stats(x) -> dict:
    x = np.asarray(x, dtype=float)
    return {"final": _num(x[-1]), "rms": _num(np.sqrt(np.mean(x**2))), "max": _num(x.max())}


# --------------------------------------------------------------------------- comparison


@dataclass
class Comparison:
    """A against B on A's time stamps inside the overlap; every difference is A - B.

    Arrays have K rows, one per compared sample of A.
    """

    label: str  #: e.g. "A vs B"
    a: str  #: name of A (its file)
    b: str
    time_s: np.ndarray  #: [K] A's stamps [s]
    horizontal_m: np.ndarray  #: [K] chord distance on the ellipsoid surface [m]
    north_m: np.ndarray  #: [K] A - B along B's north [m]
    east_m: np.ndarray  #: [K]
    along_track_m: np.ndarray  #: [K] positive: A ahead; NaN where B's ground speed < MIN_GROUND_SPEED_MPS
    cross_track_m: np.ndarray  #: [K] positive: A right of B's track; NaN likewise
    height_m: np.ndarray  #: [K] h_a - h_b [m]
    velocity_n_mps: np.ndarray  #: [K, 3] v_a - v_b, NED [m/s]
    ground_speed_mps: np.ndarray  #: [K] |v_h,a| - |v_h,b| [m/s]
    #: [K, 4] roll, pitch, heading differences (wrapped to [-pi, pi)) and the angle of q_a q_b^-1 [rad];
    #: None unless both have attitude
    attitude_rad: np.ndarray | None
    velocity_derived: dict  #: {"a": bool, "b": bool}: velocity from position differences
    summary: dict  #: the figures of the JSON "comparisons" item (units in the key names)
    notes: list = field(default_factory=list)

    @property
    def pair(self) -> tuple[str, str]:
        """Short names of the compared tracks from the label: "B vs REF" -> ("B", "REF")."""
        first, sep, second = self.label.partition(" vs ")
        return (first, second) if sep else ("A", "B")


def _at(track: Track, t: np.ndarray, vel: np.ndarray | None):
    """Track ``track`` at times ``t`` (inside its span): lat, lon, h, v_n (or None), q_nb (or None)."""
    lat = np.interp(t, track.time_s, track.lat_rad)
    lon = np.interp(t, track.time_s, np.unwrap(track.lon_rad))
    h = np.interp(t, track.time_s, track.height_m)
    v = None if vel is None else np.column_stack([np.interp(t, track.time_s, vel[:, i]) for i in range(3)])
    q = None if track.quat_nb is None else quat_interp(track.time_s, track.quat_nb, t)
    return lat, lon, h, v, q


def compare(a: Track, b: Track, label: str = "A vs B", track: Track | None = None) -> Comparison:
    """Compare track A against track B on A's time stamps inside the overlap of both spans.

    B is interpolated linearly in latitude, (unwrapped) longitude, height and
    velocity, and by slerp (:func:`sizefx.rotation.quat_interp`) in attitude.

    * Horizontal distance: the chord between the two points placed on the WGS-84
      surface (h = 0) in ECEF, short of the surface distance ``s`` by
      ``s^3 / (24 R^2)``: 1 mm at 10 km (:func:`horizontal_offset_m`). Final,
      maximum (with its time), RMS.
    * Along- and cross-track parts of A - B, relative to the direction of horizontal
      motion of ``track`` (default B; ``sizefx compare --reference`` passes the
      reference, so that a drifting solution B does not define the track), from its
      velocity, else from its position differences;
      cross-track positive to the right of the track, along-track positive ahead;
      NaN (null in JSON) where B's ground speed is under ``MIN_GROUND_SPEED_MPS``.
    * Drift rate [nmi/h, 1 nmi = 1852 m]: final distance / elapsed time, and
      maximum distance / elapsed time; elapsed = last - first compared stamp.
    * Velocity differences N, E, D and of the ground speed ``|v_h,a| - |v_h,b|``.
      A track without velocity gets it from its positions by central differences
      (:func:`velocity_from_position`), and a note says so.
    * Attitude differences (both tracks with attitude): roll, pitch, heading
      (z-y-x Euler angles, each difference wrapped to +-180 deg) and the rotation
      angle of ``q_a q_b^-1``. Each attitude is relative to its own local NED frame.
    * Height difference ``h_a - h_b``.

    Raises
    ------
    TelemetryError
        When fewer than 2 of A's samples lie in the overlap (naming A, its time
        dataset and both spans).
    """
    lo = max(a.time_s[0], b.time_s[0]) - TIME_SLACK_S
    hi = min(a.time_s[-1], b.time_s[-1]) + TIME_SLACK_S
    sel = np.flatnonzero((a.time_s >= lo) & (a.time_s <= hi))
    spans = (
        f"{a.time_s[0]:.3f}..{a.time_s[-1]:.3f} s against {b.name} {b.time_s[0]:.3f}..{b.time_s[-1]:.3f} s "
        f"({b.time_dataset})"
    )
    if sel.size == 0:
        raise TelemetryError(
            a.name, a.time_dataset, f"no time overlap: {spans}; compare solutions of the same record on the same clock"
        )
    if sel.size < MIN_OVERLAP_SAMPLES:
        raise TelemetryError(
            a.name,
            a.time_dataset,
            f"only {sel.size} sample inside the time overlap: {spans}; need at least {MIN_OVERLAP_SAMPLES}",
        )
    notes = [*a.notes, *b.notes]
    t = a.time_s[sel]
    derived = {"a": a.vel_n_mps is None, "b": b.vel_n_mps is None}
    vel_a = (
        a.vel_n_mps if a.vel_n_mps is not None else velocity_from_position(a.time_s, a.lat_rad, a.lon_rad, a.height_m)
    )
    vel_b = (
        b.vel_n_mps if b.vel_n_mps is not None else velocity_from_position(b.time_s, b.lat_rad, b.lon_rad, b.height_m)
    )
    for key, which in (("a", a), ("b", b)):
        if derived[key]:
            notes.append(f"{which.name} has no velocity: derived from its positions by central differences")
    lat_b, lon_b, h_b, v_b, q_b = _at(b, t, vel_b)
    if b.median_step_s > SPARSE_FACTOR * a.median_step_s:
        notes.append(
            f"{b.name} is sampled every {b.median_step_s:.4g} s, sparser than {a.name} "
            f"({a.median_step_s:.4g} s): differences between its samples include its linear interpolation"
        )

    horiz, north, east = horizontal_offset_m(a.lat_rad[sel], a.lon_rad[sel], lat_b, lon_b)
    if track is None or track is b:
        v_track, track_name = v_b, b.name
    else:
        vel_t = (
            track.vel_n_mps
            if track.vel_n_mps is not None
            else velocity_from_position(track.time_s, track.lat_rad, track.lon_rad, track.height_m)
        )
        v_track, track_name = _at(track, t, vel_t)[3], track.name
    along, cross = along_cross_track_m(north, east, v_track)
    span_a, span_b = a.time_s[-1] - a.time_s[0], b.time_s[-1] - b.time_s[0]
    covered = (t[-1] - t[0]) / max(min(span_a, span_b), 1e-300)
    if covered < 0.9:
        notes.append(
            f"the compared span ({t[0]:.1f}..{t[-1]:.1f} s) covers {100 * covered:.0f} % of the shorter "
            "record: final figures are at its end, not at the end of either record"
        )
    undefined = int(np.count_nonzero(np.isnan(along)))
    if undefined:
        notes.append(
            f"along/cross-track undefined at {undefined} of {t.size} samples where the ground speed of "
            f"{track_name} is under {MIN_GROUND_SPEED_MPS:g} m/s (reported as null)"
        )
    dh = a.height_m[sel] - h_b
    v_a = vel_a[sel]
    dv = v_a - v_b
    dgs = np.hypot(v_a[:, 0], v_a[:, 1]) - np.hypot(v_b[:, 0], v_b[:, 1])
    att = None
    if a.quat_nb is not None and q_b is not None:
        roll_a, pitch_a, head_a = mat_to_euler(quat_to_mat(a.quat_nb[sel]))
        roll_b, pitch_b, head_b = mat_to_euler(quat_to_mat(q_b))
        att = np.column_stack(
            [
                _wrap_pi(roll_a - roll_b),
                _wrap_pi(pitch_a - pitch_b),
                _wrap_pi(head_a - head_b),
                _rotation_angle_rad(a.quat_nb[sel], q_b),
            ]
        )
    else:
        missing = a.name if a.quat_nb is None else b.name
        notes.append(f"{missing} has no attitude: attitude not compared")

    elapsed = float(t[-1] - t[0])
    k_max = int(np.argmax(horiz))
    per_hour = SECONDS_PER_HOUR / elapsed / METRES_PER_NMI if elapsed > 0.0 else float("nan")
    summary = {
        "label": label,
        "a": a.name,
        "b": b.name,
        "samples": int(t.size),
        "time_start_s": float(t[0]),
        "time_end_s": float(t[-1]),
        "elapsed_s": elapsed,
        "horizontal_m": {**_magnitude_stats(horiz), "time_of_max_s": float(t[k_max])},
        "along_track_m": _signed_stats(along),
        "cross_track_m": _signed_stats(cross),
        "track_defined_samples": int(t.size - undefined),
        "drift_nmi_per_h": {"final": _num(horiz[-1] * per_hour), "max": _num(horiz[k_max] * per_hour)},
        "height_m": _signed_stats(dh),
        "velocity_mps": {
            "north": _signed_stats(dv[:, 0]),
            "east": _signed_stats(dv[:, 1]),
            "down": _signed_stats(dv[:, 2]),
            "ground_speed": _signed_stats(dgs),
        },
        "velocity_derived": derived,
        "attitude_deg": None
        if att is None
        else {
            "roll": _signed_stats(np.degrees(att[:, 0])),
            "pitch": _signed_stats(np.degrees(att[:, 1])),
            "heading": _signed_stats(np.degrees(att[:, 2])),
            "total": _magnitude_stats(np.degrees(att[:, 3])),
        },
        "notes": notes,
    }
    return Comparison(
        label, a.name, b.name, t, horiz, north, east, along, cross, dh, dv, dgs, att, derived, summary, notes
    )
