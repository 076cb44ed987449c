"""Gaps and continuous segments of an IMU record: the one definition of a gap, and the segments between gaps.

A gap is a time step longer than :data:`~sizefx.constants.GAP_FACTOR` nominal periods; the
nominal period is the median step of the first :data:`NOMINAL_ROWS` rows. The reader
(:mod:`sizefx.io.contract`), the streams (:mod:`sizefx.io.reader`) and the importers all count
gaps with these functions, so a record has the same gaps however it is read.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..constants import GAP_FACTOR
from ..errors import ConfigError, TelemetryError

__all__ = [
    "Gap",
    "Segment",
    "nominal_period_s",
    "find_imu_gaps",
    "imu_segments",
    "refuse_gaps",
    "NOMINAL_ROWS",
    "GAP_MATCH_TOLERANCE",
]

#: The nominal sample period is the median step of the first this many rows: one definition for a
#: whole read and a streamed one (which must know it before it has read the record), and for the
#: importers. 2^16 steps (41 s at 1600 Hz) make the median as good as the whole record's.
NOMINAL_ROWS = 1 << 16

#: A declared gap matches one in the data when its time and its length agree within this
#: fraction of the nominal period (the declaration cannot then name the neighbouring step).
GAP_MATCH_TOLERANCE = 0.5


@dataclass
class Gap:
    """A time step longer than ``GAP_FACTOR`` nominal periods.

    IMU gaps are counted once per row: a dropout that both ``/imu/time`` and
    ``/imu/accel_time`` show is one gap (named after ``/imu/time``).
    """

    dataset: str
    index: int  #: sample k: the gap lies between time[k-1] and time[k]
    time_s: float  #: time[k-1]
    duration_s: float  #: time[k] - time[k-1]
    declared: bool = False  #: listed in /imu/gaps (a known property of the record)


@dataclass
class Segment:
    """A continuous piece of an IMU record between gaps: rows ``[first_row, stop_row)``."""

    number: int  #: 1-based, in time order (``--segment K``)
    first_row: int
    stop_row: int
    start_s: float  #: time of the first row
    end_s: float  #: time of the last row
    of: int  #: how many segments the record has

    @property
    def samples(self) -> int:
        return self.stop_row - self.first_row

    def note(self) -> dict:
        """What a stage that changes the samples records of the segment it worked on (``/source``'s
        ``compensation_json`` and ``correction_json``): its number, the count, its rows and its span [s]."""
        return {
            "segment": self.number,
            "segment_of": self.of,
            "segment_rows": [self.first_row, self.stop_row],
            "segment_time_s": [self.start_s, self.end_s],
        }


def count_noun(n: int, noun: str) -> str:
    """``"1 gap"``, ``"8 gaps"``."""
    return f"{n} {noun}" + ("" if n == 1 else "s")


def nominal_period_s(time_s) -> float:
    """The nominal sample period [s]: the median step of the first :data:`NOMINAL_ROWS` rows."""
    return float(np.median(np.diff(np.asarray(time_s[: NOMINAL_ROWS + 1], dtype=float))))


def gap_rows(time_s: np.ndarray, nominal_s: float) -> np.ndarray:
    """Rows k of ``time_s`` with ``time[k] - time[k-1] > GAP_FACTOR * nominal``: the one definition of a gap."""
    return np.flatnonzero(np.diff(time_s) > GAP_FACTOR * nominal_s) + 1


def find_imu_gaps(time_s, accel_time_s=None, *, declared: bool = False) -> list[Gap]:
    """The IMU gaps of a record in memory, one per row, as the reader counts them.

    ``declared``: mark the gaps of ``/imu/time`` as declared (an importer that writes them to
    ``/imu/gaps``). A gap only the accelerometer stamps show cannot be declared (``/imu/gaps``
    lists ``/imu/time`` steps) and stays undeclared.
    """
    time_s = np.asarray(time_s, dtype=float)
    if time_s.shape[0] < 2:
        return []  # the reader refuses such a record, with its own message
    nominal = nominal_period_s(time_s)
    out = {}
    for name, t in (("/imu/time", time_s), ("/imu/accel_time", accel_time_s)):
        if t is None:
            continue
        t = np.asarray(t, dtype=float)
        for k in gap_rows(t, nominal):
            if int(k) not in out:
                out[int(k)] = Gap(
                    name, int(k), float(t[k - 1]), float(t[k] - t[k - 1]), declared=declared and name == "/imu/time"
                )
    return [out[k] for k in sorted(out)]


def segment_bounds(n_samples: int, gaps) -> list[tuple[int, int]]:
    cuts = sorted({g.index for g in gaps if g.dataset.startswith("/imu")})
    return list(zip([0] + cuts, cuts + [n_samples]))


def imu_segments(n_samples: int, gaps, time_at) -> list[Segment]:
    """The continuous segments an IMU record of ``n_samples`` rows is cut into by its ``gaps``.

    ``time_at(row)`` returns the time of a row (an array lookup, or a dataset read).
    """
    bounds = segment_bounds(n_samples, gaps)
    return [
        Segment(k + 1, a, b, float(time_at(a)), float(time_at(b - 1)), len(bounds)) for k, (a, b) in enumerate(bounds)
    ]


def choose_segment(path, n_samples: int, gaps, number: int, time_at) -> Segment:
    """Segment ``number`` (1-based), or a one-line error naming the option and the file.

    Only the chosen segment's two end rows are looked up (a stream reads them from the file).
    """
    bounds = segment_bounds(n_samples, gaps)
    n = len(bounds)
    if not 1 <= number <= n:
        listing = (
            "it has no gaps: one segment, the whole record"
            if n == 1
            else f"its {n} continuous segments are numbered 1..{n} (sizefx inspect lists them)"
        )
        raise ConfigError(f"--segment {number}: {path}: {listing}; give one of them")
    a, b = bounds[number - 1]
    seg = Segment(number, a, b, float(time_at(a)), float(time_at(b - 1)), n)
    if seg.samples < 2:
        raise ConfigError(
            f"--segment {number}: segment {number} of {path} holds {seg.samples} sample (row "
            f"{seg.first_row}, t = {seg.start_s:.6f} s) between two gaps; choose a longer one "
            "(sizefx inspect lists them)"
        )
    return seg


def refuse_gaps(path, gaps, *, command: str, why: str, bridge: bool):
    """One line for a command that cannot work across an IMU gap: what it cannot do, and the offer.

    ``bridge``: say that ``--allow-gaps`` would process the record across its gaps anyway.
    Returns quietly when ``gaps`` holds no IMU gap.
    """
    imu = [g for g in gaps if g.dataset.startswith("/imu")]
    if not imu:
        return
    declared = sum(g.declared for g in imu)
    what = (
        "declared in /imu/gaps"
        if declared == len(imu)
        else ("undeclared" if declared == 0 else f"{declared} of them declared in /imu/gaps")
    )
    first = imu[0]
    offer = ", or pass --allow-gaps to bridge the gaps" if bridge else ""
    raise TelemetryError(
        path,
        first.dataset,
        f"has {count_noun(len(imu), 'gap')} ({what}; the first at row {first.index}, "
        f"t = {first.time_s:.6f} s); {command} {why}: process one continuous segment with "
        f"--segment K (1..{len(imu) + 1}, as sizefx inspect numbers them){offer}",
    )
