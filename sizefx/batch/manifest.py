"""A batch folder's memory: what each record became, kept so that a stopped batch resumes.

Two files in the batch folder:

- ``manifest.sqlite``: the store the batch works with (SQLite, the standard library's, in WAL
  mode): one row per record, keyed by its input path, written as each record finishes. A write
  is one row, whatever the batch's size, and a transaction: killed at any instant (SIGKILL, a
  machine switched off), the store holds every record finished before and the next run reads it.
  A resume looks each record up by its path; nothing holds the whole manifest in memory. The store
  also keeps the batch's stat cache (:mod:`.digests`): each SHA-256 it computed with the file's stat
  then, so that a re-run hashes only the files whose stat changed.
- ``manifest.json`` (``sizefx/batch/1``, ``data-schemas/batch-1.json``): the same records as one
  JSON document for people and tools, written atomically from the store when a batch ends
  (however it ends, short of SIGKILL; the next run rewrites it then). A folder that has only a
  ``manifest.json`` (made by hand, or by a sizefx before the store) is read from it.

Each record's entry holds its input and SHA-256, the options, its outputs with their sizes and
hashes, the status (ok / refused with its one-line reason / failed), duration, peak memory and
headline figures; :func:`reusable` decides whether a re-run may skip it.
"""

from __future__ import annotations

import json
import math
import os
import sqlite3
import stat
from pathlib import Path

from .. import __version__
from ..errors import ConfigError
from ..io.documents import read_json, write_json_streamed
from ..io.files import file_kind, sha256_of
from ..io.schema import check_document, validate_input
from .digests import DigestCache

__all__ = [
    "BATCH_SCHEMA",
    "MANIFEST_NAME",
    "STORE_NAME",
    "STORE_FILES",
    "MAX_MANIFEST_JSON_BYTES",
    "Manifest",
    "read_manifest",
    "reusable",
    "canonical_options",
]

BATCH_SCHEMA = "sizefx/batch/1"
MANIFEST_NAME = "manifest.json"
STORE_NAME = "manifest.sqlite"
#: The store's files: the database and SQLite's write-ahead log and its index (WAL mode).
STORE_FILES = (STORE_NAME, f"{STORE_NAME}-wal", f"{STORE_NAME}-shm")
#: Largest ``manifest.json`` read where a folder has no store: about 30 000 records. A larger
#: campaign's folder has its store, which is read a record at a time.
MAX_MANIFEST_JSON_BYTES = 16 * 2**20
#: Seconds SQLite waits on a store another process is writing (a second batch is refused by the
#: folder's lock before this matters).
STORE_TIMEOUT_S = 10.0


def canonical_options(options: dict) -> dict:
    """The stage options as the manifest holds and compares them: JSON values (tuples as lists,
    NaN refused earlier by the options' own checks), keys sorted."""

    def plain(v):
        if isinstance(v, (list, tuple)):
            return [plain(x) for x in v]
        if isinstance(v, float) and not math.isfinite(v):
            return str(v)
        return v

    return {k: plain(options[k]) for k in sorted(options)}


def _own_file(path: Path, what: str) -> bool:
    """Whether the batch's own file ``path`` exists, refused in one line when it is a link (the batch
    would read or write through it) or anything but a regular file."""
    try:
        info = os.lstat(path)
    except FileNotFoundError:
        return False
    except OSError as exc:
        raise ConfigError(f"{path}: {what} cannot be read ({exc.strerror or exc}); remove it") from None
    if stat.S_ISLNK(info.st_mode):
        raise ConfigError(f"{path}: {what} is a link; remove it or give another --out")
    if not stat.S_ISREG(info.st_mode):
        raise ConfigError(f"{path}: {what} is {file_kind(info.st_mode)}; remove it or give another --out")
    return True


