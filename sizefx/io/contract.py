"""The checks of the ``sizefx/telemetry/1`` contract on an open HDF5 file.

:class:`ContractReader` makes one validation pass: structure, root attributes, each dataset's
shape, dtype and units (converted to SI), time stamps, gaps and their declaration, quaternions
and magnitudes, raising a :class:`~sizefx.errors.TelemetryError` that names the file, the
dataset and the problem, and says how to fix it. Everything about names, shapes, dtypes and
units comes from ``data-schemas/telemetry-1.json`` via :mod:`sizefx.io.schema`.
:func:`open_structure` and :func:`side_groups` are the steps a whole read and a streamed one
(:mod:`sizefx.io.reader`) share.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import NoReturn

import h5py
import numpy as np

from ..constants import GAP_FACTOR, QUATERNION_NORM_TOLERANCE
from ..errors import TelemetryError
from ..kernels.checks import scale_and_check
from .gaps import GAP_MATCH_TOLERANCE, Gap, gap_rows, nominal_period_s
from .records import Reference, Site
from .schema import POLE_REASON, TELEMETRY_SCHEMA, allowed_units, load_schema, normalise_units, unit_factor

#: Deepest group nesting and most objects the link check visits: a telemetry file has two levels
#: and a few dozen objects; the bounds keep a crafted file (thousands of nested groups, a tree
#: of millions of links) from making the check itself the attack.
MAX_GROUP_DEPTH = 32
MAX_OBJECTS = 10_000
#: Largest offset of /imu/accel_time from /imu/time, in nominal sample periods: a sensor's own
#: sampling offset and filter delay are a few periods at most (1.3 ms = 0.4 period on BROAD).
MAX_ACCEL_TIME_OFFSET_PERIODS = 10
#: Most gaps a time dataset may have: each is kept, listed and reported; a record with more dropouts
#: than this is not one recording that can be navigated (or its time axis is in other units).
MAX_GAPS = 100_000
#: Largest HDF5 chunk read at once: one row of a dataset costs its whole chunk, decompressed.
#: sizefx writes 1.5 MiB chunks; h5py's automatic chunking stays under 1 MiB.
MAX_CHUNK_BYTES = 64 * 2**20

__all__ = [
    "ContractReader",
    "open_hdf5",
    "open_structure",
    "check_magnitudes",
    "magnitude_problem",
    "side_groups",
    "site_from_attrs",
    "invalid_rows",
    "limit_problem",
    "storage_problem",
]


def attr_value(value):
    """An HDF5 attribute as plain Python (str, float, int, list), every text in it valid (:func:`attr_str`)."""
    if isinstance(value, (bytes, str)):
        return attr_str(value)
    if isinstance(value, np.ndarray):
        return attr_value(value[()]) if value.shape == () else [attr_value(v) for v in value.tolist()]
    if isinstance(value, list):  # the rows of a multi-dimensional array's tolist()
        return [attr_value(v) for v in value]
    if isinstance(value, np.generic):
        return attr_value(value.item())
    return value


def attr_str(value) -> str:
    """An HDF5 text attribute as valid text, whatever bytes the file holds.

    HDF5 does not check that a string attribute declared UTF-8 is UTF-8, and h5py hands the bytes that
    are not over as lone surrogates (``surrogateescape``), which no output can take: h5py refuses to write
    them into a new file, and stdout and JSON readers choke on them. Those bytes become backslash escapes
    (``b"caf\\xe9"`` -> ``"caf\\\\xe9"``), not an error: the text attributes sizefx only carries or prints
    (``description``, the ``/source`` provenance) are informational, and a record is not refused for a
    comment in Latin-1; they stay readable and travel into every output. The ones sizefx interprets
    (``schema``, ``units``, ``/simulation`` ``truth_json``) keep their escapes too and are then refused by
    their own checks, which quote the value."""
    if isinstance(value, np.ndarray) and value.shape == ():
        value = value[()]
    if isinstance(value, bytes):
        return value.decode("utf-8", "backslashreplace")
    text = str(value)
    try:
        raw = text.encode("utf-8", "surrogateescape")  # the bytes h5py could not decode, back as bytes
    except UnicodeEncodeError:  # a surrogate that is no escaped byte: keep it visible as \udXXX
        return text.encode("utf-8", "backslashreplace").decode("utf-8")
    return raw.decode("utf-8", "backslashreplace")


def storage_problem(dset: h5py.Dataset) -> str | None:
    """What makes a dataset unsafe to read, found before reading it: rows declared but never stored
    (a sparse chunked dataset reads back as fill values and, read whole, allocates its declared
    size), or chunks so large that reading one row decompresses more than :data:`MAX_CHUNK_BYTES`.
    None when it is safe."""
    if dset.size and dset.id.get_storage_size() == 0:
        return (
            f"declares shape {dset.shape} but stores no data (never written); the file is incomplete: write the "
            "samples, or re-import the source"
        )
    if dset.chunks is not None:
        chunk_bytes = int(np.prod(dset.chunks, dtype=np.int64)) * dset.dtype.itemsize
        if chunk_bytes > MAX_CHUNK_BYTES:
            return (
                f"is stored in chunks of {chunk_bytes / 2**20:.0f} MiB (chunk shape {dset.chunks}); at most "
                f"{MAX_CHUNK_BYTES // 2**20} MiB can be read at a time (rewrite it with h5py chunks=True, or with "
                "sizefx import)"
            )
    return None


def _bounds(schema: dict, name: str, columns: int):
    """Per column (low, high) of dataset ``name`` from the schema's ``sample_limits`` (one bound for
    all columns, or one per column, symmetric or [low, high]); None without a limit."""
    limit = schema["sample_limits"].get(name)
    if limit is None:
        return None
    per_column = limit if isinstance(limit, list) else [limit] * columns
    return (
        np.array([b[0] if isinstance(b, list) else -b for b in per_column]),
        np.array([b[1] if isinstance(b, list) else b for b in per_column]),
    )


def invalid_rows(schema: dict, name: str, data: np.ndarray) -> np.ndarray:
    """[rows, columns] bool: samples of dataset ``name`` (SI) that are not finite or lie beyond the
    schema's ``sample_limits``."""
    values = data.reshape(data.shape[0], -1)
    bad = ~np.isfinite(values)
    bounds = _bounds(schema, name, values.shape[1])
    if bounds is not None:
        with np.errstate(invalid="ignore"):
            bad |= (values < bounds[0]) | (values > bounds[1])
    return bad


