"""The batch's work: each record's stage run in warm worker processes (:mod:`.worker`), the manifest kept
as they finish; the records whose entry stands skipped first, from the stat cache (:mod:`.digests`).

Workers are spawned processes (not forked: an h5py file or a Numba compilation in the parent must
not be shared half way), ``workers`` of them for the whole batch, so each loads the Numba kernels
from the on-disk cache once and keeps them for every record it gets. A record whose stage refuses
it (a :class:`~sizefx.errors.SizefxError`, one line) is ``refused``; any other exception is
``failed`` with its one-line summary; neither stops the others. A worker that dies (killed, out of
memory) takes the records it held with it: those are run again, each alone in a fresh process, so
that only the record that kills its process is marked failed.

With a Dask scheduler (``--scheduler tcp://host:8786``, the optional ``distributed`` package) the same
:func:`.worker._work` runs as a task per record on the cluster's workers, which read the records where
they see them; a worker lost with a record is replaced and the record run again.

The folder the batch writes into (the files the batch keeps there, the check that no path it writes
is an input or written twice) is :mod:`.folder`'s, its lock (shared with a chain) is
:mod:`sizefx.runs.folder`'s; their names are imported here too.
"""

from __future__ import annotations

import contextlib
import dataclasses
import multiprocessing
import os
import threading
import time
import uuid
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

from ..errors import ConfigError
from ..io.files import remove_stale_temporaries, remove_stale_temporaries_below
from ..runs.folder import LOCK_NAME, folder_lock, make_out_dir
from .digests import DigestCache
from .fleet import FLEET_PLOT, plot_fleet
from .folder import OWN_FILES, check_batch_writes
from .manifest import Manifest, reusable
from .outcome import BatchJob, BatchResult, RecordOutcome
from .worker import MEMORY_SHARE, STAGES, _one_line, _start_worker, _work, default_memory_mib

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


def _run_locked(
    stage, jobs, out_dir, options, *, workers, previous, progress, client, plots, memory_mib, pool=None, rehash=False
) -> BatchResult:
    store = (previous if previous is not None else Manifest(out_dir, stage)).open_for_writing(options)
    try:
        store.forget_gone()  # a refused or failed record whose input was removed since: no longer the batch's
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
