"""The batch's work: each record's stage run in warm worker processes, the manifest kept as they finish.

Workers are spawned processes (not forked: an h5py file or a Numba compilation in the parent must
not be shared half way), ``workers`` of them for the whole batch, so each loads the Numba kernels
from the on-disk cache once and keeps them for every record it gets. A record whose stage refuses
it (a :class:`~sizefx.errors.SizefxError`, one line) is ``refused``; any other exception is
``failed`` with its one-line summary; neither stops the others. A worker that dies (killed, out of
memory) takes the records it held with it: those are run again, each alone in a fresh process, so
that only the record that kills its process is marked failed.

With a Dask scheduler (``--scheduler tcp://host:8786``, the optional ``distributed`` package) the same
:func:`_work` runs as a task per record on the cluster's workers, which read the records where
they see them; a worker lost with a record is replaced and the record run again.
"""

from __future__ import annotations

import contextlib
import ctypes
import dataclasses
import errno
import fcntl
import importlib
import multiprocessing
import os
import resource
import signal
import socket
import stat
import sys
import threading
import time
import uuid
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from pathlib import Path
from statistics import fmean, stdev
from typing import Any

from ..errors import ConfigError, SizefxError
from ..io.documents import write_json
from ..io.files import ABANDONED, file_kind, remove_stale_temporaries, remove_stale_temporaries_below
from ..io.schema import as_json
from ..stage import helper_threads, use_helper_threads
from .digests import DigestCache, hash_file
from .fleet import FLEET_PLOT, combine_arms, headline, plot_fleet, recurring_findings, table_figures
from .inputs import check_writes, make_out_dir
from .manifest import MANIFEST_NAME, STORE_FILES, Manifest, reusable

__all__ = [
    "BatchJob",
    "RecordOutcome",
    "BatchResult",
    "run_batch",
    "start_workers",
    "local_workers",
    "available_cores",
    "STAGES",
    "dask_client",
    "folder_lock",
    "default_memory_mib",
    "LOCK_NAME",
    "MEMORY_SHARE",
    "OWN_FILES",
    "check_batch_writes",
]

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


@dataclass(frozen=True)
class BatchJob:
    """One record's work: the stage's config (built by the caller from the stage's own options, with
    this record's input and outputs), and what the manifest needs to judge a previous run of it."""

    stage: str
    input: str  #: the record, resolved
    name: str  #: its outputs' name in the batch folder
    config: object  #: the stage's config (``sizefx.navigate.NavigateConfig``, ...)
    options: dict  #: the stage options (canonical, :func:`~.manifest.canonical_options`)
    outputs: dict  #: option -> path of every file or folder the stage writes
    summary_path: str | None = None  #: where the batch writes ``result.to_json()`` (stages with no JSON of their own)
    previous: dict | None = None  #: this record's entry in the folder's manifest, if any
    redo: bool = False
    #: other files this record's run reads, option -> path (compare's B and reference, a chain's lever
    #: arms): hashed into the manifest like the input, so that a change to one runs the record again
    paired: dict = field(default_factory=dict)
    #: path -> SHA-256 of the input and paired files whose stat the folder's stat cache knows (set by
    #: the batch): not hashed again
    known: dict = field(default_factory=dict)


@dataclass
class RecordOutcome:
    """What became of one record: its manifest entry."""

    entry: dict
    reused: bool = False
    #: path -> (signature or None, sha256) of the files the worker hashed, for the folder's stat cache
    digests: dict = field(default_factory=dict)

    @property
    def status(self) -> str:
        return self.entry["status"]