def limit_problem(schema: dict, name: str, data: np.ndarray, first_row: int = 0) -> str | None:
    """What is wrong with the rows ``data`` (SI, finite; rows ``first_row ...``) of dataset ``name``
    against the schema's ``sample_limits``; None when every sample is within them."""
    if data.size == 0 or _bounds(schema, name, 1) is None:
        return None
    values = data.reshape(data.shape[0], -1)
    bad = invalid_rows(schema, name, values)
    if not bad.any():
        return None
    low, high = _bounds(schema, name, values.shape[1])
    row, col = (int(v) for v in np.argwhere(bad)[0])
    if name == "/reference/position" and col == 0 and np.isfinite(values[row, col]):
        # a latitude is said in degrees; up to 90 deg it is a place (near a pole), beyond it a unit or column error
        lat_deg = float(np.degrees(values[row, col]))
        fix = (
            f"{POLE_REASON}: cut the record where it comes that close to the pole"
            if abs(lat_deg) <= 90.0
            else "beyond the poles: check the units attribute and that column 0 is the latitude"
        )
        return (
            f"latitude (column 0) is {lat_deg:.6g} deg at row {row + first_row} ({int(bad.any(axis=1).sum())} rows "
            f"in this read), outside [{np.degrees(low[col]):.6g}, {np.degrees(high[col]):.6g}] deg; {fix}"
        )
    column = f", column {col}" if values.shape[1] > 1 else ""
    return (
        f"holds {values[row, col]:.6g} (SI, after its units) at row {row + first_row}{column}, outside the "
        f"physical limits [{low[col]:g}, {high[col]:g}] ({int(bad.any(axis=1).sum())} rows in this read); check "
        "the units attribute, or remove or interpolate those samples (sizefx import --drop-invalid-rows)"
    )


