"""The record's ``/reference``: what diagnose requires of it, and the motion it describes.

- :func:`require_reference`, :func:`check_record`: the refusals, each naming the file and the fix;
- :class:`ReferenceMotion`: attitude, rates and specific force of the reference point as smooth
  functions of time (C2 splines: scipy's ``RotationSpline`` for attitude, whose rates come out in
  body axes; ``CubicSpline`` for position and velocity);
- :func:`reference_segments`: the rows between the reference's discontinuities (each its own splines);
- :func:`usable_mask`: the IMU samples far enough from the reference's ends, its gaps, breaks and the IMU's;
- :func:`crop`: the part of a record between two times.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.spatial.transform import Rotation, RotationSpline

from .. import earth
from ..errors import SizefxError
from ..io.telemetry import Reference, Telemetry

__all__ = [
    "DiagnoseError",
    "ReferenceMotion",
    "check_record",
    "crop",
    "reference_segments",
    "require_reference",
    "usable_mask",
    "MIN_SAMPLES",
    "MIN_REFERENCE_ROWS",
    "MAX_SAMPLES",
    "EDGE_S",
    "EDGE_REFERENCE_PERIODS",
    "REFERENCE_GAP_FACTOR",
]

#: Fewest usable samples: the gyro derivative window with room, and enough blocks for the folds.
MIN_SAMPLES = 400
#: Samples this close to the ends of the reference, or to a reference or IMU gap, are left out [s]:
#: room for delays up to 50 ms; and at least :data:`EDGE_REFERENCE_PERIODS` reference periods, where
#: the splines' end conditions still pull (5e-3 rad/s at one 20 Hz period from the end).
EDGE_S = 0.05
EDGE_REFERENCE_PERIODS = 10
#: Fewest reference rows: a spline through fewer cannot stand for the motion.
MIN_REFERENCE_ROWS = 20
#: Most IMU samples diagnosed at once. The fit is formed span by span and keeps at most MAX_ROWS
#: rows; what still grows with the record is the record itself as read (about 60 bytes per IMU
#: sample, 90 per reference row with position and velocity) and the reference's splines (about
#: 380 bytes per row): 0.8 kB per sample for a reference at the IMU's rate, 0.2 kB for a 100 Hz
#: one on a 1600 Hz IMU (benchmarks/bench_diagnose_memory.py; docs/diagnose.md). The guard keeps
#: the worst case near 10 GiB: about 2 h at 1600 Hz.
MAX_SAMPLES = 12_000_000
#: Most reference rows splined at once (:class:`_LongRotationSpline`): up to a 2.7-minute 1600 Hz
#: reference in one spline, as before; longer ones in stretches of SPLINE_PIECE_ROWS rows, each built
#: through SPLINE_OVERLAP_ROWS rows more on either side (the end conditions' pull, 0.27 per row, is
#: 1e-36 there). About 1.5 kB per row while a spline is built: at most 400 MiB, then 100 MiB.
SPLINE_ROWS = 2**18
SPLINE_PIECE_ROWS = 2**16
SPLINE_OVERLAP_ROWS = 64
#: A reference step longer than this many median periods is a gap (motion-capture dropout).
REFERENCE_GAP_FACTOR = 3.0


class DiagnoseError(SizefxError):
    """The record cannot be diagnosed (no reference, too short, no overlap)."""


def require_reference(tel: Telemetry) -> Reference:
    """Refuse a record without ``/reference``: there is nothing to predict the IMU from. Returns it."""
    if tel.reference is None:
        raise DiagnoseError(
            f"{tel.path}: diagnose needs /reference motion (attitude at least) to predict the IMU "
            "from; record it, or import it with sizefx import"
        )
    return tel.reference


def check_record(tel: Telemetry) -> None:
    """Everything the prediction needs of a (cropped) record: a reference, a site, enough rows, not too many."""
    ref = require_reference(tel)
    if tel.site is None and not ref.has_position:
        raise DiagnoseError(
            f"{tel.path}: no site: gravity needs latitude and height; add the root attributes "
            "latitude_deg, longitude_deg, height_m (sizefx import --site-deg)"
        )
    if ref.time_s.size < MIN_REFERENCE_ROWS:
        raise DiagnoseError(
            f"{tel.path}: /reference has {ref.time_s.size} rows; diagnose needs at "
            f"least {MIN_REFERENCE_ROWS} to interpolate the motion from"
        )
    if tel.n_samples > MAX_SAMPLES:
        raise DiagnoseError(
            f"{tel.path}: {tel.n_samples} IMU samples; diagnose holds the record and the "
            "reference's splines in memory (up to 0.8 kB per sample) and takes at most "
            f"{MAX_SAMPLES}: give a part of the record with --from-s/--to-s (e.g. 2 hours at "
            "1600 Hz)"
        )


class ReferenceMotion:
    """The record's ``/reference`` as smooth functions of time (IMU clock).

    ``evaluate(t)`` gives ``C_bn`` (untilted), ``omega_nb_b``, ``omega_in_n`` and the
    specific force ``f_n`` of the reference point. Without position the site is static.

    ``breaks_s``: times where the reference is discontinuous (a re-mount, a frame change;
    :func:`sizefx.diagnose.integrity.check_reference` finds them). The rows are split there
    (:func:`reference_segments`) and each segment gets its own splines, with its own initial
    conditions, so that no spline runs through a jump. A segment with fewer than
    :data:`MIN_REFERENCE_ROWS` rows is left out; :func:`usable_mask` masks its samples.
    ``evaluate`` gives each time the segment that holds it, or the nearest one (clamped to its
    span) for times in a break or a left-out segment. Without breaks: one spline through all rows.
    """

    def __init__(self, tel: Telemetry, breaks_s=()):
        ref = tel.reference
        assert ref is not None  # check_record refused a record without one
        self.t = ref.time_s
        self.breaks_s = tuple(float(b) for b in breaks_s)
        rows = [(lo, hi) for lo, hi in reference_segments(ref.time_s, self.breaks_s) if hi - lo >= MIN_REFERENCE_ROWS]
        if not rows:
            raise DiagnoseError(
                f"{tel.path}: /reference split at {len(self.breaks_s)} discontinuities leaves no "
                f"segment of {MIN_REFERENCE_ROWS} rows or more; diagnose a part without them "
                "(--from-s/--to-s)"
            )
        self._pieces = [_Piece(tel, lo, hi) for lo, hi in rows]
        # times at which evaluate() passes from one piece to the next: midway between their spans
        self._edges_s = (
            np.array([0.5 * (a.t1 + b.t0) for a, b in zip(self._pieces[:-1], self._pieces[1:])])
            if len(self._pieces) > 1
            else None
        )
        # today's attributes, kept for callers of the unsplit motion
        first = self._pieces[0]
        self.rot, self.static = first.rot, first.static
        if first.static is None:
            self.lat, self.h, self.v = first.lat, first.h, first.v

    @property
    def segment_spans_s(self) -> list[tuple[float, float]]:
        """The time span [s] of each segment that has splines."""
        return [(p.t0, p.t1) for p in self._pieces]

    def evaluate(self, t) -> dict:
        """At the times ``t`` [n]: ``C_bn`` [n, 3, 3], ``w_nb`` [n, 3] (rad/s, body), ``w_in`` and ``f_n``
        [n, 3] (rad/s and m/s^2, NED)."""
        t = np.asarray(t, dtype=float)
        if self._edges_s is None:
            return self._pieces[0].evaluate(t)
        which = np.searchsorted(self._edges_s, t, side="right")
        out = {
            "C_bn": np.empty((t.size, 3, 3)),
            "w_nb": np.empty((t.size, 3)),
            "w_in": np.empty((t.size, 3)),
            "f_n": np.empty((t.size, 3)),
        }
        for j, piece in enumerate(self._pieces):
            sel = np.flatnonzero(which == j)
            if sel.size:
                part = piece.evaluate(np.clip(t[sel], piece.t0, piece.t1))
                for key, value in part.items():
                    out[key][sel] = value
        return out


class _Piece:
    """The splines through reference rows ``[lo, hi)``: attitude, and position and velocity when present."""

    def __init__(self, tel: Telemetry, lo: int, hi: int):
        ref = tel.reference
        assert ref is not None  # check_record refused a record without one
        t = ref.time_s[lo:hi]
        self.t0, self.t1 = float(t[0]), float(t[-1])
        self.rot = _LongRotationSpline(t, Rotation.from_quat(ref.quat_nb[lo:hi][:, [1, 2, 3, 0]]))
        if ref.has_position:
            assert ref.lat_rad is not None and ref.lon_rad is not None and ref.height_m is not None  # set together
            lat, lon, h = ref.lat_rad[lo:hi], ref.lon_rad[lo:hi], ref.height_m[lo:hi]
            self.lat = CubicSpline(t, lat)
            self.h = CubicSpline(t, h)
            if ref.velocity_n_mps is not None:
                v = ref.velocity_n_mps[lo:hi]
            else:  # from the position spline's derivative
                rn, re = earth.radii_m(lat)
                lon_spline = CubicSpline(t, np.unwrap(lon))
                v = np.column_stack(
                    [(rn + h) * self.lat(t, 1), (re + h) * np.cos(lat) * lon_spline(t, 1), -self.h(t, 1)]
                )
            self.v = CubicSpline(t, v, axis=0)
            self.static = None
        else:
            site = tel.site
            assert site is not None  # check_record refused a record with neither a site nor a position
            self.static = (site.lat_rad, site.height_m)

    def evaluate(self, t) -> dict:
        mat_nb = self.rot(t).as_matrix()
        w_nb = self.rot(t, 1)
        if self.static is None:
            lat, h, v, vdot = self.lat(t), self.h(t), self.v(t), self.v(t, 1)
        else:
            lat = np.full(t.shape, self.static[0])
            h = np.full(t.shape, self.static[1])
            v = np.zeros((t.size, 3))
            vdot = np.zeros((t.size, 3))
        w_ie = earth.omega_ie_n(lat)
        w_en = earth.omega_en_n(lat, h, v)
        f_n = vdot + np.cross(2.0 * w_ie + w_en, v) - earth.gravity_n(lat, h)
        return {"C_bn": np.swapaxes(mat_nb, 1, 2), "w_nb": w_nb, "w_in": w_ie + w_en, "f_n": f_n}


class _LongRotationSpline:
    """scipy's ``RotationSpline`` through any number of rows in bounded memory: one spline through up
    to :data:`SPLINE_ROWS` rows (what it always was); beyond, one per stretch of :data:`SPLINE_PIECE_ROWS`
    rows, each built through :data:`SPLINE_OVERLAP_ROWS` more rows on either side and used only on its
    stretch. Building one spline takes about 1.5 kB per row at its peak (its angular rates are solved
    for as one banded system), 1.5 GB for a million rows of a 1600 Hz reference.

    A stretch's spline differs from the whole one by the end conditions' pull, which decays by
    2 - sqrt(3) = 0.27 per row (1e-36 after the overlap), and by the iterative solve's tolerance
    (1e-9 rad/s relative, ``RotationSpline.TOL``): 1e-4 of a navigation-grade gyro's noise per
    sample at 1600 Hz. ``tests/test_diagnose.py::test_long_rotation_spline_equals_one_spline``.
    ``self(t)`` is a ``Rotation``, ``self(t, 1)`` the rates [n, 3] (rad/s, body axes).

    **The rates between rows** are not the rotation spline's derivative there but a cubic spline
    through its rates at the rows (:class:`_Rates`; 96 bytes a row beside the rotation spline's).
    The derivative of a cubic rotation spline between its rows is off by O(h^3) of the motion's
    fourth derivative, in phase with the
    angular acceleration and of a sign that turns with the position between rows: to the gyros it
    is a reference delay that depends on the delay itself (on a 2 Hz sway logged at 200 Hz, up to
    1.6e-7 s either way; a development-range sway's 1.85 ms reference delay came out 15 sigma
    off). At the rows the spline's rates are O(h^4) (2.6e-8 rad/s there), and a cubic spline
    through them is off by O(h^4) between rows: 7e-9 s of delay on that sway, at every shift.
    Within :data:`END_ROWS` rows of either end, where the rotation spline's end conditions still
    pull its rates at the rows, its own derivative is kept (:class:`_Rates`)."""

    def __init__(self, t, rot: Rotation):
        n = t.size
        if n <= SPLINE_ROWS:
            spline = RotationSpline(t, rot)
            self._starts, self._parts = np.array([-np.inf]), [(spline, _Rates(t, spline))]
            return
        starts, parts = [], []
        for lo in range(0, n, SPLINE_PIECE_ROWS):
            hi = min(n, lo + SPLINE_PIECE_ROWS)
            a, b = max(0, lo - SPLINE_OVERLAP_ROWS), min(n, hi + SPLINE_OVERLAP_ROWS)
            starts.append(-np.inf if lo == 0 else t[lo])
            spline = RotationSpline(t[a:b], rot[a:b])
            parts.append((spline, _Rates(t[a:b], spline)))
        self._starts, self._parts = np.array(starts), parts

    def __call__(self, t, order: int = 0):
        t = np.asarray(t, dtype=float)
        if order not in (0, 1):
            raise ValueError(f"order {order}: attitude (0) or rates (1)")
        if len(self._parts) == 1:
            return self._part(0, t, order)
        which = np.searchsorted(self._starts, t, side="right") - 1
        out = np.empty((t.size, 3 if order else 4))
        for j in np.unique(which):
            sel = which == j
            value = self._part(j, t[sel], order)
            out[sel] = value if order else value.as_quat()
        return out if order else Rotation.from_quat(out)

    def _part(self, j: int, t, order: int):
        spline, rates = self._parts[j]
        return rates(t) if order else spline(t)


#: Rows at either end of a rotation spline where its rates come from its own derivative (:class:`_Rates`).
#: Its end conditions put an error of about 2e-3 rad/s into its rates at the end row of a tumble logged
#: at 200 Hz, falling by 0.27 a row; a cubic spline through those rates carries it a few rows further
#: than the rotation spline's derivative does, which is the better of the two up to 14 rows in
#: (``tests/test_diagnose.py::test_prediction_with_the_true_model_reproduces_the_simulation``); the
#: fit leaves the first and last 50 ms out anyway (:data:`EDGE_S`).
END_ROWS = 16


class _Rates:
    """Body rates [n, 3] (rad/s) at times ``t`` from a rotation spline through rows ``t_rows``: a cubic
    spline (not-a-knot) through its rates at the rows, and its own derivative within :data:`END_ROWS`
    rows of either end."""

    def __init__(self, t_rows, spline: RotationSpline):
        self._spline = spline
        self._through = CubicSpline(t_rows, spline(t_rows, 1), axis=0)
        k = min(END_ROWS, (t_rows.size - 1) // 2)
        self._inner = (float(t_rows[k]), float(t_rows[-1 - k]))

    def __call__(self, t):
        out = self._through(t)
        ends = (t < self._inner[0]) | (t > self._inner[1])
        if ends.any():
            out[ends] = self._spline(t[ends], 1)
        return out


def reference_segments(time_s: np.ndarray, breaks_s=()) -> list[tuple[int, int]]:
    """The reference rows split at ``breaks_s`` [s]: row ranges ``[lo, hi)``, in time order.

    A row at or after a break belongs to the segment that starts there. Breaks outside the rows'
    span, or with no row between them, give no empty segment.
    """
    cuts = np.searchsorted(time_s, np.sort(np.asarray(breaks_s, dtype=float)), side="left")
    bounds = np.unique(np.concatenate([[0], cuts, [time_s.size]]))
    return [(int(lo), int(hi)) for lo, hi in zip(bounds[:-1], bounds[1:]) if hi > lo]


def usable_mask(t: np.ndarray, tel: Telemetry, *, window: int, dt: float, breaks_s=()) -> np.ndarray:
    """Which IMU samples (times ``t`` [n], s) the fit may use: inside the reference's span minus
    :data:`EDGE_S` (or :data:`EDGE_REFERENCE_PERIODS` periods) at its ends and gaps, away from IMU
    gaps by the gyro derivative's ``window`` (samples of period ``dt``), and not at the series' ends.

    ``breaks_s`` [s] (reference discontinuities, see :class:`ReferenceMotion`): the samples within
    the same edge of the last row before and the first row after each break are left out, as at a
    gap, and so are the samples of a segment too short for splines (< :data:`MIN_REFERENCE_ROWS` rows).
    """
    assert tel.reference is not None  # check_record refused a record without one
    rt = tel.reference.time_s
    steps = np.diff(rt)
    edge = max(EDGE_S, EDGE_REFERENCE_PERIODS * float(np.median(steps)))
    ok = (t >= rt[0] + edge) & (t <= rt[-1] - edge)
    limit = REFERENCE_GAP_FACTOR * np.median(steps)
    for k in np.flatnonzero(steps > limit):
        ok &= ~((t > rt[k] - edge) & (t < rt[k + 1] + edge))
    if len(breaks_s):
        segments = reference_segments(rt, breaks_s)
        for (_, hi), (lo_next, _) in zip(segments[:-1], segments[1:]):
            ok &= ~((t > rt[hi - 1] - edge) & (t < rt[lo_next] + edge))
        for lo, hi in segments:
            if hi - lo < MIN_REFERENCE_ROWS:
                ok &= ~((t > rt[lo] - edge) & (t < rt[hi - 1] + edge))
    # IMU gaps (accepted with --allow-gaps): the derivative window and the splines span them
    margin = EDGE_S + window * dt
    for gap in tel.gaps:
        if gap.dataset.startswith("/imu"):
            ok &= ~((t > gap.time_s - margin) & (t < gap.time_s + gap.duration_s + margin))
    half = (window - 1) // 2
    ok[: half + 2] = False  # the gyro derivative's end fits, and the shifts' spline ends
    ok[-half - 2 :] = False
    return ok


def crop(tel: Telemetry, from_s: float | None, to_s: float | None) -> Telemetry:
    """The part of a record between two times [s] (IMU and reference alike)."""
    if from_s is None and to_s is None:
        return tel
    lo = -np.inf if from_s is None else from_s
    hi = np.inf if to_s is None else to_s
    keep = (tel.time_s >= lo) & (tel.time_s <= hi)
    if keep.sum() < MIN_SAMPLES:
        raise DiagnoseError(
            f"{tel.path}: --from-s/--to-s keep {int(keep.sum())} IMU samples; diagnose needs {MIN_SAMPLES}"
        )
    fields: dict[str, Any] = {  # keywords of replace(): an array, or None for one the record lacks
        k: (getattr(tel, k)[keep] if getattr(tel, k) is not None else None)
        for k in ("time_s", "gyro_rad_s", "accel_mps2", "dtheta_rad", "dvel_mps", "accel_time_s")
    }
    ref = tel.reference
    assert ref is not None  # run() refused a record without one (require_reference)
    rk = (ref.time_s >= lo - 1.0) & (ref.time_s <= hi + 1.0)  # a second more of reference for the splines
    ref = replace(
        ref,
        **{
            k: getattr(ref, k)[rk]
            for k in ("time_s", "quat_nb", "lat_rad", "lon_rad", "height_m", "velocity_n_mps")
            if getattr(ref, k) is not None
        },
    )
    gaps = [g for g in tel.gaps if lo <= g.time_s <= hi]
    return replace(tel, reference=ref, gaps=gaps, **fields)
