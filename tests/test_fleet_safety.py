"""The fleet's promises on hostile inputs (docs/reliability.md, "Batches and chains"), each shown on
small generated files:

- no input is ever written: every path a batch will write is checked, links followed, against every
  input and the folder's own files before anything is written; the lock and the manifest are never
  written through a link;
- bounded waiting: a FIFO, a device or a glob over a tree with links back to its parents is refused
  or walked in bounded time, never waited on;
- no orphans: the workers of a batch killed with SIGKILL end with it and write nothing after it;
  an interrupted record's temporary files are removed, also inside a chain's folder;
- one bad option file refuses the batch before it starts; a chain whose input is bad leaves nothing;
- a resume trusts only outputs it can verify (listed, at the paths this run would write, hashes
  as recorded).
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from sizefx.batch import BatchJob, run_batch
from sizefx.batch.manifest import Manifest, canonical_options
from sizefx.batch.runner import LOCK_NAME, check_batch_writes
from sizefx.errors import ConfigError
from sizefx.io.files import MAX_PID, remove_stale_temporaries_below
from sizefx.io.schema import check_document
from sizefx.levers import levers_from_preset, write_levers
from sizefx.runs.folder import _glob, expand_inputs
from sizefx.scenarios import TurntablePlan
from sizefx.simulate import SimulateConfig
from sizefx.simulate import run as simulate
from sizefx_cli.main import main

TESTS = Path(__file__).resolve().parent
#: A short turntable record (100 s at 200 Hz), as tests/test_batch.py's.
PLAN = TurntablePlan(static_s=10.0, seconds_per_axis=20.0, cycles=1)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Two records in a folder, and a levers file beside it."""
    folder = tmp_path_factory.mktemp("fleet") / "runs"
    folder.mkdir()
    for k in range(2):
        simulate(SimulateConfig("turntable", str(folder / f"r{k}.h5"), plan=PLAN, rate_hz=200.0, seed=k, force=True))
    write_levers(folder.parent / "levers.json", levers_from_preset("compact"))
    return folder


def _sizefx(*args):
    return CliRunner().invoke(main, [*map(str, args)])


def _refused(result, needle):
    """One line on the terminal, exit code 2, no traceback."""
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.output, result.output
    assert needle in lines[0], lines[0]


