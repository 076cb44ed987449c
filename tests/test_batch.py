"""``sizefx batch STAGE ... INPUTS --out DIR``.

- Every record goes through the single-file stage; outputs named after it; a manifest valid
  against ``sizefx/batch/1``; a bad record is refused alone; the exit code says whether all passed.
- Resumable: an unchanged record is skipped; a changed input, a missing output or ``--redo`` runs it
  again.
- The outputs do not depend on the number of workers (but the measured run times in them).
- A worker that dies takes only its own record with it.
- Bad batch input (no such file, a glob matching nothing, a record twice, --out inside an input
  folder, a manifest of another stage, a missing --levers file): one line, exit code 2, nothing written.
"""

from __future__ import annotations

import json
import os
import shutil
import time

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from sizefx.batch import BatchJob, BatchResult, RecordOutcome, digests, output_names, run_batch, runner
from sizefx.batch.fleet import headline, recurring_findings
from sizefx.batch.manifest import canonical_options
from sizefx.batch.runner import LOCK_NAME, default_memory_mib, folder_lock
from sizefx.io.files import sha256_of
from sizefx.io.schema import check_document
from sizefx.levers import levers_from_preset, write_levers
from sizefx.scenarios import TurntablePlan
from sizefx.simulate import SimulateConfig
from sizefx.simulate import run as simulate
from sizefx.stage import helper_threads
from sizefx_cli.main import main

#: A short turntable record (100 s at 200 Hz): each stage runs on it in about a second.
PLAN = TurntablePlan(static_s=10.0, seconds_per_axis=20.0, cycles=1)


def _record(path, seed):
    simulate(SimulateConfig("turntable", str(path), plan=PLAN, rate_hz=200.0, seed=seed, force=True))
    return path


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    """Three records in a folder."""
    folder = tmp_path_factory.mktemp("campaign") / "runs"
    folder.mkdir()
    for k in range(3):
        _record(folder / f"run{k}.h5", seed=k)
    return folder


def _batch(*args):
    return CliRunner().invoke(main, ["batch", *map(str, args)])


# A batch run costs a second or so (its workers are spawned processes that import the stage's code):
# where several tests read the same run, it is made once (module scope) and only read.


@pytest.fixture(scope="module")
def inspected(campaign, tmp_path_factory):
    """``batch inspect`` of the campaign on two workers: its result (with the progress lines) and its folder."""
    out = tmp_path_factory.mktemp("inspected") / "out"
    return _batch("inspect", campaign, "--out", out, "--workers", "2"), out


@pytest.fixture(scope="module")
def navigated(campaign, tmp_path_factory):
    """``batch navigate`` of the campaign on two workers: its folder."""
    out = tmp_path_factory.mktemp("navigated") / "out"
    result = _batch("navigate", campaign, "--out", out, "--workers", "2")
    assert result.exit_code == 0, result.output
    return out


def _manifest(out):
    doc = json.loads((out / "manifest.json").read_text())
    check_document(doc, "sizefx/batch/1")
    return doc


def test_inspect_batch_writes_one_output_per_record_and_a_manifest(inspected):
    result, out = inspected
    assert result.exit_code == 0, result.output
    doc = _manifest(out)
    assert [e["name"] for e in doc["records"]] == ["run0", "run1", "run2"]
    for entry in doc["records"]:
        assert entry["status"] == "ok" and entry["reason"] is None and len(entry["sha256"]) == 64
        summary = json.loads((out / f"{entry['name']}.inspect.json").read_text())
        assert summary["samples"] == entry["headline"]["samples"] == 24001
        assert entry["outputs"]["summary"]["bytes"] == (out / f"{entry['name']}.inspect.json").stat().st_size
        assert entry["peak_memory_mib"] > 0 and entry["duration_s"] > 0


def test_rerun_skips_what_is_unchanged(campaign, tmp_path, monkeypatch):
    """A re-run of a finished batch decides from the stat cache alone: no worker starts and no file is
    hashed (what runs again, and why: test_a_changed_input_and_an_output_changed_in_place_run_again,
    tests/test_batch_digests.py)."""
    runs = tmp_path / "runs"
    shutil.copytree(campaign, runs)
    out = tmp_path / "out"
    one = ("--workers", "1")
    assert _batch("inspect", runs, "--out", out, *one).exit_code == 0

    def refused(*_, **__):
        raise AssertionError("a re-run of an unchanged batch started a worker or hashed a file")

    with monkeypatch.context() as m:
        m.setattr(runner, "_pool", refused)
        m.setattr(runner, "start_workers", refused)
        m.setattr(digests, "sha256_of", refused)
        result = _batch("inspect", runs, "--out", out, *one)
    assert "0 ok, 3 unchanged" in result.output, result.output


