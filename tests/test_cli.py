"""The command line: help with units, simulate -> inspect, and bad input as one line with exit code 2."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest
from click.testing import CliRunner
from support import write_raw
from test_telemetry import BAD_CASES

from sizefx_cli.main import main


@pytest.fixture
def runner():
    return CliRunner()


def test_help_explains_every_command_with_units(runner):
    top = runner.invoke(main, ["--help"])
    assert top.exit_code == 0
    for cmd in ("demo", "diagnose", "inspect", "paper", "simulate"):
        assert cmd in top.output
    for args, units in (
        (["simulate", "turntable", "--help"], ["[deg/s]", "[deg/s^2]", "[s]", "[Hz]", "[mm]"]),
        (["simulate", "sway", "--help"], ["[deg/s]", "[Hz]", "[s]"]),
        (["simulate", "flight", "--help"], ["[h]", "[m/s]", "[m]", "[Hz]", "[deg]"]),
        (["inspect", "--help"], ["[Hz]", "[s]"]),
    ):
        result = runner.invoke(main, args)
        assert result.exit_code == 0, result.output
        text = " ".join(result.output.split())
        for u in units:
            assert u in text, (args, u)


def test_simulate_then_inspect(runner, tmp_path):
    out = tmp_path / "sway.h5"
    result = runner.invoke(
        main,
        [
            "simulate",
            "sway",
            "-o",
            str(out),
            "--static-s",
            "2",
            "--segment-s",
            "3",
            "--amplitudes-dps",
            "10,20",
            "--rate-hz",
            "400",
            "--form",
            "increments",
            "--ideal",
            "--set",
            "accel_delay.enabled=true",
            "--offset-mm",
            "10,0,0",
        ],
    )
    assert result.exit_code == 0, result.output
    assert "wrote" in result.output
    result = runner.invoke(main, ["inspect", str(out), "--json", "-"])
    assert result.exit_code == 0, result.output
    summary = json.loads(result.output)
    assert summary["form"] == "increments" and summary["samples"] == 3200
    effects = " ".join(summary["simulation"]["effects"])
    assert "accel_delay: 500.0 us" in effects and "(34.90, 0.00, 0.00)" in effects
    # the same output again is refused without --force, accepted with it
    again = runner.invoke(main, ["simulate", "sway", "-o", str(out), "--static-s", "2", "--segment-s", "3"])
    assert again.exit_code == 2 and "--force" in again.output


def test_print_effects_is_a_complete_template(runner):
    result = runner.invoke(main, ["simulate", "--print-effects"])
    assert result.exit_code == 0
    assert "[lever_arm]" in result.output and "[accel_delay]" in result.output


def test_bad_option_values_exit_2_with_one_line(runner, tmp_path):
    out = str(tmp_path / "x.h5")
    for args in (
        ["simulate", "turntable", "-o", out, "--set", "nonsense"],
        ["simulate", "turntable", "-o", out, "--set", 'lever_arm.preset="huge"'],
        ["simulate", "turntable", "-o", out, "--cycles", "50"],
        ["simulate", "sway", "-o", out, "--segment-s", "2.5", "--frequency-hz", "1"],
    ):
        result = runner.invoke(main, args)
        assert result.exit_code == 2, (args, result.output)
        assert "Traceback" not in result.output
        assert not (tmp_path / "x.h5").exists()


@pytest.mark.parametrize("case", list(BAD_CASES))
def test_inspect_bad_file_exits_2_with_one_line(runner, tmp_path, case):
    factory, dataset, words = BAD_CASES[case]
    path = write_raw(tmp_path / "bad.h5", mutate=factory(tmp_path))
    result = runner.invoke(main, ["inspect", str(path)])
    assert result.exit_code == 2
    lines = result.output.strip().splitlines()
    assert len(lines) == 1, result.output
    assert lines[0].startswith(f"sizefx: error: {path}: {dataset}: ") and words in lines[0]


def test_installed_console_script_exits_2_without_traceback(tmp_path):
    bad = tmp_path / "notes.h5"
    bad.write_text("not hdf5")
    exe = os.path.join(os.path.dirname(sys.executable), "sizefx")
    proc = subprocess.run([exe, "inspect", str(bad)], capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stdout == ""
    assert (
        proc.stderr.strip()
        == f"sizefx: error: {bad}: /: is not an HDF5 file (no HDF5 signature); convert it with sizefx import"
    )


def test_inspect_valid_file(runner, raw_file):
    result = runner.invoke(main, ["inspect", str(raw_file)])
    assert result.exit_code == 0
    assert "valid sizefx/telemetry/1" in result.output and "100 Hz" in result.output


# long tier: the demo end to end (6 s); CI's install command runs the real one; fast twin: tests/test_paper.py's experiments
@pytest.mark.slow
def test_demo_smoke(tmp_path):
    """The README's first command, every step at the smallest size: the three experiments, the
    table, the diagnosis, the plots. CI runs the real demo (reduced size) from a fresh clone and
    checks the same lines (.ci/run)."""
    from sizefx.experiments.demo import run_demo

    out = tmp_path / "demo"
    text = "\n".join(run_demo(out, size="smoke"))
    assert "the paper's experiments in simulation (smoke size)" in text
    for figure in ("turntable, 1 repeats", "heading sway", "flight 0.45 h"):
        assert figure in text, figure
    assert "accelerometer y sits" in text and "lag the gyros by" in text  # diagnose found both hidden effects
    for png in (
        "fig6_turntable_compensation.png",
        "fig8_sway_velocity.png",
        "fig9_sway_position.png",
        "flight_horizontal_error.png",
        "flight_ground_speed_error.png",
        "diagnosis/residuals.png",
        "diagnosis/spectra.png",
    ):
        assert (out / png).stat().st_size > 10_000, png
    assert f"plots in {out}/" in text
    # the table's paper column holds the paper's figures (sizefx.experiments.paper.PAPER, checked
    # against the paper's own tables in tests/test_paper.py)
    from sizefx.experiments.paper import PAPER

    tt, fl = PAPER["turntable"], PAPER["flight"]
    for label, figure in (
        ("|signed mean| [mm]", tt["diff_mean_mm"]),
        ("  max [mm]", tt["diff_max_mm"]),
        ("spread over repeats, mean [mm]", tt["sigma_mean_mm"]),
        ("spread over repeats, max [mm]", tt["sigma_max_mm"]),
        ("compensated vs uncompensated [km]", PAPER["sway"]["divergence_km"]),
        ("final error removed [km]", fl["gain_km"]),
        ("as a drift rate [nmi/h]", fl["gain_nmi_per_h"]),
    ):
        row = next(line for line in text.splitlines() if label in line)
        assert float(row.split(label, 1)[1].split()[0]) == figure, (label, row)


#: What ``sizefx --help`` and every ``sizefx CMD --help`` must not import (each costs
#: 0.1-0.5 s of start-up; a command imports what it needs when it runs).
HEAVY_MODULES = ("numpy", "numba", "scipy", "h5py", "matplotlib", "pyulog")

_HELP_PROBE = """
import sys
import click
from click.testing import CliRunner
from sizefx_cli.main import main