@dataclass
class BatchResult:
    """Every record's outcome (in input order) and the manifest's path."""

    stage: str
    outcomes: list = field(default_factory=list)
    manifest: str = ""
    wall_s: float = 0.0
    workers: int = 1
    fleet_plot: str | None = None  #: with plots: the headline figures across the records

    def counts(self) -> dict:
        out = {"ok": 0, "refused": 0, "failed": 0, "skipped": 0}
        for o in self.outcomes:
            out["skipped" if o.reused else o.status] += 1
        return out

    @property
    def all_ok(self) -> bool:
        return all(o.status == "ok" for o in self.outcomes)

    def report(self) -> str:
        c = self.counts()
        lines = [
            f"batch {self.stage}: {len(self.outcomes)} records in {self.wall_s:.1f} s with {self.workers} "
            f"worker(s): {c['ok']} ok, {c['skipped']} unchanged (skipped), {c['refused']} refused, "
            f"{c['failed']} failed; manifest -> {self.manifest}"
        ]
        table = {o.entry["name"]: table_figures(self.stage, o.entry["headline"]) for o in self.outcomes}
        for o in self.outcomes:
            e = o.entry
            figures = ", ".join(f"{k} {_short(v)}" for k, v in table[e["name"]].items())
            state = "unchanged" if o.reused else e["status"]
            lines.append(
                f"  {e['name']}: {state}, {e['duration_s']:.1f} s, {e['peak_memory_mib']:.0f} MiB"
                + (f"; {figures}" if figures and e["status"] == "ok" else "")
                + (f"; {e['reason']}" if e.get("reason") else "")
            )
        keys = dict.fromkeys(k for o in self.outcomes for k in table[o.entry["name"]])
        for k in keys:  # the campaign's spread of each numeric figure
            values = [
                table[o.entry["name"]][k]
                for o in self.outcomes
                if o.status == "ok" and isinstance(table[o.entry["name"]].get(k), (int, float))
            ]
            if len(values) > 1:
                lines.append(
                    f"  {k} across {len(values)} records: mean {fmean(values):.4g}, "
                    f"std {stdev(values):.3g}, min {min(values):.4g}, max {max(values):.4g}"
                )
        if self.stage == "diagnose":
            ok = sum(o.status == "ok" for o in self.outcomes)
            recurring = recurring_findings([o.entry for o in self.outcomes])
            lines.append(
                f"  findings in more than one of {ok} records: "
                + (", ".join(f"{f} ({n})" for f, n in recurring) or "none")
            )
        combined = self.combined()
        if combined:
            import numpy as np

            mm = np.array(combined["arms_m"]) * 1e3
            lines.append(
                f"  arms of {combined['runs']} runs combined (inverse-variance) [mm], +- sigma, chi2/dof across runs:"
            )
            for i, a in enumerate("xyz"):
                lines.append(
                    f"    r_{a}  "
                    + "  ".join(
                        f"{mm[i][j]:8.4f} +- {combined['sigma_m'][i][j] * 1e3:.4f} ({combined['chi2_dof'][i][j]:.2f})"
                        for j in range(3)
                    )
                )
            lines.append(
                "  runs that disagree with the others (|z| > 3.3): "
                + (", ".join(f"{name} ({z:.1f} sigma)" for name, z in combined["disagree"]) or "none")
            )
        pace = self.throughput()
        if pace["records_run"]:
            busy = list(pace["busy"].values())
            lines.append(
                f"  {pace['records_run']} records run: {pace['records_per_s']:.3g} records/s, "
                f"{pace['samples_per_s']:.3g} samples/s"
                + (
                    f"; {len(busy)} workers busy {100 * min(busy):.0f}-{100 * max(busy):.0f} % of the wall time "
                    f"(mean {100 * pace['busy_mean']:.0f} %)"
                    if busy
                    else ""
                )
            )
            phases, total = pace["phases_s"], pace["records_s"]
            if total > 0 and phases.get("stage"):
                own = [k for k in phases if k not in ("hash", "stage", "outputs")]
                lines.append(
                    f"  the records' {total:.3g} s: stage {100 * phases['stage'] / total:.0f} %"
                    + (f" ({', '.join(f'{k} {100 * phases[k] / total:.0f}' for k in own)})" if own else "")
                    + f", outputs {100 * phases.get('outputs', 0.0) / total:.0f} %"
                    + f"; hashing {100 * phases.get('hash', 0.0) / total:.0f} % (beside the stage where a core is free)"
                )
        if self.fleet_plot:
            lines.append(f"  figures across the records -> {self.fleet_plot}")
        return "\n".join(lines)

    def throughput(self) -> dict:
        """This run's pace, over the records it ran (not those skipped): how many, records and IMU
        samples per second of the batch's wall time, each worker's busy fraction (the seconds it spent
        on records over the wall time: where more workers stop helping, it falls) and their mean,
        the records' durations summed (``records_s``) and their phases summed [s] (``hash`` runs beside
        the stage; the stage's own phases, where it keeps them, add up to ``stage``)."""
        run = [o.entry for o in self.outcomes if not o.reused]
        wall = self.wall_s if self.wall_s > 0 else float("nan")
        busy: dict[str, float] = {}
        phases: dict[str, float] = {}
        for e in run:
            if e.get("worker"):
                busy[e["worker"]] = busy.get(e["worker"], 0.0) + e["duration_s"] / wall
            for k, v in (e.get("phases_s") or {}).items():
                phases[k] = phases.get(k, 0.0) + v
        samples = sum(e.get("samples") or 0 for e in run if e["status"] == "ok")
        return {
            "records_run": len(run),
            "wall_s": self.wall_s,
            "records_per_s": len(run) / wall,
            "samples_per_s": samples / wall,
            "busy": busy,
            "busy_mean": fmean(busy.values()) if busy else float("nan"),
            "records_s": sum(e["duration_s"] for e in run),
            "phases_s": phases,
        }

    def combined(self) -> dict | None:
        """Calibrations across the runs combined, with the consistency test (:func:`.fleet.combine_arms`)."""
        return combine_arms([o.entry for o in self.outcomes]) if self.stage == "calibrate" else None

    def to_json(self) -> dict:
        return {
            "stage": self.stage,
            "manifest": self.manifest,
            "wall_s": self.wall_s,
            "workers": self.workers,
            "counts": self.counts(),
            "throughput": self.throughput(),
            "records": [o.entry for o in self.outcomes],
            **({"combined_arms": self.combined()} if self.stage == "calibrate" else {}),
        }


