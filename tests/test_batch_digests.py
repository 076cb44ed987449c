"""The batch's stat cache (sizefx/batch/digests.py): a digest is taken from a file's stat only while that
stat is the one the file had when hashed, and never where a write after the hash could hide in the
same tick of the file system's clock; a re-run decides each record from it (runner._unchanged)."""

from __future__ import annotations

import os
import sqlite3
import time

import pytest

from sizefx.batch import digests
from sizefx.batch.digests import COARSE_WINDOW_NS, FINE_WINDOW_NS, DigestCache, Signature, hash_file, racy_window_ns
from sizefx.batch.runner import BatchJob, _unchanged
from sizefx.io.files import sha256_of


def _cache() -> DigestCache:
    db = sqlite3.connect(":memory:", isolation_level=None)
    db.execute(DigestCache.TABLE)
    return DigestCache(db)


def _aged(path, data: bytes):
    """``path`` written with ``data``, then left past the fine racy window (its digest may be kept)."""
    path.write_bytes(data)
    time.sleep(2 * FINE_WINDOW_NS / 1e9)
    return path


def test_the_racy_window_follows_the_stamps_resolution():
    assert racy_window_ns(Signature(1, 1_700_000_000_123_456_789, 5, 1_700_000_000_123_456_789)) == FINE_WINDOW_NS
    assert racy_window_ns(Signature(1, 1_700_000_000_000_000_000, 5, 1_700_000_002_000_000_000)) == COARSE_WINDOW_NS


def test_a_digest_is_kept_only_when_the_hash_began_a_window_after_the_last_change(tmp_path, monkeypatch):
    path = tmp_path / "f.bin"
    path.write_bytes(b"abc" * 1000)
    changed = max(os.stat(path).st_ctime_ns, os.stat(path).st_mtime_ns)
    window = racy_window_ns(digests.signature(path))
    monkeypatch.setattr(digests.time, "time_ns", lambda: changed + window // 2)
    digest, sig = hash_file(path)
    assert digest == sha256_of(path) and sig is None  # a write in the same tick could follow unseen
    monkeypatch.setattr(digests.time, "time_ns", lambda: changed + window + 1)
    digest, sig = hash_file(path)
    assert digest == sha256_of(path) and sig == digests.signature(path)


def test_a_file_just_written_waits_out_a_fine_window_and_is_kept(tmp_path):
    """Kept where the stamps are fine; where they are whole milliseconds the 2 s window is not waited
    out, and the digest is not kept (the file is hashed again, once, at the next run)."""
    path = tmp_path / "out.json"
    path.write_text("{}")
    fine = racy_window_ns(digests.signature(path)) == FINE_WINDOW_NS
    assert (hash_file(path, wait=True)[1] is not None) == fine


def test_the_cache_trusts_an_unchanged_stat_and_nothing_else(tmp_path):
    cache = _cache()
    path = _aged(tmp_path / "record.h5", b"a" * 4096)
    first = cache.digest(path)
    assert cache.known(path) == first == sha256_of(path)
    # the same size, other bytes: mtime and ctime move
    _aged(path, b"b" * 4096)
    assert cache.known(path) is None and cache.digest(path) == sha256_of(path) != first
    # the same bytes put in its place (another inode), or its times set back: hashed again
    second = cache.known(path)
    twin = _aged(tmp_path / "twin", path.read_bytes())
    os.replace(twin, path)
    assert cache.known(path) is None and cache.digest(path) == second
    info = os.stat(path)
    os.utime(path, ns=(info.st_atime_ns, info.st_mtime_ns - 10**9))
    assert cache.known(path) is None
    # a racy digest is never kept: what the cache held of that path is dropped
    cache.keep({str(path): (None, "0" * 64)})
    assert cache.known(path) is None


def _job(tmp_path, cache):
    """A finished record: its input, a paired file and an output, all hashed into ``cache``; the job a
    re-run makes of it."""
    record, levers, out = tmp_path / "run.h5", tmp_path / "levers.json", tmp_path / "run.nav.h5"
    record.write_bytes(b"imu" * 1000)
    levers.write_bytes(b"{}")
    _aged(out, b"nav" * 100)  # the three past the racy window
    entry = {
        "input": str(record),
        "name": "run",
        "sha256": cache.digest(record),
        "paired": {"--levers": {"path": str(levers), "sha256": cache.digest(levers)}},
        "options": {},
        "outputs": {"-o": {"path": str(out), "bytes": out.stat().st_size, "sha256": cache.digest(out)}},
        "status": "ok",
    }
    job = BatchJob(
        "navigate", str(record), "run", None, {}, {"-o": str(out)}, None, entry, False, {"--levers": str(levers)}
    )
    return job, record, levers, out


def test_a_rerun_reuses_a_record_only_while_every_file_is_unchanged(tmp_path, monkeypatch):
    cache = _cache()
    job, record, levers, out = _job(tmp_path, cache)
    with monkeypatch.context() as m:  # nothing hashed: the stat decides
        m.setattr(digests, "sha256_of", lambda *_, **__: pytest.fail("hashed"))
        assert _unchanged(job, cache)
    levers.write_bytes(b"[]")  # a changed paired file
    assert not _unchanged(job, cache)
    job, record, levers, out = _job(tmp_path, cache)
    record.write_bytes(b"IMU" * 1000)  # a changed input: the worker hashes it and decides
    assert not _unchanged(job, cache)
    job, record, levers, out = _job(tmp_path, cache)
    out.write_bytes(b"NAV" * 100)  # an output changed in place, its size kept: hashed again here
    assert not _unchanged(job, cache)
    job, record, levers, out = _job(tmp_path, cache)
    out.unlink()  # a lost output
    assert not _unchanged(job, cache)
    job, *_ = _job(tmp_path, cache)
    assert _unchanged(job, cache) and not _unchanged(BatchJob(**{**job.__dict__, "redo": True}), cache)


def test_a_signature_sqlite_cannot_hold_is_not_kept(tmp_path):
    """An inode beyond 2**63 (some network and FUSE file systems): nothing is kept, nothing fails."""
    cache = _cache()
    path = _aged(tmp_path / "f", b"x")
    cache.keep({str(path): (Signature(1, 1, 2**64 - 5, 1), "0" * 64)})
    assert cache.known(path) is None and cache.digest(path) == sha256_of(path)
