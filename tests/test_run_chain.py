"""``sizefx run --out DIR calibrate T.h5 navigate F.h5 compare`` (issue 18, item 7).

- The chain passes calibrate's lever arms to navigate, which navigates plain and compensated, and
  compare sets the two against the flight's reference; every output and run.json in DIR.
- A stage option keeps its meaning in the chain (given before the stage's file: click's rule for
  chained commands).
- A chain that cannot work is refused before any stage runs: one line, exit code 2, nothing written.
"""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from sizefx.io.schema import check_document
from sizefx.scenarios import FlightPlan, TurntablePlan
from sizefx.simulate import SimulateConfig
from sizefx.simulate import run as simulate
from sizefx_cli.main import main


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    """A short turntable record and the shortest flight the plan allows (27 min), both at 400 Hz."""
    folder = tmp_path_factory.mktemp("chain")
    turntable, flight = folder / "turntable.h5", folder / "flight.h5"
    simulate(SimulateConfig("turntable", str(turntable), rate_hz=400.0, seed=1,
                            plan=TurntablePlan(static_s=10.0, seconds_per_axis=20.0, cycles=1)))
    simulate(SimulateConfig("flight", str(flight), rate_hz=400.0, seed=2,
                            plan=FlightPlan(duration_s=1620.0, align_s=162.0)))
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
        ("calibrate", None), ("navigate", "plain"), ("navigate", "compensated"), ("compare", None)]
    levers = str(out / "levers.json")
    assert doc["steps"][1]["inputs"] == {"FILE": str(flight)}
    assert doc["steps"][2]["inputs"] == {"FILE": str(flight), "--levers": levers}
    assert doc["steps"][3]["inputs"] == {"A": str(out / "compensated.nav.h5"), "B": str(out / "plain.nav.h5"),
                                         "--reference": str(flight)}
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


@pytest.mark.parametrize("chain, needle", [
    (["compare"], "nothing to compare"),
    (["navigate", "{flight}", "compare"], "needs two solutions"),
    (["navigate", "{flight}", "calibrate", "{turntable}"], "out of order"),
    (["calibrate", "{turntable}", "navigate", "--levers", "{turntable}", "{flight}"], "leave out one"),
    (["calibrate", "{turntable}", "navigate", "{missing}", "compare"], "no such file"),
    (["calibrate", "{turntable}", "navigate", "{flight}", "navigate", "{flight}"], "each stage once"),
    (["--no-out", "navigate", "{flight}"], "give --out"),
], ids=["compare-alone", "one-solution", "order", "levers-twice", "missing-flight", "repeated", "no-out"])
def test_chains_that_cannot_work_are_refused_before_any_stage(records, tmp_path, chain, needle):
    turntable, flight = records
    names = {"flight": flight, "turntable": turntable, "missing": tmp_path / "nope.h5"}
    out = tmp_path / "out"
    given = [a.format(**names) for a in chain]
    result = _run(*given[1:]) if given[0] == "--no-out" else _run("--out", out, *given)
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.output, result.output
    assert needle in lines[0], lines[0]
    assert not out.exists()
