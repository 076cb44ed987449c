"""The folder a batch (or a chain) writes into, as :mod:`.runner` keeps it: its lock, held while
one writes there (:func:`folder_lock`), the files a batch keeps there besides the records' outputs
(:data:`OWN_FILES`), and the check, before anything is written, that no path a batch writes is an
input, one of those files or written twice (:func:`check_batch_writes`)."""

from __future__ import annotations

import contextlib
import errno
import fcntl
import os
import stat
from pathlib import Path

from ..errors import ConfigError
from ..io.files import file_kind
from .fleet import FLEET_PLOT
from .inputs import check_writes
from .manifest import MANIFEST_NAME, STORE_FILES
from .outcome import BatchJob

__all__ = ["LOCK_NAME", "folder_lock", "OWN_FILES", "check_batch_writes"]

#: The lock file in a batch's or a chain's folder, held while it writes there.
LOCK_NAME = ".sizefx.lock"


@contextlib.contextmanager
def folder_lock(out_dir):
    """Hold ``out_dir``'s lock (an advisory ``flock`` on :data:`LOCK_NAME`) while a batch or a chain
    writes there: a second one given the same folder is refused in one line instead of interleaving
    its outputs and manifest with the first's. Released when the process ends, however it ends.
    (``flock`` binds processes on one machine and on most local file systems; not across NFS clients.)

    The lock file is opened without following a link (``O_NOFOLLOW``) and must be a regular file:
    a link planted there (to a record, say) is refused, never written through; so are a folder, a
    FIFO or a device of that name."""
    path = Path(out_dir) / LOCK_NAME
    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC, 0o666)
    except OSError as exc:
        what = "a link" if exc.errno == errno.ELOOP else (exc.strerror or str(exc))
        raise ConfigError(
            f"{path}: the batch's lock file cannot be opened ({what}); remove it (sizefx makes its own)"
        ) from None
    info = os.fstat(fd)
    if not stat.S_ISREG(info.st_mode):
        os.close(fd)
        raise ConfigError(
            f"{path}: the batch's lock file is {file_kind(info.st_mode)}; remove it (sizefx makes its own)"
        )
    handle = os.fdopen(fd, "r+")
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = handle.read(200).strip() or "another process"
            raise ConfigError(
                f"{out_dir}: another sizefx batch or run is writing into this folder ({holder}); "
                "wait for it to finish or give another --out"
            ) from None
        handle.seek(0)
        handle.truncate()
        handle.write(f"pid {os.getpid()}")
        handle.flush()
        yield
    finally:
        handle.close()


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
