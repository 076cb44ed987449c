"""Importers: other telemetry formats into ``sizefx/telemetry/1`` (``sizefx import``).

Each module exposes ``load(path, **options) -> Telemetry`` that converts axes to
body FRD, the reference to NED, and units to SI, and records where the data
came from in ``Telemetry.source`` (:func:`provenance`, written to ``/source``). The stage
(:class:`ImportConfig` -> :func:`run` -> :class:`ImportResult`, see :mod:`sizefx.stage`; each
format's options declared in :mod:`sizefx.configs.import_`) declares the IMU gaps it finds in ``/imu/gaps`` (the reader's own definition of a
gap, :func:`sizefx.io.telemetry.find_imu_gaps`), writes the result atomically, reads it
back through the validating reader and checks its units against physics
(:mod:`sizefx.sanity`), so an importer can never produce a file the rest of sizefx
refuses, nor one whose rates are 57 times wrong.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from .. import __version__
from ..configs.import_ import FOLDER_FORMATS, ImportConfig
from ..errors import OutputError, SourceError, TelemetryError
from ..io.contract import invalid_rows, limit_problem
from ..io.files import atomic_output, sha256_of
from ..io.gaps import nominal_period_s
from ..io.provenance import Provenance
from ..io.schema import TELEMETRY_SCHEMA, allowed_units, load_schema
from ..io.telemetry import find_imu_gaps, read_telemetry, write_telemetry
from ..rotation import quat_to_mat

__all__ = [
    "FORMATS",
    "IMU_RATE_HZ",
    "REFERENCE_RATE_HZ",
    "ImportConfig",
    "ImportResult",
    "FOLDER_FORMATS",
    "REFERENCE_GRAVITY_ANGLE_MAX_DEG",
    "median_rate_hz",
    "reference_up_angle_deg",
    "run",
    "run_import",
    "provenance",
]

#: Sample rates [Hz] an imported IMU time axis may imply. A time column in the wrong unit is off by a
#: factor of 1000 (milliseconds read as seconds turn 100 Hz into 0.1 Hz) and would make a file that every
#: other command refuses or, worse, misreads. The contract accepts 1 Hz..100 kHz
#: (``plausibility.sample_rate_hz``), but IMUs sample at round rates (50, 100, 200, 400 Hz, 1, 2, 4 kHz)
#: and the contract's edges are two of them off by 1000: 1 kHz with milliseconds read as seconds is
#: exactly 1 Hz, 100 Hz with seconds read as milliseconds exactly 100 kHz. The importers take a narrower
#: range whose edges are no common rate off by 1000: no strapdown record is slower than 5 Hz (an AHRS
#: logs at 10 Hz or more), none faster than 35 kHz (the fastest MEMS gyro output is 32 kHz).
IMU_RATE_HZ = (5.0, 35_000.0)
#: Sample rates [Hz] a reference time column may imply. A reference may be sparser than the IMU (the
#: contract does not check its rate), but it carries the attitude, and the sparsest in use is a GNSS/INS
#: solution at 1 Hz: 0.7 Hz leaves room for its jitter and still catches milliseconds read as seconds
#: for a reference at up to 500 Hz. The top is the IMU's.
REFERENCE_RATE_HZ = (0.7, IMU_RATE_HZ[1])

#: format name -> (module in this package, loader function); each format's options are declared in
#: :data:`sizefx.configs.import_.IMPORT_OPTIONS`
FORMATS = {
    "broad": ("broad", "load"),
    "psins-imu": ("psins", "load_imu"),
    "psins-mat": ("psins", "load_mat_record"),
    "csv": ("table", "load"),
    "ulog": ("ulog", "load"),
    "rosbag": ("rosbag", "load"),
    "table-log": ("table_log", "load"),
}

#: Largest median angle [deg] between the specific force the accelerometers read and the
#: "up" direction the reference attitude gives in body axes. At rest they coincide; a
#: vehicle's accelerations tilt the reading by a few degrees most of the time (0.3 g of
#: braking, a rare extreme, is 17 deg). A reference in the wrong frame (ENU read as NED),
#: without the axis map, or with its quaternion in the wrong order is typically 90-180 deg
#: off; 45 deg separates the two with a wide margin on both sides.
REFERENCE_GRAVITY_ANGLE_MAX_DEG = 45.0


def provenance(
    path: Path, fmt: str, credits: str = "", *, digest: str | None = None, imu: Provenance | None = None, **extra
) -> Provenance:
    """Where an imported record came from (``/source``): the original file, its checksum, the
    importer, the credits and ``extra``, the importer's own fields, in order.

    ``digest``: the SHA-256 when the caller has it (a source that is a folder of files); by default
    that of ``path``'s bytes. ``imu``: the provenance of a sizefx record whose IMU the import took
    (``import table-log --imu``)."""
    if digest is None:
        digest = sha256_of(path, mapped=False)  # this command's own process: no SIGBUS risk
    name, importer, credited = Path(path).name, f"sizefx {__version__}", credits or None
    return Provenance(format=fmt, file=name, sha256=digest, importer=importer, credits=credited, extra=extra, imu=imu)


def median_rate_hz(time_s) -> float | None:
    """The sample rate [Hz] a time axis [s] implies: 1 / its median step over the finite stamps, the
    reader's nominal period (:func:`sizefx.io.gaps.nominal_period_s`); None when the stamps do not
    increase (refused by the time checks, with a better message)."""
    t = np.asarray(time_s, dtype=float)
    t = t[np.isfinite(t)]
    if t.size < 2:
        return None
    step_s = nominal_period_s(t)
    return 1.0 / step_s if step_s > 0.0 else None


def check_source(path, *, folder: bool = False) -> Path:
    """``path`` exists and is a non-empty file (or, with ``folder``, a folder)."""
    path = Path(path)
    if not path.exists():
        raise SourceError(path, "file does not exist")
    if path.is_dir():
        if folder:
            return path
        raise SourceError(path, "is a directory; give a file")
    if path.stat().st_size == 0:
        raise SourceError(path, "file is empty (0 bytes)")
    return path


def load_source(fmt: str, path, *, keep_invalid: bool = False, **options):
    """Convert ``path`` of format ``fmt`` into a :class:`~sizefx.io.telemetry.Telemetry` (not written).
    ``keep_invalid``: ask a loader that refuses NaN cells itself (csv) to keep them, for
    ``--drop-invalid-rows``; the other loaders pass them on anyway."""
    import importlib
    import inspect

    if fmt not in FORMATS:
        raise SourceError(path, f"unknown format '{fmt}'; use one of {', '.join(FORMATS)}")
    module_name, function = FORMATS[fmt]
    loader = getattr(importlib.import_module(f"{__name__}.{module_name}"), function)
    if keep_invalid and "keep_invalid" in inspect.signature(loader).parameters:
        options = {**options, "keep_invalid": True}
    return loader(check_source(path, folder=fmt in FOLDER_FORMATS), **options)


def _units_context(fmt: str, tel):
    """What the source declared, for the units check: ``(declared units, names, fix)``.

    The CSV importer takes the units from the user (``--gyro-units``, ``--accel-units``) and
    records them, and the column names, in ``/source``; the other formats fix their units, so
    a mismatch there means the source is not what its format promises.
    """
    from ..sanity import FORM_QUANTITIES, UNITS_OUTSIDE_CONTRACT

    src = tel.source.extra if tel.source is not None else {}
    names = dict(zip(("gyro", "accel"), FORM_QUANTITIES[tel.form]))
    datasets = {
        "gyro": "/imu/gyro" if tel.form == "rates" else "/imu/dtheta",
        "accel": "/imu/accel" if tel.form == "rates" else "/imu/dvel",
    }
    declared, where = {}, {}
    for what, dataset in datasets.items():
        if src.get(f"{what}_units"):
            declared[dataset] = str(src[f"{what}_units"])
        columns = src.get(f"{what}_columns")
        if columns:
            where[dataset] = f"{what} columns {', '.join(map(str, columns))}"

    def fix(check):
        if fmt == "csv":
            option = f"--{check.what}-units"
            if check.looks_like in allowed_units(names[check.what]):
                return f"import with {option} {check.looks_like}"
            outside = UNITS_OUTSIDE_CONTRACT.get(names[check.what], {})
            if check.looks_like in outside:
                return (
                    f"multiply the columns by {outside[check.looks_like]:g} to make them {check.declared} "
                    f"({option} takes {', '.join(allowed_units(names[check.what]))})"
                )
            return (
                f"convert the columns to {check.declared} before importing ({option} takes "
                f"{', '.join(allowed_units(names[check.what]))})"
            )
        if fmt == "table-log":  # the IMU is the record's; the gyros are judged against the log's rotation too
            imu = "re-import the IMU record (--imu)" + (f" in {check.looks_like}" if check.looks_like else "")
            log = ", or check the log's --angle-units, --counts-per-rev and --time-units"
            return imu + (log if check.what == "gyro" else "")
        return f"the {fmt} format stores {check.declared}; check that the source is a genuine {fmt} file"

    return declared, where, fix


@dataclass
class ImportResult:
    """What an import wrote: the record as read back through the validating reader."""

    path: str  #: the file written
    format: str
    samples: int
    form: str  #: rates | increments
    rate_hz: float
    duration_s: float
    imu_gaps: int  #: gaps in the IMU time stamps
    declared_gaps: int  #: of them, declared in /imu/gaps
    first_imu_gap_s: float | None
    longest_imu_gap_s: float | None
    segments: int  #: continuous segments between the IMU gaps
    reference_rows: int
    reference_gaps: int  #: dropouts of the reference
    accel_time: bool  #: separate accelerometer stamps (/imu/accel_time)
    site: bool
    units_check: dict | None  #: :meth:`sizefx.sanity.UnitsReport.as_dict`, None when skipped
    #: with ``drop_invalid_rows``: ``{"rows": count, "first_row": its source row, "after_time_s": the kept
    #: stamp before it}``
    dropped_rows: dict | None = None
    #: what the importer converted, when it says (``/source`` ``conversion``: the ROS bag importer's
    #: frames, stamps and reference), one line each
    conversion: list | None = None

    def to_json(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)}

    def report(self) -> str:
        """The lines ``sizefx import`` prints."""
        from ..sanity import report_lines

        gaps = self.imu_gaps
        lines = [
            f"wrote {self.path}: {self.samples} {self.form} samples at {self.rate_hz:.6g} Hz, "
            f"{self.duration_s:.2f} s; reference rows: {self.reference_rows}"
            + (f" ({self.reference_gaps} dropouts)" if self.reference_gaps else "")
        ]
        for k, line in enumerate(self.conversion or []):
            lines.append(("conversion: " if k == 0 else "            ") + line)
        if gaps:
            assert self.longest_imu_gap_s is not None  # set whenever there are IMU gaps (import_file)
            lines.append(
                f"gaps: {gaps} in the IMU time stamps, {self.declared_gaps} declared in /imu/gaps (the first "
                f"at t = {self.first_imu_gap_s:.6f} s, the longest {self.longest_imu_gap_s * 1e3:.4g} ms): "
                f"{self.segments} continuous segments (sizefx inspect lists them); navigate and "
                "compensate take --segment K"
            )
            if self.declared_gaps < gaps:
                lines.append(
                    f"note: {gaps - self.declared_gaps} gaps only the accelerometer stamps show cannot be "
                    "declared; pass --allow-gaps to the commands that read this file"
                )
        if self.dropped_rows:
            d = self.dropped_rows
            lines.append(
                f"dropped {d['rows']} IMU rows holding NaN, inf or values beyond the physical limits (the "
                f"first: source row {d['first_row']}, after t = {d['after_time_s']:.6f} s); they are gaps now"
            )
        checked = report_lines(self.units_check)
        lines.append(f"units: {checked[0]}")
        lines.extend(f"       {line}" for line in checked[1:])
        return "\n".join(lines)


def run(config: ImportConfig, *, progress=None) -> ImportResult:
    """Import ``config.source`` into ``config.output``; validate the written file; return what it holds.

    Pre-flight first (:func:`sizefx.stage.preflight`: the source and ``--reference-file`` exist,
    the output is new or ``force``, writable, and none of the inputs). The record is converted,
    its IMU gaps declared in ``/imu/gaps``, written to a temporary file, read back through the
    validating reader and, with ``check_units``, checked against physics
    (:func:`sizefx.sanity.check_units`); only then is it renamed to ``output``. Every error names
    the user's file (the source, or the output), never the temporary one.

    ``progress`` is accepted for the shape every stage shares and not called: the converters
    read a source whole, and the import of the longest real recording takes seconds.
    """
    from ..sanity import check_units as units_of
    from ..sanity import refuse_wrong_units
    from ..stage import preflight

    preflight(inputs=config.inputs(), outputs=config.outputs(), force=config.force)
    fmt, source, out = config.format, config.source, config.output
    tel = load_source(fmt, source, keep_invalid=config.drop_invalid_rows, **config.reader_options())
    dropped = _drop_invalid_rows(tel, source) if config.drop_invalid_rows else None
    _check_imu_rate(tel, fmt, source)
    tel.gaps = find_imu_gaps(tel.time_s, tel.accel_time_s, declared=True)  # written to /imu/gaps
    report = None
    # write and validate the temporary file: a file the reader or the units check refuses never reaches OUT
    with atomic_output(out, inputs=[p for p in config.inputs().values() if p is not None], force=config.force) as tmp:
        try:
            write_telemetry(tmp, tel, force=True)
        except OSError as exc:  # disk full, quota: name the output the user asked for
            raise OutputError(
                f"{out}: cannot be written ({exc.strerror or exc}); check the space and permissions of its folder"
            ) from None
        except OutputError as exc:  # the writer's own refusal (no room) names its file: ours is temporary
            raise OutputError(str(exc).replace(str(tmp), str(out))) from None
        # gaps only the accelerometer stamps show cannot be declared: allowed here, reported below;
        # the magnitudes are judged by the units check (its messages speak of the import's options)
        try:
            back = read_telemetry(tmp, allow_gaps=True, check_plausibility=False, check_limits=False)
        except TelemetryError as exc:  # name the user's file, never the temporary one
            raise SourceError(
                source, f"converts to a record that breaks sizefx/telemetry/1: {exc.dataset}: {exc.problem}"
            ) from None
        if config.check_units:
            declared, where, fix = _units_context(fmt, back)
            with np.errstate(over="ignore", invalid="ignore"):  # a 1e300 sample: refused by the limits below
                report = units_of(back, declared=declared)
            refuse_wrong_units(report, source, where=where, fix=fix)
        # then what no unit explains: samples beyond the physical limits (the reader's, here after the units)
        for name, data in _datasets(back):
            problem = limit_problem(load_schema(TELEMETRY_SCHEMA), name, data)
            if problem:
                raise SourceError(source, f"converts to a record that breaks sizefx/telemetry/1: {name}: {problem}")
    back.path = str(out)
    imu_gaps = [g for g in back.gaps if g.dataset.startswith("/imu")]
    ref_gaps = [g for g in back.gaps if g.dataset.startswith("/reference")]
    return ImportResult(
        path=str(out),
        format=fmt,
        samples=back.n_samples,
        form=back.form,
        rate_hz=back.sample_rate_hz,
        duration_s=back.duration_s,
        imu_gaps=len(imu_gaps),
        declared_gaps=sum(g.declared for g in imu_gaps),
        first_imu_gap_s=imu_gaps[0].time_s if imu_gaps else None,
        longest_imu_gap_s=max((g.duration_s for g in imu_gaps), default=None),
        segments=len(imu_gaps) + 1,
        reference_rows=0 if back.reference is None else int(back.reference.time_s.shape[0]),
        reference_gaps=len(ref_gaps),
        accel_time=back.accel_time_s is not None,
        site=back.site is not None,
        units_check=None if report is None else report.as_dict(),
        dropped_rows=dropped,
        conversion=_conversion_lines(back.source),
    )


def _conversion_lines(source: Provenance | None) -> list | None:
    """``/source`` ``conversion`` (text, or texts) as a list of lines; None without one."""
    found = None if source is None else source.extra.get("conversion")
    if found is None:
        return None
    return [str(v) for v in found] if isinstance(found, tuple) else [str(found)]


def _check_imu_rate(tel, fmt: str, source) -> None:
    """Refuse a record whose IMU time stamps imply a rate outside :data:`IMU_RATE_HZ`. The CSV importer
    checks its time column itself (it can name the column and suggest ``--time-units``); this catches the
    formats whose time unit is fixed, where a rate out of range means the source is not what it claims."""
    rate_hz = median_rate_hz(tel.time_s)
    lo, hi = IMU_RATE_HZ
    if rate_hz is not None and not lo <= rate_hz <= hi:
        raise SourceError(
            source,
            f"its IMU time stamps imply {rate_hz:.3g} Hz (the median step), outside the {lo:g}..{hi:g} Hz of "
            f"an IMU; check that the source is a genuine {fmt} file",
        )


def reference_up_angle_deg(ref, time_s, accel_like, period_s: float, form: str) -> float | None:
    """The median angle [deg] between the specific force the accelerometers read and "up" as the
    reference attitude puts it in body axes, over the reference rows within the IMU's span; None
    when none is (or no reading has a direction). At rest the two coincide; a reference in the
    wrong frame is typically 90-180 deg off (:data:`REFERENCE_GRAVITY_ANGLE_MAX_DEG`)."""
    t = np.asarray(time_s, dtype=float)
    inside = (ref.time_s >= t[0]) & (ref.time_s <= t[-1])
    if not inside.any():
        return None
    k = np.clip(np.searchsorted(t, ref.time_s[inside]), 0, t.size - 1)
    f_b = accel_like[k] / (period_s if form == "increments" else 1.0)
    up_b = -quat_to_mat(ref.quat_nb[inside])[:, 2, :]  # body components of NED up: -(row 3 of mat_nb)
    norm = np.linalg.norm(f_b, axis=1)
    ok = norm > 0.0
    if not ok.any():
        return None
    cos = np.einsum("ij,ij->i", f_b[ok], up_b[ok]) / norm[ok]
    return float(np.median(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))))


def _drop_invalid_rows(tel, source) -> dict | None:
    """Remove, in place, the IMU rows whose time, gyro-like or accel-like samples are not finite or lie
    beyond the telemetry schema's physical limits; the holes become gaps (declared when written).
    Returns what was dropped, or None when every row was valid."""
    schema = load_schema(TELEMETRY_SCHEMA)
    bad = np.zeros(tel.n_samples, dtype=bool)
    for name, data in _datasets(tel):
        if name.startswith("/imu"):
            bad |= invalid_rows(schema, name, data).any(axis=1)
    if not bad.any():
        return None
    first = int(np.flatnonzero(bad)[0])
    keep = ~bad
    if keep.sum() < 2:
        raise SourceError(
            source,
            f"every IMU row but {int(keep.sum())} is invalid (NaN, inf or "
            "beyond the physical limits); nothing is left to import",
        )
    for field_name in ("time_s", "gyro_rad_s", "accel_mps2", "dtheta_rad", "dvel_mps", "accel_time_s"):
        data = getattr(tel, field_name)
        if data is not None:
            setattr(tel, field_name, data[keep])
    # rows before the first dropped one are all kept: the kept row before the hole is at first - 1
    return {"rows": int(bad.sum()), "first_row": first, "after_time_s": float(tel.time_s[max(0, first - 1)])}


def _datasets(tel):
    """``(dataset name, SI rows)`` of a record, as the telemetry contract names them."""
    gyro, accel = ("/imu/gyro", "/imu/accel") if tel.form == "rates" else ("/imu/dtheta", "/imu/dvel")
    gyro_like, accel_like = tel.imu_arrays()
    pairs = [("/imu/time", tel.time_s), (gyro, gyro_like), (accel, accel_like), ("/imu/accel_time", tel.accel_time_s)]
    ref = tel.reference
    if ref is not None:
        pairs += [("/reference/time", ref.time_s), ("/reference/velocity", ref.velocity_n_mps)]
        if ref.lat_rad is not None:
            pairs.append(("/reference/position", np.column_stack([ref.lat_rad, ref.lon_rad, ref.height_m])))
    return [(name, data) for name, data in pairs if data is not None]


def run_import(fmt: str, source, out, *, force: bool = False, check_units: bool = True, **options) -> dict:
    """``run(ImportConfig(fmt, source, out, force, check_units, options)).to_json()``: the call
    scripts and tests made before the stage shape; kept so they keep working."""
    return run(ImportConfig(fmt, source, out, force=force, check_units=check_units, options=options)).to_json()


def as_array(path, name: str, value, shape_tail: tuple, *, allow_nan: bool = False) -> np.ndarray:
    """A float64 array ``[N, *shape_tail]`` from a source variable, or a SourceError naming it."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise SourceError(path, f"variable '{name}' is not numeric") from None
    if arr.ndim != 1 + len(shape_tail) or arr.shape[1:] != shape_tail:
        want = "[N" + "".join(f", {s}" for s in shape_tail) + "]"
        raise SourceError(path, f"variable '{name}' has shape {list(arr.shape)}; expected {want}")
    if arr.shape[0] == 0:
        raise SourceError(path, f"variable '{name}' holds no rows")
    if not allow_nan and not np.all(np.isfinite(arr)):
        row = int(np.argwhere(~np.isfinite(arr))[0][0])
        raise SourceError(path, f"variable '{name}' holds NaN/Inf (first at row {row})")
    return arr


def load_mat(path) -> dict:
    """A MATLAB v5 file as a dict, or a SourceError (truncated, not MATLAB, v7.3)."""
    import scipy.io

    try:
        return scipy.io.loadmat(path)
    except NotImplementedError:
        raise SourceError(path, "is a MATLAB v7.3 (HDF5) file; save it with -v7 or convert it") from None
    except Exception as exc:  # scipy raises ValueError, TypeError, OSError... on broken files
        detail = " ".join(str(exc).split())[:120]
        raise SourceError(path, f"cannot be read as a MATLAB v5 file ({detail}); truncated or not a .mat") from None
