"""Units against physics: sizefx.sanity, on import and in inspect.

Every simulated scenario passes with the figures physics predicts, and each unit mix-up is refused,
with and without a reference, for rates and increments, with exit code 2 and one line that names
the file, the dataset or columns, and the unit the data look like. The real recordings pass through
their importers in tests/test_importers.py (whose fixture imports them with the check on).
"""

from __future__ import annotations

import math
from dataclasses import replace

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from sizefx import sanity, scenarios
from sizefx.constants import STANDARD_GRAVITY_MPS2
from sizefx.errors import UnitsError
from sizefx.io.telemetry import read_telemetry
from sizefx.simulate import SimulateConfig
from sizefx.simulate import run as simulate
from sizefx_cli.main import main

DEG_PER_RAD = 180.0 / math.pi
#: Ratios of a simulated record (ideal-scale sensors, navigation-grade noise) to physics: the checks
#: integrate over intervals and medians, so they agree to well under a per cent.
SIM_RATIO_TOL = 0.005


@pytest.fixture(scope="module")
def sims(tmp_path_factory):
    """Each scenario, short and at a low rate (a few seconds of simulation in all)."""
    folder = tmp_path_factory.mktemp("sanity")
    plans = {
        "turntable": scenarios.TurntablePlan(axes="YZ", static_s=5.0, seconds_per_axis=24.0, cycles=1, settle_s=5.0),
        "sway": scenarios.SwayPlan(static_s=10.0, segment_s=10.0),
        "flight": scenarios.FlightPlan(duration_s=1100.0, align_s=60.0),
        "tumble": scenarios.TumblePlan(duration_s=30.0),
    }
    out = {}
    for name, plan in plans.items():
        out[name] = folder / f"{name}.h5"
        simulate(SimulateConfig(name, out[name], plan=plan, rate_hz=100.0, seed=3))
    out["tumble-increments"] = folder / "tumble-increments.h5"
    simulate(
        SimulateConfig(
            "tumble", out["tumble-increments"], plan=plans["tumble"], rate_hz=100.0, seed=3, form="increments"
        )
    )
    return out


@pytest.mark.parametrize("name", ["turntable", "sway", "flight", "tumble", "tumble-increments"])
def test_every_simulated_scenario_passes_with_the_figures_physics_predicts(sims, name):
    report = sanity.check_units(read_telemetry(sims[name]))
    assert report.accel.verdict == "ok" and report.accel.method == "rest"
    assert report.accel.ratio == pytest.approx(1.0, abs=SIM_RATIO_TOL)  # against normal gravity at the site
    assert report.gyro.verdict == "ok" and report.gyro.method == "reference", report.gyro.detail
    assert report.gyro.ratio == pytest.approx(1.0, abs=SIM_RATIO_TOL)
    assert report.gyro.count >= sanity.REF_MIN_INTERVALS


def _mislabel(tel, *, gyro=1.0, accel=1.0, reference=True):
    """The record as a file would hold it if its numbers were ``gyro`` / ``accel`` times the SI ones."""
    g, a = tel.imu_arrays()
    fields = ("gyro_rad_s", "accel_mps2") if tel.form == "rates" else ("dtheta_rad", "dvel_mps")
    return replace(tel, reference=tel.reference if reference else None, **dict(zip(fields, (g * gyro, a * accel))))


@pytest.mark.parametrize("form", ["rates", "increments"])
@pytest.mark.parametrize("reference", [True, False], ids=["reference", "tilt"])
@pytest.mark.parametrize(
    "factor,looks", [(DEG_PER_RAD, "deg"), (1 / DEG_PER_RAD, "rad")], ids=["deg-as-rad", "rad-as-deg"]
)
def test_gyro_mixups_are_found_with_a_reference_and_from_the_tilt(sims, form, reference, factor, looks):
    tel = read_telemetry(sims["tumble" if form == "rates" else "tumble-increments"])
    per = "/s" if form == "rates" else ""
    # numbers in `looks` units read as the other unit: the SI values are `factor` times the truth
    declared = {True: "rad", False: "deg"}[looks == "deg"] + per
    name = "/imu/gyro" if form == "rates" else "/imu/dtheta"
    report = sanity.check_units(_mislabel(tel, gyro=factor, reference=reference), declared={name: declared})
    gyro = report.gyro
    assert gyro.verdict == "wrong" and gyro.looks_like == looks + per, gyro.detail
    assert gyro.method == ("reference" if reference else "tilt")
    assert gyro.ratio == pytest.approx(factor, rel=0.05)
    assert report.accel.verdict == "ok"


