"""The Python API: every stage as ``sizefx.STAGE.run(Config) -> Result``, a batch as
``sizefx.batch.run`` and a chain as ``sizefx.chain.run``, each the very call its command makes.

- Every stage module exports its config, its result and ``run``, whose first parameter is the config.
- A batch from Python writes what ``sizefx batch`` writes for the same inputs and options: the same
  manifest (but the times) and the same outputs; run again, it skips every record without starting a
  worker, and the command line resumes the folder Python wrote.
- A chain from Python writes what ``sizefx run`` writes: the same steps in run.json and the same
  solutions.
- Options by field name, or read from a config, mean what the command's options mean; a name the
  stage does not take, an output the batch names, a bad worker count: one line, nothing written.
"""

from __future__ import annotations

import importlib
import inspect
import json

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

import sizefx.batch
import sizefx.chain
from sizefx.batch import runner
from sizefx.errors import ConfigError
from sizefx.navigate import NavConfig, NavigateConfig
from sizefx.scenarios import FlightPlan, TurntablePlan
from sizefx.simulate import SimulateConfig
from sizefx.simulate import run as simulate
from sizefx_cli.main import main

#: Stage module -> its config and result (docs/api.md's table).
STAGES = {
    "simulate": ("SimulateConfig", "SimulateResult"),
    "importers": ("ImportConfig", "ImportResult"),
    "inspect": ("InspectConfig", "InspectResult"),
    "calibrate": ("CalibrateConfig", "CalibrateResult"),
    "compensate": ("CompensateConfig", "CompensateResult"),
    "navigate": ("NavigateConfig", "NavResult"),
    "diagnose": ("DiagnoseConfig", "DiagnoseResult"),
    "compare": ("CompareConfig", "CompareResult"),
    "exporters": ("ExportConfig", "ExportResult"),
    "plan": ("PlanConfig", "PlanResult"),
}
#: Short records at 200 Hz: what is tested is which call writes what, not the accuracy.
RATE_HZ = 200.0
TURNTABLE = TurntablePlan(static_s=10.0, seconds_per_axis=20.0, cycles=1)
FLIGHT = FlightPlan(duration_s=600.0, align_s=60.0, weave_deg=0.0)
#: What a manifest entry or a run.json step holds that depends on the run, not on the records.
VOLATILE = {"duration_s", "peak_memory_mib", "worker", "phases_s", "wall_s", "kernel_s", "sizefx_version"}


def _volatile(key: str) -> bool:
    """A key of :data:`VOLATILE`, or a run's time in a chain's figures (``plain_wall_s``)."""
    return key in VOLATILE or key.endswith(("_wall_s", "_kernel_s"))


@pytest.mark.parametrize("module", STAGES)
def test_every_stage_is_a_config_a_run_and_a_result(module):
    stage = importlib.import_module(f"sizefx.{module}")
    config, result = STAGES[module]
    assert {config, result, "run"} <= set(stage.__all__)
    parameters = inspect.signature(stage.run).parameters
    first = next(iter(parameters.values()))
    assert first.annotation in (config, getattr(stage, config)), (module, first)
    assert inspect.signature(stage.run).return_annotation in (result, getattr(stage, result))
    assert all(p.kind is p.KEYWORD_ONLY for p in list(parameters.values())[1:])


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    """A turntable record and a folder of two flights."""
    folder = tmp_path_factory.mktemp("api")
    turntable, flights = folder / "turntable.h5", folder / "flights"
    flights.mkdir()
    simulate(SimulateConfig("turntable", str(turntable), rate_hz=RATE_HZ, seed=1, plan=TURNTABLE))
    for seed, name in enumerate(("day1", "day2"), start=2):
        simulate(SimulateConfig("flight", str(flights / f"{name}.h5"), rate_hz=RATE_HZ, seed=seed, plan=FLIGHT))
    return turntable, flights


def _cli(*args):
    result = CliRunner().invoke(main, [*map(str, args)])
    assert result.exit_code == 0, result.output
    return result


