"""The inputs of ``sizefx compare``: a navigation solution or a telemetry reference as a :class:`Track`.

The root attribute ``schema`` decides how a file is read:

- ``sizefx/telemetry/1``: by the io layer, :func:`sizefx.io.telemetry.read_telemetry` (the
  whole contract, gaps allowed); ``/reference/position`` is required, velocity and attitude
  are taken when present.
- ``sizefx/navigation/1`` (what ``sizefx navigate -o`` writes): each dataset checked against
  its entry in ``data-schemas/navigation-1.json`` (:func:`sizefx.io.schema.load_schema`), its
  units compared with the contract's and converted to SI by the contract's units table
  (:func:`sizefx.io.schema.unit_factor`), no value taken from anywhere else.

The structural checks of a navigation dataset (no data in other files, the contract's shape,
one time axis, numbers, finite values, unit quaternions) are written here because the io layer
makes them for telemetry datasets only, inside its private reader; they follow its rules, and
their messages name the file, the dataset and the problem as its do.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from ..constants import QUATERNION_NORM_TOLERANCE
from ..errors import TelemetryError
from ..io.schema import TELEMETRY_SCHEMA, load_schema, normalise_units, unit_factor
from ..io.telemetry import open_hdf5, read_telemetry

__all__ = ["NAVIGATION_SCHEMA", "Track", "read_track"]

NAVIGATION_SCHEMA = "sizefx/navigation/1"

#: The quantity of each dataset of the navigation contract, the key of the units table of
#: ``data-schemas/telemetry-1.json`` that converts it to SI (navigation-1.json states its units
#: but, unlike telemetry-1.json, not its quantities; its conventions are telemetry's).
NAVIGATION_QUANTITIES = {"/time": "time", "/position": "geodetic", "/velocity": "velocity",
                         "/quaternion": "dimensionless"}

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


def _decode(value) -> str:
    if isinstance(value, bytes):
        return value.decode("utf-8", "replace")
    if isinstance(value, np.ndarray) and value.shape == ():
        return _decode(value[()])
    return str(value)


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
            raise TelemetryError(path, "/", f"root attribute 'schema' is missing; compare reads {NAVIGATION_SCHEMA} "
                                            f"(sizefx navigate -o) or {TELEMETRY_SCHEMA} with /reference/position")
        declared = _decode(h5.attrs["schema"])
        if declared == NAVIGATION_SCHEMA:
            return _read_navigation(path, h5)
    if declared == TELEMETRY_SCHEMA:
        return _read_telemetry_track(path)
    raise TelemetryError(path, "/", f"root attribute schema is '{declared}'; compare reads {NAVIGATION_SCHEMA} "
                                    f"(sizefx navigate -o) or {TELEMETRY_SCHEMA} with /reference/position")


def _nav_dataset(path: Path, h5: h5py.File, name: str, rows: dict) -> np.ndarray:
    """One dataset of a navigation file, checked against its contract entry; float64, SI units.

    ``rows`` binds the contract's row symbol (``"M"``) to the first dataset's length, so that
    every later dataset must share the time axis.
    """
    spec = load_schema(NAVIGATION_SCHEMA)["datasets"][name]
    if name not in h5:
        raise TelemetryError(path, name, "dataset is missing; sizefx navigate -o writes it")
    link = h5.get(name, getlink=True)
    if isinstance(link, h5py.ExternalLink):
        raise TelemetryError(path, name, f"is an HDF5 external link to {link.filename}:{link.path}; "
                                         "navigation files must be self-contained")
    dset = h5[name]
    if not isinstance(dset, h5py.Dataset):
        raise TelemetryError(path, name, f"is a {type(dset).__name__}, expected a dataset")
    if dset.is_virtual or dset.external:
        raise TelemetryError(path, name, "keeps its data in other files; store the data in this file")
    shape = spec["shape"]
    if dset.ndim != len(shape) or any(isinstance(w, int) and w != g for w, g in zip(shape, dset.shape)):
        raise TelemetryError(path, name, f"has shape {dset.shape}; expected [{', '.join(map(str, shape))}]")
    bound = rows.setdefault(shape[0], dset.shape[0])
    if dset.shape[0] != bound:
        raise TelemetryError(path, name, f"has {dset.shape[0]} rows but /time has {bound}; "
                                         "all datasets share the time axis")
    if dset.dtype.kind not in "fiu":
        raise TelemetryError(path, name, f"has dtype {dset.dtype}; expected numbers (float64)")
    # The navigation contract allows its own units only (an absent attribute means them); the
    # telemetry contract's units table converts them to SI.
    units = dset.attrs.get("units")
    if units is not None and normalise_units(_decode(units)) != normalise_units(spec["units"]):
        raise TelemetryError(path, name, f"has units '{_decode(units)}'; {NAVIGATION_SCHEMA} stores "
                                         f"'{spec['units']}'")
    factor = unit_factor(NAVIGATION_QUANTITIES[name], spec["units"])
    try:
        data = np.asarray(dset[()], dtype=np.float64)
    except OSError as exc:
        raise TelemetryError(path, name, f"cannot be read ({exc}); the file is truncated or corrupt") from None
    bad = ~np.isfinite(data)
    if bad.any():
        first = int(np.argwhere(bad)[0][0])
        raise TelemetryError(path, name, f"holds {int(bad.sum())} NaN/Inf values, the first at row {first}")
    return data * np.asarray(factor, dtype=float)


def _read_navigation(path: Path, h5: h5py.File) -> Track:
    rows: dict = {}
    t = _nav_dataset(path, h5, "/time", rows)
    if t.shape[0] < 2:
        raise TelemetryError(path, "/time", f"holds {t.shape[0]} sample; a track needs at least 2")
    step = np.diff(t)
    if np.any(step <= 0.0):
        k = int(np.flatnonzero(step <= 0.0)[0]) + 1
        raise TelemetryError(path, "/time", f"is not strictly increasing at row {k} ({t[k - 1]:.6f} s -> "
                                            f"{t[k]:.6f} s)")
    pos = _nav_dataset(path, h5, "/position", rows)  # latitude [rad], longitude [rad], height [m]
    outside = np.abs(pos[:, 0]) > 0.5 * np.pi
    if outside.any():
        k = int(np.flatnonzero(outside)[0])
        raise TelemetryError(path, "/position", f"latitude {np.degrees(pos[k, 0]):g} deg at row {k} is outside "
                                                "[-90, 90]; columns are latitude [deg], longitude [deg], height [m]")
    vel = _nav_dataset(path, h5, "/velocity", rows)
    quat = _nav_dataset(path, h5, "/quaternion", rows)
    norm = np.linalg.norm(quat, axis=1)
    k = int(np.argmax(np.abs(norm - 1.0)))
    if abs(norm[k] - 1.0) > QUATERNION_NORM_TOLERANCE:
        raise TelemetryError(path, "/quaternion", f"row {k} has norm {norm[k]:.9g}; q_nb must be unit "
                                                  "(scalar-first [w, x, y, z])")
    return Track(t, pos[:, 0], pos[:, 1], pos[:, 2], vel, quat / norm[:, None], name=str(path), time_dataset="/time")


def _read_telemetry_track(path: Path) -> Track:
    tel = read_telemetry(path, allow_gaps=True)
    ref = tel.reference
    if ref is None:
        raise TelemetryError(path, "/reference", "group is missing; compare needs /reference/position "
                                                 "(latitude, longitude, height) or a navigation file")
    if not ref.has_position:
        raise TelemetryError(path, "/reference/position", "dataset is missing; compare needs the reference "
                                                          "position (latitude, longitude, height) of a telemetry file")
    notes = []
    quat = ref.quat_nb
    if tel.source and tel.source.get("reference_is_approximate"):
        # As sizefx navigate does: an importer marked the attitude as approximate (e.g. PSINS's).
        quat = None
        notes.append(f"{path}: the reference attitude is marked approximate (/source reference_is_approximate); "
                     "attitude not compared")
    return Track(ref.time_s, ref.lat_rad, ref.lon_rad, ref.height_m, ref.velocity_n_mps, quat, name=str(path),
                 time_dataset="/reference/time", notes=notes)
