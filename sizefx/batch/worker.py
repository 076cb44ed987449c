"""A batch worker: a record's stage run in a worker process or a Dask task, its files hashed (beside
the stage where a core is free, after it otherwise; not at all where the batch's stat cache knows
them), its outputs collected, where its time went and its peak memory, and the worker's start (its
memory bound, its death with the batch, the stage's code imported).

A record whose stage refuses it (a :class:`~sizefx.errors.SizefxError`, one line) is ``refused``;
any other exception is ``failed`` with its one-line summary; :func:`_work` never raises for the
record's own faults.
"""

from __future__ import annotations

import contextlib
import ctypes
import importlib
import os
import resource
import signal
import socket
import sys
import threading
import time
from pathlib import Path
from typing import Any

from ..errors import SizefxError
from ..io.documents import write_json
from ..io.files import ABANDONED
from ..io.schema import as_json
from ..runs.figures import headline
from ..stage import helper_threads, use_helper_threads
from .digests import hash_file
from .manifest import reusable
from .outcome import BatchJob, RecordOutcome

__all__ = ["STAGES", "MEMORY_SHARE", "default_memory_mib"]

#: The stages a batch runs: the module whose ``run(config)`` is the stage (the same the single-file
#: command calls). A job may also name a module of its own (the tests' stage that kills its worker).
STAGES = {
    "navigate": "sizefx.navigate",
    "compensate": "sizefx.compensate",
    "calibrate": "sizefx.calibrate",
    "diagnose": "sizefx.diagnose",
    "inspect": "sizefx.inspect",
    "compare": "sizefx.compare",
    "run": "sizefx.chain",
}


#: A worker's memory bound by default: this share of the machine's memory, split among the workers.
#: A record that needs more fails alone (``MemoryError``, reported as such) instead of the kernel's
#: out-of-memory killer taking another worker, the batch itself or the user's session; the rest is
#: left to the parent, the page cache (the records are read through it) and the rest of the machine.
MEMORY_SHARE = 0.8
#: The bound the worker process runs under (MiB; None: unbounded), set by :func:`_bound_memory`.
_memory_limit_mib: float | None = None


def default_memory_mib(workers: int) -> float | None:
    """:data:`MEMORY_SHARE` of the machine's physical memory over ``workers`` [MiB] (None where the
    size cannot be read)."""
    try:
        total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return None
    return MEMORY_SHARE * total / 2**20 / max(1, workers)


def _bound_memory(mib: float | None) -> None:
    """Limit this (worker) process's data (heap and anonymous mappings: what NumPy, h5py and Numba
    allocate; Linux ``RLIMIT_DATA``) to ``mib``: an allocation beyond it raises ``MemoryError``."""
    global _memory_limit_mib
    if mib is None:
        return
    limit = int(mib * 2**20)
    _, hard = resource.getrlimit(resource.RLIMIT_DATA)
    if hard != resource.RLIM_INFINITY:
        limit = min(limit, hard)
    with contextlib.suppress(ValueError, OSError):  # a platform without it: the stages' own bounds only
        resource.setrlimit(resource.RLIMIT_DATA, (limit, hard))
        _memory_limit_mib = limit / 2**20


