"""``sizefx run --out DIR calibrate T.h5 navigate F.h5 compare``.

- The chain passes calibrate's lever arms to navigate, which navigates plain and compensated, and
  compare sets the two against the flight's reference; every output and run.json in DIR.
- A stage option keeps its meaning in the chain (given before the stage's file: click's rule for
  chained commands).
- A chain that cannot work is refused before any stage runs: one line, exit code 2, nothing written.
"""

from __future__ import annotations

import json
import shutil

import h5py
import numpy as np
import pytest
from click.testing import CliRunner
from support import write_tiny_flight

from sizefx.io.schema import check_document
from sizefx.levers import levers_from_preset, write_levers
from sizefx.scenarios import FlightPlan, TurntablePlan
from sizefx.simulate import SimulateConfig
from sizefx.simulate import run as simulate
from sizefx_cli.main import main

#: The chains' records: what is tested is the plumbing (which stage gets which file and option, what
#: is written where), not the accuracy, so short and at 200 Hz. The flight: a minute of alignment, no
#: S-turns (FlightPlan's weave), 10 min, a little more than the shortest the plan then allows (571 s).
RATE_HZ = 200.0
TURNTABLE = TurntablePlan(static_s=10.0, seconds_per_axis=20.0, cycles=1)
FLIGHT = FlightPlan(duration_s=600.0, align_s=60.0, weave_deg=0.0)


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    """A short turntable record (100 s) and a short flight (10 min)."""
    folder = tmp_path_factory.mktemp("chain")
    turntable, flight = folder / "turntable.h5", folder / "flight.h5"
    simulate(SimulateConfig("turntable", str(turntable), rate_hz=RATE_HZ, seed=1, plan=TURNTABLE))
    simulate(SimulateConfig("flight", str(flight), rate_hz=RATE_HZ, seed=2, plan=FLIGHT))
    return turntable, flight


def _run(*args):
    return CliRunner().invoke(main, ["run", *map(str, args)])


def test_calibrate_navigate_compare(records, tmp_path):
    turntable, flight = records
    out = tmp_path / "out"
    result = _run("--out", out, "calibrate", turntable, "navigate", "--output-rate-hz", "1", flight, "compare")
    assert result.exit_code == 0, result.output
    doc = json.loads((out / "run.json").read_text())
    check_document(doc, "sizefx/run/1")
    assert [(s["stage"], s.get("run")) for s in doc["steps"]] == [
        ("calibrate", None),
        ("navigate", "plain"),
        ("navigate", "compensated"),
        ("compare", None),
    ]
    levers = str(out / "levers.json")
    assert doc["steps"][1]["inputs"] == {"FILE": str(flight)}
    assert doc["steps"][2]["inputs"] == {"FILE": str(flight), "--levers": levers}
    assert doc["steps"][3]["inputs"] == {
        "A": str(out / "compensated.nav.h5"),
        "B": str(out / "plain.nav.h5"),
        "--reference": str(flight),
    }
    with h5py.File(out / "plain.nav.h5") as f:  # --output-rate-hz kept its meaning: a row a second
        t = f["/time"][()]
        assert np.allclose(np.diff(t), 1.0)
    comparison = json.loads((out / "comparison.json").read_text())
    assert comparison["schema"] == "sizefx/comparison/1"
    assert "A and B diverge by" in result.output


def test_navigate_with_its_own_levers_and_compare(records, tmp_path):
    turntable, flight = records
    cal = tmp_path / "cal"
    assert _run("--out", cal, "calibrate", turntable).exit_code == 0
    out = tmp_path / "out"
    result = _run("--out", out, "navigate", "--levers", cal / "levers.json", flight, "compare")
    assert result.exit_code == 0, result.output
    assert (out / "plain.nav.h5").exists() and (out / "compensated.nav.h5").exists()


