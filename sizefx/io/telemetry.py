"""Read, validate and write ``sizefx/telemetry/1`` HDF5 files.

Everything about names, shapes, dtypes and units comes from
``data-schemas/telemetry-1.json`` via :mod:`sizefx.io.schema`. The reader converts
to SI and refuses bad input with a :class:`~sizefx.errors.TelemetryError`
whose message names the file, the dataset and the problem, and says how to fix
it. The writer writes atomically (see :mod:`sizefx.io.files`) and in chunks, so
a simulator or importer can stream a long record without holding it all.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace
from pathlib import Path

import h5py
import numpy as np

from ..constants import GAP_FACTOR, QUATERNION_NORM_TOLERANCE
from ..errors import ConfigError, TelemetryError
from .files import atomic_output
from .schema import TELEMETRY_SCHEMA, allowed_units, load_schema, normalise_units, unit_factor

__all__ = [
    "Reference",
    "Site",
    "open_hdf5",
    "TelemetryStream",
    "ReferenceStream",
    "Telemetry",
    "read_telemetry",
    "TelemetryWriter",
    "write_telemetry",
    "Gap",
    "Segment",
    "nominal_period_s",
    "find_imu_gaps",
    "imu_segments",
    "refuse_gaps",
]

#: HDF5 chunk length (rows) of written datasets: 2^16 rows of 3 float64 is
#: 1.5 MiB, large enough for fast sequential reads and small enough to stream.
WRITE_CHUNK_ROWS = 1 << 16

#: The nominal sample period is the median step of the first this many rows: one definition for a
#: whole read and a streamed one (which must know it before it has read the record), and for the
#: importers. 2^16 steps (41 s at 1600 Hz) make the median as good as the whole record's.
NOMINAL_ROWS = 1 << 16

#: A declared gap matches one in the data when its time and its length agree within this
#: fraction of the nominal period (the declaration cannot then name the neighbouring step).
GAP_MATCH_TOLERANCE = 0.5

#: Rows read at a time when a stream scans /imu/time for gaps at open (8 MiB of float64).
SCAN_ROWS = 1 << 20


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


def _count(n: int, noun: str) -> str:
    """``"1 gap"``, ``"8 gaps"``."""
    return f"{n} {noun}" + ("" if n == 1 else "s")


def nominal_period_s(time_s) -> float:
    """The nominal sample period [s]: the median step of the first :data:`NOMINAL_ROWS` rows."""
    return float(np.median(np.diff(np.asarray(time_s[: NOMINAL_ROWS + 1], dtype=float))))


def _gap_rows(time_s: np.ndarray, nominal_s: float) -> np.ndarray:
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
        for k in _gap_rows(t, nominal):
            if int(k) not in out:
                out[int(k)] = Gap(name, int(k), float(t[k - 1]), float(t[k] - t[k - 1]),
                                  declared=declared and name == "/imu/time")
    return [out[k] for k in sorted(out)]


def _segment_bounds(n_samples: int, gaps) -> list[tuple[int, int]]:
    cuts = sorted({g.index for g in gaps if g.dataset.startswith("/imu")})
    return list(zip([0] + cuts, cuts + [n_samples]))


def imu_segments(n_samples: int, gaps, time_at) -> list[Segment]:
    """The continuous segments an IMU record of ``n_samples`` rows is cut into by its ``gaps``.

    ``time_at(row)`` returns the time of a row (an array lookup, or a dataset read).
    """
    bounds = _segment_bounds(n_samples, gaps)
    return [Segment(k + 1, a, b, float(time_at(a)), float(time_at(b - 1)), len(bounds))
            for k, (a, b) in enumerate(bounds)]


def _choose_segment(path, n_samples: int, gaps, number: int, time_at) -> Segment:
    """Segment ``number`` (1-based), or a one-line error naming the option and the file.

    Only the chosen segment's two end rows are looked up (a stream reads them from the file).
    """
    bounds = _segment_bounds(n_samples, gaps)
    n = len(bounds)
    if not 1 <= number <= n:
        listing = "it has no gaps: one segment, the whole record" if n == 1 else \
            f"its {n} continuous segments are numbered 1..{n} (sizefx inspect lists them)"
        raise ConfigError(f"--segment {number}: {path}: {listing}; give one of them")
    a, b = bounds[number - 1]
    seg = Segment(number, a, b, float(time_at(a)), float(time_at(b - 1)), n)
    if seg.samples < 2:
        raise ConfigError(f"--segment {number}: segment {number} of {path} holds {seg.samples} sample (row "
                          f"{seg.first_row}, t = {seg.start_s:.6f} s) between two gaps; choose a longer one "
                          "(sizefx inspect lists them)")
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
    what = "declared in /imu/gaps" if declared == len(imu) else \
        ("undeclared" if declared == 0 else f"{declared} of them declared in /imu/gaps")
    first = imu[0]
    raise TelemetryError(path, first.dataset,
                         f"has {_count(len(imu), 'gap')} ({what}; the first at row {first.index}, t = {first.time_s:.6f} s); "
                         f"{command} {why}: process one continuous segment with --segment K (1..{len(imu) + 1}, "
                         "as sizefx inspect numbers them)" + (", or pass --allow-gaps to bridge the gaps"
                                                              if bridge else ""))


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
    source: dict | None = None  #: provenance written by the importers (/source attributes)
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

    def continuous_pieces(self) -> list[tuple[Segment, "Telemetry"]]:
        """The record cut at its IMU gaps: each continuous segment with a record of its IMU rows
        (views, not copies; ``/reference``, site and provenance shared). One piece, the record
        itself, when it has no IMU gap."""
        imu_gaps = [g for g in self.gaps if g.dataset.startswith("/imu")]
        segments = imu_segments(self.n_samples, imu_gaps, self.time_s.__getitem__)
        if len(segments) == 1:
            return [(segments[0], self)]
        names = ("time_s", "gyro_rad_s", "accel_mps2", "dtheta_rad", "dvel_mps", "accel_time_s")
        others = [g for g in self.gaps if not g.dataset.startswith("/imu")]
        return [(s, replace(self, gaps=others, segment=s,
                            **{k: getattr(self, k)[s.first_row:s.stop_row] for k in names if getattr(self, k) is not None}))
                for s in segments]


# --------------------------------------------------------------------------- reading


def _attr_value(value):
    """An HDF5 attribute as plain Python (str, float, int, list)."""
    if isinstance(value, bytes):
        return value.decode("utf-8", "replace")
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def _attr_str(value) -> str:
    if isinstance(value, bytes):
        return value.decode("utf-8", "replace")
    if isinstance(value, np.ndarray) and value.shape == ():
        return _attr_str(value[()])
    return str(value)


class _Reader:
    """One validation pass over an open file; raises on the first problem."""

    def __init__(self, path: Path, h5: h5py.File, allow_gaps: bool, check_plausibility: bool):
        self.path = path
        self.h5 = h5
        self.schema = load_schema(TELEMETRY_SCHEMA)
        self.allow_gaps = allow_gaps
        self.check_plausibility = check_plausibility
        self.sizes: dict[str, int] = {}
        self.units: dict[str, str] = {}
        self.dtypes: dict[str, str] = {}
        self.gaps: list[Gap] = []

    def fail(self, dataset: str, problem: str):
        raise TelemetryError(self.path, dataset, problem)

    # -- structure ------------------------------------------------------------------
    def refuse_links_to_other_files(self):
        """Refuse external links, virtual datasets and external raw storage.

        A telemetry file must not make the tool read other files (a path in a
        link could point anywhere on the machine).
        """

        def walk(group: h5py.Group, prefix: str):
            for name in group:
                full = f"{prefix}/{name}" if prefix != "/" else f"/{name}"
                link = group.get(name, getlink=True)
                if isinstance(link, h5py.ExternalLink):
                    self.fail(full, f"is an HDF5 external link to {link.filename}:{link.path}; "
                                    "telemetry files must be self-contained (copy the data in with h5copy or h5py)")
                if isinstance(link, h5py.SoftLink):
                    continue  # resolved by name lookups inside this file; not followed here (no cycles)
                try:
                    obj = group[name]
                except (KeyError, OSError) as exc:
                    self.fail(full, f"cannot be opened ({exc}); the file may be truncated or corrupt")
                if isinstance(obj, h5py.Group):
                    walk(obj, full)
                elif isinstance(obj, h5py.Dataset):
                    if obj.is_virtual:
                        self.fail(full, "is an HDF5 virtual dataset (its data lives in other files); "
                                        "store the data in this file")
                    if obj.external:
                        self.fail(full, "stores its raw data in external files; store the data in this file")

        walk(self.h5, "/")

    def root_attributes(self):
        spec = self.schema["root_attributes"]
        attrs = self.h5.attrs
        if "schema" not in attrs:
            self.fail("/", f"root attribute 'schema' is missing; a telemetry file declares "
                           f"schema = \"{TELEMETRY_SCHEMA}\" (sizefx import converts other formats)")
        declared = _attr_str(attrs["schema"])
        if declared != spec["schema"]["value"]:
            self.fail("/", f"root attribute schema is '{declared}', expected '{TELEMETRY_SCHEMA}'")
        values = {}
        for key, rule in spec.items():
            if key == "schema" or key not in attrs:
                continue
            raw = attrs[key]
            if rule["type"] == "number":
                try:
                    val = float(np.asarray(raw).reshape(()))
                except (TypeError, ValueError):
                    self.fail("/", f"root attribute {key} = {raw!r} is not a number")
                if not np.isfinite(val) or not rule["min"] <= val <= rule["max"]:
                    self.fail("/", f"root attribute {key} = {val} is outside [{rule['min']}, {rule['max']}]")
                values[key] = val
            else:
                values[key] = _attr_str(raw)
        site_keys = ("latitude_deg", "longitude_deg", "height_m")
        present = [k for k in site_keys if k in values]
        if present and len(present) != 3:
            missing = [k for k in site_keys if k not in values]
            self.fail("/", f"root attributes give {', '.join(present)} but not {', '.join(missing)}; "
                           "give all three site attributes or none")
        return values

    # -- datasets -------------------------------------------------------------------
    def dataset(self, name: str, required: bool):
        """Read, check and convert one dataset listed in the schema; None if absent and optional."""
        handle = self.handle(name, required)
        if handle is None:
            return None
        return self.rows(name, handle, slice(None))

    def rows(self, name: str, handle, rows: slice, first_row: int = 0):
        """Rows ``rows`` of a dataset from :meth:`handle`, checked (finite) and in SI units.

        ``first_row`` numbers the rows in messages (the absolute row of ``rows.start``).
        """
        dset, factor = handle
        try:
            data = np.asarray(dset[rows], dtype=np.float64)
        except OSError as exc:
            self.fail(name, f"cannot be read ({exc}); the file is truncated or corrupt")
        if data.shape[0] == 0:
            self.fail(name, "holds no samples")
        bad = ~np.isfinite(data)
        if bad.any():
            first = int(np.argwhere(bad)[0][0]) + first_row
            self.fail(name, f"holds NaN/Inf values, the first at row {first}; "
                            "remove or interpolate them (or cut the record) before processing")
        return data * np.asarray(factor, dtype=float)

    def handle(self, name: str, required: bool):
        """``(h5py dataset, SI factor)`` of a dataset listed in the schema, its structure, dtype and units
        checked; None if absent and optional. The values are read by :meth:`rows`."""
        spec = self.schema["datasets"][name]
        if name not in self.h5:
            if required:
                self.fail(name, "dataset is missing")
            return None
        dset = self.h5[name]
        if not isinstance(dset, h5py.Dataset):
            self.fail(name, f"is a {type(dset).__name__}, expected a dataset")
        shape = spec["shape"]
        if dset.ndim != len(shape):
            self.fail(name, f"has rank {dset.ndim} (shape {dset.shape}); expected shape "
                            f"[{', '.join(map(str, shape))}]")
        for axis, (want, got) in enumerate(zip(shape, dset.shape)):
            if isinstance(want, int):
                if got != want:
                    self.fail(name, f"has shape {dset.shape}; axis {axis} must have length {want}")
            else:
                bound = self.sizes.setdefault(want, got)
                if got != bound:
                    self.fail(name, f"has {got} rows but its companions have {bound}; "
                                    "all datasets of a group share the time axis")
        if dset.dtype.name not in self.schema["dtypes"]:
            self.fail(name, f"has dtype {dset.dtype}; expected one of {', '.join(self.schema['dtypes'])} "
                            "(convert with numpy .astype(float))")
        quantity = spec["quantity"]
        units = dset.attrs.get("units")
        if units is None:
            if spec.get("units_required"):
                self.fail(name, f"has no 'units' attribute; set it to one of {', '.join(allowed_units(quantity))}")
            units = spec.get("default_units", next(iter(self.schema["units"][quantity])))
        units = normalise_units(_attr_str(units))
        factor = unit_factor(quantity, units)
        if factor is None:
            self.fail(name, f"units '{units}' are not known; use one of {', '.join(allowed_units(quantity))}")
        self.units[name] = units
        self.dtypes[name] = dset.dtype.name
        return dset, factor

    def check_time(self, name: str, t: np.ndarray, first_row: int = 0, nominal: float | None = None):
        """Check time stamps ``t`` (rows ``first_row ...`` of dataset ``name``); return ``(nominal, gaps)``.

        Strictly increasing, and (from row 0) at a plausible rate. ``nominal``: the record's nominal
        period when ``t`` is a later chunk (default: :func:`nominal_period_s` of ``t``). Gaps of a
        dataset whose policy is "report" are kept in ``self.gaps``; IMU gaps are returned to be
        settled together (:meth:`settle_imu_gaps`).
        """
        if first_row == 0 and t.shape[0] < 2:
            self.fail(name, f"holds {t.shape[0]} sample; at least 2 are needed to know the sample rate")
        dt = np.diff(t)
        dup = np.flatnonzero(dt == 0.0)
        if dup.size:
            k = int(dup[0]) + 1
            self.fail(name, f"has {dup.size} duplicated time stamps, the first at row {k + first_row} "
                            f"(t = {t[k]:.6f} s); drop the repeated samples")
        back = np.flatnonzero(dt < 0.0)
        if back.size:
            k = int(back[0]) + 1
            self.fail(name, f"is not strictly increasing: time goes back at row {k + first_row} "
                            f"({t[k - 1]:.6f} s -> {t[k]:.6f} s), {back.size} times in all; sort or split the record")
        spec = self.schema["datasets"][name]
        if first_row == 0:
            own = nominal_period_s(t)
            lo, hi = self.schema["plausibility"]["sample_rate_hz"]
            if self.check_plausibility and spec["rate_check"] and not lo <= 1.0 / own <= hi:
                self.fail(name, f"median time step is {own:g} s ({1.0 / own:g} Hz), outside "
                                f"{lo:g}..{hi:g} Hz; time must be in seconds (is it in ms or us?)")
            nominal = own if nominal is None else nominal
        gaps = [Gap(name, int(k) + first_row, float(t[k - 1]), float(t[k] - t[k - 1])) for k in _gap_rows(t, nominal)]
        if spec["gaps"] == "report":
            self.gaps.extend(gaps)
        return nominal, gaps

    def declared_gaps(self, n_samples: int):
        """``/imu/gaps`` as ``[G, 2]`` seconds (time before the gap, length), or None when absent."""
        handle = self.handle("/imu/gaps", required=False)
        if handle is None:
            return None
        rows = handle[0].shape[0]
        if rows == 0:
            return np.zeros((0, 2))
        if rows > n_samples - 1:
            self.fail("/imu/gaps", f"declares {rows} gaps in a record of {n_samples} samples; there can be at "
                                   f"most {n_samples - 1} (one per step)")
        return self.rows("/imu/gaps", handle, slice(None))

    def settle_imu_gaps(self, found: list, nominal: float, declared):
        """Count the IMU gaps once per row, match them with ``/imu/gaps``, refuse the undeclared ones
        (unless gaps are allowed), and keep them (first) in ``self.gaps``.

        ``found``: the gaps of ``/imu/time``, then those of ``/imu/accel_time`` (a dropout both show
        is one gap, named after ``/imu/time``). A declaration that does not match ``/imu/time``
        exactly is an error even with ``--allow-gaps``: the file contradicts itself.
        """
        by_row: dict[int, Gap] = {}
        for g in found:
            by_row.setdefault(g.index, g)
        gaps = [by_row[k] for k in sorted(by_row)]
        if declared is not None:
            self.match_declared_gaps(gaps, declared, nominal)
        loose = [g for g in gaps if not g.declared]
        if loose and not self.allow_gaps:
            g = loose[0]
            noun = "gap" if len(loose) == 1 else "gaps"
            which = f"undeclared {noun}" if declared is None else f"{noun} that /imu/gaps does not declare"
            self.fail(g.dataset, f"has {len(loose)} {which} longer than {GAP_FACTOR} sample periods "
                                 f"({nominal * 1e3:.4g} ms); the first at row {g.index} (t = {g.time_s:.6f} s, "
                                 f"{g.duration_s * 1e3:.4g} ms); pass --allow-gaps to proceed anyway")
        self.gaps[:0] = gaps

    def match_declared_gaps(self, gaps: list, declared: np.ndarray, nominal: float):
        """Mark the gaps ``/imu/gaps`` declares; fail, naming both, where it and ``/imu/time`` differ."""
        tol = GAP_MATCH_TOLERANCE * nominal
        on_time = [g for g in gaps if g.dataset == "/imu/time"]
        t_found = np.array([g.time_s for g in on_time])
        fix = ("re-import the source (sizefx import writes /imu/gaps from the data it finds), or delete /imu/gaps "
               "and pass --allow-gaps")
        for i, (t_d, length_d) in enumerate(declared):
            said = f"row {i} declares a gap after t = {t_d:.6f} s lasting {length_d * 1e3:.4g} ms"
            if not length_d > 0.0:
                self.fail("/imu/gaps", f"{said}; gap lengths are positive (columns: time before the gap [s], "
                                       "length [s])")
            if i and not t_d > declared[i - 1, 0]:
                self.fail("/imu/gaps", f"{said}, not after row {i - 1} (t = {declared[i - 1, 0]:.6f} s); "
                                       "rows are in time order")
            k = int(np.argmin(np.abs(t_found - t_d))) if t_found.size else -1
            if k < 0 or abs(t_found[k] - t_d) > tol:
                self.fail("/imu/gaps", f"{said}, but /imu/time has no gap there (its gaps: {t_found.size}); {fix}")
            g = on_time[k]
            if g.declared:
                self.fail("/imu/gaps", f"{said}, the same gap as row {i - 1}; declare each gap once")
            if abs(g.duration_s - length_d) > tol:
                self.fail("/imu/gaps", f"{said}, but the gap of /imu/time there (row {g.index}) lasts "
                                       f"{g.duration_s * 1e3:.4g} ms; {fix}")
            g.declared = True
        missing = [g for g in on_time if not g.declared]
        if missing:
            g = missing[0]
            self.fail("/imu/gaps", f"declares {declared.shape[0]} gaps but /imu/time has {len(on_time)}: the gap "
                                   f"at row {g.index} (t = {g.time_s:.6f} s, {g.duration_s * 1e3:.4g} ms) is not "
                                   f"declared; {fix}")

    def check_unit_quaternions(self, name: str, q: np.ndarray):
        err = np.abs(np.linalg.norm(q, axis=1) - 1.0)
        k = int(np.argmax(err))
        if err[k] > QUATERNION_NORM_TOLERANCE:
            self.fail(name, f"row {k} has norm {np.linalg.norm(q[k]):.9g}; quaternions must be unit "
                            f"(|q| - 1 within {QUATERNION_NORM_TOLERANCE:g}); normalise them, and check "
                            "the order is scalar-first [w, x, y, z]")
        return q / np.linalg.norm(q, axis=1, keepdims=True)

    def check_plausible(self, name: str, values: np.ndarray, key: str, what: str, units: str):
        lo, hi = self.schema["plausibility"][key]
        med = float(np.median(np.linalg.norm(values, axis=1)))
        if not lo <= med <= hi:
            quantity = self.schema["datasets"][name]["quantity"]
            base = unit_factor(quantity, units)
            # the units under which the same numbers would be plausible: the data look like those
            fits = [u for u, factor in self.schema["units"][quantity].items()
                    if u != units and lo <= med / base * factor <= hi]
            hint = (f"the data look like {fits[0]}: set the units attribute to '{fits[0]}'" if len(fits) == 1
                    else "the units attribute is probably wrong")
            self.fail(name, f"median |{what}| is {med:.4g} in SI after converting from '{units}', outside the "
                            f"plausible {lo:g}..{hi:g}; {hint}")


def open_hdf5(path: Path, hint: str) -> h5py.File:
    """Open ``path`` read-only, or raise a one-line error saying why it is not a readable HDF5 file.

    ``hint`` ends the message when the file is not HDF5 at all (what to do instead).
    """
    path = Path(path)
    if not path.exists():
        raise TelemetryError(path, "/", "file does not exist")
    if path.is_dir():
        raise TelemetryError(path, "/", "is a directory, not an HDF5 file")
    if path.stat().st_size == 0:
        raise TelemetryError(path, "/", "file is empty (0 bytes)")
    try:
        is_hdf5 = h5py.is_hdf5(path)
    except OSError:
        is_hdf5 = False
    if not is_hdf5:
        raise TelemetryError(path, "/", f"is not an HDF5 file (no HDF5 signature); {hint}")
    try:
        return h5py.File(path, "r")
    except OSError as exc:
        raise TelemetryError(path, "/", f"cannot be opened as HDF5 ({str(exc).splitlines()[0]}); "
                                        "the file is truncated or corrupt") from None


def read_telemetry(path, *, allow_gaps: bool = False, check_plausibility: bool = True,
                   segment: int | None = None) -> Telemetry:
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

    Raises
    ------
    TelemetryError
        For every violation of the contract, with a one-line message.
    ConfigError
        For a ``segment`` the record does not have.
    """
    path = Path(path)
    with open_hdf5(path, "convert it with sizefx import") as h5:
        r, attrs, form = _open_structure(path, h5, allow_gaps, check_plausibility)
        schema = r.schema
        time_s = r.dataset("/imu/time", required=True)
        nominal, found = r.check_time("/imu/time", time_s)
        accel_time = r.dataset("/imu/accel_time", required=False)
        if accel_time is not None:
            found += r.check_time("/imu/accel_time", accel_time, nominal=nominal)[1]
        r.settle_imu_gaps(found, nominal, r.declared_gaps(time_s.shape[0]))
        rows, seg, gaps = slice(None), None, r.gaps
        if segment is not None:
            seg = _choose_segment(path, time_s.shape[0], r.gaps, segment, time_s.__getitem__)
            rows = slice(seg.first_row, seg.stop_row)
            time_s = time_s[rows]
            accel_time = None if accel_time is None else accel_time[rows]
            gaps = [g for g in r.gaps if not g.dataset.startswith("/imu")]  # none inside a segment
        gyro_name, accel_name = schema["forms"][form]["datasets"]
        first = rows.start or 0
        gyro = r.rows(gyro_name, r.handle(gyro_name, required=True), rows, first)
        accel = r.rows(accel_name, r.handle(accel_name, required=True), rows, first)
        if check_plausibility:
            _check_magnitudes(r, form, nominal, gyro, accel)
        reference, source, simulation = _side_groups(r, h5)
    tel = Telemetry(
        time_s=time_s, form=form, accel_time_s=accel_time, reference=reference, site=_site(attrs),
        description=attrs.get("description", ""), simulation=simulation, source=source, path=str(path),
        stored_units=r.units, stored_dtypes=r.dtypes, gaps=gaps, segment=seg,
    )
    if form == "rates":
        tel.gyro_rad_s, tel.accel_mps2 = gyro, accel
    else:
        tel.dtheta_rad, tel.dvel_mps = gyro, accel
    return tel


