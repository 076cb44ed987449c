"""The inputs of ``sizefx compare``: a navigation solution or a telemetry reference as a :class:`Track`.

The root attribute ``schema`` decides how a file is read:

- ``sizefx/telemetry/1``: by the io layer, :func:`sizefx.io.telemetry.read_telemetry` (the
  whole contract, gaps allowed); ``/reference/position`` is required, velocity and attitude
  are taken when present.
- ``sizefx/navigation/1`` (what ``sizefx navigate -o`` writes): by the io layer,
  :func:`sizefx.io.navigation.read_navigation_datasets` (each dataset checked against its
  entry in ``data-schemas/navigation-1.json`` and converted to SI).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import TelemetryError
from ..io.contract import attr_str
from ..io.navigation import NAVIGATION_SCHEMA, read_navigation_datasets
from ..io.schema import TELEMETRY_SCHEMA
from ..io.telemetry import open_hdf5, read_telemetry

__all__ = ["NAVIGATION_SCHEMA", "Track", "read_track"]

#: What compare reads, for the messages that refuse another file.
_READS = f"compare reads {NAVIGATION_SCHEMA} (sizefx navigate -o) or {TELEMETRY_SCHEMA} files"


@dataclass
class Track:
    """A trajectory on the IMU clock, SI units, WGS-84.

    Attributes
    ----------
    time_s : ndarray [M]
        Strictly increasing time stamps [s].
    lat_rad, lon_rad : ndarray [M]
        Geodetic latitude and longitude [rad].
    height_m : ndarray [M]
        Height above the WGS-84 ellipsoid [m].
    vel_n_mps : ndarray [M, 3] or None
        NED velocity [m/s]; None when the source has none.
    quat_nb : ndarray [M, 4] or None
        Attitude, scalar-first, rotating body (FRD) vectors into NED; None when unknown.
    name : str
        The file (or a label), for messages and reports.
    time_dataset : str
        Where the times came from (``/time``, ``/reference/time``), for messages.
    notes : list of str
        What the reader had to decide (e.g. an approximate reference attitude left out).
    """

    time_s: np.ndarray
    lat_rad: np.ndarray
    lon_rad: np.ndarray
    height_m: np.ndarray
    vel_n_mps: np.ndarray | None
    quat_nb: np.ndarray | None
    name: str
    time_dataset: str = "/time"
    notes: list = field(default_factory=list)

    def __post_init__(self):
        self.time_s = np.asarray(self.time_s, dtype=float)
        m = self.time_s.shape[0]
        for attr in ("lat_rad", "lon_rad", "height_m"):
            value = np.broadcast_to(np.asarray(getattr(self, attr), dtype=float), (m,))
            setattr(self, attr, value)
        for attr, width in (("vel_n_mps", 3), ("quat_nb", 4)):
            value = getattr(self, attr)
            if value is not None:
                value = np.asarray(value, dtype=float)
                if value.shape != (m, width):
                    raise ValueError(f"Track {self.name}: {attr} has shape {value.shape}, expected ({m}, {width})")
                setattr(self, attr, value)
        if m >= 2 and np.any(np.diff(self.time_s) <= 0.0):
            raise ValueError(f"Track {self.name}: time_s must be strictly increasing")

    @property
    def median_step_s(self) -> float:
        return float(np.median(np.diff(self.time_s))) if self.time_s.size > 1 else float("nan")


def read_track(path) -> Track:
    """Read a navigation solution or a telemetry file's reference as a :class:`Track`.

    The root attribute ``schema`` decides: ``sizefx/navigation/1`` (checked against
    ``data-schemas/navigation-1.json``: ``/time`` [s], ``/position`` [deg, deg, m],
    ``/velocity`` NED [m/s], ``/quaternion`` q_nb) or ``sizefx/telemetry/1`` (read by
    :func:`sizefx.io.telemetry.read_telemetry` with gaps allowed; ``/reference/position``
    required, velocity and attitude taken when present).

    Raises
    ------
    TelemetryError
        For a missing, empty or non-HDF5 file, another schema, or a dataset that breaks
        its contract; the one-line message names the file, the dataset and the problem.
    """
    path = Path(path)
    with open_hdf5(path, _READS) as h5:
        if "schema" not in h5.attrs:
            raise TelemetryError(
                path,
                "/",
                f"root attribute 'schema' is missing; compare reads {NAVIGATION_SCHEMA} "
                f"(sizefx navigate -o) or {TELEMETRY_SCHEMA} with /reference/position",
            )
        declared = attr_str(h5.attrs["schema"])
        if declared == NAVIGATION_SCHEMA:
            sol = read_navigation_datasets(path, h5)
            return Track(
                sol.time_s,
                sol.lat_rad,
                sol.lon_rad,
                sol.height_m,
                sol.v_n,
                sol.quat_nb,
                name=str(path),
                time_dataset="/time",
            )
    if declared == TELEMETRY_SCHEMA:
        return _read_telemetry_track(path)
    raise TelemetryError(
        path,
        "/",
        f"root attribute schema is '{declared}'; compare reads {NAVIGATION_SCHEMA} "
        f"(sizefx navigate -o) or {TELEMETRY_SCHEMA} with /reference/position",
    )


def _read_telemetry_track(path: Path) -> Track:
    tel = read_telemetry(path, allow_gaps=True)
    ref = tel.reference
    if ref is None:
        raise TelemetryError(
            path,
            "/reference",
            "group is missing; compare needs /reference/position (latitude, longitude, height) or a navigation file",
        )
    if ref.lat_rad is None or ref.lon_rad is None or ref.height_m is None:  # not ref.has_position
        raise TelemetryError(
            path,
            "/reference/position",
            "dataset is missing; compare needs the reference "
            "position (latitude, longitude, height) of a telemetry file",
        )
    notes = []
    quat: np.ndarray | None = ref.quat_nb
    if tel.source is not None and tel.source.reference_is_approximate:
        # As sizefx navigate does: an importer marked the attitude as approximate (e.g. PSINS's).
        quat = None
        notes.append(
            f"{path}: the reference attitude is marked approximate (/source reference_is_approximate); "
            "attitude not compared"
        )
    return Track(
        ref.time_s,
        ref.lat_rad,
        ref.lon_rad,
        ref.height_m,
        ref.velocity_n_mps,
        quat,
        name=str(path),
        time_dataset="/reference/time",
        notes=notes,
    )