def _digest(path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def _copy(runs, tmp_path) -> Path:
    folder = tmp_path / "runs"
    shutil.copytree(runs, folder)
    return folder


# -- no input is ever written ---------------------------------------------------------------------


def test_out_that_holds_the_records_is_refused(runs, tmp_path):
    """The shell expanded ``d/*.h5`` before sizefx saw it: with ``--out d`` record a's output would
    replace the input ``d/a.compensated.h5``. Any --out that holds a record is refused."""
    d = _copy(runs, tmp_path)
    shutil.copy(d / "r1.h5", d / "r0.compensated.h5")
    before = {p.name: _digest(p) for p in d.iterdir()}
    records = sorted(d.glob("*.h5"))
    _refused(
        _sizefx("batch", "compensate", *records, "--levers", runs.parent / "levers.json", "--out", d),
        "--out holds the input",
    )
    assert {p.name: _digest(p) for p in d.iterdir()} == before


def test_an_output_that_links_to_an_input_is_refused(runs, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "r0.inspect.json").symlink_to(runs / "r1.h5")
    before = _digest(runs / "r1.h5")
    _refused(_sizefx("batch", "inspect", runs, "--out", out), "output would overwrite the record")
    assert _digest(runs / "r1.h5") == before
    assert sorted(p.name for p in out.iterdir()) == ["r0.inspect.json"]  # not even a lock


@pytest.mark.parametrize("plant", ["lock-link", "lock-dangling", "lock-folder", "lock-fifo", "manifest-link"])
def test_a_planted_lock_or_manifest_is_never_written_through(runs, tmp_path, plant):
    out = tmp_path / "out"
    out.mkdir()
    record = runs / "r1.h5"
    before = _digest(record)
    lock = out / LOCK_NAME
    if plant == "lock-link":
        lock.symlink_to(record)
    elif plant == "lock-dangling":
        lock.symlink_to(tmp_path / "nowhere")
    elif plant == "lock-folder":
        lock.mkdir()
    elif plant == "lock-fifo":
        os.mkfifo(lock)
    else:
        (out / "manifest.json").symlink_to(record)
    needle = "the batch manifest is a link" if plant == "manifest-link" else "the batch's lock file"
    _refused(_sizefx("batch", "inspect", runs, "--out", out), needle)
    assert _digest(record) == before
    assert not (tmp_path / "nowhere").exists()


def test_a_record_named_like_the_batch_files_is_refused_up_front(runs, tmp_path):
    """A flight ``manifest.json.h5`` in ``batch run`` would get the folder ``DIR/manifest.json``."""
    flights = tmp_path / "flights"
    flights.mkdir()
    shutil.copy(runs / "r0.h5", flights / "manifest.json.h5")
    shutil.copy(runs / "r1.h5", flights / "fine.h5")
    out = tmp_path / "out"
    levers = runs.parent / "levers.json"
    result = _sizefx("batch", "run", "--out", out, "navigate", "--levers", levers, flights, "compare")
    _refused(result, "record manifest.json's output is also the batch's manifest")
    assert not out.exists()
    # the same check, as a Python caller of the library meets it
    job = BatchJob(
        "run", str(flights / "fine.h5"), "fleet.png", None, canonical_options({}), {"folder": str(out / "fleet.png")}
    )
    with pytest.raises(ConfigError, match="the batch's figure across the records"):
        check_batch_writes(out, [job])


# -- bounded waiting --------------------------------------------------------------------------------


@pytest.mark.parametrize("case", ["fifo-record", "device-record", "device-levers", "fifo-levers"])
def test_anything_but_a_regular_file_is_refused_before_it_is_opened(runs, tmp_path, case):
    fifo = tmp_path / "pipe.h5"
    os.mkfifo(fifo)
    out = tmp_path / "out"
    if case == "fifo-record":
        result, needle = _sizefx("batch", "inspect", fifo, "--out", out), "is a FIFO (named pipe)"
    elif case == "device-record":
        result, needle = _sizefx("batch", "inspect", "/dev/zero", "--out", out), "is a character device"
    else:
        levers = fifo if case == "fifo-levers" else "/dev/zero"
        result, needle = _sizefx("batch", "navigate", runs, "--levers", levers, "--out", out), "--levers: is a"
    _refused(result, needle)
    assert not out.exists()


def test_a_glob_does_not_follow_links_to_folders(tmp_path):
    """``**`` walks the tree below its root once: links back to a parent (a loop) or out of the tree
    are not descended into, hidden names are left out, and FIFOs are no records."""
    tree = tmp_path / "tree"
    (tree / "a" / "b").mkdir(parents=True)
    (tree / "a" / "b" / "x.h5").write_bytes(b"x")
    (tree / "top.h5").write_bytes(b"t")
    (tree / ".hidden.h5").write_bytes(b"h")
    os.mkfifo(tree / "pipe.h5")
    (tree / "a" / "up").symlink_to("..")
    (tree / "a" / "b" / "upup").symlink_to("../..")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "out.h5").write_bytes(b"o")
    (tree / "away").symlink_to(elsewhere)
    found = _glob(f"{tree}/**/*.h5")
    assert found == [tree / "a" / "b" / "x.h5", tree / "top.h5"]
    assert _glob(f"{tree}/**") == found  # ``DIR/**``: every file below, as ``DIR/**/*``
    assert _glob(f"{tree}/a/*/x.h5") == [tree / "a" / "b" / "x.h5"]
    assert expand_inputs([f"{tree}/**/*.h5"]) == found


@pytest.mark.parametrize(
    "case, needle",
    [
        ("empty", "--out '': give the folder"),
        ("loop", "--out cannot be resolved"),
        ("file", "is a file"),
        ("proc", "--out cannot be made"),
    ],
)
def test_an_out_that_cannot_hold_the_outputs_is_one_line(runs, tmp_path, case, needle):
    if case == "proc" and not Path("/proc/self").is_dir():
        pytest.skip("no /proc here")
    out = {"empty": "", "loop": tmp_path / "l1", "file": tmp_path / "f", "proc": "/proc/nope"}[case]
    (tmp_path / "l1").symlink_to(tmp_path / "l2")
    (tmp_path / "l2").symlink_to(tmp_path / "l1")
    (tmp_path / "f").write_text("")
    before = sorted(Path.cwd().iterdir())
    _refused(_sizefx("batch", "inspect", runs, "--out", out), needle)
    assert sorted(Path.cwd().iterdir()) == before


