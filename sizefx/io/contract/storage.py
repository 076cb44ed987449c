"""An HDF5 file and its datasets before anything is read (:mod:`sizefx.io.contract`): the file
exists, is HDF5 and opens (:func:`open_hdf5`), and a dataset is safe to read (:func:`storage_problem`:
every declared row stored, no chunk larger than :data:`MAX_CHUNK_BYTES`).
"""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

from ...errors import TelemetryError

__all__ = ["open_hdf5", "storage_problem", "MAX_CHUNK_BYTES"]

#: Largest HDF5 chunk read at once: one row of a dataset costs its whole chunk, decompressed.
#: sizefx writes 1.5 MiB chunks; h5py's automatic chunking stays under 1 MiB.
MAX_CHUNK_BYTES = 64 * 2**20


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