def _short(v) -> str:
    return f"{v:.4g}" if isinstance(v, float) else str(v)


# --------------------------------------------------------------------------- in the worker

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


class _Hashing(threading.Thread):
    """The SHA-256 of a record and of its paired files, computed in a thread of its own while the
    stage runs (``start``; else the caller calls :meth:`run` itself); ``seconds``: how long that took."""

    def __init__(self, path, paired: dict, known: dict, start: bool = True):
        super().__init__(daemon=True)
        self.path, self.paired, self.known, self.digest = path, paired, known, ""
        self.paired_digests: dict[str, dict] = {}
        self.digests: dict = {}
        self.seconds = 0.0
        if start:
            self.start()

    def run(self):
        t0 = time.perf_counter()
        with contextlib.suppress(OSError):
            self.digest = _digest(self.path, self.known, self.digests)
        self.paired_digests = _paired_hashes(self.paired, self.known, self.digests)
        self.seconds = time.perf_counter() - t0

    def result(self) -> tuple[str, dict]:
        if self.is_alive():
            self.join()
        return self.digest, self.paired_digests


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
    else:  # workers that fill the cores: a thread beside each stage would take another worker's core
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
    if not may_reuse:
        if hashing is None:  # after the stage, in this thread
            hashing = _Hashing(job.input, job.paired, job.known, start=False)
            hashing.run()
        entry["sha256"], paired = hashing.result()  # "" if a file could not be read (the stage said why)
        digests.update(hashing.digests)
        phases["hash"] = hashing.seconds
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


# --------------------------------------------------------------------------- in the parent


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
    most of a worker's start-up)."""
    if parent is not None:
        _die_with_parent(parent)
    _bound_memory(memory_mib)
    use_helper_threads(helpers)
    if module is not None:
        with contextlib.suppress(Exception):  # the record that needs it says why (in _work)
            importlib.import_module(module)


def local_workers(workers: int | None, n_jobs: int) -> int:
    """The local workers a batch of ``n_jobs`` records runs in: ``workers`` (default: the cores), no
    more than there are records."""
    return max(1, min(workers or available_cores(), max(1, n_jobs)))


def _pool(workers: int, memory_mib: float | None, stage: str | None = None) -> ProcessPoolExecutor:
    """``workers`` spawned worker processes, which import ``stage``'s module as they start. Where they
    are as many as the cores, a stage's helper thread would only compete with the other workers
    (:func:`sizefx.stage.helper_threads`): each worker is given its share of the cores, and a helper
    only when that share is two or more."""
    helpers = available_cores() // workers >= 2
    return ProcessPoolExecutor(
        max_workers=workers,
        mp_context=multiprocessing.get_context("spawn"),
        initializer=_start_worker,
        initargs=(memory_mib, helpers, STAGES.get(stage, stage) if stage else None, os.getpid()),
    )