@pytest.mark.parametrize(
    "form,declared,factor,looks",
    [
        ("rates", "m/s^2", 1 / STANDARD_GRAVITY_MPS2, "g"),
        ("rates", "g", STANDARD_GRAVITY_MPS2, "m/s^2"),
        ("increments", "m/s", 1 / STANDARD_GRAVITY_MPS2, "g*s"),
    ],
)
def test_accelerometer_mixups_are_found_at_rest(sims, form, declared, factor, looks):
    tel = read_telemetry(sims["turntable"])
    if form == "increments":
        tel = replace(
            tel,
            form="increments",
            dtheta_rad=tel.gyro_rad_s / 100.0,
            dvel_mps=tel.accel_mps2 / 100.0,
            gyro_rad_s=None,
            accel_mps2=None,
        )
    name = "/imu/accel" if form == "rates" else "/imu/dvel"
    report = sanity.check_units(_mislabel(tel, accel=factor), declared={name: declared})
    assert report.accel.verdict == "wrong" and report.accel.looks_like == looks
    assert report.accel.method == "rest" and report.accel.ratio == pytest.approx(factor, rel=0.01)


def test_nothing_is_refused_when_nothing_can_be_decided(sims):
    """A record that neither rotates against a reference nor tilts: the gyro check says why it was not made."""
    tel = read_telemetry(sims["flight"])
    static = tel.time_s < 50.0  # the alignment on the ground
    tel = replace(
        tel,
        time_s=tel.time_s[static],
        gyro_rad_s=tel.gyro_rad_s[static] * DEG_PER_RAD,
        accel_mps2=tel.accel_mps2[static],
        reference=None,
    )
    report = sanity.check_units(tel)
    assert report.gyro.verdict == "unchecked" and not report.wrong
    assert "no reference" in report.gyro.detail and "no tilt" in report.gyro.detail


# --------------------------------------------------------------------------- the commands


def _csv(path, tel, *, gyro=1.0, accel=1.0):
    """A CSV of the record's IMU columns, the numbers scaled as a mislabelled logger would write them."""
    g, a = tel.imu_arrays()
    table = np.column_stack([tel.time_s, g * gyro, a * accel])
    np.savetxt(path, table, delimiter=",", header="t,gx,gy,gz,ax,ay,az", comments="", fmt="%.10g")
    return path


def _import(src, out, *extra):
    return CliRunner().invoke(
        main,
        ["import", "csv", str(src), "-o", str(out), "--time", "t", "--gyro", "gx,gy,gz", "--accel", "ax,ay,az", *extra],
    )


@pytest.mark.parametrize(
    "form,case",
    [
        (form, case)
        for form in ("rates", "increments")
        for case in ("gyro deg/s as rad/s", "gyro rad/s as deg/s", "accel g as m/s^2", "accel m/s^2 as g")
        if (form, case) != ("increments", "accel m/s^2 as g")
    ],
)  # velocity has one unit (m/s): no g to mislabel
def test_import_refuses_each_mixup_in_one_line(sims, tmp_path, form, case):
    tel = read_telemetry(sims["tumble" if form == "rates" else "tumble-increments"])
    per = "/s" if form == "rates" else ""
    cases = {  # scale of the numbers, options, the columns named, the unit they look like
        "gyro deg/s as rad/s": ({"gyro": DEG_PER_RAD}, [], "gyro columns gx, gy, gz", f"deg{per}, not rad{per}"),
        "gyro rad/s as deg/s": (
            {},
            ["--gyro-units", f"deg{per}"],
            "gyro columns gx, gy, gz",
            f"rad{per}, not deg{per}",
        ),
        "accel g as m/s^2": (
            {"accel": 1 / STANDARD_GRAVITY_MPS2},
            [],
            "accel columns ax, ay, az",
            "g, not m/s^2" if form == "rates" else "g*s, not m/s",
        ),
        "accel m/s^2 as g": ({}, ["--accel-units", "g"], "accel columns ax, ay, az", "m/s^2, not g"),
    }
    scale, options, columns, words = cases[case]
    src = _csv(tmp_path / "log.csv", tel, **scale)
    out = tmp_path / "out.h5"
    base = [] if form == "rates" else ["--gyro-units", "rad", "--accel-units", "m/s"]
    result = _import(src, out, "--form", form, *base, *options)  # the last --gyro-units given counts
    assert result.exit_code == 2, result.output
    line = result.output.strip()
    assert "\n" not in line and line.startswith(f"sizefx: error: {src}: {columns}: "), line
    assert f"the data look like {words}" in line, line
    if words.startswith("g*s"):  # not a unit of the contract: the fix is arithmetic
        assert "multiply the columns by 9.80665 to make them m/s" in line, line
    assert "--no-units-check" in line
    assert not out.exists()  # refused before the output appears


def test_import_tells_which_option_fixes_it_and_no_units_check_lets_it_through(sims, tmp_path):
    tel = read_telemetry(sims["tumble"])
    src = _csv(tmp_path / "log.csv", tel, gyro=DEG_PER_RAD)
    result = _import(src, tmp_path / "a.h5")
    assert "import with --gyro-units deg/s" in result.output and result.exit_code == 2
    fixed = _import(src, tmp_path / "b.h5", "--gyro-units", "deg/s")
    assert fixed.exit_code == 0, fixed.output
    assert "gyro against the tilt the accelerometers see: ratio 1.0" in fixed.output  # CSV: no reference
    forced = _import(src, tmp_path / "c.h5", "--no-units-check")
    assert forced.exit_code == 0 and "units: not checked (--no-units-check)" in forced.output