class ContractReader:
    """One validation pass over an open file; raises on the first problem."""

    def __init__(self, path: Path, h5: h5py.File, allow_gaps: bool, check_plausibility: bool):
        self.path = path
        self.h5 = h5
        self.schema = load_schema(TELEMETRY_SCHEMA)
        self.allow_gaps = allow_gaps
        self.check_plausibility = check_plausibility
        self.limits = True  #: check each sample against the schema's sample_limits (:meth:`check_limits`)
        self.n_gaps: dict[str, int] = {}  #: gaps found so far per time dataset (bounded by MAX_GAPS)
        self.sizes: dict[str, int] = {}
        self.units: dict[str, str] = {}
        self.dtypes: dict[str, str] = {}
        self.gaps: list[Gap] = []
        self._limits: dict = {}  #: (dataset, columns) -> per-column (low, high) of its sample_limits

    def fail(self, dataset: str, problem: str) -> NoReturn:
        raise TelemetryError(self.path, dataset, problem)

    # -- structure ------------------------------------------------------------------
    def refuse_links_to_other_files(self):
        """Refuse external links, virtual datasets and external raw storage.

        A telemetry file must not make the tool read other files (a path in a
        link could point anywhere on the machine).
        """

        # iterative, each object once (a hard link may point back at a parent), with the depth and
        # the number of objects bounded: a crafted file cannot recurse or loop the check
        seen = {self.h5.id}
        stack = [(self.h5, "/", 0)]
        count = 0
        while stack:
            group, prefix, depth = stack.pop()
            for name in group:
                count += 1
                if count > MAX_OBJECTS:
                    self.fail(
                        prefix,
                        f"the file holds more than {MAX_OBJECTS} HDF5 objects; a telemetry file "
                        "needs a few dozen (copy /imu and /reference into a new file)",
                    )
                if isinstance(name, bytes):  # h5py hands over a name that is not UTF-8 undecoded
                    self.fail(
                        f"{prefix.rstrip('/')}/{attr_str(name)}",
                        "is an HDF5 object whose name is not UTF-8 text; h5py cannot open it, so it cannot "
                        "be checked (rename it in UTF-8, or copy /imu and /reference into a new file)",
                    )
                full = f"{prefix}/{name}" if prefix != "/" else f"/{name}"
                link = group.get(name, getlink=True)
                if isinstance(link, h5py.ExternalLink):
                    self.fail(
                        full,
                        f"is an HDF5 external link to {link.filename}:{link.path}; "
                        "telemetry files must be self-contained (copy the data in with h5copy or h5py)",
                    )
                if isinstance(link, h5py.SoftLink):
                    # not followed (its target is visited under its own name); but one that loops
                    # (a -> b -> a) is refused here, once, rather than where a dataset is looked up
                    try:
                        group.get(name)
                    except (RuntimeError, KeyError, OSError):
                        self.fail(
                            full,
                            f"is a soft link to {link.path} that cannot be resolved (links that point "
                            "at each other); store the dataset itself",
                        )
                    continue
                try:
                    obj = group[name]
                except (KeyError, OSError, RuntimeError) as exc:
                    self.fail(full, f"cannot be opened ({exc}); the file may be truncated or corrupt")
                if obj.id in seen:
                    continue  # a second hard link to an object already checked
                seen.add(obj.id)
                if isinstance(obj, h5py.Group):
                    if depth + 1 > MAX_GROUP_DEPTH:
                        self.fail(
                            full,
                            f"groups nest deeper than {MAX_GROUP_DEPTH} levels; a telemetry file "
                            "needs two (copy /imu and /reference into a new file)",
                        )
                    stack.append((obj, full, depth + 1))
                elif isinstance(obj, h5py.Dataset):
                    if obj.is_virtual:
                        self.fail(
                            full,
                            "is an HDF5 virtual dataset (its data lives in other files); store the data in this file",
                        )
                    if obj.external:
                        self.fail(full, "stores its raw data in external files; store the data in this file")

    def root_attributes(self):
        spec = self.schema["root_attributes"]
        attrs = self.h5.attrs
        if "schema" not in attrs:
            self.fail(
                "/",
                f"root attribute 'schema' is missing; a telemetry file declares "
                f'schema = "{TELEMETRY_SCHEMA}" (sizefx import converts other formats)',
            )
        declared = attr_str(attrs["schema"])
        if declared != spec["schema"]["value"]:
            self.fail("/", f"root attribute schema is '{declared}', expected '{TELEMETRY_SCHEMA}'")
        values: dict[str, float | str] = {}
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
                    why = f" ({POLE_REASON})" if key == "latitude_deg" and np.isfinite(val) else ""
                    self.fail("/", f"root attribute {key} = {val} is outside [{rule['min']}, {rule['max']}]{why}")
                values[key] = val
            else:
                values[key] = attr_str(raw)
        site_keys = ("latitude_deg", "longitude_deg", "height_m")
        present = [k for k in site_keys if k in values]
        if present and len(present) != 3:
            missing = [k for k in site_keys if k not in values]
            self.fail(
                "/",
                f"root attributes give {', '.join(present)} but not {', '.join(missing)}; "
                "give all three site attributes or none",
            )
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
            data = np.require(dset[rows], dtype=np.float64, requirements=["C", "W"])  # h5py's own array: no copy
        except OSError as exc:
            self.fail(name, f"cannot be read ({exc}); the file is truncated or corrupt")
        if data.shape[0] == 0:
            self.fail(name, "holds no samples")
        values = data.reshape(data.shape[0], -1)  # a view: scaled in place
        columns = values.shape[1]
        bounds = self._limit_columns(name, columns) if self.limits else None
        limited = bounds is not None
        low, high = bounds if bounds is not None else (np.full(columns, -np.inf), np.full(columns, np.inf))
        factors = np.broadcast_to(np.asarray(factor, dtype=np.float64), (columns,)).copy()
        first_not_finite, first_beyond = scale_and_check(values, factors, low, high)
        if first_not_finite >= 0:
            self.fail(
                name,
                f"holds NaN/Inf values, the first at row {first_not_finite // columns + first_row}; "
                "remove or interpolate them (or cut the record) before processing",
            )
        if limited and first_beyond >= 0:  # the message (and its count of rows) from the NumPy twin
            self.check_limits(name, data, first_row)
        return data

    def _limit_columns(self, name: str, columns: int):
        """Per column (low, high) of ``name``'s ``sample_limits`` as arrays (None without a limit),
        kept for the next read."""
        key = (name, columns)
        if key not in self._limits:
            bounds = _bounds(self.schema, name, columns)
            self._limits[key] = (
                None if bounds is None else tuple(np.ascontiguousarray(b, dtype=np.float64) for b in bounds)
            )
        return self._limits[key]

    def check_limits(self, name: str, data: np.ndarray, first_row: int):
        """Refuse, with its first row, a sample beyond what is physically possible (the schema's
        ``sample_limits``, :func:`limit_problem`); skipped while ``limits`` is off."""
        if self.limits:
            problem = limit_problem(self.schema, name, data, first_row)
            if problem:
                self.fail(name, problem)

    def handle(self, name: str, required: bool):
        """``(h5py dataset, SI factor)`` of a dataset listed in the schema, its structure, dtype and units
        checked; None if absent and optional. The values are read by :meth:`rows`."""
        spec = self.schema["datasets"][name]
        try:
            present = name in self.h5
            dset = self.h5[name] if present else None
        except (RuntimeError, KeyError, OSError) as exc:  # a link chain that loops, a damaged object header
            self.fail(name, f"cannot be opened ({exc}); store the dataset itself, not links to it")
        if not present:
            if required:
                self.fail(name, "dataset is missing")
            return None
        if not isinstance(dset, h5py.Dataset):
            self.fail(name, f"is a {type(dset).__name__}, expected a dataset")
        shape = spec["shape"]
        if dset.ndim != len(shape):
            self.fail(name, f"has rank {dset.ndim} (shape {dset.shape}); expected shape [{', '.join(map(str, shape))}]")
        for axis, (want, got) in enumerate(zip(shape, dset.shape)):
            if isinstance(want, int):
                if got != want:
                    self.fail(name, f"has shape {dset.shape}; axis {axis} must have length {want}")
            else:
                bound = self.sizes.setdefault(want, got)
                if got != bound:
                    self.fail(
                        name,
                        f"has {got} rows but its companions have {bound}; all datasets of a group share the time axis",
                    )
        self.check_storage(name, dset)
        if dset.dtype.name not in self.schema["dtypes"]:
            self.fail(
                name,
                f"has dtype {dset.dtype}; expected one of {', '.join(self.schema['dtypes'])} "
                "(convert with numpy .astype(float))",
            )
        quantity = spec["quantity"]
        units = dset.attrs.get("units")
        if units is None:
            if spec.get("units_required"):
                self.fail(name, f"has no 'units' attribute; set it to one of {', '.join(allowed_units(quantity))}")
            units = spec.get("default_units", next(iter(self.schema["units"][quantity])))
        units = normalise_units(attr_str(units))
        factor = unit_factor(quantity, units)
        if factor is None:
            self.fail(name, f"units '{units}' are not known; use one of {', '.join(allowed_units(quantity))}")
        self.units[name] = units
        self.dtypes[name] = dset.dtype.name
        return dset, factor

    def check_storage(self, name: str, dset: h5py.Dataset):
        """Before any read: :func:`storage_problem`."""
        problem = storage_problem(dset)
        if problem:
            self.fail(name, problem)

    def check_rows(self, name: str, limit: int, why: str):
        """Before a whole read: the dataset's declared rows within ``limit`` (bounded memory); ``why``
        may name ``{limit}``."""
        dset = self.h5.get(name)
        if not isinstance(dset, h5py.Dataset) or dset.ndim == 0:
            return  # absent, or not a dataset: handle() says so when the dataset is read
        rows = int(dset.shape[0])
        if rows > limit:
            self.fail(name, f"holds {rows} rows; {why.format(limit=limit)}")

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
            self.fail(
                name,
                f"has {dup.size} duplicated time stamps, the first at row {k + first_row} "
                f"(t = {t[k]:.6f} s); drop the repeated samples",
            )
        back = np.flatnonzero(dt < 0.0)
        if back.size:
            k = int(back[0]) + 1
            self.fail(
                name,
                f"is not strictly increasing: time goes back at row {k + first_row} "
                f"({t[k - 1]:.6f} s -> {t[k]:.6f} s), {back.size} times in all; sort or split the record",
            )
        spec = self.schema["datasets"][name]
        if first_row == 0:
            own = nominal_period_s(t)
            lo, hi = self.schema["plausibility"]["sample_rate_hz"]
            if self.check_plausibility and spec["rate_check"] and not lo <= 1.0 / own <= hi:
                self.fail(
                    name,
                    f"median time step is {own:g} s ({1.0 / own:g} Hz), outside "
                    f"{lo:g}..{hi:g} Hz; time must be in seconds (is it in ms or us?)",
                )
            nominal = own if nominal is None else nominal
        assert nominal is not None, "a later chunk (first_row > 0) comes with the record's nominal period"
        rows = gap_rows(t, nominal)
        self.n_gaps[name] = self.n_gaps.get(name, 0) + rows.size
        if self.n_gaps[name] > MAX_GAPS:
            self.fail(
                name,
                f"has more than {MAX_GAPS} gaps longer than {GAP_FACTOR} sample periods (the "
                f"{MAX_GAPS + 1}th at row {int(rows[MAX_GAPS - self.n_gaps[name]]) + first_row}); is "
                "the time axis in the units it declares, and the record one recording?",
            )
        gaps = [Gap(name, int(k) + first_row, float(t[k - 1]), float(t[k] - t[k - 1])) for k in rows]
        if spec["gaps"] == "report":
            self.gaps.extend(gaps)
        return nominal, gaps

    def check_accel_time(self, time_s: np.ndarray, accel_time_s: np.ndarray, nominal: float, first_row: int = 0):
        """``/imu/accel_time`` within :data:`MAX_ACCEL_TIME_OFFSET_PERIODS` sample periods of ``/imu/time``,
        row by row (rows ``first_row ...``): the accelerometers sample the same instants as the gyros
        up to their own timing offset, a fraction of a period; a larger offset is a different clock
        or a stamp in other units, which no delay estimate should absorb."""
        offset = accel_time_s - time_s
        bad = np.flatnonzero(np.abs(offset) > MAX_ACCEL_TIME_OFFSET_PERIODS * nominal)
        if bad.size:
            k = int(bad[0])
            self.fail(
                "/imu/accel_time",
                f"is {offset[k]:.6g} s from /imu/time at row {k + first_row} "
                f"({bad.size} rows in this read), more than {MAX_ACCEL_TIME_OFFSET_PERIODS} "
                f"sample periods ({MAX_ACCEL_TIME_OFFSET_PERIODS * nominal:.4g} s); both "
                "must count the same clock in seconds (subtract the offset, or drop "
                "/imu/accel_time if the accelerometers sample with the gyros)",
            )

    def declared_gaps(self, n_samples: int):
        """``/imu/gaps`` as ``[G, 2]`` seconds (time before the gap, length), or None when absent."""
        handle = self.handle("/imu/gaps", required=False)
        if handle is None:
            return None
        rows = handle[0].shape[0]
        if rows == 0:
            return np.zeros((0, 2))
        if rows > n_samples - 1:
            self.fail(
                "/imu/gaps",
                f"declares {rows} gaps in a record of {n_samples} samples; there can be at "
                f"most {n_samples - 1} (one per step)",
            )
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
            self.fail(
                g.dataset,
                f"has {len(loose)} {which} longer than {GAP_FACTOR} sample periods "
                f"({nominal * 1e3:.4g} ms); the first at row {g.index} (t = {g.time_s:.6f} s, "
                f"{g.duration_s * 1e3:.4g} ms); pass --allow-gaps to proceed anyway",
            )
        self.gaps[:0] = gaps

    def match_declared_gaps(self, gaps: list, declared: np.ndarray, nominal: float):
        """Mark the gaps ``/imu/gaps`` declares; fail, naming both, where it and ``/imu/time`` differ."""
        tol = GAP_MATCH_TOLERANCE * nominal
        on_time = [g for g in gaps if g.dataset == "/imu/time"]
        t_found = np.array([g.time_s for g in on_time])
        fix = (
            "re-import the source (sizefx import writes /imu/gaps from the data it finds), or delete /imu/gaps "
            "and pass --allow-gaps"
        )
        for i, (t_d, length_d) in enumerate(declared):
            said = f"row {i} declares a gap after t = {t_d:.6f} s lasting {length_d * 1e3:.4g} ms"
            if not length_d > 0.0:
                self.fail(
                    "/imu/gaps", f"{said}; gap lengths are positive (columns: time before the gap [s], length [s])"
                )
            if i and not t_d > declared[i - 1, 0]:
                self.fail(
                    "/imu/gaps",
                    f"{said}, not after row {i - 1} (t = {declared[i - 1, 0]:.6f} s); rows are in time order",
                )
            k = int(np.argmin(np.abs(t_found - t_d))) if t_found.size else -1
            if k < 0 or abs(t_found[k] - t_d) > tol:
                self.fail("/imu/gaps", f"{said}, but /imu/time has no gap there (its gaps: {t_found.size}); {fix}")
            g = on_time[k]
            if g.declared:
                self.fail("/imu/gaps", f"{said}, the same gap as row {i - 1}; declare each gap once")
            if abs(g.duration_s - length_d) > tol:
                self.fail(
                    "/imu/gaps",
                    f"{said}, but the gap of /imu/time there (row {g.index}) lasts {g.duration_s * 1e3:.4g} ms; {fix}",
                )
            g.declared = True
        missing = [g for g in on_time if not g.declared]
        if missing:
            g = missing[0]
            self.fail(
                "/imu/gaps",
                f"declares {declared.shape[0]} gaps but /imu/time has {len(on_time)}: the gap "
                f"at row {g.index} (t = {g.time_s:.6f} s, {g.duration_s * 1e3:.4g} ms) is not "
                f"declared; {fix}",
            )

    def check_unit_quaternions(self, name: str, q: np.ndarray):
        err = np.abs(np.linalg.norm(q, axis=1) - 1.0)
        k = int(np.argmax(err))
        if err[k] > QUATERNION_NORM_TOLERANCE:
            self.fail(
                name,
                f"row {k} has norm {np.linalg.norm(q[k]):.9g}; quaternions must be unit "
                f"(|q| - 1 within {QUATERNION_NORM_TOLERANCE:g}); normalise them, and check "
                "the order is scalar-first [w, x, y, z]",
            )
        return q / np.linalg.norm(q, axis=1, keepdims=True)


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
        raise TelemetryError(
            path, "/", f"cannot be opened as HDF5 ({str(exc).splitlines()[0]}); the file is truncated or corrupt"
        ) from None


