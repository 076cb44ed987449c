"""The records a telemetry file holds, in SI units: :class:`Telemetry`, its :class:`Reference` and :class:`Site`.

Plain dataclasses, without file access: :mod:`sizefx.io.reader` fills them from a file and
:mod:`sizefx.io.writer` writes them; simulators and importers build them in memory.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from .gaps import Segment, imu_segments
from .provenance import Provenance

__all__ = ["Site", "Reference", "Telemetry"]


@dataclass
class Site:
    """Site or start position (root attributes), radians and metres."""

    lat_rad: float
    lon_rad: float
    height_m: float


@dataclass
class Reference:
    """True or commanded motion of the reference point, on the IMU clock."""

    time_s: np.ndarray  #: [M] s
    quat_nb: np.ndarray  #: [M, 4] scalar-first, body to NED
    lat_rad: np.ndarray | None = None  #: [M] rad
    lon_rad: np.ndarray | None = None  #: [M] rad
    height_m: np.ndarray | None = None  #: [M] m
    velocity_n_mps: np.ndarray | None = None  #: [M, 3] NED, m/s

    @property
    def has_position(self) -> bool:
        return self.lat_rad is not None


@dataclass
class Telemetry:
    """One IMU record in SI units, as read from (or to be written to) a file.

    Exactly one of the two forms is present: ``"rates"`` (``gyro_rad_s``,
    ``accel_mps2`` sampled at ``time_s``) or ``"increments"``
    (``dtheta_rad``, ``dvel_mps`` over ``(time_s[k-1], time_s[k]]``).
    All IMU arrays are ``[N, 3]`` float64 in body axes.
    """

    time_s: np.ndarray
    form: str
    gyro_rad_s: np.ndarray | None = None
    accel_mps2: np.ndarray | None = None
    dtheta_rad: np.ndarray | None = None
    dvel_mps: np.ndarray | None = None
    accel_time_s: np.ndarray | None = None
    reference: Reference | None = None
    site: Site | None = None
    description: str = ""
    simulation: dict | None = None
    #: where the record came from and what was done to it since (``/source``); None: nothing is known
    source: Provenance | None = None
    path: str | None = None
    stored_units: dict = field(default_factory=dict)
    stored_dtypes: dict = field(default_factory=dict)
    gaps: list = field(default_factory=list)
    #: the continuous segment this record holds (read with ``segment=K``), or None: the whole record
    segment: Segment | None = None

    @property
    def n_samples(self) -> int:
        return int(self.time_s.shape[0])

    @property
    def sample_period_s(self) -> float:
        """Nominal sample period: the median time step."""
        return float(np.median(np.diff(self.time_s)))

    @property
    def sample_rate_hz(self) -> float:
        return 1.0 / self.sample_period_s

    @property
    def duration_s(self) -> float:
        return float(self.time_s[-1] - self.time_s[0])

    def imu_arrays(self):
        """The two IMU arrays of this record's form: (gyro-like, accel-like)."""
        if self.form == "rates":
            return self.gyro_rad_s, self.accel_mps2
        return self.dtheta_rad, self.dvel_mps

    def continuous_pieces(self) -> list[tuple[Segment, Telemetry]]:
        """The record cut at its IMU gaps: each continuous segment with a record of its IMU rows
        (views, not copies; ``/reference``, site and provenance shared). One piece, the record
        itself, when it has no IMU gap."""
        imu_gaps = [g for g in self.gaps if g.dataset.startswith("/imu")]
        segments = imu_segments(self.n_samples, imu_gaps, self.time_s.__getitem__)
        if len(segments) == 1:
            return [(segments[0], self)]
        names = ("time_s", "gyro_rad_s", "accel_mps2", "dtheta_rad", "dvel_mps", "accel_time_s")
        others = [g for g in self.gaps if not g.dataset.startswith("/imu")]
        return [
            (
                s,
                replace(
                    self,
                    gaps=others,
                    segment=s,
                    **{k: getattr(self, k)[s.first_row : s.stop_row] for k in names if getattr(self, k) is not None},
                ),
            )
            for s in segments
        ]