class Manifest:
    """A batch folder's records (the store, :data:`STORE_NAME`; or, in a folder without one, its
    ``manifest.json``), by input path.

    ``Manifest(out_dir, stage)`` reads (nothing is created: a folder without a manifest has no
    entries); :meth:`open_for_writing` makes the store if new, for the batch that holds the folder's
    lock. A folder that holds another stage's batch is refused in one line."""

    def __init__(self, out_dir, stage: str):
        self.out_dir, self.stage = Path(out_dir), stage
        self.path = self.out_dir / STORE_NAME
        self._db: sqlite3.Connection | None = None
        self._legacy: dict[str, dict] = {}
        self._writable = False
        for name in STORE_FILES[1:]:
            _own_file(self.out_dir / name, "the batch manifest's log")
        if _own_file(self.path, "the batch manifest"):
            self._connect(read_only=True)
        elif _own_file(self.out_dir / MANIFEST_NAME, "the batch manifest"):
            doc = read_manifest(self.out_dir, stage)
            self._legacy = {e["input"]: e for e in (doc or {}).get("records", [])}

    def _fail(self, exc: Exception) -> ConfigError:
        return ConfigError(
            f"{self.path}: the batch manifest cannot be used ({' '.join(str(exc).split())}); remove it "
            "(and manifest.json) to start the batch afresh, or give another --out"
        )

    def _connect(self, read_only: bool) -> None:
        try:
            db = sqlite3.connect(self.path, timeout=STORE_TIMEOUT_S, isolation_level=None)
            if not read_only:
                db.execute("PRAGMA journal_mode=WAL")
                # NORMAL in WAL mode: a commit survives the process's death at any instant; a power cut
                # may lose the last records (run again), never the store
                db.execute("PRAGMA synchronous=NORMAL")
                db.execute("CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)")
                db.execute("CREATE TABLE IF NOT EXISTS records (input TEXT PRIMARY KEY, entry TEXT NOT NULL)")
                db.execute(DigestCache.TABLE)
            meta = dict(db.execute("SELECT key, value FROM meta").fetchall())
        except sqlite3.Error as exc:
            raise self._fail(exc) from None
        if meta and meta.get("schema") != BATCH_SCHEMA:
            raise self._fail(ValueError(f"schema {meta.get('schema')!r}, not {BATCH_SCHEMA}"))
        if meta and meta.get("stage") != self.stage:
            raise ConfigError(
                f"{self.out_dir}: the folder holds a batch of '{meta.get('stage')}', not '{self.stage}'; give another --out"
            )
        if self._db is not None:
            self._db.close()
        self._db = db

    def open_for_writing(self, options: dict) -> Manifest:
        """Make the store if new (with a ``manifest.json``'s records, in a folder that has only that),
        ready for :meth:`record`; ``options``: this run's stage options."""
        legacy, self._legacy = self._legacy, {}
        self._connect(read_only=False)
        assert self._db is not None
        try:
            with self._db:
                self._db.execute("BEGIN")
                for key, value in (("schema", BATCH_SCHEMA), ("stage", self.stage)):
                    self._db.execute("INSERT OR IGNORE INTO meta VALUES (?, ?)", (key, value))
                for key, value in (("sizefx_version", __version__), ("options", json.dumps(options))):
                    self._db.execute("INSERT OR REPLACE INTO meta VALUES (?, ?)", (key, value))
                self._db.executemany(
                    "INSERT OR IGNORE INTO records VALUES (?, ?)", ((k, json.dumps(e)) for k, e in legacy.items())
                )
        except sqlite3.Error as exc:
            raise self._fail(exc) from None
        self._writable = True
        return self

    def has_entries(self) -> bool:
        """Whether the folder holds an entry of any record (a re-run or a resume, not a new batch)."""
        if self._db is None:
            return bool(self._legacy)
        try:
            return self._db.execute("SELECT 1 FROM records LIMIT 1").fetchone() is not None
        except sqlite3.Error as exc:
            raise self._fail(exc) from None

    @property
    def digests(self) -> DigestCache:
        """The folder's stat cache (:mod:`.digests`), kept in the store; empty until
        :meth:`open_for_writing`."""
        return DigestCache(self._db if self._writable else None)

    def entry(self, record: str) -> dict | None:
        """The entry of the record whose input is ``record`` (its resolved path), or None."""
        if self._db is None:
            return self._legacy.get(record)
        try:
            row = self._db.execute("SELECT entry FROM records WHERE input = ?", (record,)).fetchone()
        except sqlite3.Error as exc:
            raise self._fail(exc) from None
        return None if row is None else json.loads(row[0])

    def forget_gone(self) -> list[str]:
        """Drop the entries of refused or failed records whose input no longer exists, and return
        their inputs: such a record has no outputs in the folder, and its entry would list a record
        the batch no longer has. A finished record's entry stays while its outputs are in the folder,
        whatever became of its input."""
        assert self._writable and self._db is not None, "open_for_writing first"
        try:
            try:  # SQLite reads the status (its JSON functions: built in from 3.38, an extension before)
                rows = self._db.execute("SELECT input FROM records WHERE json_extract(entry, '$.status') != 'ok'")
                unfinished = [record for (record,) in rows]
            except sqlite3.OperationalError:  # without them, a row at a time
                rows = self._db.execute("SELECT input, entry FROM records")
                unfinished = [record for record, text in rows if json.loads(text).get("status") != "ok"]
            gone = [record for record in unfinished if not os.path.lexists(record)]
            if not gone:
                return gone
            with self._db:
                self._db.execute("BEGIN")
                self._db.executemany("DELETE FROM records WHERE input = ?", ((g,) for g in gone))
        except sqlite3.Error as exc:
            raise self._fail(exc) from None
        return gone

    def record(self, entry: dict, options: dict) -> None:
        """Keep a finished record's ``entry`` (checked against the contract): one row, committed."""
        assert self._writable and self._db is not None, "open_for_writing first"
        check_document(self._document(options, [entry]), BATCH_SCHEMA)
        try:
            self._db.execute("INSERT OR REPLACE INTO records VALUES (?, ?)", (entry["input"], json.dumps(entry)))
        except sqlite3.Error as exc:
            raise self._fail(exc) from None

    def _document(self, options: dict, records: list) -> dict:
        return {
            "schema": BATCH_SCHEMA,
            "stage": self.stage,
            "sizefx_version": __version__,
            "options": options,
            "records": records,
        }

    def export(self, options: dict) -> Path:
        """Write ``manifest.json`` atomically from the store, a record at a time (memory bounded
        whatever the batch's size), the records sorted by input path.

        Also after a signal stopped the batch: unlike a record's outputs (which
        :func:`~sizefx.io.files.atomic_output` then discards), the manifest of the records done is
        what the user needs. The batch checked before it started that this path is no input
        (:func:`.inputs.check_writes`)."""
        assert self._db is not None
        db = self._db

        def entries():  # each as the store keeps it: its JSON text
            try:
                for (text,) in db.execute("SELECT entry FROM records ORDER BY input"):
                    yield text
            except sqlite3.Error as exc:
                raise self._fail(exc) from None

        # published also after a signal stopped the batch (interrupted=True), unlike a record's outputs
        doc = self._document(options, [])
        return write_json_streamed(
            self.out_dir / MANIFEST_NAME, doc, "records", entries(), force=True, interrupted=True
        )

    def close(self) -> None:
        if self._db is not None:
            self._db.close()
            self._db = None


