"""Regression tests for defects found in review (each one line of the review, each a real failure before)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner
from support import write_raw

from sizefx import scenarios
from sizefx.errors import SourceError
from sizefx.importers import run_import
from sizefx_cli.main import main


def test_short_rate_changes_keep_the_turntable_on_time():
    # peak/accel (0.2 s) shorter than a ramp (0.5 s): each change takes two ramps, which the plan must count
    plan = scenarios.TurntablePlan(peak_rate_dps=2.0, accel_dps2=10.0)
    traj, _ = scenarios.turntable(plan)
    outer = traj.attitude.profiles[0]
    for name, t0, _ in traj.segments:
        if name.startswith("reposition"):
            _, rate, _ = outer.evaluate(np.array([t0 - 1e-6, t0 + 1.0]))
            assert np.abs(rate).max() < 1e-12, name  # the outer axis is at rest when repositioning starts


def test_csv_with_the_wrong_number_of_columns_is_refused(tmp_path):
    p = tmp_path / "log.csv"
    p.write_text("t,gx,gy,gz,ax,ay,az\n" + "".join(f"{k / 100},1,2,3,1,2,9.8\n" for k in range(200)))
    for gyro in (("gx", "gy"), ("gx", "gy", "gz", "ax")):
        with pytest.raises(SourceError, match="give exactly three"):
            run_import("csv", p, tmp_path / "o.h5", time="t", gyro=gyro, accel=("ax", "ay", "az"))


def test_a_rejected_import_leaves_no_output(tmp_path):
    p = tmp_path / "back.csv"
    rows = [f"{k / 100},0,0,0,0,0,-9.8\n" for k in range(200)]
    rows[100] = "0.5,0,0,0,0,0,-9.8\n"  # time goes back
    p.write_text("t,gx,gy,gz,ax,ay,az\n" + "".join(rows))
    out = tmp_path / "o.h5"
    result = CliRunner().invoke(
        main, ["import", "csv", str(p), "-o", str(out), "--time", "t", "--gyro", "gx,gy,gz", "--accel", "ax,ay,az"]
    )
    assert result.exit_code == 2 and "not strictly increasing" in result.output
    assert sorted(x.name for x in tmp_path.iterdir()) == ["back.csv"]


@pytest.mark.parametrize(
    "args,words",
    [
        (["simulate", "turntable", "--reference-rate-hz", "7"], "must divide the IMU rate"),
        (["simulate", "sway", "--amplitudes-dps", "10,x"], "not a list of numbers"),
        (["simulate", "turntable", "--static-s", "0"], "--static-s: 0 is outside [1, 86400] s"),
        (["simulate", "turntable", "--accel-dps2", "0"], "--accel-dps2: 0 is outside [0.01, 100000] deg/s^2"),
        (["simulate", "turntable", "--accel-dps2", "nan"], "nan is not a finite number"),
    ],
)
def test_bad_simulate_options_are_one_line(tmp_path, args, words):
    result = CliRunner().invoke(main, args + ["-o", str(tmp_path / "x.h5")])
    assert result.exit_code == 2 and words in result.output and "Traceback" not in result.output


@pytest.mark.parametrize(
    "change,words",
    [
        ({"accel_delay_s": "5e-4"}, "accel_delay_s"),
        ({"axes": [[1, 0, 0], [0, 1]]}, "axes must be"),
        ({"tilt_arcsec": [1.0]}, "tilt_arcsec"),
    ],
)
def test_levers_file_extras_are_checked(tmp_path, change, words):
    from sizefx.levers import levers_from_preset, write_levers

    p = tmp_path / "lev.json"
    write_levers(p, levers_from_preset("high-precision"))
    doc = json.loads(p.read_text()) | change
    p.write_text(json.dumps(doc))
    raw = write_raw(tmp_path / "rec.h5")
    for args in (
        ["navigate", str(raw), "--levers", str(p), "--align-s", "5"],
        ["compensate", str(raw), "--levers", str(p), "-o", str(tmp_path / "c.h5")],
    ):
        result = CliRunner().invoke(main, args)
        assert result.exit_code == 2 and words in result.output, (args, result.output)


def test_short_and_siteless_records_are_one_line(tmp_path):
    short = write_raw(tmp_path / "short.h5", n=30)
    from sizefx.levers import levers_from_preset, write_levers

    lev = tmp_path / "lev.json"
    write_levers(lev, levers_from_preset("high-precision"))
    for args in (
        ["compensate", str(short), "--levers", str(lev), "-o", str(tmp_path / "c.h5")],
        ["calibrate", str(short)],
    ):
        result = CliRunner().invoke(main, args)
        assert result.exit_code == 2 and "samples" in result.output, result.output

    def drop_site(h5):
        for k in ("latitude_deg", "longitude_deg", "height_m"):
            del h5.attrs[k]

    siteless = write_raw(tmp_path / "nosite.h5", mutate=drop_site)
    result = CliRunner().invoke(main, ["calibrate", str(siteless)])
    assert result.exit_code == 2 and "no site" in result.output


def test_plot_into_a_missing_folder_fails_before_the_work(tmp_path):
    raw = write_raw(tmp_path / "rec.h5")
    result = CliRunner().invoke(
        main, ["navigate", str(raw), "--align-s", "5", "--plot", str(tmp_path / "no" / "f.png")]
    )
    assert result.exit_code == 2 and "does not exist" in result.output


def test_navigate_syncs_separately_stamped_accelerometers():
    from dataclasses import replace

    from sizefx.navigate import NavConfig, navigate
    from sizefx.simulate import simulate_in_memory
    from sizefx.sync import resample_onto

    # roll sway: gravity sweeps through the y and z accelerometers, so their timing matters
    sway = scenarios.sway(scenarios.SwayPlan(axis="roll", amplitudes_dps=(30.0,), static_s=5.0, segment_s=30.0))[0]
    tel = simulate_in_memory(sway, form="rates")
    tau = 2e-3
    # the accelerometers sampled 2 ms after the gyros, and stamped so
    late = replace(
        tel, accel_mps2=resample_onto(tel.accel_mps2, tel.time_s, tel.time_s + tau), accel_time_s=tel.time_s + tau
    )
    ignored = replace(late, accel_time_s=None)  # what navigating without the stamps would use
    err = {
        name: navigate(t, NavConfig()).summary["max_horizontal_error_m"]
        for name, t in (("ok", tel), ("synced", late), ("ignored", ignored))
    }
    assert err["ignored"] > 10 * err["synced"], err


def test_diagnose_from_a_model_that_holds_everything_reports_in_a_band(tmp_path):
    """A banded fit from a model that already holds what the record shows estimates nothing; the
    report's band line had taken the largest of no parameters (a traceback after the JSON)."""
    rec, runner = str(tmp_path / "t.h5"), CliRunner()
    args = ["simulate", "tumble", "-o", rec, "--rate-hz", "200", "--duration-s", "20", "--seed", "1"]
    assert runner.invoke(main, [*args, "--set", "accel_delay.enabled=true"]).exit_code == 0
    first = runner.invoke(main, ["diagnose", rec, "--bandwidth-hz", "20", "--no-navigation"])
    assert first.exit_code == 0, first.output
    again = runner.invoke(
        main,
        ["diagnose", rec, "--model", str(tmp_path / "t.model.toml"), "--bandwidth-hz", "20", "--no-navigation"]
        + ["--model-out", str(tmp_path / "b.model.toml")],
    )
    assert again.exit_code == 0, again.output
    assert "standard errors include the band's and the selection's part" in again.output


def test_a_record_without_translation_is_not_cut_by_its_accelerometers_noise(tmp_path):
    """The parts by translation were sorted by the accelerometers' own |f| - g: on a yaw-only tumble
    that sorts by their noise, and each part's z bias disagreed (chi2/dof about 28, a false warning
    that 'an effect the model lacks may follow the motion'). They follow the reference's motion now."""
    rec, out, runner = str(tmp_path / "yaw.h5"), str(tmp_path / "yaw.json"), CliRunner()
    args = ["simulate", "tumble", "-o", rec, "--rate-hz", "400", "--duration-s", "60", "--seed", "1", "--gimbals", "z"]
    assert runner.invoke(main, [*args, "--set", "accel_bias.enabled=true"]).exit_code == 0
    result = runner.invoke(main, ["diagnose", rec, "--json", out, "--no-navigation"])
    assert result.exit_code == 0, result.output
    by_motion = [
        w
        for w in json.loads(open(out).read())["warnings"]
        if w["kind"] == "inconsistent_blocks" and "by time" not in w["message"]
    ]
    assert not by_motion, by_motion
