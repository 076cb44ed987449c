"""Compare navigation solutions: ``sizefx compare A B [--reference REF]``.

The seed paper's question is how far a solution navigated with the size effect
compensated and one navigated without it diverge, and how far each is from the
truth. This module answers it for any two tracks:

1. *Reading* (:func:`read_track`): a ``sizefx/navigation/1`` file (the output
   of ``sizefx navigate -o``) or a ``sizefx/telemetry/1`` file with
   ``/reference/position``, detected by the root attribute ``schema``, becomes
   a :class:`Track` in SI units.
2. *Numerics* (:func:`compare` and the array functions it uses): A against B on
   A's time stamps inside the overlap of both spans, B interpolated (linearly
   for position and velocity, by slerp for attitude). No file access here.
3. *Report* (:func:`format_comparison`, :func:`to_json`, :func:`run`): text, a
   ``sizefx/comparison/1`` JSON document checked against
   ``data-schemas/comparison-1.json``, atomic outputs; the figures are drawn by
   :mod:`sizefx.compare.plots`.

Differences are always A minus B. Attitude differences compare each solution's
``q_nb`` in its own local NED frame, as the navigation error reports of
``sizefx navigate`` do (the two local frames differ by distance / Earth
radius: 0.009 deg per km of separation).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from .. import __version__, earth
from .plots import plot_names, pyplot, write_plots
from ..constants import METRES_PER_NMI, QUATERNION_NORM_TOLERANCE, WGS84_A_M, WGS84_E2
from ..errors import OutputError, TelemetryError
from ..io.files import atomic_output, check_output_path
from ..rotation import (
    mat_to_euler,
    quat_conjugate,
    quat_interp,
    quat_multiply,
    quat_to_mat,
)
from ..io.schema import TELEMETRY_SCHEMA, check_document, load_schema, normalise_units
from ..io.telemetry import open_hdf5, read_telemetry

__all__ = [
    "COMPARISON_SCHEMA",
    "MIN_GROUND_SPEED_MPS",
    "NAVIGATION_SCHEMA",
    "CompareReport",
    "Comparison",
    "Track",
    "along_cross_track_m",
    "compare",
    "format_comparison",
    "format_report",
    "horizontal_offset_m",
    "read_track",
    "run",
    "surface_ecef_m",
    "to_json",
    "velocity_from_position",
]

COMPARISON_SCHEMA = "sizefx/comparison/1"
NAVIGATION_SCHEMA = "sizefx/navigation/1"

#: Below this ground speed of B [m/s] its direction of motion is not defined well enough to split
#: A - B into along- and cross-track parts: at rest, or hovering, the direction of B's velocity
#: (or of its position differences) is that of noise and vibration, and turns from sample to sample.
MIN_GROUND_SPEED_MPS = 0.5

#: Slack [s] on the ends of the time overlap: stamps of the same instant written by different
#: programs (k / rate against a running sum of steps) differ by float64 rounding, about 1e-12 s
#: after an hour; a microsecond is far below any sample period the contracts allow (<= 100 kHz).
TIME_SLACK_S = 1e-6

#: Minimum number of A's samples inside the overlap: a difference history needs a start and an end.
MIN_OVERLAP_SAMPLES = 2

#: B is "sparser" than A when its median step exceeds A's by this factor; its interpolation
#: between samples then shows in the differences, and the report says so.
SPARSE_FACTOR = 1.5

# --------------------------------------------------------------------------- tracks


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


def _open_hdf5(path: Path) -> h5py.File:
    return open_hdf5(path, f"compare reads {NAVIGATION_SCHEMA} (sizefx navigate -o) or {TELEMETRY_SCHEMA} files")


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
    with _open_hdf5(path) as h5:
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
    """One dataset of a navigation file, checked against its contract entry; float64, contract units."""
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
    units = dset.attrs.get("units")
    if units is not None and normalise_units(_decode(units)) != normalise_units(spec["units"]):
        raise TelemetryError(path, name, f"has units '{_decode(units)}'; {NAVIGATION_SCHEMA} stores "
                                         f"'{spec['units']}'")
    try:
        data = np.asarray(dset[()], dtype=np.float64)
    except OSError as exc:
        raise TelemetryError(path, name, f"cannot be read ({exc}); the file is truncated or corrupt") from None
    bad = ~np.isfinite(data)
    if bad.any():
        first = int(np.argwhere(bad)[0][0])
        raise TelemetryError(path, name, f"holds {int(bad.sum())} NaN/Inf values, the first at row {first}")
    return data


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
    pos = _nav_dataset(path, h5, "/position", rows)
    if np.any(np.abs(pos[:, 0]) > 90.0):
        k = int(np.flatnonzero(np.abs(pos[:, 0]) > 90.0)[0])
        raise TelemetryError(path, "/position", f"latitude {pos[k, 0]:g} deg at row {k} is outside [-90, 90]; "
                                                "columns are latitude [deg], longitude [deg], height [m]")
    vel = _nav_dataset(path, h5, "/velocity", rows)
    quat = _nav_dataset(path, h5, "/quaternion", rows)
    norm = np.linalg.norm(quat, axis=1)
    k = int(np.argmax(np.abs(norm - 1.0)))
    if abs(norm[k] - 1.0) > QUATERNION_NORM_TOLERANCE:
        raise TelemetryError(path, "/quaternion", f"row {k} has norm {norm[k]:.9g}; q_nb must be unit "
                                                  "(scalar-first [w, x, y, z])")
    return Track(t, np.radians(pos[:, 0]), np.radians(pos[:, 1]), pos[:, 2], vel, quat / norm[:, None],
                 name=str(path), time_dataset="/time")


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


# --------------------------------------------------------------------------- numerics (arrays in, arrays out)


def surface_ecef_m(lat_rad, lon_rad) -> np.ndarray:
    """ECEF position [m], shape ``[..., 3]``, of points on the WGS-84 ellipsoid surface (h = 0).

    ``x = N cos(lat) cos(lon), y = N cos(lat) sin(lon), z = N (1 - e^2) sin(lat)``,
    ``N = a / sqrt(1 - e^2 sin^2(lat))`` (Groves 2013, eq. 2.112 with h = 0).
    """
    lat = np.asarray(lat_rad, dtype=float)
    lon = np.asarray(lon_rad, dtype=float)
    n = WGS84_A_M / np.sqrt(1.0 - WGS84_E2 * np.sin(lat) ** 2)
    return np.stack([n * np.cos(lat) * np.cos(lon), n * np.cos(lat) * np.sin(lon),
                     n * (1.0 - WGS84_E2) * np.sin(lat)], axis=-1)


def horizontal_offset_m(lat_a_rad, lon_a_rad, lat_b_rad, lon_b_rad):
    """Horizontal distance from B to A, and its north and east components at B.

    Both points are placed on the WGS-84 surface (h = 0, so height differences do
    not enter) and the distance is the straight line (chord) between them in ECEF.
    Against the distance along the surface ``s`` the chord is short by
    ``s^3 / (24 R^2)`` (R the radius of curvature along the line): 1.0 mm at 10 km,
    1.0 m at 100 km (``tests/test_compare.py`` pins this on the equator and a meridian).

    Returns
    -------
    chord_m : ndarray [...]
        ``|p_a - p_b|`` [m].
    north_m, east_m : ndarray [...]
        ``p_a - p_b`` resolved along B's local north and east [m]. They omit the
        chord's component along B's vertical (``s^2 / (2 R)``, 7.8 m at 10 km), so
        ``hypot(north, east)`` is short of the chord by about ``s^3 / (8 R^2)``
        (3 mm at 10 km).
    """
    lat_b = np.asarray(lat_b_rad, dtype=float)
    lon_b = np.asarray(lon_b_rad, dtype=float)
    d_e = surface_ecef_m(lat_a_rad, lon_a_rad) - surface_ecef_m(lat_b, lon_b)
    sl, cl, so, co = np.sin(lat_b), np.cos(lat_b), np.sin(lon_b), np.cos(lon_b)
    north = -sl * co * d_e[..., 0] - sl * so * d_e[..., 1] + cl * d_e[..., 2]
    east = -so * d_e[..., 0] + co * d_e[..., 1]
    return np.linalg.norm(d_e, axis=-1), north, east


def along_cross_track_m(north_m, east_m, v_n_b_mps, min_speed_mps: float = MIN_GROUND_SPEED_MPS):
    """Split a horizontal offset A - B into along- and cross-track parts of B's motion.

    With B's ground velocity ``(v_N, v_E)`` and speed ``V``:
    ``along = (north v_N + east v_E) / V`` (positive: A ahead of B) and
    ``cross = (east v_N - north v_E) / V`` (positive: A to the right of B's track,
    looking along it; flying north, right is east).

    Parameters
    ----------
    north_m, east_m : ndarray [K]
        Offset of A from B along B's local north and east [m].
    v_n_b_mps : ndarray [K, 3]
        B's NED velocity [m/s] (only north and east are used).
    min_speed_mps : float
        Below this ground speed the direction is undefined: NaN.

    Returns
    -------
    along_m, cross_m : ndarray [K]
        NaN where B's ground speed is under ``min_speed_mps``.
    """
    v = np.asarray(v_n_b_mps, dtype=float)
    speed = np.hypot(v[:, 0], v[:, 1])
    ok = speed >= min_speed_mps
    with np.errstate(invalid="ignore", divide="ignore"):
        along = np.where(ok, (north_m * v[:, 0] + east_m * v[:, 1]) / speed, np.nan)
        cross = np.where(ok, (east_m * v[:, 0] - north_m * v[:, 1]) / speed, np.nan)
    return along, cross


def velocity_from_position(time_s, lat_rad, lon_rad, height_m) -> np.ndarray:
    """NED velocity [m/s], ``[M, 3]``, from positions by central differences.

    ``v_N = lat' (R_M + h)``, ``v_E = lon' (R_T + h) cos(lat)``, ``v_D = -h'``
    (Groves 2013, eq. 2.111), derivatives by :func:`numpy.gradient` (second order
    inside, also for uneven steps; first order at the two ends). Longitude is unwrapped
    first, so a track across +-180 deg is differentiated correctly.
    """
    t = np.asarray(time_s, dtype=float)
    lat = np.asarray(lat_rad, dtype=float)
    h = np.asarray(height_m, dtype=float)
    r_mer, r_tr = earth.radii_m(lat)
    return np.column_stack([np.gradient(lat, t) * (r_mer + h),
                            np.gradient(np.unwrap(np.asarray(lon_rad, dtype=float)), t) * (r_tr + h) * np.cos(lat),
                            -np.gradient(h, t)])


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
    spans = (f"{a.time_s[0]:.3f}..{a.time_s[-1]:.3f} s against {b.name} {b.time_s[0]:.3f}..{b.time_s[-1]:.3f} s "
             f"({b.time_dataset})")
    if sel.size == 0:
        raise TelemetryError(a.name, a.time_dataset, f"no time overlap: {spans}; compare solutions of the same "
                                                     "record on the same clock")
    if sel.size < MIN_OVERLAP_SAMPLES:
        raise TelemetryError(a.name, a.time_dataset, f"only {sel.size} sample inside the time overlap: {spans}; "
                                                     f"need at least {MIN_OVERLAP_SAMPLES}")
    notes = [*a.notes, *b.notes]
    t = a.time_s[sel]
    derived = {"a": a.vel_n_mps is None, "b": b.vel_n_mps is None}
    vel_a = a.vel_n_mps if a.vel_n_mps is not None else velocity_from_position(a.time_s, a.lat_rad, a.lon_rad,
                                                                               a.height_m)
    vel_b = b.vel_n_mps if b.vel_n_mps is not None else velocity_from_position(b.time_s, b.lat_rad, b.lon_rad,
                                                                               b.height_m)
    for key, which in (("a", a), ("b", b)):
        if derived[key]:
            notes.append(f"{which.name} has no velocity: derived from its positions by central differences")
    lat_b, lon_b, h_b, v_b, q_b = _at(b, t, vel_b)
    if b.median_step_s > SPARSE_FACTOR * a.median_step_s:
        notes.append(f"{b.name} is sampled every {b.median_step_s:.4g} s, sparser than {a.name} "
                     f"({a.median_step_s:.4g} s): differences between its samples include its linear interpolation")

    horiz, north, east = horizontal_offset_m(a.lat_rad[sel], a.lon_rad[sel], lat_b, lon_b)
    if track is None or track is b:
        v_track, track_name = v_b, b.name
    else:
        vel_t = track.vel_n_mps if track.vel_n_mps is not None else velocity_from_position(
            track.time_s, track.lat_rad, track.lon_rad, track.height_m)
        v_track, track_name = _at(track, t, vel_t)[3], track.name
    along, cross = along_cross_track_m(north, east, v_track)
    span_a, span_b = a.time_s[-1] - a.time_s[0], b.time_s[-1] - b.time_s[0]
    covered = (t[-1] - t[0]) / max(min(span_a, span_b), 1e-300)
    if covered < 0.9:
        notes.append(f"the compared span ({t[0]:.1f}..{t[-1]:.1f} s) covers {100 * covered:.0f} % of the shorter "
                     "record: final figures are at its end, not at the end of either record")
    undefined = int(np.count_nonzero(np.isnan(along)))
    if undefined:
        notes.append(f"along/cross-track undefined at {undefined} of {t.size} samples where the ground speed of "
                     f"{track_name} is under {MIN_GROUND_SPEED_MPS:g} m/s (reported as null)")
    dh = a.height_m[sel] - h_b
    v_a = vel_a[sel]
    dv = v_a - v_b
    dgs = np.hypot(v_a[:, 0], v_a[:, 1]) - np.hypot(v_b[:, 0], v_b[:, 1])
    att = None
    if a.quat_nb is not None and q_b is not None:
        roll_a, pitch_a, head_a = mat_to_euler(quat_to_mat(a.quat_nb[sel]))
        roll_b, pitch_b, head_b = mat_to_euler(quat_to_mat(q_b))
        att = np.column_stack([_wrap_pi(roll_a - roll_b), _wrap_pi(pitch_a - pitch_b), _wrap_pi(head_a - head_b),
                               _rotation_angle_rad(a.quat_nb[sel], q_b)])
    else:
        missing = a.name if a.quat_nb is None else b.name
        notes.append(f"{missing} has no attitude: attitude not compared")

    elapsed = float(t[-1] - t[0])
    k_max = int(np.argmax(horiz))
    per_hour = 3600.0 / elapsed / METRES_PER_NMI if elapsed > 0.0 else float("nan")
    summary = {
        "label": label, "a": a.name, "b": b.name, "samples": int(t.size),
        "time_start_s": float(t[0]), "time_end_s": float(t[-1]), "elapsed_s": elapsed,
        "horizontal_m": {**_magnitude_stats(horiz), "time_of_max_s": float(t[k_max])},
        "along_track_m": _signed_stats(along),
        "cross_track_m": _signed_stats(cross),
        "track_defined_samples": int(t.size - undefined),
        "drift_nmi_per_h": {"final": _num(horiz[-1] * per_hour), "max": _num(horiz[k_max] * per_hour)},
        "height_m": _signed_stats(dh),
        "velocity_mps": {"north": _signed_stats(dv[:, 0]), "east": _signed_stats(dv[:, 1]),
                         "down": _signed_stats(dv[:, 2]), "ground_speed": _signed_stats(dgs)},
        "velocity_derived": derived,
        "attitude_deg": None if att is None else {
            "roll": _signed_stats(np.degrees(att[:, 0])), "pitch": _signed_stats(np.degrees(att[:, 1])),
            "heading": _signed_stats(np.degrees(att[:, 2])), "total": _magnitude_stats(np.degrees(att[:, 3]))},
        "notes": notes,
    }
    return Comparison(label, a.name, b.name, t, horiz, north, east, along, cross, dh, dv, dgs, att, derived,
                      summary, notes)


# --------------------------------------------------------------------------- text


def _fmt(x, spec: str = ".4g") -> str:
    return "n/a" if x is None else format(x, spec)


def format_comparison(result: Comparison) -> str:
    """Several lines of text: the figures of one comparison with their units."""
    s = result.summary
    one, two = result.pair
    h = s["horizontal_m"]
    drift = s["drift_nmi_per_h"]
    lines = [
        (f"{s['label']}: {s['a']} minus {s['b']} on {s['samples']} samples of {one}, "
         f"t = {s['time_start_s']:.3f} .. {s['time_end_s']:.3f} s ({s['elapsed_s'] / 60.0:.2f} min)"),
        (f"  horizontal distance: final {_fmt(h['final'])} m, max {_fmt(h['max'])} m at t = "
         f"{h['time_of_max_s']:.3f} s, RMS {_fmt(h['rms'])} m"),
        f"  drift: final {_fmt(drift['final'])} nmi/h, max {_fmt(drift['max'])} nmi/h (distance / elapsed time)",
    ]
    for key, what in (("along_track_m", f"along track ({one} ahead +)"),
                      ("cross_track_m", f"cross track ({one} right of {two}'s track +)")):
        st = s[key]
        lines.append(f"  {what}: final {_fmt(st['final'])} m, max |.| {_fmt(st['max_abs'])} m, "
                     f"RMS {_fmt(st['rms'])} m")
    if s["track_defined_samples"] < s["samples"]:
        lines.append(f"    (n/a: along/cross track undefined at {s['samples'] - s['track_defined_samples']} samples, "
                     f"{two} slower than {MIN_GROUND_SPEED_MPS:g} m/s)")
    st = s["height_m"]
    lines.append(f"  height: final {_fmt(st['final'])} m, RMS {_fmt(st['rms'])} m, max |.| {_fmt(st['max_abs'])} m")
    v = s["velocity_mps"]
    lines.append("  velocity N / E / D: final " + " / ".join(_fmt(v[k]["final"]) for k in ("north", "east", "down"))
                 + " m/s, RMS " + " / ".join(_fmt(v[k]["rms"]) for k in ("north", "east", "down")) + " m/s")
    lines.append(f"  ground speed: final {_fmt(v['ground_speed']['final'])} m/s, "
                 f"RMS {_fmt(v['ground_speed']['rms'])} m/s")
    att = s["attitude_deg"]
    if att is not None:
        names = ("roll", "pitch", "heading")
        lines.append("  attitude roll / pitch / heading: final " + " / ".join(_fmt(att[k]["final"]) for k in names)
                     + " deg, RMS " + " / ".join(_fmt(att[k]["rms"]) for k in names)
                     + " deg, max |.| " + " / ".join(_fmt(att[k]["max_abs"]) for k in names) + " deg")
        tot = att["total"]
        lines.append(f"  attitude rotation angle: final {_fmt(tot['final'])} deg, RMS {_fmt(tot['rms'])} deg, "
                     f"max {_fmt(tot['max'])} deg")
    lines += [f"  note: {n}" for n in s["notes"]]
    return "\n".join(lines)


@dataclass
class CompareReport:
    """What :func:`run` found: the comparisons in order, the JSON document, the figures written."""

    inputs: dict  #: {"a": path, "b": path, "reference": path or None}
    comparisons: list  #: [Comparison]: A vs B, or A vs REF, B vs REF, A vs B
    document: dict  #: the sizefx/comparison/1 document
    tracks: dict  #: {"A": Track, "B": Track, "REF": Track}
    plots: list = field(default_factory=list)  #: [Path]


def format_report(report: CompareReport) -> str:
    """All comparisons of a run, and with a reference the divergence in one line."""
    blocks = [format_comparison(c) for c in report.comparisons]
    if report.inputs.get("reference"):
        by = {c.label: c.summary["horizontal_m"]["final"] for c in report.comparisons}
        blocks.append(f"final horizontal distance: A from REF {_fmt(by['A vs REF'])} m, B from REF "
                      f"{_fmt(by['B vs REF'])} m; A and B diverge by {_fmt(by['A vs B'])} m")
    return "\n".join(blocks)


# --------------------------------------------------------------------------- JSON


def to_json(comparisons, inputs: dict, plots=()) -> dict:
    """The ``sizefx/comparison/1`` document (checked against ``data-schemas/comparison-1.json``)."""
    doc = {
        "schema": COMPARISON_SCHEMA,
        "sizefx_version": __version__,
        "inputs": {"a": str(inputs["a"]), "b": str(inputs["b"]),
                   "reference": None if inputs.get("reference") is None else str(inputs["reference"])},
        "units": {"distance": "m", "time": "s", "drift": "nmi/h (1852 m)", "velocity": "m/s", "angle": "deg",
                  "sign": "each comparison is its a minus its b; along track positive when a is ahead, cross track "
                          "positive when a is right of b's track"},
        "min_ground_speed_mps": MIN_GROUND_SPEED_MPS,
        "comparisons": [c.summary for c in comparisons],
        "plots": [str(p) for p in plots],
    }
    _check_document(doc)
    return doc


def _check_document(doc: dict):
    """Our writer against our contract (a bug if it fails)."""
    check_document(doc, COMPARISON_SCHEMA)


# --------------------------------------------------------------------------- entry point


def _prepare_plot_dir(plots_dir, inputs) -> Path:
    out = Path(plots_dir)
    if out.exists() and not out.is_dir():
        raise OutputError(f"{out}: --plots needs a directory, and this is a file")
    for inp in inputs:
        if inp is not None and out.exists() and Path(inp).exists() and out.resolve() == Path(inp).resolve():
            raise OutputError(f"{out}: the plot directory is an input")
    parent = out.parent if str(out.parent) else Path(".")
    if not parent.is_dir():
        raise OutputError(f"{out}: directory {parent} does not exist; create it first")
    return out


def run(a, b, *, reference=None, json_path=None, plots_dir=None, force: bool = False) -> CompareReport:
    """Entry point of ``sizefx compare``: read, compare, write what was asked; return the report.

    Without ``reference``: A vs B. With it: A vs REF, B vs REF and A vs B (how far
    the two solutions diverge, and how far each is from the truth). ``plots_dir`` is
    created if missing (its parent must exist); its PNGs and ``json_path`` replace
    existing files only with ``force``, and never an input.
    """
    inputs = [a, b, reference]
    if json_path:
        check_output_path(json_path, inputs=inputs, force=force)
    if plots_dir:
        pyplot()  # fail before the work when matplotlib is missing
        _prepare_plot_dir(plots_dir, inputs)
    tracks = {"A": read_track(a), "B": read_track(b)}
    if reference is None:
        comparisons = [compare(tracks["A"], tracks["B"], "A vs B")]
    else:
        tracks["REF"] = read_track(reference)
        comparisons = [compare(tracks["A"], tracks["REF"], "A vs REF"), compare(tracks["B"], tracks["REF"], "B vs REF"),
                       compare(tracks["A"], tracks["B"], "A vs B", track=tracks["REF"])]
    pngs = []
    if plots_dir:
        out_dir = Path(plots_dir)
        pngs = [out_dir / name for name in plot_names(comparisons)]
        if out_dir.is_dir():  # a new directory holds nothing to replace
            for png in pngs:
                check_output_path(png, inputs=inputs, force=force)
    ins = {"a": str(a), "b": str(b), "reference": None if reference is None else str(reference)}
    document = to_json(comparisons, ins, pngs)
    report = CompareReport(ins, comparisons, document, tracks)
    if plots_dir:
        Path(plots_dir).mkdir(exist_ok=True)
        report.plots = write_plots(comparisons, tracks, plots_dir)
    if json_path:
        with atomic_output(json_path, inputs=inputs, force=force) as tmp:
            Path(tmp).write_text(json.dumps(document, indent=2, allow_nan=False) + "\n", encoding="utf-8")
    return report