def _open_structure(path, h5, allow_gaps, check_plausibility):
    """Links, root attributes, groups and the IMU form: ``(reader, root attributes, form)``."""
    r = _Reader(path, h5, allow_gaps, check_plausibility)
    r.refuse_links_to_other_files()
    attrs = r.root_attributes()
    schema = r.schema
    for gname, gspec in schema["groups"].items():
        if gname in h5 and not isinstance(h5[gname], h5py.Group):
            r.fail(gname, "must be a group")
        if gspec["required"] and gname not in h5:
            r.fail(gname, "group is missing; IMU samples belong in /imu")
    # IMU: exactly one form.
    present = {form: [d for d in spec["datasets"] if d in h5] for form, spec in schema["forms"].items()}
    complete = [form for form, names in present.items() if len(names) == len(schema["forms"][form]["datasets"])]
    if len(complete) == 2:
        r.fail("/imu", "holds both gyro/accel and dtheta/dvel; keep one form")
    if not complete:
        partial = [d for names in present.values() for d in names]
        if partial:
            form = next(f for f, names in present.items() if names)
            missing = [d for d in schema["forms"][form]["datasets"] if d not in h5]
            r.fail(missing[0], f"dataset is missing ({partial[0]} is present; {form} need both)")
        r.fail("/imu", "holds neither gyro+accel (rates) nor dtheta+dvel (increments)")
    return r, attrs, complete[0]