def test_inspect_refuses_mislabelled_data_against_the_reference_and_reports_what_it_checked(sims, tmp_path):
    good = CliRunner().invoke(main, ["inspect", str(sims["turntable"])])
    assert good.exit_code == 0, good.output
    assert "checked   specific force at rest" in good.output and "ratio 1.000" in good.output
    assert "gyro against the reference attitude: ratio 1.000 over" in good.output
    bad = tmp_path / "bad.h5"
    bad.write_bytes(sims["turntable"].read_bytes())
    with h5py.File(bad, "r+") as h5:  # deg/s numbers under a rad/s label (slow table: the broad range passes)
        h5["imu/gyro"][...] = h5["imu/gyro"][...] * DEG_PER_RAD
    result = CliRunner().invoke(main, ["inspect", str(bad)])
    assert result.exit_code == 2
    line = result.output.strip()
    assert "\n" not in line and line.startswith(f"sizefx: error: {bad}: /imu/gyro: integrates to 57.2"), line
    assert "the data look like deg/s, not rad/s: set its units attribute to 'deg/s'" in line
    skipped = CliRunner().invoke(main, ["inspect", str(bad), "--no-units-check"])
    assert skipped.exit_code == 0 and "units not checked (--no-units-check)" in skipped.output


def test_a_units_error_names_file_dataset_and_unit():
    err = UnitsError("f.h5", "/imu/gyro", "x; the data look like deg/s")
    assert str(err) == "f.h5: /imu/gyro: x; the data look like deg/s" and err.exit_code == 2


def test_looks_like_reads_the_units_from_the_contract():
    assert sanity.looks_like("angular_rate", "rad/s", DEG_PER_RAD, sanity.GYRO_BAND) == "deg/s"
    assert sanity.looks_like("angular_rate", "deg/s", 1 / DEG_PER_RAD, sanity.GYRO_BAND) == "rad/s"
    assert sanity.looks_like("acceleration", "m/s^2", 1 / STANDARD_GRAVITY_MPS2, sanity.ACCEL_BAND) == "g"
    assert sanity.looks_like("velocity", "m/s", 1 / STANDARD_GRAVITY_MPS2, sanity.ACCEL_BAND) == "g*s"
    assert sanity.looks_like("angular_rate", "rad/s", 3.0, sanity.GYRO_BAND) is None  # no unit fits


# --------------------------------------------------------------------------- what a streamed writer keeps


def _turning_between(t_a, t_b):
    """A reference attitude [N, 4] at times [N] that turns about the vertical (1 rad/s) only in [t_a, t_b]."""

    def quat(t):
        angle = np.clip(np.asarray(t, dtype=float), t_a, t_b) - t_a
        return np.column_stack([np.cos(angle / 2), np.zeros_like(angle), np.zeros_like(angle), np.sin(angle / 2)])

    return quat


def test_a_short_record_is_judged_whole():
    assert sanity.sample_blocks(sanity.SAMPLE_ROWS, 1600.0) == [(0, sanity.SAMPLE_ROWS)]


@pytest.mark.parametrize("rate_hz", [1.0, 100.0, 1600.0, 1e5])
def test_a_long_record_is_judged_on_bounded_blocks_many_where_the_reference_turns(rate_hz):
    n = 50 * sanity.SAMPLE_ROWS + 7
    turn_rows = (int(0.61 * n), int(0.62 * n))  # 1 % of the record
    in_turn = {}
    for reference in (None, _turning_between(turn_rows[0] / rate_hz, turn_rows[1] / rate_hz)):
        rows = np.array(sanity.sample_blocks(n, rate_hz, reference))
        assert rows[0, 0] == 0  # the start (an alignment rests there)
        assert rows[-1, 1] == n or reference is not None  # and the end, given two evenly spread blocks
        assert np.all(rows[:, 1] > rows[:, 0]) and np.all(rows[1:, 0] > rows[:-1, 1])  # in order, apart
        assert (rows[:, 1] - rows[:, 0]).sum() <= sanity.SAMPLE_ROWS
        # each block holds a rest run: REST_MIN_WINDOWS windows of WINDOW_S (or of MIN_WINDOW_SAMPLES)
        run_rows = sanity.REST_MIN_WINDOWS * max(sanity.MIN_WINDOW_SAMPLES, round(sanity.WINDOW_S * rate_hz))
        assert np.all(rows[:, 1] - rows[:, 0] >= run_rows)
        overlap = np.minimum(rows[:, 1], turn_rows[1]) - np.maximum(rows[:, 0], turn_rows[0])
        in_turn[reference is None] = int(np.clip(overlap, 0, None).sum())
    assert in_turn[False] > 0 and in_turn[False] >= 5 * in_turn[True], in_turn