# -- one bad option file, one bad chain input -----------------------------------------------------


def test_a_bad_option_file_refuses_the_batch_before_it_starts(runs, tmp_path):
    doc = json.loads((runs.parent / "levers.json").read_text())
    doc["r_x"][0] = float("nan")
    bad = tmp_path / "nan.json"
    bad.write_text(json.dumps(doc))  # json writes NaN, which is no JSON number
    out = tmp_path / "out"
    _refused(_sizefx("batch", "navigate", runs, "--levers", bad, "--out", out), f"{bad}: NaN is not a JSON number")
    assert not out.exists()
    _refused(_sizefx("batch", "compensate", runs, "--out", out), "give the lever arms (--levers")
    assert not out.exists()


def test_a_chain_with_a_bad_input_at_its_second_step_leaves_nothing(runs, tmp_path):
    not_hdf5 = tmp_path / "flight.h5"
    not_hdf5.write_text("not a record")
    out = tmp_path / "out"
    _refused(
        _sizefx("run", "--out", out, "calibrate", runs / "r0.h5", "navigate", not_hdf5, "compare"),
        "is not an HDF5 file",
    )
    assert not out.exists()  # checked before calibrate wrote anything
    # a reference whose samples are bad is refused only when compare reads it, after navigate has
    # written both solutions: the chain's folder goes with the refusal
    reference = tmp_path / "reference.h5"
    shutil.copy(runs / "r1.h5", reference)
    with h5py.File(reference, "r+") as f:
        f["reference/position"][100, 0] = np.nan
    levers = runs.parent / "levers.json"
    result = _sizefx(
        "run", "--out", out, "navigate", "--levers", levers, runs / "r1.h5", "compare", "--reference", reference
    )
    assert result.exit_code == 2 and "Traceback" not in result.output, result.output
    assert not out.exists()


# -- a resume trusts only what it can verify --------------------------------------------------------


# long tier: two batch runs, each starting its worker (about 1.8 s each); fast twin:
# tests/test_batch.py::test_rerun_skips_what_is_unchanged, which reruns a record whose output is lost
@pytest.mark.slow
def test_a_resume_reruns_records_whose_outputs_it_cannot_verify(runs, tmp_path):
    out = tmp_path / "out"
    one = ("--workers", "1")
    assert _sizefx("batch", "inspect", runs, "--out", out, *one).exit_code == 0
    with sqlite3.connect(out / "manifest.sqlite") as db:  # edited by hand: an ok record with no outputs
        (key, text), *_ = db.execute("SELECT input, entry FROM records ORDER BY input").fetchall()
        db.execute(
            "UPDATE records SET entry = ? WHERE input = ?", (json.dumps({**json.loads(text), "outputs": {}}), key)
        )
    assert "1 ok, 1 unchanged" in _sizefx("batch", "inspect", runs, "--out", out, *one).output


# long tier: four batch runs, each starting its worker (about a second each); fast twin as above
@pytest.mark.slow
def test_a_resume_from_a_json_manifest_or_a_copied_folder_reruns_what_it_cannot_verify(runs, tmp_path):
    out = tmp_path / "out"
    one = ("--workers", "1")
    assert _sizefx("batch", "inspect", runs, "--out", out, *one).exit_code == 0
    assert "0 ok, 2 unchanged" in _sizefx("batch", "inspect", runs, "--out", out, *one).output
    # a folder with only its manifest.json (made by hand): read from it, and edited by hand
    for name in ("manifest.sqlite", "manifest.sqlite-wal", "manifest.sqlite-shm"):
        (out / name).unlink(missing_ok=True)
    manifest = json.loads((out / "manifest.json").read_text())
    manifest["records"][1]["outputs"] = {}
    (out / "manifest.json").write_text(json.dumps(manifest))
    assert "1 ok, 1 unchanged" in _sizefx("batch", "inspect", runs, "--out", out, *one).output
    # the folder copied elsewhere (cp -a), then damaged: its manifest names the original's files
    copy = tmp_path / "copy"
    shutil.copytree(out, copy, symlinks=True)
    (copy / "r1.inspect.json").write_text("{}")
    assert "2 ok, 0 unchanged" in _sizefx("batch", "inspect", runs, "--out", copy, *one).output
    assert json.loads((copy / "r1.inspect.json").read_text())["samples"] == 24001