def test_navigate_with_a_model_and_compare(records, tmp_path):
    """A --model is navigate's correction in a chain as --levers is: the plain run goes without it,
    the compensated one with it, and compare sets them side by side."""
    _, flight = records
    model = tmp_path / "model.toml"
    model.write_text('schema = "sizefx/effects/1"\n\n[lever_arm]\nenabled = true\n')
    out = tmp_path / "out"
    result = _run("--out", out, "navigate", "--model", model, "--output-rate-hz", "1", flight, "compare")
    assert result.exit_code == 0, result.output
    doc = json.loads((out / "run.json").read_text())
    runs = {s.get("run"): s for s in doc["steps"] if s["stage"] == "navigate"}
    assert set(runs) == {"plain", "compensated"}
    assert runs["plain"]["options"]["model"] is None and runs["compensated"]["options"]["model"] == str(model)
    assert (out / "comparison.json").exists()


@pytest.mark.parametrize(
    "chain, needle",
    [
        (["compare"], "nothing to compare"),
        (["navigate", "{flight}", "compare"], "needs two solutions"),
        (["navigate", "{flight}", "calibrate", "{turntable}"], "out of order"),
        (["calibrate", "{turntable}", "navigate", "--levers", "{turntable}", "{flight}"], "leave out one"),
        (["calibrate", "{turntable}", "navigate", "{missing}", "compare"], "no such file"),
        (["calibrate", "{turntable}", "navigate", "{flight}", "navigate", "{flight}"], "each stage once"),
        (["calibrate", "--nominal", "{missing_levers}", "{turntable}"], "--nominal"),
        # a good levers file: the chain reads it (sizefx.batch.inputs.check_option_files) before the flight
        (["navigate", "--levers", "{levers}", "{not_hdf5}", "compare"], "is not an HDF5 file"),
        (["--no-out", "compare"], "nothing to compare"),
        (["navigate", "--levers", "{levers}", "{no_truth}", "compare"], "has no /reference/position"),
    ],
    ids=[
        "compare-alone",
        "one-solution",
        "order",
        "levers-twice",
        "missing-flight",
        "repeated",
        "missing-nominal",
        "flight-not-hdf5",
        "no-out-no-file",
        "flight-without-truth",
    ],
)
def test_chains_that_cannot_work_are_refused_before_any_stage(records, tmp_path, chain, needle):
    turntable, flight = records
    (tmp_path / "notes.txt").write_text("not a record")
    names = {
        "flight": flight,
        "turntable": turntable,
        "missing": tmp_path / "nope.h5",
        "missing_levers": tmp_path / "nope.json",
        "not_hdf5": tmp_path / "notes.txt",
    }
    if "{levers}" in chain:
        names["levers"] = tmp_path / "levers.json"
        write_levers(names["levers"], levers_from_preset("high-precision"))
    if "{no_truth}" in chain:
        names["no_truth"] = _without_truth(flight, tmp_path / "no-truth.h5")
    out = tmp_path / "out"
    given = [a.format(**names) for a in chain]
    result = _run(*given[1:]) if given[0] == "--no-out" else _run("--out", out, *given)
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.output, result.output
    assert needle in lines[0], lines[0]
    assert not out.exists()


def _without_truth(flight, path):
    """A copy of ``flight`` without /reference/position (compare would have no truth)."""
    shutil.copyfile(flight, path)
    with h5py.File(path, "a") as f:
        del f["reference/position"]
    return path


def test_without_out_the_chain_writes_into_a_folder_named_after_its_file(records, tmp_path, monkeypatch):
    """The everyday form, without --out: the outputs go to run-NAME in the current folder, and the
    chain ends with one summary, a line per step with its figures."""
    turntable, _ = records
    monkeypatch.chdir(tmp_path)
    result = _run("calibrate", turntable)
    assert result.exit_code == 0, result.output
    assert (tmp_path / "run-turntable" / "levers.json").exists()
    head, summary = result.output.split("run: calibrate; every output and run.json in ")[1].split("\n", 1)
    assert head.endswith("run-turntable"), head
    assert summary.strip().startswith("calibrate: ") and "r_x[x]_mm 24." in summary, summary


# --------------------------------------------------------------------------- a chain per flight (sizefx batch run)