def open_structure(path, h5, allow_gaps, check_plausibility):
    """Links, root attributes, groups and the IMU form: ``(reader, root attributes, form)``."""
    r = ContractReader(path, h5, allow_gaps, check_plausibility)
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


def magnitude_problem(schema: dict, form: str, period: float, gyro, accel, units: dict) -> tuple[str, str, str] | None:
    """The first median magnitude outside the schema's ``plausibility`` (specific force, then angular
    rate) of IMU rows ``gyro``, ``accel`` (SI; increments divided by the sample ``period`` [s]), as
    ``(dataset, figures, hint)``: what the data read against the plausible range, and the units
    under which the same numbers would be plausible. None when both are plausible.

    The reader's check (:func:`check_magnitudes`); :func:`sizefx.sanity.implausible` applies it to
    a record in memory (``sizefx simulate``). ``units``: dataset -> the units the data were read in.
    """
    gyro_name, accel_name = schema["forms"][form]["datasets"]
    f_est = accel if form == "rates" else accel / period
    w_est = gyro if form == "rates" else gyro / period
    for name, values, key, what in (
        (accel_name, f_est, "median_specific_force_mps2", "specific force"),
        (gyro_name, w_est, "median_angular_rate_rad_s", "angular rate"),
    ):
        lo, hi = schema["plausibility"][key]
        med = float(np.median(np.linalg.norm(values, axis=1)))
        if lo <= med <= hi:
            continue
        quantity = schema["datasets"][name]["quantity"]
        base = unit_factor(quantity, units[name])
        # the units under which the same numbers would be plausible: the data look like those
        fits = [
            u for u, factor in schema["units"][quantity].items() if u != units[name] and lo <= med / base * factor <= hi
        ]
        hint = (
            f"the data look like {fits[0]}: set the units attribute to '{fits[0]}'"
            if len(fits) == 1
            else "the units attribute is probably wrong"
        )
        figures = (
            f"median |{what}| is {med:.4g} in SI after converting from '{units[name]}', outside the "
            f"plausible {lo:g}..{hi:g}"
        )
        return name, figures, hint
    return None