def walk(cmd, path):
    yield path
    if isinstance(cmd, click.Group):
        for name, sub in cmd.commands.items():
            yield from walk(sub, path + [name])

runner = CliRunner()
paths = list(walk(main, []))
for path in paths:
    result = runner.invoke(main, path + ["--help"])
    assert result.exit_code == 0, (path, result.output)
print(len(paths), ",".join(m for m in {heavy!r} if m in sys.modules))
"""


def test_help_of_every_command_imports_nothing_heavy():
    """Start-up is kept fast by construction, not measured here (benchmarks/bench_startup.py times it)."""
    proc = subprocess.run(
        [sys.executable, "-c", _HELP_PROBE.format(heavy=HEAVY_MODULES)], capture_output=True, text=True, timeout=60
    )
    assert proc.returncode == 0, proc.stderr
    count, heavy = proc.stdout.split()[0], proc.stdout.split()[1:]
    assert int(count) >= 18, proc.stdout  # the group, 10 commands, 4 scenarios, 5 importers
    assert heavy == [], f"--help imports {heavy}; import them inside the command function"


# --------------------------------------------------------------------------- stages and progress


def test_inspect_is_a_stage_whose_report_the_command_prints(runner, raw_file, tmp_path):
    from sizefx.errors import ConfigError
    from sizefx.inspect import InspectConfig, run

    res = run(InspectConfig(raw_file))
    text = runner.invoke(main, ["inspect", str(raw_file)])
    assert text.exit_code == 0 and text.output == res.report() + "\n"
    assert res.report().startswith(f"{raw_file}: valid sizefx/telemetry/1\n  IMU       1000 samples of rates, 100 Hz")
    as_json = runner.invoke(main, ["inspect", str(raw_file), "--json", "-"])
    assert json.loads(as_json.output) == json.loads(json.dumps(res.to_json()))
    assert res.to_json()["units_check"]["accel"]["verdict"] == "ok"
    # --json FILE: the same summary in a file, the text on stdout; an existing file only with --force,
    # and never the record itself
    summary = tmp_path / "summary.json"
    written = runner.invoke(main, ["inspect", str(raw_file), "--json", str(summary)])
    assert written.exit_code == 0 and written.output == res.report() + f"\nsummary -> {summary}\n"
    assert json.loads(summary.read_text()) == json.loads(as_json.output)
    again = runner.invoke(main, ["inspect", str(raw_file), "--json", str(summary)])
    assert again.exit_code == 2 and "--force" in again.output
    assert runner.invoke(main, ["inspect", str(raw_file), "--json", str(summary), "--force"]).exit_code == 0
    itself = runner.invoke(main, ["inspect", str(raw_file), "--json", str(raw_file), "--force"])
    assert itself.exit_code == 2 and "input" in itself.output
    with pytest.raises(ConfigError, match="FILE: no such file"):  # the shared pre-flight
        run(InspectConfig(tmp_path / "none.h5"))


class _Terminal:
    """A stand-in for stderr on a terminal, keeping what is written."""

    def __init__(self):
        self.text = ""

    def isatty(self):
        return True

    def write(self, text):
        self.text += text

    def flush(self):
        pass


def test_progress_is_a_bar_on_a_terminal_and_silent_when_quiet_or_piped(monkeypatch):
    from sizefx_cli.options import Progress

    term = _Terminal()
    monkeypatch.setattr(sys, "stderr", term)
    bar = Progress("navigate", quiet=False)
    for done in (0, 2500, 5000, 10000):
        bar(done, 10000)
    assert "navigate" in term.text and "100%" in term.text and "10.0k/10.0k" in term.text, term.text
    assert term.text.endswith("\n")  # closed at the end, on its own line
    term.text = ""
    quiet = Progress("navigate", quiet=True)
    quiet(10, 10)
    assert term.text == ""
    monkeypatch.setattr(term, "isatty", lambda: False)  # piped or redirected
    piped = Progress("navigate", quiet=False)
    piped(10, 10)
    assert term.text == ""
