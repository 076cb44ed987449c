"""Importers: other telemetry formats into ``sizefx/telemetry/1`` (``sizefx import``).

Each module exposes ``load(path, **options) -> Telemetry`` that converts axes to
body FRD, the reference to NED, and units to SI, and records where the data
came from in ``Telemetry.source`` (written to ``/source``). :func:`run_import`
writes the result atomically and reads it back through the validating reader,
so an importer can never produce a file the rest of sizefx refuses.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np

from .. import __version__
from ..errors import SourceError
from ..fileio import atomic_output
from ..telemetry import read_telemetry, write_telemetry

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
    """Convert ``path`` of format ``fmt`` into a :class:`~sizefx.telemetry.Telemetry` (not written)."""
    import importlib

    if fmt not in FORMATS:
        raise SourceError(path, f"unknown format '{fmt}'; use one of {', '.join(FORMATS)}")
    module_name, function = FORMATS[fmt]
    loader = getattr(importlib.import_module(f"{__name__}.{module_name}"), function)
    return loader(check_source(path), **options)


def run_import(fmt: str, source, out, *, force: bool = False, **options) -> dict:
    """Import ``source`` into ``out``; validate the written file; return a summary."""
    tel = load_source(fmt, source, **options)
    # write and validate the temporary file: a file the reader refuses never reaches OUT
    with atomic_output(out, inputs=[source, options.get("reference_file")], force=force) as tmp:
        write_telemetry(tmp, tel, force=True)
        back = read_telemetry(tmp, allow_gaps=True)
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
        "first_imu_gap_s": imu_gaps[0].time_s if imu_gaps else None,
        "reference_rows": 0 if back.reference is None else int(back.reference.time_s.shape[0]),
        "reference_gaps": len(ref_gaps),
        "accel_time": back.accel_time_s is not None,
        "site": back.site is not None,
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