# long tier: two batch runs (2 s); fast twins: test_rerun_skips_what_is_unchanged and
# tests/test_batch_digests.py::test_a_rerun_reuses_a_record_only_while_every_file_is_unchanged
@pytest.mark.slow
def test_a_changed_input_and_an_output_changed_in_place_run_again(campaign, tmp_path):
    runs = tmp_path / "runs"
    shutil.copytree(campaign, runs)
    out = tmp_path / "out"
    one = ("--workers", "1")
    assert _batch("inspect", runs, "--out", out, *one).exit_code == 0
    _record(runs / "run1.h5", seed=11)  # a changed input
    summary = out / "run2.inspect.json"  # an output changed in place, its size kept
    text = summary.read_text()
    summary.write_text(text.replace('"samples"', '"SAMPLES"'))
    result = _batch("inspect", runs, "--out", out, *one)
    assert "2 ok, 1 unchanged" in result.output, result.output
    assert {e["name"]: e["sha256"] for e in _manifest(out)["records"]}["run1"] == sha256_of(runs / "run1.h5")
    assert json.loads(summary.read_text())["samples"] == 24001


# long tier: three more batch runs, each starting its worker (about a second each); the fast tier's
# test above keeps the skipping itself
@pytest.mark.slow
def test_redo_and_other_options_run_every_record_again(campaign, tmp_path):
    out = tmp_path / "out"
    one = ("--workers", "1")
    assert _batch("inspect", campaign, "--out", out, *one).exit_code == 0
    assert "3 ok, 0 unchanged" in _batch("inspect", campaign, "--out", out, "--redo", *one).output
    result = _batch("inspect", campaign, "--out", out, "--no-units-check", *one)  # other options: run again
    assert "3 ok, 0 unchanged" in result.output, result.output


# long tier: navigates the three records (3 s); fast twin:
# test_a_record_of_a_handful_of_samples_is_refused_alone_with_its_reason
@pytest.mark.slow
def test_one_bad_record_is_refused_alone(campaign, tmp_path):
    runs = tmp_path / "runs"
    shutil.copytree(campaign, runs)
    (runs / "broken.h5").write_text("not HDF5")
    out = tmp_path / "out"
    result = _batch("navigate", runs, "--out", out, "--workers", "1")
    assert result.exit_code == 1, result.output
    entries = {e["name"]: e for e in _manifest(out)["records"]}
    assert entries["broken"]["status"] == "refused" and "broken.h5" in entries["broken"]["reason"]
    assert entries["broken"]["outputs"] == {}
    for name in ("run0", "run1", "run2"):
        assert entries[name]["status"] == "ok"
        assert (out / f"{name}.nav.h5").exists() and (out / f"{name}.navigate.json").exists()
        assert entries[name]["headline"]["final_horizontal_error_m"] > 0


def _content(path):
    """An HDF5 file's datasets and attributes, the run times taken out of its summary."""
    found = {}
    with h5py.File(path) as f:

        def visit(name, obj):
            for key, value in obj.attrs.items():
                if key == "summary_json":
                    value = {k: v for k, v in json.loads(value).items() if k not in ("wall_s", "kernel_s")}
                found[f"{name}@{key}"] = value
            if isinstance(obj, h5py.Dataset):
                found[name] = obj[()]

        f.visititems(visit)
        visit("/", f)
    return found


def test_outputs_do_not_depend_on_the_workers(campaign, navigated, tmp_path):
    one, two = tmp_path / "one", navigated  # two workers there
    assert _batch("navigate", campaign, "--out", one, "--workers", "1").exit_code == 0
    for k in range(3):
        a, b = _content(one / f"run{k}.nav.h5"), _content(two / f"run{k}.nav.h5")
        assert a.keys() == b.keys()
        for key in a:
            assert np.array_equal(a[key], b[key]) if isinstance(a[key], np.ndarray) else a[key] == b[key], key


def _crash_stage_jobs(folder, names):
    """A job of tests/batch_crash_stage.py per name, on a record file of that name."""
    for name in names:
        (folder / f"{name}.h5").write_text(name)
    return [
        BatchJob("batch_crash_stage", str(folder / f"{n}.h5"), n, str(folder / f"{n}.h5"), canonical_options({}), {})
        for n in names
    ]


def test_a_worker_that_dies_takes_only_its_record(tmp_path):
    """A stage that kills its process on one record (tests/batch_crash_stage.py): that record is
    failed, the others (in flight with it, or after it) are done. (Each record the broken pool held
    runs again alone in a fresh worker: one record after the crash, not two, saves a worker's start.)"""
    out = tmp_path / "out"
    jobs = _crash_stage_jobs(tmp_path, ["a", "crash", "b"])
    result = run_batch("inspect", jobs, out, {}, workers=2)
    status = {o.entry["name"]: o.status for o in result.outcomes}
    assert status == {"a": "ok", "crash": "failed", "b": "ok"}, status
    assert "worker process died" in result.outcomes[1].entry["reason"]
    assert [e["status"] for e in _manifest(out)["records"]] == ["ok", "ok", "failed"]  # by input path


# long tier: a long batch with a crash (1.5 s); fast twin: test_a_worker_that_dies_takes_only_its_record
@pytest.mark.slow
def test_a_worker_that_dies_early_in_a_long_batch_loses_no_record(tmp_path):
    """More records than the queue holds (2 per worker): the pool breaks while the rest wait to be
    submitted, and every record still gets its entry (only the crash fails)."""
    names = ["a", "b", "crash", *"defghi"]
    result = run_batch("inspect", _crash_stage_jobs(tmp_path, names), tmp_path / "out", {}, workers=2)
    status = {o.entry["name"]: o.status for o in result.outcomes}
    assert status == {n: "failed" if n == "crash" else "ok" for n in names}, status
    assert len(_manifest(tmp_path / "out")["records"]) == len(names)