@pytest.fixture(scope="module")
def flights(records, tmp_path_factory):
    """A folder of two flights: the fixture's and one with other noise."""
    _, flight = records
    folder = tmp_path_factory.mktemp("flights") / "flights"
    folder.mkdir()
    (folder / "day1.h5").write_bytes(flight.read_bytes())
    simulate(SimulateConfig("flight", str(folder / "day2.h5"), rate_hz=RATE_HZ, seed=3, plan=FLIGHT))
    return folder


@pytest.fixture(scope="module")
def one_flight(records, tmp_path_factory):
    """A folder of one flight, the fixture's: enough for the chains refused before any stage runs
    (``flights`` simulates a second one for the chains that run)."""
    _, flight = records
    folder = tmp_path_factory.mktemp("one-flight") / "flights"
    folder.mkdir()
    (folder / "day1.h5").write_bytes(flight.read_bytes())
    return folder


def _batch_run(*args):
    return CliRunner().invoke(main, ["batch", "run", *map(str, args)])


# long tier: the chain over several flights with workers (8 s); fast twin: test_calibrate_navigate_compare
@pytest.mark.slow
def test_batch_run_calibrates_once_and_chains_every_flight(records, flights, tmp_path):
    """calibrate once into DIR; each flight navigated plain and compensated and compared, in DIR/NAME/,
    the same as a single chain on it; the manifest lists the flights with the lever arms' hash; a
    re-run skips them all, and new lever arms run them all again."""
    turntable, _ = records
    out = tmp_path / "campaign"
    args = [
        "--out",
        out,
        "-q",
        "--workers",
        "2",
        "calibrate",
        turntable,
        "navigate",
        "--output-rate-hz",
        "1",
        flights,
        "compare",
    ]
    result = _batch_run(*args)
    assert result.exit_code == 0, result.output
    doc = json.loads((out / "manifest.json").read_text())
    check_document(doc, "sizefx/batch/1")
    assert doc["stage"] == "run" and doc["options"]["navigate.output_rate_hz"] == 1.0
    levers = out / "levers.json"
    assert [s["stage"] for s in json.loads((out / "run.json").read_text())["steps"]] == ["calibrate"]
    for entry, name in zip(doc["records"], ("day1", "day2")):
        assert entry["status"] == "ok" and entry["name"] == name
        assert entry["paired"]["navigate --levers"]["path"] == str(levers)
        steps = json.loads((out / name / "run.json").read_text())["steps"]
        assert [(s["stage"], s.get("run")) for s in steps] == [
            ("navigate", "plain"),
            ("navigate", "compensated"),
            ("compare", None),
        ]
        assert steps[1]["inputs"] == {"FILE": str(flights.resolve() / f"{name}.h5"), "--levers": str(levers)}
        assert set(entry["outputs"]) == {
            f"folder/{f}"
            for f in (
                "plain.nav.h5",
                "compensated.nav.h5",
                "plain.navigate.json",
                "compensated.navigate.json",
                "comparison.json",
                "run.json",
            )
        }
        assert (
            entry["headline"]["compensated_final_horizontal_error_m"]
            == steps[1]["headline"]["final_horizontal_error_m"]
        )
    # the same numbers as sizefx run on the flight alone
    single = tmp_path / "single"
    assert (
        _run(
            "--out", single, "calibrate", turntable, "navigate", "--output-rate-hz", "1", flights / "day1.h5", "compare"
        ).exit_code
        == 0
    )
    with h5py.File(out / "day1" / "compensated.nav.h5") as a, h5py.File(single / "compensated.nav.h5") as b:
        assert np.array_equal(a["/position"][()], b["/position"][()])
    again = _batch_run(*args)
    assert again.exit_code == 0 and "0 ok, 2 unchanged" in again.output, again.output
    turntable2 = tmp_path / "turntable2.h5"  # another calibration run: other noise, other arms
    simulate(SimulateConfig("turntable", str(turntable2), rate_hz=RATE_HZ, seed=7, plan=TURNTABLE))
    other = _batch_run(*[turntable2 if a == turntable else a for a in args])
    assert other.exit_code == 0 and "2 ok, 0 unchanged" in other.output, other.output