# -- no orphans, no leftovers -----------------------------------------------------------------------

_KILLED_BATCH = """
import sys
from sizefx.batch import BatchJob, run_batch
from sizefx.batch.manifest import Manifest, canonical_options
jobs = [BatchJob("batch_sleep_stage", r, r, r, canonical_options({}), {}) for r in sys.argv[2:]]
run_batch("inspect", jobs, sys.argv[1], {}, workers=len(jobs))
"""


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    stat = Path(f"/proc/{pid}/stat")
    # a zombie has ended: it only waits for its new parent to reap it
    return not (stat.exists() and stat.read_text().split(")")[-1].split()[0] == "Z")


def test_the_workers_of_a_killed_batch_end_with_it(tmp_path):
    records = [tmp_path / f"{n}.h5" for n in ("a", "b")]
    for r in records:
        r.write_text("")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(TESTS), os.environ.get("PYTHONPATH", "")])}
    # run from tmp_path: ``python -c`` puts its working folder first on sys.path, and a checkout's
    # sizefx/ there would shadow the installed package
    parent = subprocess.Popen(
        [sys.executable, "-c", _KILLED_BATCH, str(tmp_path / "out"), *map(str, records)], env=env, cwd=tmp_path
    )
    try:
        pid_files = [Path(f"{r}.pid") for r in records]
        deadline = time.monotonic() + 60.0
        while not all(p.exists() and p.read_text() for p in pid_files):
            assert parent.poll() is None and time.monotonic() < deadline, "the workers never started"
            time.sleep(0.05)
        workers = [int(p.read_text()) for p in pid_files]
        parent.send_signal(signal.SIGKILL)
        parent.wait()
        deadline = time.monotonic() + 10.0
        while any(_alive(w) for w in workers) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not any(_alive(w) for w in workers), "a worker outlived its batch"
        assert not any(Path(f"{r}.late").exists() for r in records)
        # the next run reads what the killed one left and completes every record, each once
        rerun = subprocess.run(
            [sys.executable, "-c", _KILLED_BATCH, str(tmp_path / "out"), *map(str, records)],
            env={**env, "SLEEP_STAGE_S": "0"},
            cwd=tmp_path,
            timeout=120,
        )
        assert rerun.returncode == 0
        doc = json.loads((tmp_path / "out" / "manifest.json").read_text())
        assert [e["status"] for e in doc["records"]] == ["ok", "ok"]
        assert all(Path(f"{r}.late").exists() for r in records)
        assert not list((tmp_path / "out").glob(".*.tmp")) and not list(tmp_path.glob(".*.tmp"))
    finally:
        if parent.poll() is None:
            parent.kill()


def test_stale_temporaries_inside_a_folder_output_are_removed(tmp_path):
    """A chain's record folder after its worker was stopped mid-write: the dead writer's temporary files
    go, a live writer's (this process's) stay."""
    folder = tmp_path / "flight07"
    (folder / "compare-plots").mkdir(parents=True)
    dead = MAX_PID - 1  # above any pid the kernel hands out by default, and so no process
    stale = [folder / f".plain.nav.h5.{dead}.12345678.tmp", folder / "compare-plots" / f".a.png.{dead}.x1y2.tmp"]
    live = folder / f".compensated.nav.h5.{os.getpid()}.abcdefgh.tmp"
    for p in [*stale, live]:
        p.write_text("")
    remove_stale_temporaries_below(folder)
    assert not any(p.exists() for p in stale) and live.exists()


_WRITER = """
import sys
from sizefx.batch.manifest import Manifest
store = Manifest(sys.argv[1], "inspect").open_for_writing({})
for k in range(10**9):
    store.record({"input": f"/r/{k:09d}.h5", "name": f"r{k}", "sha256": "", "options": {}, "outputs": {},
                  "status": "ok", "reason": None, "duration_s": 0.0, "peak_memory_mib": 0.0, "headline": {}}, {})
    if k == 50:
        print("going", flush=True)
"""