# long tier: signals to a running pool (4 s); fast twin: test_a_worker_that_dies_takes_only_its_record
@pytest.mark.slow
def test_a_stopped_batch_stops_its_workers(tmp_path):
    """Ctrl-C (here: raised by the progress callback after the first record): the record still
    running is stopped rather than run to its end, the queued ones never start, and no temporary
    file is left in the folder."""
    jobs = _crash_stage_jobs(tmp_path, ["a", "slow", "b", "c", "d", "e"])

    def interrupt(event):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_batch("inspect", jobs, tmp_path / "out", {}, workers=2, progress=interrupt)
    time.sleep(4.0)  # longer than "slow" takes: it would have finished by now
    assert not (tmp_path / "slow.h5.finished").exists()
    assert not (tmp_path / "e.h5.helpers").exists()  # queued behind the first four: never started
    assert not list((tmp_path / "out").glob("*.tmp"))


# long tier: three batch runs (1.5 s); fast twin: test_rerun_skips_what_is_unchanged
@pytest.mark.slow
def test_a_reused_record_whose_input_is_gone_is_refused_alone(campaign, tmp_path):
    """A record deleted after the batch listed it, on a re-run: its hash cannot be taken, so it is not
    reused but run (a real stage then refuses the missing file in one line; this one reads nothing);
    the others are unchanged, and the batch ends normally instead of raising."""
    runs = tmp_path / "runs"
    shutil.copytree(campaign, runs)
    out = tmp_path / "out"
    assert _batch("inspect", runs, "--out", out).exit_code == 0
    names = output_names([runs / f"run{k}.h5" for k in range(3)])
    jobs = [
        BatchJob(
            "batch_crash_stage",
            str(runs / f"run{k}.h5"),
            names[runs / f"run{k}.h5"],
            str(runs / f"run{k}.h5"),
            e["options"],
            {},
            str(out / f"{names[runs / f'run{k}.h5']}.inspect.json"),  # where the batch wrote it: a resume checks
            e,
            False,
        )
        for k, e in enumerate(_manifest(out)["records"])
    ]
    (runs / "run1.h5").unlink()
    result = run_batch("inspect", jobs, out, {}, workers=2)
    assert [o.reused for o in result.outcomes] == [True, False, True]
    assert result.outcomes[1].status == "ok"  # the crash stage reads nothing: it ran, unhashed
    assert result.outcomes[1].entry["sha256"] == ""


# long tier: two batch runs (3 s); fast twin: test_rerun_skips_what_is_unchanged (a changed input reruns)
@pytest.mark.slow
def test_a_changed_levers_file_reruns_the_records(campaign, tmp_path):
    """--levers (like --model and --nominal) is hashed with each record: a new calibration written
    into the same levers.json makes the next run navigate every record again."""
    levers = tmp_path / "levers.json"
    write_levers(levers, levers_from_preset("high-precision"))
    out = tmp_path / "out"
    assert _batch("navigate", campaign, "--levers", levers, "--out", out).exit_code == 0
    entry = _manifest(out)["records"][0]
    assert entry["paired"]["--levers"] == {"path": str(levers), "sha256": sha256_of(levers)}
    assert "0 ok, 3 unchanged" in _batch("navigate", campaign, "--levers", levers, "--out", out).output
    write_levers(levers, levers_from_preset("compact"), force=True)
    result = _batch("navigate", campaign, "--levers", levers, "--out", out)
    assert "3 ok, 0 unchanged" in result.output, result.output


# long tier: a batch and a single command (1.5 s); fast twins: test_outputs_do_not_depend_on_the_workers
# (a batch's outputs are the stage's) and the compensate command's own tests (tests/test_sizeeffect.py)
@pytest.mark.slow
def test_compensate_batch_writes_each_record_compensated(campaign, tmp_path):
    """batch compensate: one compensated file per record, the levers file hashed with each, and each
    output equal to the single command's."""
    levers = tmp_path / "levers.json"
    write_levers(levers, levers_from_preset("high-precision"))
    out = tmp_path / "out"
    result = _batch("compensate", campaign, "--levers", levers, "--out", out, "-q", "--workers", "1")
    assert result.exit_code == 0, result.output
    single = tmp_path / "single.h5"
    assert (
        CliRunner()
        .invoke(main, ["compensate", str(campaign / "run1.h5"), "--levers", str(levers), "-o", str(single)])
        .exit_code
        == 0
    )
    for entry in _manifest(out)["records"]:
        assert entry["status"] == "ok" and set(entry["paired"]) == {"--levers"}
        assert (out / f"{entry['name']}.compensated.h5").exists()
    a, b = _content(out / "run1.compensated.h5"), _content(single)
    assert a.keys() == b.keys()
    for key in a:
        assert np.array_equal(a[key], b[key]) if isinstance(a[key], np.ndarray) else a[key] == b[key], key