# long tier: a batch chain (2 s); fast twin: tests/test_batch.py::test_one_bad_record_is_refused_alone
@pytest.mark.slow
def test_batch_run_a_flight_without_truth_is_refused_alone(records, flights, tmp_path):
    """A flight without /reference/position cannot be compared: that record is refused, the other done."""
    turntable, _ = records
    folder = tmp_path / "mixed"
    folder.mkdir()
    (folder / "good.h5").write_bytes((flights / "day1.h5").read_bytes())
    (folder / "blind.h5").write_bytes((flights / "day2.h5").read_bytes())
    with h5py.File(folder / "blind.h5", "a") as f:
        del f["reference/position"]
    out = tmp_path / "out"
    result = _batch_run("--out", out, "-q", "calibrate", turntable, "navigate", folder, "compare")
    assert result.exit_code == 1, result.output
    status = {e["name"]: (e["status"], e["reason"]) for e in json.loads((out / "manifest.json").read_text())["records"]}
    assert status["good"] == ("ok", None)
    assert status["blind"][0] == "refused" and "no /reference/position" in status["blind"][1]
    assert not (out / "blind" / "plain.nav.h5").exists()  # refused before navigating


@pytest.mark.parametrize(
    "chain, needle",
    [
        (["calibrate", "{turntable}"], "put navigate FLIGHTS in it"),
        (["navigate", "{flights}", "compare"], "needs two solutions"),
        (["calibrate", "{turntable}", "navigate", "{nothing}", "compare"], "matches no file"),
        (["calibrate", "{turntable}", "navigate", "{flights}", "compare", "--inside"], "inside the input folder"),
    ],
    ids=["no-flights", "one-solution", "glob-matches-nothing", "out-inside"],
)
def test_batch_chains_that_cannot_work_are_one_line(records, one_flight, tmp_path, chain, needle):
    turntable, _ = records
    flights = one_flight
    out = flights / "out" if "--inside" in chain else tmp_path / "out"
    given = [
        a.format(turntable=turntable, flights=flights, nothing=tmp_path / "*.h5") for a in chain if a != "--inside"
    ]
    result = _batch_run("--out", out, *given)
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.output, result.output
    assert needle in lines[0] and lines[0].startswith("sizefx: error: "), lines[0]
    assert not out.exists()


def test_batch_run_with_an_unreachable_scheduler_writes_nothing(records, one_flight, tmp_path, monkeypatch):
    """The scheduler is reached before calibrate runs or the folder is made: one line, exit 2."""
    pytest.importorskip("distributed")
    # nothing listens on port 9: the wait for it is not what is tested (5 s by default)
    monkeypatch.setattr("sizefx.batch.runner.DASK_CONNECT_S", 0.5)
    turntable, _ = records
    out = tmp_path / "out"
    result = _batch_run(
        "--out", out, "--scheduler", "tcp://127.0.0.1:9", "calibrate", turntable, "navigate", one_flight, "compare"
    )
    assert result.exit_code == 2, result.output
    assert len(result.output.strip().splitlines()) == 1 and "cannot reach it" in result.output, result.output
    assert not out.exists()


@pytest.mark.parametrize("n,needle", [(5, "the solution (-o) needs at least 1 row"), (10, "(--plot) needs at least 2")])
def test_a_flight_of_a_handful_of_samples_is_refused_and_leaves_no_folder(tmp_path, n, needle):
    """run --with-plots on a flight too short for a solution or a curve: navigate, the first stage, refuses it in
    one line (it ended in a traceback), and the --out folder the chain made for it is gone again."""
    flight = write_tiny_flight(tmp_path / "tiny.h5", n)
    levers = tmp_path / "levers.json"
    write_levers(levers, levers_from_preset("high-precision"))
    out = tmp_path / "out"
    result = _run("--out", out, "--with-plots", "navigate", "--levers", levers, flight, "compare")
    assert result.exit_code == 2, result.output
    text = result.output.strip()
    assert "\n" not in text and "Traceback" not in text, text
    assert text.startswith(f"sizefx: error: {flight}: /imu/time: {n} samples give ") and needle in text, text
    assert not out.exists()