def test_a_store_killed_mid_write_is_read_by_the_next_run(tmp_path):
    """SIGKILL while records are being kept: the store holds every record committed before, and the
    next batch reads it, keeps more and writes manifest.json."""
    writer = subprocess.Popen(  # from tmp_path: not the checkout's sizefx/ before the installed one
        [sys.executable, "-c", _WRITER, str(tmp_path)], stdout=subprocess.PIPE, text=True, cwd=tmp_path
    )
    assert writer.stdout is not None and writer.stdout.readline() == "going\n"
    time.sleep(0.2)
    writer.send_signal(signal.SIGKILL)
    writer.wait()
    store = Manifest(tmp_path, "inspect")
    assert store.entry("/r/000000050.h5")["name"] == "r50"
    store.open_for_writing({}).record({**store.entry("/r/000000000.h5"), "name": "again"}, {})
    doc = json.loads(store.export({}).read_text())
    check_document(doc, "sizefx/batch/1")
    assert len(doc["records"]) > 50 and doc["records"][0]["name"] == "again"
    store.close()


# -- Dask like local ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "address, needle",
    [
        ("", "give a Dask scheduler's address"),
        ("tcp://", "give a Dask scheduler's address"),
        ("ucx://127.0.0.1:8786", "give a Dask scheduler's address"),
        ("tcp://127.0.0.1:notaport", "not an address"),
    ],
)
def test_a_scheduler_address_that_is_none_is_one_line_at_once(runs, tmp_path, address, needle):
    out = tmp_path / "out"
    _refused(_sizefx("batch", "inspect", runs, "--out", out, "--scheduler", address), needle)
    assert not out.exists()


# long tier: a second of waiting on the connection's bound; fast twin:
# tests/test_batch.py::test_an_unreachable_scheduler_is_one_line_and_writes_nothing
@pytest.mark.slow
def test_a_server_that_is_no_scheduler_is_one_line_within_seconds(runs, tmp_path, monkeypatch):
    """A server that accepts the connection and then says nothing (as an HTTP server waits for its
    request): refused after the connection's bound, not waited on for ever."""
    pytest.importorskip("distributed")
    import socket
    import threading

    monkeypatch.setattr("sizefx.batch.runner.DASK_CONNECT_S", 0.5)
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen()
    accepted = []
    threading.Thread(target=lambda: accepted.append(server.accept()), daemon=True).start()
    out = tmp_path / "out"
    try:
        address = f"tcp://127.0.0.1:{server.getsockname()[1]}"
        _refused(_sizefx("batch", "inspect", runs, "--out", out, "--scheduler", address), "cannot reach it (no answer)")
    finally:
        server.close()
    assert not out.exists()


def _sleep_jobs(folder, seconds: dict) -> list:
    """A job of tests/batch_sleep_stage.py per name, on a record file that says how long it sleeps."""
    jobs = []
    for name, s in seconds.items():
        (folder / f"{name}.h5").write_text(str(s))
        jobs.append(BatchJob("batch_sleep_stage", str(folder / f"{name}.h5"), name, str(folder / f"{name}.h5"), {}, {}))
    return jobs


@pytest.fixture
def one_worker_cluster():
    """A Dask cluster on this machine: one worker process of two threads (two records at once)."""
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=True, dashboard_address=None) as c:
        yield c


# long tier: a Dask cluster of its own and a record given up mid-way (8 s); fast twin:
# test_the_workers_of_a_killed_batch_end_with_it (the local workers' promise)
@pytest.mark.slow
def test_a_stopped_dask_batch_writes_nothing_after_it(tmp_path, one_worker_cluster):
    """Ctrl-C (raised by the progress callback after the first record): the task running on the cluster
    is cancelled and its output discarded, not published after the batch has gone."""
    jobs = _sleep_jobs(tmp_path, {"a": 0.1, "b": 3.0})

    def interrupt(event):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_batch(
            "inspect", jobs, tmp_path / "out", {}, scheduler=one_worker_cluster.scheduler_address, progress=interrupt
        )
    deadline = time.monotonic() + 30.0
    while not Path(f"{tmp_path}/b.h5.pid").exists() and time.monotonic() < deadline:
        time.sleep(0.1)
    assert Path(f"{tmp_path}/b.h5.pid").exists()  # b was running beside a when the batch stopped
    time.sleep(4.0)  # longer than b sleeps: its output would be there by now
    assert Path(f"{tmp_path}/a.h5.late").exists() and not Path(f"{tmp_path}/b.h5.late").exists()