def read_manifest(out_dir, stage: str) -> dict | None:
    """The ``manifest.json`` in ``out_dir`` as a document, checked against its schema (None when there
    is none); at most :data:`MAX_MANIFEST_JSON_BYTES`. A manifest of another stage is refused: one
    batch folder holds one stage's outputs. (A batch itself reads its folder's :class:`Manifest`.)"""
    path = Path(out_dir) / MANIFEST_NAME
    if not _own_file(path, "the batch manifest"):
        return None
    doc = read_json(path, "batch manifest")
    validate_input(doc, BATCH_SCHEMA, path)
    if doc["stage"] != stage:
        raise ConfigError(f"{path}: the folder holds a batch of '{doc['stage']}', not '{stage}'; give another --out")
    return doc


def reusable(
    entry: dict | None, sha256: str, options: dict, paired: dict | None = None, expected=None, digest=sha256_of
) -> bool:
    """Whether a previous run's ``entry`` for a record stands: it succeeded, on the same input bytes,
    options and paired files (``{option: {"path", "sha256"}}``), and its outputs are still there with
    the sizes and hashes it wrote. ``expected`` (option -> path, what this run would write): the entry
    must list an output for each, at that path (a file) or inside it (a folder's files, listed as
    ``option/...``), and nothing else; a manifest copied with its folder or edited by hand names
    files elsewhere, or none, and the record runs again. ``digest(path)``: an output's SHA-256 (the
    batch's stat cache, :meth:`.digests.DigestCache.digest`, hashes only a file whose stat changed)."""
    if not entry or entry.get("status") != "ok" or entry.get("sha256") != sha256 or entry.get("options") != options:
        return False
    if entry.get("paired", {}) != (paired or {}):
        return False
    outputs = entry.get("outputs", {})
    if expected is not None:
        expected = {option: Path(path).resolve() for option, path in expected.items()}
        listed = {key.split("/")[0] for key in outputs}
        if listed != set(expected):
            return False
        for key, out in outputs.items():
            where = expected[key.split("/")[0]]
            path = Path(out["path"]).resolve()
            if path != where and where not in path.parents:
                return False
    for out in outputs.values():
        path = Path(out["path"])
        if not path.is_file() or path.stat().st_size != out["bytes"] or digest(path) != out["sha256"]:
            return False
    return True
