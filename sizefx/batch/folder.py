"""The folder a batch writes into, as :mod:`.runner` keeps it: the files a batch keeps there besides
the records' outputs (:data:`OWN_FILES`), and the check, before anything is written, that no path a
batch writes is an input, one of those files or written twice (:func:`check_batch_writes`). The
folder's lock, held while a batch or a chain writes there (:func:`folder_lock`, :data:`LOCK_NAME`),
is :mod:`sizefx.runs.folder`'s; its names are imported here too."""

from __future__ import annotations

from pathlib import Path

from ..runs.folder import LOCK_NAME, folder_lock
from .fleet import FLEET_PLOT
from .inputs import check_writes
from .manifest import MANIFEST_NAME, STORE_FILES
from .outcome import BatchJob

__all__ = ["LOCK_NAME", "folder_lock", "OWN_FILES", "check_batch_writes"]

#: The files a batch keeps in its folder besides the records' outputs: name -> what it is.
OWN_FILES = {
    MANIFEST_NAME: "the batch's manifest",
    **{name: "the batch's manifest store" for name in STORE_FILES},
    LOCK_NAME: "the batch's lock file",
    FLEET_PLOT: "the batch's figure across the records",
}


def check_batch_writes(out_dir, jobs: list[BatchJob], own: dict | None = None) -> None:
    """Refuse in one line, before anything is written, a batch into ``out_dir`` that would write over an
    input, over its own files (:data:`OWN_FILES`, and ``own``: name -> what it is) or one path twice
    (:func:`.inputs.check_writes`)."""
    out = Path(out_dir)
    check_writes(out, jobs, {out / name: what for name, what in {**OWN_FILES, **(own or {})}.items()})