# long tier: three diagnoses (4 s); fast twin: test_compensate_batch_writes_each_record_compensated
@pytest.mark.slow
def test_diagnose_batch_finds_what_the_single_command_finds_and_what_recurs(tmp_path):
    """batch diagnose over three records, an accelerometer bias hidden in two: a report and a model
    per record, each record's findings those of 'sizefx diagnose' on it, and the bias on each axis
    named as recurring in two of the three."""
    runs = tmp_path / "runs"
    runs.mkdir()
    for k, hidden in enumerate([{"accel_bias": {"enabled": True}}, {"accel_bias": {"enabled": True}}, None]):
        simulate(
            SimulateConfig("turntable", str(runs / f"r{k}.h5"), plan=PLAN, rate_hz=200.0, seed=k, overrides=hidden)
        )
    out = tmp_path / "out"
    result = _batch("diagnose", runs, "--out", out, "--workers", "2")
    assert result.exit_code == 0, result.output
    single = tmp_path / "single.json"
    assert (
        CliRunner()
        .invoke(
            main, ["diagnose", str(runs / "r0.h5"), "--json", str(single), "--model-out", str(tmp_path / "single.toml")]
        )
        .exit_code
        == 0
    )
    entries = {e["name"]: e for e in _manifest(out)["records"]}
    for name in ("r0", "r1", "r2"):
        assert entries[name]["status"] == "ok"
        assert (out / f"{name}.diagnosis.json").exists() and (out / f"{name}.model.toml").exists()

    def timeless(headline):  # without the run's own time
        return {k: v for k, v in headline.items() if k != "wall_s"}

    assert timeless(entries["r0"]["headline"]) == timeless(headline("diagnose", json.loads(single.read_text())))
    assert entries["r2"]["headline"]["effects"] == []
    assert (
        "findings in more than one of 3 records: accel_bias accel_x (2), accel_bias accel_y (2), accel_bias accel_z (2)"
    ) in result.output, result.output


# long tier: two batch runs (2 s); fast twin: test_outputs_do_not_depend_on_the_workers
@pytest.mark.slow
def test_outputs_do_not_depend_on_the_order_of_the_inputs(campaign, tmp_path):
    """The records given in reverse: the same outputs, byte for byte, and the manifest in path order."""
    ahead, behind = tmp_path / "ahead", tmp_path / "behind"
    assert _batch("inspect", campaign, "--out", ahead, "-q").exit_code == 0
    reverse = [campaign / f"run{k}.h5" for k in (2, 1, 0)]
    assert _batch("inspect", *reverse, "--out", behind, "-q").exit_code == 0
    for k in range(3):
        assert (ahead / f"run{k}.inspect.json").read_bytes() == (behind / f"run{k}.inspect.json").read_bytes()
    assert [e["name"] for e in _manifest(behind)["records"]] == ["run0", "run1", "run2"]


def test_progress_off_a_terminal_is_a_plain_line_per_record(inspected):
    """Not a terminal (as here): a line per record with the count, the record, the rate and the time left."""
    result, _ = inspected
    assert result.exit_code == 0, result.output
    lines = [line for line in result.output.splitlines() if line.startswith("batch inspect: ") and "/3 " in line]
    assert [line.split()[2] for line in lines] == ["1/3", "2/3", "3/3"], result.output
    assert all("records/s" in line for line in lines) and "s left" in lines[0]


def test_a_record_beyond_the_memory_bound_fails_alone(tmp_path):
    """--memory-per-worker-mib: the record that needs more (4 GiB against 1 GiB) is failed with a
    MemoryError that names the bound; the others, in the same warm worker (one: b and c run in the
    worker whose allocation failed), are done."""
    out = tmp_path / "out"
    jobs = _crash_stage_jobs(tmp_path, ["a", "hog", "b", "c"])
    result = run_batch("inspect", jobs, out, {}, workers=1, memory_mib=1024)
    status = {o.entry["name"]: o.status for o in result.outcomes}
    assert status == {"a": "ok", "hog": "failed", "b": "ok", "c": "ok"}, status
    reason = result.outcomes[1].entry["reason"]
    assert reason.startswith("MemoryError") and "bound of 1024 MiB" in reason, reason


@pytest.mark.parametrize("cores, workers, helpers", [(2, 2, "False"), (4, 2, "True"), (2, 1, "True")])
def test_workers_that_fill_the_cores_run_no_helper_threads(tmp_path, monkeypatch, cores, workers, helpers):
    """A stage's helper thread (navigate's read-ahead) only where a worker's share of the cores is
    two or more; the single command keeps it."""
    monkeypatch.setattr(runner, "available_cores", lambda: cores)
    jobs = _crash_stage_jobs(tmp_path, ["a", "b"])
    run_batch("inspect", jobs, tmp_path / "out", {}, workers=workers)
    assert {(tmp_path / f"{n}.h5.helpers").read_text() for n in "ab"} == {helpers}
    assert helper_threads()