def _steady(value, here, there):
    """A manifest's or a run.json's content without what depends on the run (times, the worker; an
    output's size and hash, as the summaries hold times and paths) and with the folder ``here``
    written as ``there``."""
    if isinstance(value, dict):
        if set(value) == {"path", "bytes", "sha256"}:  # an output of a manifest entry
            return _steady(value["path"], here, there)
        return {k: _steady(v, here, there) for k, v in value.items() if not _volatile(k)}
    if isinstance(value, list):
        return [_steady(v, here, there) for v in value]
    if isinstance(value, str):
        return value.replace(str(here), str(there))
    return value


def _arrays(path):
    with h5py.File(path) as f:
        return {name: f[name][()] for name in ("time", "position", "velocity", "attitude") if name in f}


@pytest.fixture(scope="module")
def navigated(records, tmp_path_factory):
    """The flights navigated with a non-default option, by ``sizefx batch navigate`` and by
    ``sizefx.batch.run``: the two folders."""
    _, flights = records
    cli, py = tmp_path_factory.mktemp("cli") / "nav", tmp_path_factory.mktemp("py") / "nav"
    _cli("batch", "navigate", flights, "--out", cli, "--workers", "1", "--output-rate-hz", "1", "-q")
    result = sizefx.batch.run("navigate", flights, py, options={"output_rate_hz": 1.0}, workers=1)
    assert result.all_ok and result.counts()["ok"] == 2
    return cli, py


def test_a_batch_from_python_writes_what_the_command_writes(navigated):
    cli, py = navigated
    a, b = (json.loads((folder / "manifest.json").read_text()) for folder in (cli, py))
    assert a["options"] == b["options"] and a["options"]["output_rate_hz"] == 1.0
    assert _steady(a, cli, py) == _steady(b, py, py)
    for name in ("day1", "day2"):
        x, y = _arrays(cli / f"{name}.nav.h5"), _arrays(py / f"{name}.nav.h5")
        assert x.keys() == y.keys() and x
        for key in x:
            assert np.array_equal(x[key], y[key]), (name, key)


def test_a_batch_from_python_resumes_without_a_worker(records, navigated, monkeypatch):
    """Run again into its folder, the batch skips both records from the stat cache alone; the command
    line resumes the folder Python wrote as its own."""
    _, flights = records
    _, py = navigated

    def refused(*_, **__):
        raise AssertionError("a resumed batch started a worker")

    monkeypatch.setattr(runner, "_pool", refused)
    monkeypatch.setattr(runner, "start_workers", refused)
    again = sizefx.batch.run("navigate", [flights], py, options={"output_rate_hz": 1.0})
    assert again.counts() == {"ok": 0, "refused": 0, "failed": 0, "skipped": 2}
    assert [o.reused for o in again.outcomes] == [True, True]
    result = _cli("batch", "navigate", flights, "--out", py, "--output-rate-hz", "1", "-q")
    assert "0 ok, 2 unchanged" in result.output, result.output


def test_options_read_from_a_config_are_the_options_by_name(records, navigated, monkeypatch):
    """navigate's NavConfig (or the stage's own config as a template, its record and outputs not
    read) gives the batch the same options, so the folder written with them by name is done."""
    _, flights = records
    _, py = navigated
    monkeypatch.setattr(runner, "start_workers", lambda *_, **__: pytest.fail("a worker started"))
    for options in (NavConfig(output_rate_hz=1.0), NavigateConfig("x.h5", options=NavConfig(output_rate_hz=1.0))):
        again = sizefx.batch.run("navigate", flights, py, options=options)
        assert again.counts()["skipped"] == 2, again.report()


