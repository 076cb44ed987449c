"""The validation pass of the ``sizefx/telemetry/1`` contract over an open HDF5 file
(:mod:`sizefx.io.contract`): :class:`ContractReader` checks the structure, the root attributes, each
dataset's shape, dtype and units (converted to SI), time stamps, gaps and their declaration, and
quaternions, within bounds that keep a crafted file from making the check itself the attack.

One class of about 420 lines: a pass keeps its state (the units, sizes and gaps found so far, each
dataset's bounds) across its steps, and :mod:`sizefx.io.reader` drives the steps one by one, whole or
streamed.
"""

from __future__ import annotations

from pathlib import Path
from typing import NoReturn

import h5py
import numpy as np

from ...constants import GAP_FACTOR, QUATERNION_NORM_TOLERANCE
from ...errors import TelemetryError
from ...kernels.checks import scale_and_check
from ..gaps import GAP_MATCH_TOLERANCE, Gap, gap_rows, nominal_period_s
from ..schema import POLE_REASON, TELEMETRY_SCHEMA, allowed_units, load_schema, normalise_units, unit_factor
from .attrs import attr_str
from .limits import _bounds, limit_problem
from .storage import storage_problem

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

__all__ = ["ContractReader", "MAX_GROUP_DEPTH", "MAX_OBJECTS", "MAX_ACCEL_TIME_OFFSET_PERIODS", "MAX_GAPS"]


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