def test_available_cores_follow_the_affinity():
    """The default --workers counts the cores this process may run on, not the machine's."""
    assert runner.available_cores() == len(os.sched_getaffinity(0))
    assert runner.local_workers(None, 100) == runner.available_cores()
    assert runner.local_workers(8, 3) == 3 and runner.local_workers(None, 0) == 1


def test_default_memory_bound_shares_the_machine():
    one, two = default_memory_mib(1), default_memory_mib(2)
    assert one is not None and 0 < two < one < os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**20
    assert two == pytest.approx(one / 2)


def test_a_folder_in_use_by_another_batch_is_refused(campaign, tmp_path):
    """Two batches into one folder at once: the second is refused in one line, exit 2, and writes
    nothing; once the first is done the folder is free again. (One record: one worker to start.)"""
    out = tmp_path / "out"
    out.mkdir()
    with folder_lock(out):  # the first batch, still writing
        result = _batch("inspect", campaign / "run0.h5", "--out", out)
        _one_line_refusal(result, "another sizefx batch or run is writing into this folder (pid ")
        assert sorted(p.name for p in out.iterdir()) == [LOCK_NAME]
    with folder_lock(out):  # free again once the first is done
        pass


def test_records_with_one_stem_get_names_of_their_folders(tmp_path):
    paths = [
        tmp_path / "day1" / "imu.h5",
        tmp_path / "day2" / "imu.h5",
        tmp_path / "day2" / "imu.hdf5",
        tmp_path / "other.h5",
    ]
    names = output_names(paths)
    assert names[paths[0]] == "day1__imu" and names[paths[3]] == "other"
    assert len(set(names.values())) == 4
    assert output_names(list(reversed(paths))) == names


def _one_line_refusal(result, needle):
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.output, result.output
    assert needle in lines[0], lines[0]


@pytest.mark.parametrize(
    "case, needle",
    [
        ("missing", "no such file or folder"),
        ("glob", "matches no file"),
        ("twice", "given twice"),
        ("inside", "inside the input folder"),
        ("out-is-file", "is a file"),
        ("empty-folder", "holds no record"),
        ("levers", "--levers"),
    ],
)
def test_bad_batch_input_is_one_line_and_writes_nothing(campaign, tmp_path, case, needle):
    out = tmp_path / "out"
    args = {
        "missing": ["navigate", tmp_path / "nope.h5"],
        "glob": ["navigate", str(tmp_path / "*.h5")],
        "twice": ["navigate", campaign / "run0.h5", campaign / ".." / "runs" / "run0.h5"],
        "inside": ["navigate", campaign],
        "out-is-file": ["navigate", campaign / "run0.h5"],
        "empty-folder": ["navigate", tmp_path / "empty"],
        "levers": ["navigate", campaign / "run0.h5", "--levers", tmp_path / "levers.json"],
    }[case]
    if case == "inside":
        out = campaign / "batch-out"
    if case == "out-is-file":
        out.write_text("x")
    if case == "empty-folder":
        (tmp_path / "empty").mkdir()
    _one_line_refusal(_batch(*args, "--out", out), needle)
    assert case == "out-is-file" or not out.exists()


# long tier: navigates and compares three records twice (4 s); fast twin: test_compare_without_a_partner_is_one_line
@pytest.mark.slow
def test_compare_pairs_each_solution_with_its_partner_and_reference(campaign, tmp_path):
    """batch compare: each record's solution A with its B (--against, paired by name) and the record's
    own telemetry as truth (--reference, a folder); the paired files hashed into the manifest, so that
    a changed B runs that record again and only it."""
    plain, coarse, out = tmp_path / "plain", tmp_path / "coarse", tmp_path / "cmp"
    assert _batch("navigate", campaign, "--out", plain, "-q").exit_code == 0
    assert _batch("navigate", campaign, "--subsamples", "1", "--out", coarse, "-q").exit_code == 0
    result = _batch("compare", coarse, "--against", plain, "--reference", campaign, "--out", out, "-q")
    assert result.exit_code == 0, result.output
    doc = _manifest(out)
    assert doc["stage"] == "compare"
    for k, entry in enumerate(doc["records"]):
        assert entry["status"] == "ok" and entry["input"] == str(coarse / f"run{k}.nav.h5")
        assert {o: p["path"] for o, p in entry["paired"].items()} == {
            "--against": str(plain / f"run{k}.nav.h5"),
            "--reference": str(campaign.resolve() / f"run{k}.h5"),
        }
        assert entry["paired"]["--against"]["sha256"] == sha256_of(plain / f"run{k}.nav.h5")
        comparison = json.loads((out / f"run{k}.nav.comparison.json").read_text())
        assert [c["label"] for c in comparison["comparisons"]] == ["A vs REF", "B vs REF", "A vs B"]
        assert comparison["inputs"]["b"] == str(plain / f"run{k}.nav.h5")
        assert entry["headline"]["a_vs_b_max_horizontal_m"] == comparison["comparisons"][2]["horizontal_m"]["max"]
    # a changed B: that record again, the others unchanged
    shutil.copyfile(coarse / "run1.nav.h5", plain / "run1.nav.h5")
    result = _batch("compare", coarse, "--against", plain, "--reference", campaign, "--out", out, "-q")
    assert result.exit_code == 0 and "1 ok, 2 unchanged" in result.output, result.output
    assert _manifest(out)["records"][1]["headline"]["a_vs_b_max_horizontal_m"] == 0.0


