"""Reading ``sizefx/telemetry/1`` files: whole (:func:`read_telemetry`) or in chunks (:class:`TelemetryStream`,
:class:`ReferenceStream`), each read validated by :mod:`sizefx.io.contract` and converted to SI.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..constants import GAP_FACTOR, MAX_WHOLE_READ_ROWS
from .contract import ContractReader, check_magnitudes, open_hdf5, open_structure, side_groups, site_from_attrs
from .gaps import NOMINAL_ROWS, choose_segment, segment_bounds
from .records import Reference, Telemetry

__all__ = ["read_telemetry", "TelemetryStream", "ReferenceStream", "SCAN_ROWS", "MAX_WHOLE_READ_ROWS"]

#: Rows read at a time when a stream scans /imu/time for gaps at open (8 MiB of float64).
SCAN_ROWS = 1 << 20
#: Why a whole read refuses a file over :data:`~sizefx.constants.MAX_WHOLE_READ_ROWS` (the message's tail).
WHOLE_READ_WHY = (
    "commands that load the whole record (inspect, calibrate, compensate, diagnose, compare) take at "
    "most {limit} rows (2 h at 1600 Hz): cut the record, or use sizefx navigate, which streams"
)


def read_telemetry(
    path,
    *,
    allow_gaps: bool = False,
    check_plausibility: bool = True,
    segment: int | None = None,
    check_limits: bool = True,
) -> Telemetry:
    """Read and validate a ``sizefx/telemetry/1`` file; return SI arrays.

    Parameters
    ----------
    path : str or Path
        The HDF5 file.
    allow_gaps : bool
        Accept IMU time steps longer than 1.5 nominal periods that ``/imu/gaps`` does not
        declare (all gaps are listed in ``Telemetry.gaps``) instead of refusing the file.
        Declared gaps are accepted without it.
    check_plausibility : bool
        Refuse data whose magnitudes betray wrong units (see the schema's
        ``plausibility`` section).
    segment : int, optional
        Read only the IMU rows of continuous segment ``segment`` (1-based, between gaps, as
        ``sizefx inspect`` numbers them); ``/reference`` is read whole.
    check_limits : bool
        Refuse samples beyond the schema's ``sample_limits`` (physically impossible values).
        Off only for a caller that checks them itself, later (import, after its units check,
        whose message explains a wrong unit better).

    Raises
    ------
    TelemetryError
        For every violation of the contract, with a one-line message.
    ConfigError
        For a ``segment`` the record does not have.
    """
    path = Path(path)
    with open_hdf5(path, "convert it with sizefx import") as h5:
        r, attrs, form = open_structure(path, h5, allow_gaps, check_plausibility)
        r.limits = check_limits
        schema = r.schema
        for name in ("/imu/time", "/reference/time"):  # before anything is allocated
            r.check_rows(name, MAX_WHOLE_READ_ROWS, WHOLE_READ_WHY)
        time_s = r.dataset("/imu/time", required=True)
        nominal, found = r.check_time("/imu/time", time_s)
        accel_time = r.dataset("/imu/accel_time", required=False)
        if accel_time is not None:
            found += r.check_time("/imu/accel_time", accel_time, nominal=nominal)[1]
            r.check_accel_time(time_s, accel_time, nominal)
        r.settle_imu_gaps(found, nominal, r.declared_gaps(time_s.shape[0]))
        rows, seg, gaps = slice(None), None, r.gaps
        if segment is not None:
            seg = choose_segment(path, time_s.shape[0], r.gaps, segment, time_s.__getitem__)
            rows = slice(seg.first_row, seg.stop_row)
            time_s = time_s[rows]
            accel_time = None if accel_time is None else accel_time[rows]
            gaps = [g for g in r.gaps if not g.dataset.startswith("/imu")]  # none inside a segment
        gyro_name, accel_name = schema["forms"][form]["datasets"]
        first = rows.start or 0
        gyro = r.rows(gyro_name, r.handle(gyro_name, required=True), rows, first)
        accel = r.rows(accel_name, r.handle(accel_name, required=True), rows, first)
        if check_plausibility:
            check_magnitudes(r, form, nominal, gyro, accel)
        reference, source, simulation = side_groups(r, h5)
    tel = Telemetry(
        time_s=time_s,
        form=form,
        accel_time_s=accel_time,
        reference=reference,
        site=site_from_attrs(attrs),
        description=attrs.get("description", ""),
        simulation=simulation,
        source=source,
        path=str(path),
        stored_units=r.units,
        stored_dtypes=r.dtypes,
        gaps=gaps,
        segment=seg,
    )
    if form == "rates":
        tel.gyro_rad_s, tel.accel_mps2 = gyro, accel
    else:
        tel.dtheta_rad, tel.dvel_mps = gyro, accel
    return tel


class ReferenceStream:
    """``/reference`` of an open file, read a time window at a time (long records, dense references).

    At open: structure, units and the first and last stamps; the extremes of the position
    (for the stationary test) in one chunked pass. :meth:`window` returns the rows that
    bracket ``[t_lo, t_hi]`` (one more on each side) as a :class:`Reference`, after the
    checks :func:`read_telemetry` makes on the whole group (finite, strictly increasing
    time, unit quaternions, latitude range), naming absolute rows.
    """

    PASS_ROWS = 1 << 20

    def __init__(self, r: ContractReader, h5):
        self._r = r
        self._time = r.handle("/reference/time", required=True)
        self._quat = r.handle("/reference/quaternion", required=True)
        self._pos = r.handle("/reference/position", required=False)
        self._vel = r.handle("/reference/velocity", required=False)
        self.n = int(self._time[0].shape[0])
        if self.n < 2:
            r.fail("/reference/time", f"holds {self.n} sample; at least 2 are needed")
        self.first_s = float(r.rows("/reference/time", self._time, slice(0, 1))[0])
        self.last_s = float(r.rows("/reference/time", self._time, slice(self.n - 1, self.n), self.n - 1)[0])
        self.has_position = self._pos is not None
        self.has_velocity = self._vel is not None
        head = r.rows("/reference/time", self._time, slice(0, min(self.n, 1 << 16)))
        self.median_step_s = float(np.median(np.diff(head)))
        self.position_min = self.position_max = None
        if self.has_position:
            lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
            for k0 in range(0, self.n, self.PASS_ROWS):
                pos = r.rows("/reference/position", self._pos, slice(k0, k0 + self.PASS_ROWS), k0)
                lo, hi = np.minimum(lo, pos.min(axis=0)), np.maximum(hi, pos.max(axis=0))
            self.position_min, self.position_max = lo, hi

    def _search(self, t: float) -> int:
        """Index of the last stamp <= t (binary search on the dataset, a few reads)."""
        dset, factor = self._time
        factor = float(np.asarray(factor).ravel()[0])
        lo, hi = 0, self.n - 1
        while lo < hi:
            mid = (lo + hi + 1) // 2
            if float(dset[mid]) * factor <= t:
                lo = mid
            else:
                hi = mid - 1
        return lo

    def window(self, t_lo: float, t_hi: float) -> Reference:
        r = self._r
        k0 = max(0, self._search(t_lo) - 1)
        k1 = min(self.n, self._search(t_hi) + 3)
        rows = slice(k0, k1)
        t = r.rows("/reference/time", self._time, rows, k0)
        if np.any(np.diff(t) <= 0.0):
            k = int(np.flatnonzero(np.diff(t) <= 0.0)[0]) + k0 + 1
            r.fail("/reference/time", f"is not strictly increasing at row {k}; sort the reference")
        q = r.check_unit_quaternions("/reference/quaternion", r.rows("/reference/quaternion", self._quat, rows, k0))
        ref = Reference(time_s=t, quat_nb=q)
        if self._vel is not None:
            ref.velocity_n_mps = r.rows("/reference/velocity", self._vel, rows, k0)
        if self._pos is not None:
            pos = r.rows("/reference/position", self._pos, rows, k0)
            if np.any(np.abs(pos[:, 0]) > np.pi / 2):
                r.fail("/reference/position", "latitude outside [-90, 90] deg; columns are latitude, longitude, height")
            ref.lat_rad, ref.lon_rad, ref.height_m = pos[:, 0], pos[:, 1], pos[:, 2]
        return ref

    def summary(self) -> Reference:
        """A two-row stand-in for decisions about the whole reference: the first and last stamps,
        and the position extremes (so ``ptp`` of each position column is the whole record's)."""
        ref = Reference(time_s=np.array([self.first_s, self.last_s]), quat_nb=np.tile([1.0, 0.0, 0.0, 0.0], (2, 1)))
        if self.has_position:
            assert self.position_min is not None and self.position_max is not None  # found at open with has_position
            ref.lat_rad, ref.lon_rad, ref.height_m = (
                np.array([self.position_min[c], self.position_max[c]]) for c in range(3)
            )
        if self.has_velocity:
            ref.velocity_n_mps = np.zeros((2, 3))
        return ref


class TelemetryStream:
    """A telemetry file read in chunks of IMU rows, validated as it is read.

    At open: the structure, root attributes, IMU form, units, ``/reference`` as a
    :class:`ReferenceStream` (read by time window), ``/source`` and ``/simulation``; the time
    stamps scanned in chunks of :data:`SCAN_ROWS` (strictly increasing, and the gaps, matched
    with ``/imu/gaps`` and refused unless declared or allowed, exactly as :func:`read_telemetry`
    does); the magnitude check from the first :data:`PROBE_ROWS` rows. With ``segment=K`` the
    stream holds only the rows of continuous segment K (row 0 is the segment's first row;
    messages name absolute rows). :meth:`read` returns rows ``[k0, k1)`` in SI units after the
    same checks :func:`read_telemetry` makes (finite values; time strictly increasing, no gap,
    across chunk boundaries too). Memory: the chunk, not the record.
    """

    PROBE_ROWS = 1 << 16

    def __init__(self, path, *, allow_gaps: bool = False, check_plausibility: bool = True, segment: int | None = None):
        self.path = Path(path)
        self.h5 = open_hdf5(self.path, "convert it with sizefx import")
        try:
            r, attrs, form = open_structure(self.path, self.h5, allow_gaps, check_plausibility)
            self._r = r
            self.form = form
            gyro_name, accel_name = r.schema["forms"][form]["datasets"]
            self.names = ("/imu/time", gyro_name, accel_name)
            self._handles = [r.handle(name, required=True) for name in self.names]
            self._accel_time = r.handle("/imu/accel_time", required=False)
            n_all = int(self._handles[0][0].shape[0])
            head = r.rows("/imu/time", self._handles[0], slice(0, min(n_all, NOMINAL_ROWS + 1)))
            nominal, _ = r.check_time("/imu/time", head)  # >= 2 samples, a plausible rate
            r.n_gaps.pop("/imu/time", None)  # the scan below counts the head's gaps again
            found = self._scan("/imu/time", self._handles[0], n_all, nominal)
            if self._accel_time is not None:
                found += self._scan("/imu/accel_time", self._accel_time, n_all, nominal)
                probe = slice(0, min(n_all, NOMINAL_ROWS + 1))
                r.check_accel_time(head, r.rows("/imu/accel_time", self._accel_time, probe), nominal)
            r.settle_imu_gaps(found, nominal, r.declared_gaps(n_all))
            self.gaps = r.gaps
            self.n_segments = len(segment_bounds(n_all, self.gaps))
            self.segment = None
            self.first_row = 0  #: the file row of stream row 0 (a segment's first)
            self.n_samples = n_all
            if segment is not None:
                self.segment = choose_segment(self.path, n_all, self.gaps, segment, self._time_at)
                self.first_row = self.segment.first_row
                self.n_samples = self.segment.samples
                self.gaps = []  # none inside a segment (the stream reads no reference gaps)
            self.sample_period_s = nominal
            if check_plausibility:
                probe = slice(self.first_row, self.first_row + min(self.n_samples, self.PROBE_ROWS))
                check_magnitudes(
                    r,
                    form,
                    nominal,
                    r.rows(gyro_name, self._handles[1], probe, self.first_row),
                    r.rows(accel_name, self._handles[2], probe, self.first_row),
                )
            self.reference = ReferenceStream(r, self.h5) if "/reference" in self.h5 else None
            _, self.source, self.simulation = side_groups(r, self.h5, reference=False)
            self.site = site_from_attrs(attrs)
            self.description = attrs.get("description", "")
            self._last_t: tuple[int, float] | None = None  #: (row, stamp) of the last chunk's last sample
        except BaseException:
            self.h5.close()
            raise

    def _time_at(self, row: int) -> float:
        return float(self._r.rows("/imu/time", self._handles[0], slice(row, row + 1), row)[0])

    def _scan(self, name: str, handle, n: int, nominal: float) -> list:
        """The gaps of a time dataset, read in chunks that overlap by one row (each step seen once)."""
        gaps = []
        for k0 in range(0, n, SCAN_ROWS):
            lo = max(0, k0 - 1)
            t = self._r.rows(name, handle, slice(lo, min(n, k0 + SCAN_ROWS)), lo)
            gaps += self._r.check_time(name, t, first_row=lo, nominal=nominal)[1]
        return gaps

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self):
        self.h5.close()

    def read(self, k0: int, k1: int):
        """Rows ``[k0, k1)``: ``(time_s, gyro_like, accel_like, accel_time_s or None)``, SI, checked.

        Reading in order lets the time checks span chunk boundaries; out-of-order reads
        (margins) are checked within the chunk.
        """
        r = self._r
        a0 = k0 + self.first_row  # the absolute row (in the file) of stream row k0
        rows = slice(a0, k1 + self.first_row)
        t = r.rows("/imu/time", self._handles[0], rows, a0)
        before = self._last_t if (self._last_t is not None and self._last_t[0] == k0 - 1) else None
        full = t if before is None else np.concatenate([[before[1]], t])
        if full.size >= 2:
            dt = np.diff(full)
            bad = np.flatnonzero(dt <= 0.0)
            if bad.size:
                k = int(bad[0]) + a0 + (0 if before is not None else 1)
                r.fail("/imu/time", f"is not strictly increasing at row {k}; sort or split the record")
            gap = np.flatnonzero(dt > GAP_FACTOR * self.sample_period_s)
            if gap.size:  # the callers refuse gaps at open (refuse_gaps); this guards a reader that did not
                k = int(gap[0]) + a0 + (0 if before is not None else 1)
                r.fail(
                    "/imu/time",
                    f"has a gap at row {k} ({dt[gap[0]] * 1e3:.4g} ms); this needs continuous "
                    "samples: process one segment (--segment K)",
                )
        if k1 > k0:
            self._last_t = (k1 - 1, float(t[-1]))
        g = r.rows(self.names[1], self._handles[1], rows, a0)
        a = r.rows(self.names[2], self._handles[2], rows, a0)
        ta = None if self._accel_time is None else r.rows("/imu/accel_time", self._accel_time, rows, a0)
        if ta is not None:
            r.check_accel_time(t, ta, self.sample_period_s, a0)
        return t, g, a, ta
