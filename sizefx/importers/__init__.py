"""Importers: other telemetry formats into ``sizefx/telemetry/1`` (``sizefx import``).

Each module exposes ``load(path, **options) -> Telemetry`` that converts axes to
body FRD, the reference to NED, and units to SI, and records where the data
came from in ``Telemetry.source`` (written to ``/source``). :func:`run_import`
declares the IMU gaps it finds in ``/imu/gaps`` (the reader's own definition of a
gap, :func:`sizefx.io.telemetry.find_imu_gaps`), writes the result atomically, reads it
back through the validating reader and checks its units against physics
(:mod:`sizefx.sanity`), so an importer can never produce a file the rest of sizefx
refuses, nor one whose rates are 57 times wrong.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

from .. import __version__
from ..errors import SourceError, TelemetryError
from ..io.files import atomic_output
from ..io.schema import allowed_units
from ..io.telemetry import find_imu_gaps, read_telemetry, write_telemetry

__all__ = ["FORMATS", "run_import", "provenance"]

#: format name -> (module in this package, loader function)
FORMATS = {
    "broad": ("broad", "load"),
    "psins-imu": ("psins", "load_imu"),
    "psins-mat": ("psins", "load_mat_record"),
    "csv": ("table", "load"),
    "ulog": ("ulog", "load"),
}


def provenance(path: Path, fmt: str, credits: str = "", **extra) -> dict:
    """``/source`` attributes: the original file, its checksum, the importer and credits."""
    digest = hashlib.sha256(Path(path).read_bytes()).hexdigest()
    out = {"format": fmt, "file": Path(path).name, "sha256": digest, "importer": f"sizefx {__version__}"}
    if credits:
        out["credits"] = credits
    out.update(extra)
    return out


def check_source(path) -> Path:
    path = Path(path)
    if not path.exists():
        raise SourceError(path, "file does not exist")
    if path.is_dir():
        raise SourceError(path, "is a directory; give a file")
    if path.stat().st_size == 0:
        raise SourceError(path, "file is empty (0 bytes)")
    return path


def load_source(fmt: str, path, **options):
    """Convert ``path`` of format ``fmt`` into a :class:`~sizefx.io.telemetry.Telemetry` (not written)."""
    import importlib

    if fmt not in FORMATS:
        raise SourceError(path, f"unknown format '{fmt}'; use one of {', '.join(FORMATS)}")
    module_name, function = FORMATS[fmt]
    loader = getattr(importlib.import_module(f"{__name__}.{module_name}"), function)
    return loader(check_source(path), **options)


def _units_context(fmt: str, tel):
    """What the source declared, for the units check: ``(declared units, names, fix)``.

    The CSV importer takes the units from the user (``--gyro-units``, ``--accel-units``) and
    records them, and the column names, in ``/source``; the other formats fix their units, so
    a mismatch there means the source is not what its format promises.
    """
    from ..sanity import FORM_QUANTITIES, UNITS_OUTSIDE_CONTRACT

    src = tel.source or {}
    names = dict(zip(("gyro", "accel"), FORM_QUANTITIES[tel.form]))
    datasets = {"gyro": "/imu/gyro" if tel.form == "rates" else "/imu/dtheta",
                "accel": "/imu/accel" if tel.form == "rates" else "/imu/dvel"}
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
                return f"multiply the columns by {outside[check.looks_like]:g} to make them {check.declared} " \
                       f"({option} takes {', '.join(allowed_units(names[check.what]))})"
            return f"convert the columns to {check.declared} before importing ({option} takes " \
                   f"{', '.join(allowed_units(names[check.what]))})"
        return f"the {fmt} format stores {check.declared}; check that the source is a genuine {fmt} file"

    return declared, where, fix


def run_import(fmt: str, source, out, *, force: bool = False, check_units: bool = True, **options) -> dict:
    """Import ``source`` into ``out``; validate the written file; return a summary.

    ``check_units``: check the magnitudes against physics (:func:`sizefx.sanity.check_units`) and
    refuse data that look like another unit (``--no-units-check`` turns it off).
    """
    from ..sanity import check_units as units_of, refuse_wrong_units

    tel = load_source(fmt, source, **options)
    tel.gaps = find_imu_gaps(tel.time_s, tel.accel_time_s, declared=True)  # written to /imu/gaps
    report = None
    # write and validate the temporary file: a file the reader or the units check refuses never reaches OUT
    with atomic_output(out, inputs=[source, options.get("reference_file")], force=force) as tmp:
        write_telemetry(tmp, tel, force=True)
        # gaps only the accelerometer stamps show cannot be declared: allowed here, reported below;
        # the magnitudes are judged by the units check (its messages speak of the import's options)
        try:
            back = read_telemetry(tmp, allow_gaps=True, check_plausibility=False)
        except TelemetryError as exc:  # name the user's file, never the temporary one
            raise SourceError(source, f"converts to a record that breaks sizefx/telemetry/1: {exc.dataset}: "
                                      f"{exc.problem}") from None
        if check_units:
            declared, where, fix = _units_context(fmt, back)
            report = units_of(back, declared=declared)
            refuse_wrong_units(report, source, where=where, fix=fix)
    back.path = str(out)
    imu_gaps = [g for g in back.gaps if g.dataset.startswith("/imu")]
    ref_gaps = [g for g in back.gaps if g.dataset.startswith("/reference")]
    return {
        "path": str(out),
        "format": fmt,
        "samples": back.n_samples,
        "form": back.form,
        "rate_hz": back.sample_rate_hz,
        "duration_s": back.duration_s,
        "imu_gaps": len(imu_gaps),
        "declared_gaps": sum(g.declared for g in imu_gaps),
        "first_imu_gap_s": imu_gaps[0].time_s if imu_gaps else None,
        "longest_imu_gap_s": max((g.duration_s for g in imu_gaps), default=None),
        "segments": len(imu_gaps) + 1,
        "reference_rows": 0 if back.reference is None else int(back.reference.time_s.shape[0]),
        "reference_gaps": len(ref_gaps),
        "accel_time": back.accel_time_s is not None,
        "site": back.site is not None,
        "units_check": None if report is None else report.as_dict(),
    }


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