def _check_magnitudes(r, form, period, gyro, accel):
    gyro_name, accel_name = r.schema["forms"][form]["datasets"]
    f_est = accel if form == "rates" else accel / period
    w_est = gyro if form == "rates" else gyro / period
    r.check_plausible(accel_name, f_est, "median_specific_force_mps2", "specific force", r.units[accel_name])
    r.check_plausible(gyro_name, w_est, "median_angular_rate_rad_s", "angular rate", r.units[gyro_name])


def _side_groups(r, h5, reference: bool = True):
    """``/reference`` (read whole; None with ``reference=False``), ``/source`` and ``/simulation``."""
    want_reference = reference
    reference = None
    if want_reference and "/reference" in h5:
        ref_t = r.dataset("/reference/time", required=True)
        r.check_time("/reference/time", ref_t)
        quat = r.check_unit_quaternions("/reference/quaternion", r.dataset("/reference/quaternion", required=True))
        pos = r.dataset("/reference/position", required=False)
        vel = r.dataset("/reference/velocity", required=False)
        reference = Reference(time_s=ref_t, quat_nb=quat, velocity_n_mps=vel)
        if pos is not None:
            if np.any(np.abs(pos[:, 0]) > np.pi / 2):
                r.fail("/reference/position", "latitude outside [-90, 90] deg; columns are latitude, longitude, height")
            reference.lat_rad, reference.lon_rad, reference.height_m = pos[:, 0], pos[:, 1], pos[:, 2]
    source = None
    if "/source" in h5:
        source = {k: _attr_value(v) for k, v in h5["/source"].attrs.items()}
    simulation = None
    if "/simulation" in h5:
        sim_attrs = h5["/simulation"].attrs
        if "truth_json" not in sim_attrs:
            r.fail("/simulation", "attribute truth_json is missing")
        try:
            simulation = json.loads(_attr_str(sim_attrs["truth_json"]))
        except json.JSONDecodeError as exc:
            r.fail("/simulation", f"attribute truth_json is not valid JSON ({exc})")
    return reference, source, simulation


