"""Whether a file is unchanged since it was hashed, from its stat alone: the batch's stat cache.

A re-run of a finished batch must decide, for every record, that its input, its paired files and
its outputs are the ones the manifest lists. Hashing them all again reads every byte of the campaign
(64 records of a 1.8 h flight at 800 Hz: 21 GB) to learn that nothing changed. As git's index and
DVC do, the batch keeps, beside each SHA-256 it computed, the file's stat as it was when hashed:

    size, mtime_ns, inode, ctime_ns  ->  SHA-256

and takes the digest from there while the stat is the same. A write to the file changes its mtime
and ctime (``ctime`` also changes when the file is replaced by a rename, or its mtime is set back by
hand: ``touch -d``, ``cp -p``), and a file put in its place has another inode. The device number is
left out: a network file system mounted on two machines (a Dask cluster's workers and the batch)
gives the same file two devices.

**Racy entries.** A file system stamps a write with a clock that advances in ticks (the kernel's
coarse clock on Linux: 1-10 ms; whole seconds on some file systems, two on FAT). A file hashed
within a tick of its last write could be written again in the same tick, after the hash, with the
same size: its stat would not change. Such a signature is never kept (git calls these entries
"racily clean"): a digest is kept only when the hash began at least :func:`racy_window_ns` after the
file's mtime and ctime, and when the stat before and after the hash are the same. A worker that
hashes an output it has just written waits out that window first when it is short (see
:data:`WAIT_RACY_NS`), so that a finished batch's outputs are trusted at the next run; where it is
long (a file system of whole seconds) the output is hashed again once, at the next run, and kept then.

The window is measured against this machine's clock: on a network file system whose server's clock
runs ahead of the machine that hashed by more than the window, give ``--rehash``.
"""

from __future__ import annotations

import os
import sqlite3
import stat
import time
from typing import NamedTuple

from ..io.files import sha256_of

__all__ = ["Signature", "signature", "racy_window_ns", "hash_file", "DigestCache", "WAIT_RACY_NS"]

#: A window for file systems with sub-millisecond stamps: two ticks of the slowest kernel clock
#: (HZ=100) that stamps them.
FINE_WINDOW_NS = 20_000_000
#: A window for stamps in whole milliseconds or seconds: FAT's two seconds.
COARSE_WINDOW_NS = 2_000_000_000
#: Longest wait before hashing a file just written, so that its digest can be kept (a fine window;
#: a coarse one is not waited out: the file is hashed again, once, at the next run).
WAIT_RACY_NS = FINE_WINDOW_NS


class Signature(NamedTuple):
    """A regular file's stat as the cache compares it."""

    size: int
    mtime_ns: int
    inode: int
    ctime_ns: int


def signature(path) -> Signature | None:
    """``path``'s :class:`Signature` (following a link, as a read does), or None where it is no
    regular file or cannot be stat'ed."""
    try:
        info = os.stat(path)
    except (OSError, ValueError):
        return None
    if not stat.S_ISREG(info.st_mode):
        return None
    return Signature(info.st_size, info.st_mtime_ns, info.st_ino, info.st_ctime_ns)


def racy_window_ns(sig: Signature) -> int:
    """How long after ``sig``'s last change a hash must begin for its digest to be kept: fine where
    the stamps carry sub-millisecond digits, coarse where both are whole milliseconds (a file system
    that stamps in seconds or two; a fine stamp is a whole millisecond once in a million, and is
    then treated as coarse)."""
    whole_ms = sig.mtime_ns % 1_000_000 == 0 and sig.ctime_ns % 1_000_000 == 0
    return COARSE_WINDOW_NS if whole_ms else FINE_WINDOW_NS


def hash_file(path, *, mapped: bool = True, wait: bool = False) -> tuple[str, Signature | None]:
    """``(sha256, signature)`` of ``path``: the signature is None unless the digest may be kept (the
    stat the same before and after the hash, the hash begun a racy window after the last change).
    ``wait``: a file changed less than :data:`WAIT_RACY_NS` ago is hashed when that time has passed
    (a worker hashing the output it has just written). Raises ``OSError`` as
    :func:`~sizefx.io.files.sha256_of` does."""
    before = signature(path)
    started = time.time_ns()
    if before is not None and wait:
        window = racy_window_ns(before)
        late = max(before.mtime_ns, before.ctime_ns) + window - started
        if 0 < late <= WAIT_RACY_NS:
            time.sleep(late / 1e9)
            started = time.time_ns()
    digest = sha256_of(path, mapped=mapped)
    after = signature(path)
    if before is None or after != before or max(before.mtime_ns, before.ctime_ns) > started - racy_window_ns(before):
        return digest, None
    return digest, before


class DigestCache:
    """The stat cache of a batch folder: a table of the manifest's store (``manifest.sqlite``),
    path -> (:class:`Signature`, SHA-256). ``db`` None: an empty cache that keeps nothing (a store
    not opened for writing)."""

    TABLE = (
        "CREATE TABLE IF NOT EXISTS digests (path TEXT PRIMARY KEY, size INTEGER NOT NULL, "
        "mtime_ns INTEGER NOT NULL, inode INTEGER NOT NULL, ctime_ns INTEGER NOT NULL, sha256 TEXT NOT NULL)"
    )

    def __init__(self, db: sqlite3.Connection | None):
        self.db = db

    def known(self, path) -> str | None:
        """The SHA-256 of ``path`` if its stat is the one it had when hashed, else None (nothing read)."""
        if self.db is None:
            return None
        sig = signature(path)
        if sig is None:
            return None
        try:
            row = self.db.execute(
                "SELECT size, mtime_ns, inode, ctime_ns, sha256 FROM digests WHERE path = ?", (str(path),)
            ).fetchone()
        except sqlite3.Error:  # a store from before the cache, read-only: nothing known
            return None
        return row[4] if row is not None and Signature(*row[:4]) == sig else None

    def digest(self, path) -> str:
        """The SHA-256 of ``path``: from the cache while its stat is unchanged, else hashed (and kept)."""
        known = self.known(path)
        if known is not None:
            return known
        digest, sig = hash_file(path, mapped=False)
        self.keep({str(path): (sig, digest)})
        return digest

    def keep(self, found: dict) -> None:
        """Keep ``{path: (signature or None, sha256)}``: the keepable ones replace what the cache held of
        those paths, the others (racy, changed while hashed) remove it."""
        if self.db is None or not found:
            return
        try:
            self.db.execute("BEGIN")
            self.db.executemany(
                "DELETE FROM digests WHERE path = ?", [(p,) for p, (s, _) in found.items() if s is None]
            )
            self.db.executemany(
                "INSERT OR REPLACE INTO digests VALUES (?, ?, ?, ?, ?, ?)",
                [(p, *s, d) for p, (s, d) in found.items() if s is not None],
            )
            self.db.execute("COMMIT")
        # a store from before the cache or read-only; an inode beyond SQLite's 64-bit integers (some
        # network and FUSE file systems): nothing kept, those files are hashed at each run
        except (sqlite3.Error, OverflowError):
            if self.db.in_transaction:
                self.db.execute("ROLLBACK")