@pytest.mark.parametrize(
    "call, needle",
    [
        (dict(stage="navigate", options={"align": 3.0}), "has no option 'align'"),
        (dict(stage="navigate", options={"output": "x.h5"}), "'output' is not an option here"),
        (dict(stage="navigate", options={"align_s": 0.0}), "--align-s: 0 is outside (0, 86400] s"),
        (dict(stage="navigate", workers=0), "--workers: 0"),
        (dict(stage="compare"), "give 'b' (--against)"),
        (dict(stage="simulate"), "no such stage"),
        (dict(stage="run", options={"navigate": {}, "compare": {}}), "compare needs two solutions"),
    ],
)
def test_bad_batch_arguments_are_one_line_and_write_nothing(records, tmp_path, call, needle):
    _, flights = records
    out = tmp_path / "out"
    with pytest.raises(ConfigError) as caught:
        sizefx.batch.run(call.pop("stage"), flights, out, **call)
    assert needle in str(caught.value) and "\n" not in str(caught.value)
    assert not out.exists()


def test_a_chain_from_python_writes_what_sizefx_run_writes(records, tmp_path):
    turntable, flights = records
    flight = flights / "day1.h5"
    cli, py = tmp_path / "cli", tmp_path / "py"
    printed = _cli("run", "--out", cli, "calibrate", turntable, "navigate", "--output-rate-hz", "1", flight, "compare")
    seen = []
    stages = {
        "calibrate": {"records": [turntable]},
        "navigate": {"input": flight, "output_rate_hz": 1.0},
        "compare": {},
    }
    result = sizefx.chain.run(stages, py, echo=lambda title, _: seen.append(title))
    assert seen == ["== calibrate", "== navigate (plain)", "== navigate (compensated)", "== compare"]
    assert result.report().splitlines()[0] == "== calibrate" and "A and B diverge by" in result.report()
    a, b = (json.loads((folder / "run.json").read_text()) for folder in (cli, py))
    assert _steady(a, cli, py) == _steady(b, py, py)
    assert result.to_json()["steps"] == b["steps"]
    for label in ("plain", "compensated"):
        x, y = _arrays(cli / f"{label}.nav.h5"), _arrays(py / f"{label}.nav.h5")
        assert all(np.array_equal(x[k], y[k]) for k in x) and x.keys() == y.keys()
    assert "run: calibrate -> navigate -> compare" in printed.output
    assert [line.split(":")[0].strip() for line in result.summary().splitlines()] == [
        "calibrate",
        "navigate (plain)",
        "navigate (compensated)",
        "compare",
    ]


def test_a_chain_that_cannot_work_is_refused_before_anything_is_written(records, tmp_path):
    turntable, flights = records
    out = tmp_path / "out"
    for stages, needle in (
        ({"navigate": {"input": flights / "day1.h5"}, "compare": {}}, "needs two solutions"),
        ([("navigate", {"input": flights / "day1.h5"}), ("calibrate", {"records": [turntable]})], "out of order"),
        ({"navigate": {"output_rate_hz": 1.0}}, "navigate needs 'input'"),
        ({"navigate": {"input": flights / "day1.h5", "json_path": "x.json"}}, "'json_path' is not an option here"),
    ):
        with pytest.raises(ConfigError, match=needle):
            sizefx.chain.run(stages, out)
        assert not out.exists()


# long tier: two batches of chains, each spawning its worker (3 s); fast twins: the chain and the
# batch above, from Python and from the command line
@pytest.mark.slow
def test_a_batch_of_chains_from_python_writes_what_sizefx_batch_run_writes(records, tmp_path):
    turntable, flights = records
    cli, py = tmp_path / "cli", tmp_path / "py"
    _cli("batch", "run", "--out", cli, "-q", "--workers", "1", "calibrate", turntable, "navigate", flights, "compare")
    stages = {"calibrate": {"records": [turntable]}, "navigate": {}, "compare": {}}
    result = sizefx.batch.run("run", str(flights), py, options=stages, workers=1)
    assert result.all_ok and result.counts()["ok"] == 2
    a, b = (json.loads((folder / "manifest.json").read_text()) for folder in (cli, py))
    assert _steady(a, cli, py) == _steady(b, py, py)
    for name in ("day1", "day2"):
        steps = [json.loads((folder / name / "run.json").read_text()) for folder in (cli, py)]
        assert _steady(steps[0], cli, py) == _steady(steps[1], py, py)