@pytest.mark.parametrize("case, needle", [("no-partner", "nothing for run2.nav.h5"), ("self", "compared with itself")])
def test_compare_without_a_partner_is_one_line(navigated, tmp_path, case, needle):
    plain = navigated
    if case == "no-partner":
        other = tmp_path / "other"
        other.mkdir()
        for k in range(2):
            shutil.copyfile(plain / f"run{k}.nav.h5", other / f"run{k}.nav.h5")
        args = [plain, "--against", other]
    else:
        args = [plain / "run0.nav.h5", "--against", plain / "run0.nav.h5"]
    out = tmp_path / "cmp"
    _one_line_refusal(_batch("compare", *args, "--out", out), needle)
    assert not out.exists()


def test_a_folder_of_another_stage_is_refused(campaign, inspected, tmp_path):
    done, out = inspected[0], tmp_path / "out"
    assert done.exit_code == 0, done.output
    shutil.copytree(inspected[1], out)  # a folder batch inspect wrote
    _one_line_refusal(_batch("navigate", campaign / "run0.h5", "--out", out), "a batch of 'inspect'")


# long tier: a batch run for its progress lines (1 s); fast twin: test_progress_off_a_terminal_is_a_plain_line_per_record
@pytest.mark.slow
def test_json_progress_is_one_object_per_record(campaign, tmp_path):
    result = CliRunner().invoke(
        main, ["batch", "inspect", str(campaign), "--out", str(tmp_path / "out"), "--json-progress"]
    )
    assert result.exit_code == 0, result.output
    events = [json.loads(line) for line in result.stderr.splitlines()]
    assert [e["done"] for e in events] == [1, 2, 3] and all(e["total"] == 3 for e in events)
    assert events[-1]["ok"] == 3 and events[-1]["eta_s"] == 0


def _calibration(name, arms, sigma):
    return {
        "name": name,
        "status": "ok",
        "headline": {
            **{f"r_{a}_m": arms[i].tolist() for i, a in enumerate("xyz")},
            **{f"sigma_{a}_m": sigma[i].tolist() for i, a in enumerate("xyz")},
        },
    }


def test_calibrations_of_one_unit_combine_and_the_odd_run_is_named():
    """Twenty runs scattered by their sigma: the combination's sigma is sigma / sqrt(20) and chi2/dof
    near 1; one run 10 sigma off on one component is named, and raises that component's chi2/dof."""
    from sizefx.batch.fleet import combine_arms

    rng = np.random.default_rng(1)
    truth, sigma = np.diag([0.025, 0.025, 0.025]), np.full((3, 3), 3e-5)
    runs = [_calibration(f"run{k}", truth + sigma * rng.standard_normal((3, 3)), sigma) for k in range(20)]
    good = combine_arms(runs)
    np.testing.assert_allclose(good["sigma_m"], sigma / np.sqrt(20))
    assert 0.4 < np.mean(good["chi2_dof"]) < 1.6 and good["disagree"] == []
    odd = truth + sigma * rng.standard_normal((3, 3))
    odd[0, 2] += 10 * sigma[0, 2]
    bad = combine_arms(runs + [_calibration("odd", odd, sigma)])
    assert [name for name, _ in bad["disagree"]] == ["odd"] and bad["chi2_dof"][0][2] > 3
    assert combine_arms(runs[:1]) is None


def _outcome(entry):
    return RecordOutcome(
        {
            "input": entry["name"],
            "sha256": "",
            "options": {},
            "outputs": {},
            "reason": None,
            "duration_s": 1.0,
            "peak_memory_mib": 100.0,
            **entry,
        }
    )


def test_fleet_table_lists_each_runs_arms_and_their_spread():
    """batch calibrate's table: every run's nine arm components [mm] on its line, the spread of each
    across the runs, then the combination."""
    sigma = np.full((3, 3), 3e-5)
    runs = [_calibration(f"run{k}", np.diag([0.025, 0.025, 0.025]) + k * 1e-4, sigma) for k in range(3)]
    report = BatchResult("calibrate", [_outcome(r) for r in runs]).report()
    assert "run2: ok, 1.0 s, 100 MiB; r_x[x]_mm 25.2, r_x[y]_mm 0.2, r_x[z]_mm 0.2, r_y[x]_mm 0.2" in report
    assert "r_z[z]_mm across 3 records: mean 25.1, std 0.1, min 25, max 25.2" in report
    assert "arms of 3 runs combined" in report


def test_fleet_table_names_the_diagnose_findings_that_recur():
    """batch diagnose's table: the findings (effect and channel) that more than one record reports, with
    how many; a finding of one record alone is not among them."""
    effects = [["accel_bias x", "delay"], ["accel_bias x", "delay", "scale y"], ["accel_bias x"]]
    entries = [
        {"name": f"r{k}", "status": "ok", "headline": {"effects": e, "warnings": 0, "unexplained": 0}}
        for k, e in enumerate(effects)
    ]
    report = BatchResult("diagnose", [_outcome(e) for e in entries]).report()
    assert "findings in more than one of 3 records: accel_bias x (3), delay (2)" in report
    assert recurring_findings(entries) == [("accel_bias x", 3), ("delay", 2)]