#: Seconds to wait for a stopped worker to end (SIGTERM; a worker ends at once unless the system is stuck).
STOP_WAIT_S = 5.0


def _stop(pool: ProcessPoolExecutor) -> None:
    """Cancel ``pool``'s queued records and end its workers now, rather than let the records they
    hold run to their end (``ProcessPoolExecutor.terminate_workers`` does this from Python 3.14;
    before it, the executor's own table of processes). Their unfinished outputs are temporary files,
    which the caller removes (:func:`sizefx.io.files.remove_stale_temporaries`)."""
    processes = list((getattr(pool, "_processes", None) or {}).values())  # shutdown forgets them
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        with contextlib.suppress(Exception):
            process.terminate()
    for process in processes:
        with contextlib.suppress(Exception):
            process.join(STOP_WAIT_S)


def _abandon(pool: ProcessPoolExecutor, jobs) -> None:
    """Stop ``pool`` now (:func:`_stop`) and remove the temporary files of the ``jobs`` it was running."""
    _stop(pool)
    for job in jobs:
        for path in [*job.outputs.values(), *([job.summary_path] if job.summary_path else [])]:
            remove_stale_temporaries(path)
            remove_stale_temporaries_below(path)  # a folder output: a chain's, a stage's plots


def available_cores() -> int:
    """The cores this process may run on (its CPU affinity, which a container or ``taskset`` narrows;
    ``os.cpu_count()`` where the platform has none)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def _nothing() -> None:
    """A task that makes the pool spawn a worker for it."""


def start_workers(stage: str, workers: int, memory_mib: float | None = None) -> ProcessPoolExecutor:
    """The local workers of a batch of ``stage``, spawned now (``workers`` from :func:`local_workers`,
    ``memory_mib`` as :func:`run_batch` takes it), for :func:`run_batch`'s ``pool``.

    A worker's start (Python, then the stage's code with NumPy, Numba and h5py) is about 0.9 s of CPU;
    started before the caller lists the records and builds their configs, it runs on the cores the
    caller leaves idle meanwhile, instead of after it. The caller shuts the pool down if it gives up
    before :func:`run_batch` (``shutdown(wait=False, cancel_futures=True)``); a worker still
    starting then exits when it has started.
    """
    pool = _pool(workers, memory_mib or default_memory_mib(workers), stage)
    for _ in range(workers):  # the pool spawns a process per task submitted while none is idle
        pool.submit(_nothing)
    return pool


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


def _died(
    job: BatchJob, why: str, what: str = "the worker process died", then: str = "run it alone to see why"
) -> RecordOutcome:
    return RecordOutcome(
        {
            "input": job.input,
            "name": job.name,
            "sha256": (job.previous or {}).get("sha256", ""),
            "options": job.options,
            "outputs": {},
            "status": "failed",
            "reason": f"{what} ({why}); {then}",
            "duration_s": 0.0,
            "peak_memory_mib": 0.0,
            "headline": {},
        }
    )


#: Seconds to reach a Dask scheduler, and to see a worker of its cluster, before the batch is refused.
DASK_CONNECT_S = 5.0
#: Seconds a cluster may be without any worker while records are left before the batch gives them up.
DASK_NO_WORKERS_S = 30.0
#: The address schemes of a Dask scheduler sizefx connects to.
DASK_SCHEMES = ("tcp", "tls")


def _scheduler_address(address: str) -> str:
    """``address`` checked to be ``tcp://HOST:PORT`` or ``tls://HOST:PORT`` (a one-line refusal
    otherwise: empty, another scheme, no host, no port)."""
    from urllib.parse import urlsplit

    text = (address or "").strip()
    try:
        parts = urlsplit(text)
        port = parts.port
    except ValueError as exc:
        raise ConfigError(f"--scheduler {address!r}: not an address ({exc}); give tcp://HOST:PORT") from None
    if parts.scheme not in DASK_SCHEMES or not parts.hostname or port is None or parts.path not in ("", "/"):
        raise ConfigError(
            f"--scheduler {address!r}: give a Dask scheduler's address, "
            f"{' or '.join(f'{s}://HOST:PORT' for s in DASK_SCHEMES)} (as 'dask scheduler' prints it)"
        )
    return text


def dask_client(address: str):
    """A client of the Dask scheduler at ``address`` (``tcp://host:8786``) whose cluster has a worker, or
    a one-line :class:`~sizefx.errors.ConfigError` within about :data:`DASK_CONNECT_S` (twice, at most:
    the connection, then the first worker): a malformed address, the ``distributed`` package missing,
    nothing listening, something that is not a Dask scheduler (an HTTP server, a server sending
    garbage), a cluster without workers."""
    address = _scheduler_address(address)
    try:
        from distributed import Client
    except ImportError:
        raise ConfigError(
            f"--scheduler {address}: needs the 'distributed' package: pip install 'sizefx[dask]'"
        ) from None
    box: dict = {}

    def connect():  # in a thread of its own: a peer that never answers must not hold the batch
        try:
            box["client"] = Client(address, timeout=DASK_CONNECT_S, set_as_default=False)
        except BaseException as exc:  # whatever the peer made the client raise: reported below
            box["error"] = exc

    thread = threading.Thread(target=connect, daemon=True, name="sizefx-dask-connect")
    thread.start()
    thread.join(DASK_CONNECT_S + min(DASK_CONNECT_S, 2.0))  # the client gives up at DASK_CONNECT_S; a grace to say so
    if thread.is_alive() or "error" in box:
        why = "no answer" if thread.is_alive() else _one_line(box["error"])
        raise ConfigError(
            f"--scheduler {address}: cannot reach it ({why}); start a Dask scheduler there (dask scheduler) "
            "or check the address"
        ) from None
    client = box["client"]
    try:
        client.wait_for_workers(1, timeout=DASK_CONNECT_S)
    except Exception:
        client.close()
        raise ConfigError(
            f"--scheduler {address}: the cluster has no worker (none joined in {DASK_CONNECT_S:g} s); "
            "start workers (dask worker ADDRESS) or check the address"
        ) from None
    return client


def _run_dask(client, jobs: list[BatchJob], finished) -> None:
    """Every job as a Dask task on ``client``'s cluster (the same :func:`_work`), finished as they come.
    A worker that dies with a record is replaced by its nanny and the record run again; a record that
    kills its worker more often than the scheduler allows (``distributed.scheduler.allowed-failures``,
    3 by default) fails alone (``KilledWorker``). A cluster left without any worker, or a scheduler
    gone, for :data:`DASK_NO_WORKERS_S` while records are left fails those records (each named in
    the manifest) and ends the batch. Stopped (Ctrl-C, SIGTERM, an error here), the batch cancels every
    task it sent before it exits."""
    from distributed import as_completed

    futures = {
        client.submit(_work, job, pure=False, key=f"sizefx-batch-{job.name}-{uuid.uuid4().hex}"): job for job in jobs
    }
    done: set = set()
    try:
        pending = as_completed(futures, loop=client.loop)  # not the default client's loop: there may be none
        alone_since = None
        while len(done) < len(futures):
            batch = pending.next_batch(block=False)
            for fut in batch:
                job = futures[fut]
                try:
                    outcome = fut.result()
                except Exception as exc:
                    why = f"{type(exc).__name__}: {_one_line(exc)}"
                    if type(exc).__name__ == "KilledWorker":  # the record took its worker down every time
                        outcome = _died(job, why)
                    else:  # the cluster gave it up (its scheduler lost): not the record's fault
                        outcome = _died(job, why, "the Dask cluster lost the record", "run the batch again")
                done.add(fut)
                finished(job, outcome)
            if batch:
                alone_since = None
                continue
            # a scheduler gone leaves its last word (workers included) in the client: its status says
            if client.status == "running" and client.scheduler_info().get("workers"):
                alone_since = None
            elif alone_since is None:
                alone_since = time.monotonic()
            elif time.monotonic() - alone_since > DASK_NO_WORKERS_S:
                left = [f for f in futures if f not in done]
                with contextlib.suppress(Exception):  # a scheduler gone cannot be told
                    client.cancel(left, force=True)
                for fut in left:
                    finished(
                        futures[fut],
                        _died(
                            futures[fut],
                            f"the Dask cluster had no worker (or its scheduler was gone) for {DASK_NO_WORKERS_S:g} s",
                        ),
                    )
                return
            time.sleep(0.1)
    except BaseException:
        with contextlib.suppress(Exception):  # a scheduler gone cannot be told
            client.cancel([f for f in futures if f not in done], force=True)
        raise


def run_batch(
    stage: str,
    jobs: list[BatchJob],
    out_dir,
    options: dict,
    *,
    workers: int | None = None,
    previous: Manifest | None = None,
    progress=None,
    scheduler: str | None = None,
    plots: bool = False,
    memory_mib: float | None = None,
    locked: bool = False,
    pool: ProcessPoolExecutor | None = None,
    client=None,
    own: dict | None = None,
    rehash: bool = False,
) -> BatchResult:
    """Run ``jobs`` (one per record, in input order) in ``workers`` processes (default: the cores), or
    on the Dask cluster whose scheduler is at ``scheduler``, and keep ``out_dir``'s manifest as they
    finish. ``previous``: the folder's manifest (:class:`.manifest.Manifest`, read by the caller to find
    each job's ``previous`` entry; read here if not given), which keeps the other records' entries.
    ``progress(event)`` after each record: done, total, counts, rate, time left. ``plots``: also
    the headline figures across the records (:func:`.fleet.plot_fleet`). ``memory_mib``: each local
    worker's memory bound (default :func:`default_memory_mib`; a Dask cluster's workers have their
    own, ``dask worker --memory-limit``). The folder is locked (:func:`folder_lock`) for the run, unless
    the caller holds its lock already (``locked``: ``sizefx batch run`` calibrates there first).
    ``pool``: the local workers, already started (:func:`start_workers`, with the same ``workers``
    and ``memory_mib``); ``client``: the Dask client of ``scheduler``, already connected
    (:func:`dask_client`, by a caller that writes before the batch). Both are closed here in any case.

    Before anything is written, every path the jobs write is checked against every input and the
    folder's own files (:func:`check_batch_writes`; ``own``: more of them, name -> what it is).

    A record whose entry stands is skipped here, before any worker: the folder's stat cache
    (:mod:`.digests`) gives the digests of its input, paired files and outputs while their stat is
    unchanged, and only an output whose stat changed is hashed again. A record whose input or paired
    file changed stat goes to a worker, which hashes them and skips the record if the bytes are the
    same. ``rehash``: trust no stat, hash every file again (in the workers)."""
    try:
        if client is None and scheduler is not None:
            client = dask_client(scheduler)  # refused before anything is written
        workers = local_workers(workers, len(jobs))
        if client is not None:
            workers = len(client.scheduler_info().get("workers", {})) or workers
        out_dir = Path(out_dir)
        check_batch_writes(out_dir, jobs, own)
        make_out_dir(out_dir)
        with contextlib.nullcontext() if locked else folder_lock(out_dir):
            return _run_locked(
                stage,
                jobs,
                out_dir,
                options,
                workers=workers,
                previous=previous,
                progress=progress,
                client=client,
                plots=plots,
                memory_mib=memory_mib or default_memory_mib(workers),
                pool=None if client is not None else pool,
                rehash=rehash,
            )
    finally:
        if pool is not None:  # unused (a refusal, a Dask run), or done with
            pool.shutdown(wait=False, cancel_futures=True)
        if client is not None:
            client.close()


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


def _run_locked(
    stage, jobs, out_dir, options, *, workers, previous, progress, client, plots, memory_mib, pool=None, rehash=False
) -> BatchResult:
    store = (previous if previous is not None else Manifest(out_dir, stage)).open_for_writing(options)
    try:
        return _run_stored(
            stage, jobs, out_dir, store, options, workers, progress, client, plots, memory_mib, pool, rehash
        )
    finally:  # however the batch ends (short of SIGKILL): the JSON manifest of what is done
        store.export(options)
        store.close()


def _unchanged(job: BatchJob, cache: DigestCache) -> bool:
    """Whether ``job``'s previous entry stands, decided from the stat cache: its input and paired files
    unchanged since they were hashed (nothing read), its outputs too (one whose stat changed is
    hashed again). False where the cache cannot tell: a worker then hashes and decides."""
    previous = job.previous
    if job.redo or not previous or previous.get("status") != "ok":
        return False
    if cache.known(job.input) != previous.get("sha256"):
        return False
    paired = {}
    for option, path in sorted(job.paired.items()):
        digest = cache.known(path)
        if digest is None:
            return False
        paired[option] = {"path": str(path), "sha256": digest}
    expected = {**job.outputs, **({"summary": job.summary_path} if job.summary_path else {})}
    try:
        return reusable(previous, previous["sha256"], job.options, paired, expected, cache.digest)
    except OSError:  # an output cannot be read now: the record runs again
        return False


def _run_stored(stage, jobs, out_dir, store, options, workers, progress, client, plots, memory_mib, pool, rehash):
    outcomes: dict[str, RecordOutcome] = {}
    counts = {"ok": 0, "refused": 0, "failed": 0, "skipped": 0}
    t0 = time.perf_counter()
    cache = store.digests

    def finished(job: BatchJob, outcome: RecordOutcome):
        outcomes[job.input] = outcome
        counts["skipped" if outcome.reused else outcome.status] += 1
        cache.keep(outcome.digests)
        if not outcome.reused:
            store.record(outcome.entry, options)
        if progress is not None:
            done = len(outcomes)
            elapsed = time.perf_counter() - t0
            rate = done / elapsed if elapsed > 0 else 0.0
            progress(
                {
                    "done": done,
                    "total": len(jobs),
                    **counts,
                    "record": job.name,
                    "status": "unchanged" if outcome.reused else outcome.status,
                    "elapsed_s": round(elapsed, 3),
                    "records_per_s": round(rate, 4),
                    "eta_s": round((len(jobs) - done) / rate, 1) if rate > 0 else None,
                }
            )

    left = []
    for job in jobs:  # the records whose entry stands are done before any worker starts
        if rehash:
            left.append(job)
        elif _unchanged(job, cache):
            finished(job, RecordOutcome(job.previous, reused=True))
        else:  # the files the cache knows are not hashed again (a --redo, a resume)
            files = [job.input, *map(str, job.paired.values())]
            known = {path: digest for path in files if (digest := cache.known(path)) is not None}
            left.append(dataclasses.replace(job, known=known) if known else job)
    if client is not None:
        _run_dask(client, left, finished)
    pending: list[BatchJob] = [] if client is not None else left
    suspects: list[BatchJob] = []
    started = pool  # the first round's workers, if the caller started them
    while pending:
        running: dict = {}
        with started or _pool(workers, memory_mib, stage) as pool:
            started = None
            try:
                while pending or running:
                    while pending and len(running) < 2 * workers:  # a short queue: the input's order
                        running[pool.submit(_work, pending[0])] = pending[0]
                        pending.pop(0)  # once submitted: a pool broken meanwhile refuses it, and it waits
                    done, _ = wait(running, return_when=FIRST_COMPLETED)
                    for fut in done:
                        outcome = fut.result()  # BrokenProcessPool: the job stays among the running
                        finished(running.pop(fut), outcome)
            except BrokenProcessPool:
                suspects += running.values()  # the rest go on in a fresh pool
            except BaseException:  # Ctrl-C, SIGTERM, a bug here: no queued record starts, none runs on
                _abandon(pool, running.values())
                raise
    for job in suspects:  # each alone in a fresh process: only the record that kills it fails
        with _pool(1, memory_mib, stage) as pool:
            try:
                finished(job, pool.submit(_work, job).result())
            except BrokenProcessPool as exc:
                finished(job, _died(job, _one_line(exc)))
            except BaseException:
                _abandon(pool, [job])
                raise
    ordered = [outcomes[j.input] for j in jobs]
    result = BatchResult(stage, ordered, str(out_dir / "manifest.json"), time.perf_counter() - t0, workers)
    if plots:
        drawn = plot_fleet(stage, [o.entry for o in ordered], out_dir / FLEET_PLOT)
        result.fleet_plot = str(drawn) if drawn else None
    return result