def _reset_peak_memory() -> bool:
    """Reset the process's peak resident memory (Linux: ``/proc/self/clear_refs``), so that the peak
    read after a record is that record's, not an earlier one's in the same warm worker."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        return True
    except OSError:
        return False


def _peak_memory_mib(reset: bool) -> float:
    """Peak resident memory [MiB] since the reset (or, where it cannot be reset, of the process so far)."""
    if reset:
        try:
            for line in Path("/proc/self/status").read_text().splitlines():
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024.0
        except OSError:
            pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _collect(outputs: dict, digests: dict) -> dict:
    """``{option: {path, bytes, sha256}}`` of the files the stage wrote (a folder's files each as
    ``option/relative/path``); each digest also into ``digests`` (path -> (signature, sha256), for the
    folder's stat cache: :func:`.digests.hash_file`, which waits out the racy window of a file just
    written where it is short)."""
    found = {}
    for option, path in sorted(outputs.items()):
        p = Path(path)
        files = sorted(q for q in p.rglob("*") if q.is_file()) if p.is_dir() else ([p] if p.is_file() else [])
        for q in files:
            key = f"{option}/{q.relative_to(p).as_posix()}" if p.is_dir() else option
            digest, sig = hash_file(q, wait=True)
            digests[str(q)] = (sig, digest)
            found[key] = {"path": str(q), "bytes": q.stat().st_size, "sha256": digest}
    return found


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__


def _digest(path, known: dict, digests: dict) -> str:
    """``path``'s SHA-256: from ``known`` (the stat cache's, passed with the job), else hashed and put
    into ``digests`` (as :func:`_collect`). Raises ``OSError`` for a file that cannot be read."""
    if str(path) in known:
        return known[str(path)]
    digest, sig = hash_file(path)
    digests[str(path)] = (sig, digest)
    return digest


def _paired_hashes(paired: dict, known: dict, digests: dict) -> dict:
    """``{option: {"path", "sha256"}}`` of a job's paired files ("" for one that cannot be read: the
    stage says why), by :func:`_digest`."""
    out = {}
    for option, path in sorted(paired.items()):
        digest = ""
        with contextlib.suppress(OSError):
            digest = _digest(path, known, digests)
        out[option] = {"path": str(path), "sha256": digest}
    return out


def _hash_inputs(path, paired: dict, known: dict) -> tuple[str, dict, dict, float]:
    """``(sha256, paired, digests, seconds)`` of a record and its paired files: the input's SHA-256
    ("" if it cannot be read: the stage says why), the paired files' (:func:`_paired_hashes`), every
    digest computed (for the stat cache) and how long that took."""
    t0 = time.perf_counter()
    digests: dict = {}
    digest = ""
    with contextlib.suppress(OSError):
        digest = _digest(path, known, digests)
    return digest, _paired_hashes(paired, known, digests), digests, time.perf_counter() - t0


class _Hashing(threading.Thread):
    """:func:`_hash_inputs` in a thread of its own while the stage runs."""

    def __init__(self, *args):
        super().__init__(daemon=True)
        self.args = args
        self.out: tuple[str, dict, dict, float] = ("", {}, {}, 0.0)
        self.start()

    def run(self):
        self.out = _hash_inputs(*self.args)

    def result(self) -> tuple[str, dict, dict, float]:
        self.join()
        return self.out


class _DaskWatch(threading.Thread):
    """In a Dask worker: looks every :data:`DASK_WATCH_S` whether the task running this record is still
    wanted (its batch cancels it when stopped, or its scheduler forgets it); once not, the thread
    running the record is marked abandoned (:data:`sizefx.io.files.ABANDONED`) and its outputs are
    discarded instead of published. Outside a Dask task it does nothing."""

    def __init__(self):
        super().__init__(daemon=True, name="sizefx-dask-watch")
        self.owner, self.stopped = threading.get_ident(), threading.Event()
        self.worker = self.key = None
        if "distributed" not in sys.modules:  # a local worker: no Dask task to watch, and no import of it
            return
        with contextlib.suppress(Exception):  # not in a Dask task: nothing to watch
            from distributed import get_worker
            from distributed.worker import thread_state

            self.worker, self.key = get_worker(), thread_state.key
        if self.worker is not None:
            self.start()

    def wanted(self) -> bool:
        tasks = getattr(getattr(self.worker, "state", self.worker), "tasks", {})
        task = tasks.get(self.key)
        return task is not None and getattr(task, "state", "executing") not in ("cancelled", "released", "forgotten")

    def run(self):
        while not self.stopped.wait(DASK_WATCH_S):
            if not self.wanted():
                ABANDONED.add(self.owner)
                return

    def close(self):
        self.stopped.set()
        if self.is_alive():
            self.join()  # at most one look: after it, the mark below cannot come back
        ABANDONED.discard(self.owner)


#: Seconds between a Dask task's looks at whether its batch still wants it.
DASK_WATCH_S = 0.2


def _work(job: BatchJob) -> RecordOutcome:
    """Run one record (in a worker process, or a Dask task: :class:`_DaskWatch`); never raises for the
    record's own faults."""
    watch = _DaskWatch()
    try:
        return _work_watched(job)
    finally:
        watch.close()