def _site(attrs):
    if "latitude_deg" not in attrs:
        return None
    return Site(np.radians(attrs["latitude_deg"]), np.radians(attrs["longitude_deg"]), attrs["height_m"])


class ReferenceStream:
    """``/reference`` of an open file, read a time window at a time (long records, dense references).

    At open: structure, units and the first and last stamps; the extremes of the position
    (for the stationary test) in one chunked pass. :meth:`window` returns the rows that
    bracket ``[t_lo, t_hi]`` (one more on each side) as a :class:`Reference`, after the
    checks :func:`read_telemetry` makes on the whole group (finite, strictly increasing
    time, unit quaternions, latitude range), naming absolute rows.
    """

    PASS_ROWS = 1 << 20

    def __init__(self, r: _Reader, h5):
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
            ref.lat_rad, ref.lon_rad, ref.height_m = (np.array([self.position_min[c], self.position_max[c]])
                                                      for c in range(3))
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

    def __init__(self, path, *, allow_gaps: bool = False, check_plausibility: bool = True,
                 segment: int | None = None):
        self.path = Path(path)
        self.h5 = open_hdf5(self.path, "convert it with sizefx import")
        try:
            r, attrs, form = _open_structure(self.path, self.h5, allow_gaps, check_plausibility)
            self._r = r
            self.form = form
            gyro_name, accel_name = r.schema["forms"][form]["datasets"]
            self.names = ("/imu/time", gyro_name, accel_name)
            self._handles = [r.handle(name, required=True) for name in self.names]
            self._accel_time = r.handle("/imu/accel_time", required=False)
            n_all = int(self._handles[0][0].shape[0])
            head = r.rows("/imu/time", self._handles[0], slice(0, min(n_all, NOMINAL_ROWS + 1)))
            nominal, _ = r.check_time("/imu/time", head)  # >= 2 samples, a plausible rate
            found = self._scan("/imu/time", self._handles[0], n_all, nominal)
            if self._accel_time is not None:
                found += self._scan("/imu/accel_time", self._accel_time, n_all, nominal)
            r.settle_imu_gaps(found, nominal, r.declared_gaps(n_all))
            self.gaps = r.gaps
            self.n_segments = len(_segment_bounds(n_all, self.gaps))
            self.segment = None
            self.first_row = 0  #: the file row of stream row 0 (a segment's first)
            self.n_samples = n_all
            if segment is not None:
                self.segment = _choose_segment(self.path, n_all, self.gaps, segment, self._time_at)
                self.first_row = self.segment.first_row
                self.n_samples = self.segment.samples
                self.gaps = []  # none inside a segment (the stream reads no reference gaps)
            self.sample_period_s = nominal
            if check_plausibility:
                probe = slice(self.first_row, self.first_row + min(self.n_samples, self.PROBE_ROWS))
                _check_magnitudes(r, form, nominal, r.rows(gyro_name, self._handles[1], probe, self.first_row),
                                  r.rows(accel_name, self._handles[2], probe, self.first_row))
            self.reference = ReferenceStream(r, self.h5) if "/reference" in self.h5 else None
            _, self.source, self.simulation = _side_groups(r, self.h5, reference=False)
            self.site = _site(attrs)
            self.description = attrs.get("description", "")
            self._last_t = None
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
                r.fail("/imu/time", f"has a gap at row {k} ({dt[gap[0]] * 1e3:.4g} ms); this needs continuous "
                                    "samples: process one segment (--segment K)")
        if k1 > k0:
            self._last_t = (k1 - 1, float(t[-1]))
        g = r.rows(self.names[1], self._handles[1], rows, a0)
        a = r.rows(self.names[2], self._handles[2], rows, a0)
        ta = None if self._accel_time is None else r.rows("/imu/accel_time", self._accel_time, rows, a0)
        return t, g, a, ta