# long tier: a Dask cluster of its own, emptied mid-record (8 s); fast twin:
# test_a_server_that_is_no_scheduler_is_one_line_within_seconds
@pytest.mark.slow
def test_a_cluster_that_loses_every_worker_fails_the_records_left(tmp_path, one_worker_cluster, monkeypatch):
    monkeypatch.setattr("sizefx.batch.runner.DASK_NO_WORKERS_S", 2.0)
    jobs = _sleep_jobs(tmp_path, {"a": 30.0, "b": 30.0})

    def empty_the_cluster():
        deadline = time.monotonic() + 30.0
        while not Path(f"{tmp_path}/a.h5.pid").exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        one_worker_cluster.scale(0)

    import threading

    threading.Thread(target=empty_the_cluster, daemon=True).start()
    result = run_batch("inspect", jobs, tmp_path / "out", {}, scheduler=one_worker_cluster.scheduler_address)
    assert [o.status for o in result.outcomes] == ["failed", "failed"]
    assert all("had no worker (or its scheduler was gone) for 2 s" in o.entry["reason"] for o in result.outcomes)
    doc = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert [e["status"] for e in doc["records"]] == ["failed", "failed"]


def test_the_manifest_is_written_also_after_a_signal(tmp_path, monkeypatch):
    """SIGTERM stops a batch: the records' outputs it was writing are discarded, but manifest.json of
    the records done is written (a record's output in the same state is not)."""
    from sizefx.io import files

    store = Manifest(tmp_path, "inspect").open_for_writing({})
    store.record({**_entry_of("a"), "input": "/r/a.h5"}, {})
    monkeypatch.setitem(files.INTERRUPTED, "signum", signal.SIGTERM)
    doc = json.loads(store.export({}).read_text())
    assert [e["name"] for e in doc["records"]] == ["a"]
    with pytest.raises(files.Interrupted), files.atomic_output(tmp_path / "a.inspect.json") as tmp:
        Path(tmp).write_text("{}")
    assert not (tmp_path / "a.inspect.json").exists()
    store.close()


def _entry_of(name: str) -> dict:
    return {
        "input": f"/r/{name}.h5",
        "name": name,
        "sha256": "",
        "options": {},
        "outputs": {},
        "status": "ok",
        "reason": None,
        "duration_s": 0.0,
        "peak_memory_mib": 0.0,
        "headline": {},
    }


# long tier: a Dask scheduler and worker of their own, the scheduler killed mid-record (10 s); fast
# twin: test_a_server_that_is_no_scheduler_is_one_line_within_seconds
@pytest.mark.slow
def test_a_scheduler_gone_mid_batch_fails_the_records_left(tmp_path, monkeypatch):
    pytest.importorskip("distributed")
    import socket
    import threading

    monkeypatch.setattr("sizefx.batch.runner.DASK_NO_WORKERS_S", 2.0)
    with socket.socket() as probe:  # a free port for the scheduler
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(TESTS), os.environ.get("PYTHONPATH", "")])}
    bin_dir = Path(sys.executable).parent
    scheduler = subprocess.Popen(
        [str(bin_dir / "dask"), "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
        cwd=tmp_path,
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    worker = subprocess.Popen(
        [str(bin_dir / "dask"), "worker", address, "--nthreads", "2", "--no-nanny", "--no-dashboard"],
        cwd=tmp_path,
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        jobs = _sleep_jobs(tmp_path, {"a": 30.0, "b": 30.0})

        def kill_the_scheduler():
            deadline = time.monotonic() + 60.0
            while not Path(f"{tmp_path}/a.h5.pid").exists() and time.monotonic() < deadline:
                time.sleep(0.1)
            scheduler.kill()

        threading.Thread(target=kill_the_scheduler, daemon=True).start()
        monkeypatch.setattr("sizefx.batch.runner.DASK_CONNECT_S", 20.0)  # two processes starting
        result = run_batch("inspect", jobs, tmp_path / "out", {}, scheduler=address)
        assert [o.status for o in result.outcomes] == ["failed", "failed"]
        # the client gives the futures up itself when it loses the scheduler, or the batch after 2 s
        reasons = [o.entry["reason"] for o in result.outcomes]
        assert all("scheduler" in r and "worker process died" not in r for r in reasons), reasons
    finally:
        for process in (scheduler, worker):
            process.kill()
            process.wait()