@pytest.fixture(scope="module")
def cluster():
    """A Dask cluster on this machine: two worker processes, one thread each."""
    distributed = pytest.importorskip("distributed")  # a test extra; skipped only outside CI's install
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as c:
        yield c


def test_dask_batch_gives_the_local_outputs(campaign, inspected, tmp_path, cluster):
    (local_result, local), remote = inspected, tmp_path / "dask"
    assert local_result.exit_code == 0, local_result.output
    result = _batch("inspect", campaign, "--out", remote, "--scheduler", cluster.scheduler_address)
    assert result.exit_code == 0, result.output
    for k in range(3):
        assert (local / f"run{k}.inspect.json").read_bytes() == (remote / f"run{k}.inspect.json").read_bytes()
    assert [e["sha256"] for e in _manifest(local)["records"]] == [e["sha256"] for e in _manifest(remote)["records"]]


def test_dask_worker_killed_mid_record_is_retried(tmp_path, cluster):
    """A worker dies in the middle of a record (tests/batch_crash_stage.py kills it once): the scheduler
    runs the record again on a fresh worker; nothing is lost and the manifest lists every record."""
    out = tmp_path / "out"
    jobs = _crash_stage_jobs(tmp_path, ["a", "killonce", "b"])
    result = run_batch("inspect", jobs, out, {}, scheduler=cluster.scheduler_address)
    assert [o.status for o in result.outcomes] == ["ok", "ok", "ok"]
    assert (tmp_path / "killonce.h5.killed").exists()  # it did die once
    assert [e["name"] for e in _manifest(out)["records"]] == ["a", "b", "killonce"]


def test_an_unreachable_scheduler_is_one_line_and_writes_nothing(campaign, tmp_path, monkeypatch):
    pytest.importorskip("distributed")
    # nothing listens on port 9: the wait for it is not what is tested (5 s by default)
    monkeypatch.setattr("sizefx.batch.runner.DASK_CONNECT_S", 0.5)
    out = tmp_path / "out"
    _one_line_refusal(_batch("inspect", campaign, "--out", out, "--scheduler", "tcp://127.0.0.1:9"), "cannot reach it")
    assert not out.exists()


# long tier: calibrates three turntable records and draws (5 s); fast twin: test_compare.py's and test_diagnose.py's plots
@pytest.mark.slow
def test_plots_draw_the_figures_across_the_records(campaign, tmp_path):
    """--with-plots: fleet.png with calibrate's nine arm components (and each run's own figure); for a stage
    without figures of its own, --with-plots does not make the records run again."""
    out = tmp_path / "cal"
    result = _batch("calibrate", campaign, "--out", out, "--with-plots")
    assert result.exit_code == 0, result.output
    assert (out / "fleet.png").stat().st_size > 10_000 and (out / "run0.calibrate.png").exists()
    assert "figures across the records" in result.output and "chi2/dof" in result.output
    checked = tmp_path / "inspect"
    assert _batch("inspect", campaign, "--out", checked).exit_code == 0
    result = _batch("inspect", campaign, "--out", checked, "--with-plots")
    assert "0 ok, 3 unchanged" in result.output and (checked / "fleet.png").exists(), result.output


def test_headline_figures_of_each_stage():
    """The manifest's headline figures from each stage's JSON (the keys its schema gives)."""
    from sizefx.batch.fleet import headline

    assert headline(
        "diagnose",
        {
            "effects": [{"id": "lever_arm", "channel": "accel_y"}, {"id": "accel_delay"}],
            "warnings": [{}],
            "unexplained": [],
        },
    ) == {"effects": ["accel_delay", "lever_arm accel_y"], "warnings": 1, "unexplained": 0}
    arms = {f"r_{a}": [0.0, 0.0, 0.0] for a in "xyz"} | {f"sigma_{a}": [1e-5] * 3 for a in "xyz"}
    figures = headline("calibrate", {"levers": {**arms, "accel_delay_s": 5e-4}})
    assert figures["r_y_m"] == [0.0, 0.0, 0.0] and figures["sigma_z_m"] == [1e-5] * 3
    assert figures["accel_delay_s"] == 5e-4
    assert headline("inspect", {"samples": 10, "units_ok": True, "path": "x.h5"}) == {"samples": 10}


def test_a_record_of_a_handful_of_samples_is_refused_alone_with_its_reason(campaign, tmp_path):
    """batch navigate --with-plots: a 5-sample record is refused (the single command's one line as the reason),
    not 'failed' with a ValueError, and the other records run."""
    from support import write_tiny_flight

    runs = tmp_path / "runs"
    runs.mkdir()
    shutil.copy(campaign / "run0.h5", runs)  # one good record beside it is enough to see it run
    write_tiny_flight(runs / "tiny.h5", 5)
    out = tmp_path / "out"
    result = _batch("navigate", runs, "--out", out, "--with-plots", "--workers", "1")
    assert result.exit_code == 1, result.output
    entries = {e["name"]: e for e in _manifest(out)["records"]}
    assert entries["tiny"]["status"] == "refused" and entries["tiny"]["outputs"] == {}
    assert "5 samples give 1 navigation step of 0.04 s" in entries["tiny"]["reason"]
    assert entries["run0"]["status"] == "ok"