# --------------------------------------------------------------------------- writing


class TelemetryWriter:
    """Stream a ``sizefx/telemetry/1`` file to disk, atomically.

    The sizes are declared up front; rows are written in any number of calls
    of :meth:`write_imu` and :meth:`write_reference` (in order). The file
    appears under its final name only when the ``with`` block ends without an
    exception and every declared row has been written.

    Data are stored in SI units (the first units of each quantity in the
    schema) as float64 unless ``dtype`` says otherwise.
    """

    def __init__(self, path, *, n_samples: int, form: str, n_reference: int = 0,
                 reference_position: bool = False, reference_velocity: bool = False,
                 accel_time: bool = False, site: Site | None = None, description: str = "",
                 simulation: dict | None = None, source: dict | None = None, inputs=(), force: bool = False,
                 dtype=np.float64, gaps=None):
        self.schema = load_schema(TELEMETRY_SCHEMA)
        self.source = source
        if form not in self.schema["forms"]:
            raise ValueError(f"form must be one of {list(self.schema['forms'])}, got {form!r}")
        self.path = Path(path)
        self.n_samples = n_samples
        self.form = form
        self.n_reference = n_reference
        self.site = site
        self.description = description
        self.simulation = simulation
        self.inputs = inputs
        self.force = force
        self.dtype = np.dtype(dtype)
        #: declared IMU gaps, [G, 2] s (time before the gap, length), written whole at creation
        self.gaps = None if gaps is None or len(gaps) == 0 else np.asarray(gaps, dtype=np.float64).reshape(-1, 2)
        self._plan = {"/imu/time": n_samples}
        for name in self.schema["forms"][form]["datasets"]:
            self._plan[name] = n_samples
        if accel_time:
            self._plan["/imu/accel_time"] = n_samples
        if n_reference:
            self._plan["/reference/time"] = n_reference
            self._plan["/reference/quaternion"] = n_reference
            if reference_position:
                self._plan["/reference/position"] = n_reference
            if reference_velocity:
                self._plan["/reference/velocity"] = n_reference
        self._written = dict.fromkeys(self._plan, 0)

    def __enter__(self):
        self._ctx = atomic_output(self.path, inputs=self.inputs, force=self.force)
        tmp = self._ctx.__enter__()
        try:
            self.h5 = h5py.File(tmp, "w")
            self._create()
        except BaseException as exc:
            self._ctx.__exit__(type(exc), exc, exc.__traceback__)
            raise
        return self

    def _create(self):
        h5 = self.h5
        h5.attrs["schema"] = TELEMETRY_SCHEMA
        if self.site is not None:
            h5.attrs["latitude_deg"] = float(np.degrees(self.site.lat_rad))
            h5.attrs["longitude_deg"] = float(np.degrees(self.site.lon_rad))
            h5.attrs["height_m"] = float(self.site.height_m)
        if self.description:
            h5.attrs["description"] = self.description
        for name, rows in self._plan.items():
            spec = self.schema["datasets"][name]
            shape = tuple(rows if isinstance(s, str) else s for s in spec["shape"])
            chunks = (min(rows, WRITE_CHUNK_ROWS),) + shape[1:] if rows else None
            dtype = np.float64 if spec["quantity"] == "time" else self.dtype  # time keeps full precision
            dset = h5.create_dataset(name, shape=shape, dtype=dtype, chunks=chunks)
            units = spec.get("default_units") or next(iter(self.schema["units"][spec["quantity"]]))
            if spec["quantity"] != "dimensionless":
                dset.attrs["units"] = units
        if self.gaps is not None:
            spec = self.schema["datasets"]["/imu/gaps"]
            dset = h5.create_dataset("/imu/gaps", data=self.gaps, dtype=np.float64)
            dset.attrs["units"] = next(iter(self.schema["units"][spec["quantity"]]))
        if self.source is not None:
            g = h5.create_group("source")
            for key, value in self.source.items():
                g.attrs[key] = value
        if self.simulation is not None:
            g = h5.create_group("simulation")
            g.attrs["truth_json"] = json.dumps(self.simulation, sort_keys=True)
            g.attrs["scenario"] = str(self.simulation.get("scenario", "custom"))
            g.attrs["seed"] = int(self.simulation.get("seed", 0))

    def _put(self, name: str, values):
        values = np.asarray(values, dtype=float)
        start = self._written[name]
        stop = start + values.shape[0]
        if stop > self._plan[name]:
            raise ValueError(f"{name}: writing rows {start}:{stop} beyond the declared {self._plan[name]}")
        self.h5[name][start:stop] = values
        self._written[name] = stop

    def write_imu(self, time_s, gyro_like, accel_like, accel_time_s=None):
        """Append IMU rows: rates (rad/s, m/s^2) or increments (rad, m/s) as declared."""
        gname, aname = self.schema["forms"][self.form]["datasets"]
        self._put("/imu/time", time_s)
        self._put(gname, gyro_like)
        self._put(aname, accel_like)
        if accel_time_s is not None:
            self._put("/imu/accel_time", accel_time_s)

    def write_reference(self, time_s, quat_nb, lat_rad=None, lon_rad=None, height_m=None, velocity_n_mps=None):
        """Append reference rows (positions in radians and metres; stored as deg, deg, m)."""
        self._put("/reference/time", time_s)
        self._put("/reference/quaternion", quat_nb)
        if "/reference/position" in self._plan:
            self._put("/reference/position", np.column_stack([np.degrees(lat_rad), np.degrees(lon_rad), height_m]))
        if "/reference/velocity" in self._plan:
            self._put("/reference/velocity", velocity_n_mps)

    def __exit__(self, exc_type, exc, tb):
        """Close the file; publish it only if the block succeeded and every declared row was written."""
        try:
            self.h5.close()
        except BaseException as close_exc:  # the temporary file is unusable: discard it, report the first error
            self._ctx.__exit__(type(close_exc), close_exc, close_exc.__traceback__)
            if exc is not None:
                raise exc from close_exc
            raise
        if exc_type is None:
            short = {k: (self._written[k], n) for k, n in self._plan.items() if self._written[k] != n}
            if short:
                err = RuntimeError(f"{self.path}: incomplete write {short}")
                self._ctx.__exit__(RuntimeError, err, None)
                raise err
        return self._ctx.__exit__(exc_type, exc, tb)


def write_telemetry(path, tel: Telemetry, *, inputs=(), force: bool = False, dtype=np.float64) -> Path:
    """Write a whole :class:`Telemetry` in one call (atomically)."""
    ref = tel.reference
    writer = TelemetryWriter(
        path, n_samples=tel.n_samples, form=tel.form,
        n_reference=0 if ref is None else ref.time_s.shape[0],
        reference_position=bool(ref is not None and ref.has_position),
        reference_velocity=bool(ref is not None and ref.velocity_n_mps is not None),
        accel_time=tel.accel_time_s is not None, site=tel.site, description=tel.description,
        simulation=tel.simulation, source=tel.source, inputs=inputs, force=force, dtype=dtype,
        gaps=[(g.time_s, g.duration_s) for g in tel.gaps if g.declared and g.dataset == "/imu/time"],
    )
    with writer as w:
        g, a = tel.imu_arrays()
        w.write_imu(tel.time_s, g, a, tel.accel_time_s)
        if ref is not None:
            w.write_reference(ref.time_s, ref.quat_nb, ref.lat_rad, ref.lon_rad, ref.height_m, ref.velocity_n_mps)
    return Path(path)