def check_magnitudes(r, form, period, gyro, accel):
    """Refuse (``r.fail``) median magnitudes that betray wrong units: :func:`magnitude_problem`."""
    found = magnitude_problem(r.schema, form, period, gyro, accel, r.units)
    if found is not None:
        name, figures, hint = found
        r.fail(name, f"{figures}; {hint}")


def side_groups(r, h5, reference: bool = True):
    """``/reference`` (read whole; None with ``reference=False``), ``/source`` and ``/simulation``."""
    found: Reference | None = None
    if reference and "/reference" in h5:
        ref_t = r.dataset("/reference/time", required=True)
        r.check_time("/reference/time", ref_t)
        quat = r.check_unit_quaternions("/reference/quaternion", r.dataset("/reference/quaternion", required=True))
        pos = r.dataset("/reference/position", required=False)
        vel = r.dataset("/reference/velocity", required=False)
        found = Reference(time_s=ref_t, quat_nb=quat, velocity_n_mps=vel)
        if pos is not None:  # columns within their limits (ContractReader.check_limits)
            found.lat_rad, found.lon_rad, found.height_m = pos[:, 0], pos[:, 1], pos[:, 2]
    source = None
    if "/source" in h5:
        source = {attr_str(k): attr_value(v) for k, v in h5["/source"].attrs.items()}
    simulation = None
    if "/simulation" in h5:
        sim_attrs = h5["/simulation"].attrs
        if "truth_json" not in sim_attrs:
            r.fail("/simulation", "attribute truth_json is missing")
        try:
            simulation = json.loads(attr_str(sim_attrs["truth_json"]))
        except json.JSONDecodeError as exc:
            r.fail("/simulation", f"attribute truth_json is not valid JSON ({exc})")
        except (RecursionError, ValueError) as exc:  # nesting past the parser, a 5000-digit integer
            r.fail(
                "/simulation",
                f"attribute truth_json cannot be read ({type(exc).__name__}); it is not one sizefx simulate wrote",
            )
    return found, source, simulation


def site_from_attrs(attrs):
    if "latitude_deg" not in attrs:
        return None
    return Site(np.radians(attrs["latitude_deg"]), np.radians(attrs["longitude_deg"]), attrs["height_m"])