def test_a_refused_record_whose_input_was_removed_leaves_the_manifest(campaign, tmp_path):
    """A refused record has no outputs; once its input is gone, the next run drops its entry. A
    finished record's entry stays with its outputs in the folder, whatever became of its input."""
    runs = tmp_path / "runs"
    runs.mkdir()
    for k in (0, 1):
        shutil.copy(campaign / f"run{k}.h5", runs)
    (runs / "broken.h5").write_text("not HDF5")
    out = tmp_path / "out"
    assert _batch("inspect", runs, "--out", out, "--workers", "1").exit_code == 1
    assert {e["name"]: e["status"] for e in _manifest(out)["records"]} == {
        "broken": "refused",
        "run0": "ok",
        "run1": "ok",
    }
    (runs / "broken.h5").unlink()
    (runs / "run1.h5").unlink()
    assert _batch("inspect", runs, "--out", out, "--workers", "1").exit_code == 0
    assert {e["name"]: e["status"] for e in _manifest(out)["records"]} == {"run0": "ok", "run1": "ok"}


def test_an_option_file_is_kept_by_its_resolved_path(campaign, tmp_path, monkeypatch):
    """--levers given relative: the manifest names the file itself, and a re-run from another folder
    that names the same file another way finds every record unchanged."""
    from sizefx.levers import levers_from_preset, write_levers

    runs = tmp_path / "runs"
    runs.mkdir()
    shutil.copy(campaign / "run0.h5", runs)
    write_levers(tmp_path / "lev.json", levers_from_preset("high-precision"))
    monkeypatch.chdir(tmp_path)
    assert _batch("compensate", "runs", "--levers", "lev.json", "--out", "out", "--workers", "1").exit_code == 0
    doc = _manifest(tmp_path / "out")
    assert doc["options"]["levers"] == str(tmp_path.resolve() / "lev.json")
    assert doc["records"][0]["paired"]["--levers"]["path"] == str(tmp_path.resolve() / "lev.json")
    monkeypatch.chdir(runs)
    result = _batch("compensate", ".", "--levers", "../lev.json", "--out", "../out", "--workers", "1")
    assert result.exit_code == 0 and "0 ok, 1 unchanged" in result.output, result.output


def test_each_record_says_where_its_time_went(navigated):
    """navigate's own phases add up to its stage time; the entry names its worker and its samples."""
    for entry in _manifest(navigated)["records"]:
        phases = entry["phases_s"]
        own = ("open_checks", "initial", "read", "kernels", "write", "other")
        assert set(phases) == {"hash", "stage", "outputs", *own}, phases
        assert sum(phases[k] for k in own) == pytest.approx(phases["stage"], abs=1e-3)  # each rounded to 0.1 ms
        assert phases["stage"] + phases["outputs"] <= entry["duration_s"]
        assert entry["samples"] == 24001 and "pid" in entry["worker"]


def test_throughput_counts_the_records_run_and_each_workers_busy_share():
    def outcome(name, worker, duration, reused=False):
        entry = {
            "input": name,
            "name": name,
            "status": "ok",
            "duration_s": duration,
            "peak_memory_mib": 1.0,
            "headline": {},
            "worker": worker,
            "samples": 1000,
            "phases_s": {"stage": duration},
        }
        return RecordOutcome(entry, reused=reused)

    result = BatchResult(
        "inspect",
        [outcome("a", "w1", 3.0), outcome("b", "w1", 1.0), outcome("c", "w2", 2.0), outcome("d", "w1", 9.0, True)],
        wall_s=5.0,
        workers=2,
    )
    pace = result.throughput()
    assert pace["records_run"] == 3 and pace["records_per_s"] == pytest.approx(0.6)
    assert pace["samples_per_s"] == pytest.approx(600.0)
    assert pace["busy"] == pytest.approx({"w1": 0.8, "w2": 0.4}) and pace["busy_mean"] == pytest.approx(0.6)
    assert "3 records run: 0.6 records/s, 600 samples/s; 2 workers busy 40-80 %" in result.report()


# long tier: two batch runs, the second starting its worker (1.5 s); fast twin: test_rerun_skips_what_is_unchanged
@pytest.mark.slow
def test_rehash_trusts_no_stat_and_still_skips_what_is_unchanged(campaign, tmp_path, monkeypatch):
    out = tmp_path / "out"
    assert _batch("inspect", campaign, "--out", out, "--workers", "1").exit_code == 0
    monkeypatch.setattr(runner, "_unchanged", lambda *_: pytest.fail("--rehash consulted the stat cache"))
    result = _batch("inspect", campaign, "--out", out, "--workers", "1", "--rehash")
    assert "0 ok, 3 unchanged" in result.output, result.output