def _work_watched(job: BatchJob) -> RecordOutcome:
    t0 = time.perf_counter()
    reset = _reset_peak_memory()
    entry: dict[str, Any] = {  # the record's manifest entry (a JSON object)
        "input": job.input,
        "name": job.name,
        "sha256": "",
        "options": job.options,
        "outputs": {},
        "status": "ok",
        "reason": None,
        "duration_s": 0.0,
        "peak_memory_mib": 0.0,
        "headline": {},
    }
    digests: dict = {}  # path -> (signature, sha256) of every file hashed here, for the stat cache
    phases: dict[str, float] = {}  # where the record's time went [s]
    may_reuse = not job.redo and job.previous is not None and job.previous.get("status") == "ok"
    if may_reuse:  # the stat cache could not tell (a file's stat changed): the hashes decide
        assert job.previous is not None  # may_reuse says so
        started = time.perf_counter()
        paired = _paired_hashes(job.paired, job.known, digests)

        def output_digest(path) -> str:
            digest, sig = hash_file(path)
            digests[str(path)] = (sig, digest)
            return digest

        try:
            entry["sha256"] = _digest(job.input, job.known, digests)
            expected = {**job.outputs, **({"summary": job.summary_path} if job.summary_path else {})}
            if reusable(job.previous, entry["sha256"], job.options, paired, expected, output_digest):
                return RecordOutcome(job.previous, reused=True, digests=digests)
        except OSError:  # the input (or an output) cannot be read now: the stage runs and says why
            entry["sha256"] = ""
        if paired:
            entry["paired"] = paired
        hashing = None
        phases["hash"] = time.perf_counter() - started
    elif helper_threads():  # it runs anyway: hash beside the stage, on a core the other workers leave idle
        hashing = _Hashing(job.input, job.paired, job.known)
    else:  # workers that fill the cores: after the stage (a thread beside it would take another worker's core)
        hashing = None
    try:
        started = time.perf_counter()
        result = importlib.import_module(STAGES.get(job.stage, job.stage)).run(job.config)
        phases["stage"] = time.perf_counter() - started
        phases.update(getattr(result, "phases_s", None) or {})  # the stage's own account, where it keeps one
        started = time.perf_counter()
        doc = as_json(result.to_json())
        if job.summary_path:
            write_json(job.summary_path, doc, inputs=[job.input], force=True)
        entry["headline"] = headline(job.stage, doc)
        entry["outputs"] = _collect(
            {**job.outputs, **({"summary": job.summary_path} if job.summary_path else {})}, digests
        )
        phases["outputs"] = time.perf_counter() - started
    except SizefxError as exc:
        entry["status"], entry["reason"] = "refused", _one_line(exc)
    except MemoryError as exc:  # beyond the worker's bound (or the machine's): this record only
        bound = f"the worker's bound of {_memory_limit_mib:.0f} MiB" if _memory_limit_mib else "the memory there is"
        entry["status"], entry["reason"] = (
            "failed",
            (
                f"MemoryError: the record needs more than {bound} "
                f"({_one_line(exc)}); give it fewer --workers or a larger "
                "--memory-per-worker-mib, or cut it"
            ),
        )
    except Exception as exc:  # a bug or a library's failure on this record: the others go on
        entry["status"], entry["reason"] = "failed", f"{type(exc).__name__}: {_one_line(exc)}"
    if not may_reuse:  # "" for a file that could not be read (the stage said why)
        hashed = hashing.result() if hashing is not None else _hash_inputs(job.input, job.paired, job.known)
        entry["sha256"], paired, found, phases["hash"] = hashed
        digests.update(found)
        if paired:
            entry["paired"] = paired
    entry["duration_s"] = time.perf_counter() - t0
    entry["peak_memory_mib"] = _peak_memory_mib(reset)
    entry["worker"] = f"{socket.gethostname()} pid {os.getpid()}"
    entry["phases_s"] = {k: round(v, 4) for k, v in phases.items()}
    samples = _samples_of(job.input) if entry["status"] == "ok" else None
    if samples is not None:
        entry["samples"] = samples
    return RecordOutcome(entry, digests=digests)


def _samples_of(path) -> int | None:
    """IMU samples in the record ``path`` (the length of ``/imu/time``), for the batch's samples per
    second; None where it has none (a stage's input that is no telemetry record)."""
    with contextlib.suppress(Exception):
        import h5py

        with h5py.File(path, "r") as f:
            return int(f["imu/time"].shape[0])
    return None


#: Seconds between a worker's looks at its parent where the system cannot signal a parent's death.
PARENT_POLL_S = 0.5


def _die_with_parent(parent: int) -> None:
    """End this worker the moment the batch's process ``parent`` ends, however it ends (``kill -9``
    included), so that no worker outlives its batch or writes after it. Linux: the kernel sends
    SIGKILL on the parent's death (``prctl(PR_SET_PDEATHSIG)``); elsewhere a daemon thread looks
    every :data:`PARENT_POLL_S`. A parent already gone (before the call) ends the worker at once."""
    armed = False
    if sys.platform.startswith("linux"):
        with contextlib.suppress(OSError, AttributeError):
            libc = ctypes.CDLL(None, use_errno=True)
            armed = libc.prctl(1, signal.SIGKILL, 0, 0, 0) == 0  # 1: PR_SET_PDEATHSIG
    if os.getppid() != parent:
        os._exit(1)
    if not armed:

        def watch():
            while os.getppid() == parent:
                time.sleep(PARENT_POLL_S)
            os._exit(1)

        threading.Thread(target=watch, daemon=True, name="sizefx-parent-watch").start()


def _start_worker(memory_mib: float | None, helpers: bool, module: str | None, parent: int | None = None) -> None:
    """A worker's start: it dies with ``parent`` (:func:`_die_with_parent`), its memory bound,
    whether its stages may run helper threads, and the stage's code imported (NumPy, Numba, h5py:
    most of a worker's start-up), with what the stage's ``preload()`` loads where it has one (a
    stage whose package imports its code only when it runs: :func:`sizefx.navigate.preload`)."""
    if parent is not None:
        _die_with_parent(parent)
    _bound_memory(memory_mib)
    use_helper_threads(helpers)
    if module is not None:
        with contextlib.suppress(Exception):  # the record that needs it says why (in _work)
            preload = getattr(importlib.import_module(module), "preload", None)
            if preload is not None:
                preload()
