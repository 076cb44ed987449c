"""Correction with an effect model (sizefx.correct): simulate with errors -> correct -> the ideal point IMU."""

from __future__ import annotations

import json
import tomllib

import numpy as np
import pytest
from click.testing import CliRunner

from sizefx import scenarios
from sizefx.constants import DEG_PER_H, MICRO_G
from sizefx.correct import correct_imu, load_model
from sizefx.effects import IDEAL, load_effects
from sizefx.errors import ConfigError
from sizefx.io.telemetry import read_telemetry
from sizefx.motion import RotationChain, Sinusoids, StaticSite, Trajectory
from sizefx.navigate import NavConfig, navigate
from sizefx.omegadot import SAVGOL_WINDOW
from sizefx.simulate import simulate_in_memory
from sizefx_cli.main import main

RATE_HZ = 1600.0
#: Samples left out at each end: the Savitzky-Golay fit and np.gradient are one-sided there,
#: and the spline that undoes the delay extrapolates over the last tau.
EDGE = SAVGOL_WINDOW

#: Every deterministic effect on at once, noise off, in the file's units (what diagnose writes).
#: Values are tens of times the defaults, so that a wrong sign or order shows far above the floor.
MODEL_TOML = """
schema = "sizefx/effects/1"

[lever_arm]
enabled = true
preset = "compact"
r_vehicle_m = [0.03, -0.02, 0.05]

[accel_delay]
enabled = true
tau_s = 0.0005

[accel_bias]
enabled = true
bias_ug = [800.0, -500.0, 1200.0]

[accel_scale_factor]
enabled = true
ppm = [500.0, -300.0, 700.0]

[accel_misalignment]
enabled = true
arcsec = [[0.0, 60.0, -40.0], [50.0, 0.0, 30.0], [-70.0, 20.0, 0.0]]

[accel_quadratic]
enabled = true
ug_per_g2 = [50.0, -30.0, 40.0]

[gyro_bias]
enabled = true
deg_per_h = [5.0, -3.0, 4.0]

[gyro_scale_factor]
enabled = true
ppm = [300.0, -200.0, 400.0]

[gyro_misalignment]
enabled = true
arcsec = [[0.0, 40.0, -30.0], [20.0, 0.0, 50.0], [-60.0, 10.0, 0.0]]

[gyro_g_sensitivity]
enabled = true
deg_per_h_per_g = [[2.0, 0.5, -0.3], [0.4, -1.5, 0.2], [-0.6, 0.3, 1.0]]
"""
MODEL = tomllib.loads(MODEL_TOML)
SENSOR_ONLY = {k: v for k, v in MODEL.items() if k != "lever_arm"}

#: Round-trip tolerances with every effect on: (accelerometers [ug], gyros [deg/h]), interior samples.
#: The floor is the size-effect compensation's own (sizefx.compensate): the angular-acceleration
#: estimate's error times the ~8 cm arms. The gyro floor is G (up to 2 deg/h/g) times that
#: accelerometer floor, through G f_b. Measured on TUMBLING: savgol 17.3 ug / 3.9e-5 deg/h (the
#: 41-sample window's response is 3.2e-4 short at 0.7 Hz, sizefx.omegadot.response: 3e-4 of
#: 8.4 rad/s^2 times 8 cm); central 0.069 ug / 1.7e-7 deg/h; increments 0.071 ug / 1.75e-7 deg/h
#: (the centripetal term from the interval's mean rate, second order); on CONING (2 Hz,
#: 31 rad/s^2) increments 2.56 ug / 5.2e-6 deg/h. Tolerances leave 2.3x to 3x margin.
ROUND_TRIP_TOL = {
    ("tumbling", "rates", "savgol"): (40.0, 1e-4),
    ("tumbling", "rates", "central"): (0.2, 5e-7),
    ("tumbling", "increments", "increments"): (0.2, 5e-7),
    ("coning", "increments", "increments"): (6.0, 1.5e-5),
}
#: Without the lever arms nothing is estimated: the inversion is exact but for the spline that
#: undoes the 0.5 ms delay (for increments through their cumulative sum) and, for increments,
#: K2 var(a) over an interval. Measured: rates 4.2e-8 ug / 9.2e-11 deg/h, increments 2.8e-6 ug /
#: 2.1e-10 deg/h; the tolerances leave 35x and more.
EXACT_TOL_UG = 1e-4
EXACT_TOL_DEG_H = 1e-8


def tumbling(duration_s: float = 4.0) -> Trajectory:
    """Heading, pitch and roll swinging together (0.4, 0.55, 0.7 Hz; up to 2.2 rad/s, 8.4 rad/s^2)."""
    lat, lon, h = scenarios.PAPER_AIRFIELD.radians()
    chain = RotationChain(
        [scenarios.E_DOWN, scenarios.E_EAST, scenarios.E_NORTH],
        [Sinusoids([0.5], [0.4], [0.3]), Sinusoids([0.3], [0.55], [1.0]), Sinusoids([0.35], [0.7], [2.0])],
    )
    return Trajectory(StaticSite(lat, lon, h), chain, duration_s, name="tumbling")


TRAJECTORIES = {"tumbling": tumbling, "coning": lambda: scenarios.coning(2.0, 0.2, 4.0)}


def model(sections: dict):
    return load_effects(base=IDEAL, overrides=sections)


def errors(tel, truth):
    """Largest interior differences: accelerometers [ug], gyros [deg/h] (increments as mean rates)."""
    per_sample = 1.0 if tel.form == "rates" else 1.0 / RATE_HZ
    (g, a), (g0, a0) = tel.imu_arrays(), truth.imu_arrays()
    inner = slice(EDGE, -EDGE)
    return (np.abs(a - a0)[inner].max() / per_sample / MICRO_G, np.abs(g - g0)[inner].max() / per_sample / DEG_PER_H)


@pytest.fixture(scope="module")
def records():
    """(trajectory, form) -> (record with every effect, ideal point-IMU record)."""
    out = {}
    for name, form in {(name, form) for name, form, _ in ROUND_TRIP_TOL}:
        traj = TRAJECTORIES[name]()
        out[name, form] = (
            simulate_in_memory(traj, model(MODEL), rate_hz=RATE_HZ, form=form, seed=1),
            simulate_in_memory(traj, model({}), rate_hz=RATE_HZ, form=form, seed=1),
        )
    return out


@pytest.mark.parametrize("name,form,estimator", list(ROUND_TRIP_TOL))
def test_correction_reproduces_the_ideal_point_imu(records, name, form, estimator):
    tel, point = records[name, form]
    tol_ug, tol_deg_h = ROUND_TRIP_TOL[name, form, estimator]
    before_ug, before_deg_h = errors(tel, point)
    out = correct_imu(tel, model(MODEL), mode="center", estimator=estimator)
    after_ug, after_deg_h = errors(out, point)
    assert before_ug > 1e4 and before_deg_h > 100.0, (before_ug, before_deg_h)  # the errors were there
    assert after_ug < tol_ug and after_deg_h < tol_deg_h, (after_ug, after_deg_h)
    assert out.form == form and np.array_equal(out.time_s, tel.time_s) and out.accel_time_s is None


@pytest.mark.parametrize("form", ["rates", "increments"])
def test_sensor_errors_alone_invert_exactly(form):
    traj = tumbling()
    tel = simulate_in_memory(traj, model(SENSOR_ONLY), rate_hz=RATE_HZ, form=form, seed=1)
    point = simulate_in_memory(traj, model({}), rate_hz=RATE_HZ, form=form, seed=1)
    after_ug, after_deg_h = errors(correct_imu(tel, model(SENSOR_ONLY)), point)
    assert after_ug < EXACT_TOL_UG and after_deg_h < EXACT_TOL_DEG_H, (after_ug, after_deg_h)


def test_triad_mode_leaves_the_triad_points_specific_force(records):
    # d_i removed, the offset kept: the record of a point IMU sitting at the triad point (measured
    # 0.022 ug). The gyros stay exact (1.7e-7 deg/h): G f_b takes f_b at the reference point, as the
    # simulator does; taking the triad point's f_b there would leave 0.088 deg/h.
    tel, _ = records["tumbling", "increments"]
    at_triad = simulate_in_memory(
        tumbling(),
        model({"lever_arm": {**MODEL["lever_arm"], "preset": "none"}}),
        rate_hz=RATE_HZ,
        form="increments",
        seed=1,
    )
    after_ug, after_deg_h = errors(correct_imu(tel, model(MODEL), mode="triad"), at_triad)
    assert after_ug < ROUND_TRIP_TOL["tumbling", "increments", "increments"][0]
    assert after_deg_h < ROUND_TRIP_TOL["tumbling", "increments", "increments"][1]


def test_a_model_file_switches_off_what_it_omits(tmp_path, records):
    _, point = records["tumbling", "rates"]
    path = tmp_path / "bias.toml"
    path.write_text(
        "[gyro_bias]\nenabled = true\ndeg_per_h = [5.0, -3.0, 4.0]\n"
        "[accel_noise]\nenabled = true\n[level_tilt]\nenabled = true\n"
        "[reference_delay]\nenabled = true\n[accel_bias]\nenabled = false\nbias_ug = [1e4, 0.0, 0.0]\n"
    )
    fx = load_model(path)
    assert not fx.enabled("lever_arm") and not fx.enabled("gyro_noise")  # on by the schema's defaults
    out = correct_imu(point, fx)
    # only the gyro bias is taken off; the noise, tilt and reference delay are not IMU output errors
    np.testing.assert_array_equal(out.accel_mps2, point.accel_mps2)
    np.testing.assert_allclose(
        out.gyro_rad_s - point.gyro_rad_s,
        np.broadcast_to(-np.array([5.0, -3.0, 4.0]) * DEG_PER_H, point.gyro_rad_s.shape),
        rtol=0.0,
        atol=1e-15,
    )  # rounding of rates up to 3 rad/s
    applied = out.source.correction
    assert applied["corrected"] == ("gyro_bias",)
    assert applied["ignored"] == ("reference_delay", "level_tilt", "accel_noise")


@pytest.mark.parametrize(
    "sections,words",
    [
        # beyond its range already when read (the inverse's own refusal is tested in test_sensor_model)
        (
            {"accel_quadratic": {"enabled": True, "ug_per_g2": [0.0, 0.0, 1e6]}},
            "ug_per_g2 = 1e+06 is outside its range",
        ),
        ({"gyro_scale_factor": {"enabled": True, "ppm": [0.0, -1.5e6, 0.0]}}, "[gyro_scale_factor]"),
        (
            {"accel_misalignment": {"enabled": True, "arcsec": [[0.0, 2e5, 0.0], [2e5, 0.0, 0.0], [0.0, 0.0, 0.0]]}},
            "[accel_misalignment]",
        ),
    ],
)
def test_a_model_that_cannot_be_inverted_is_named(records, sections, words):
    tel, _ = records["tumbling", "rates"]
    with pytest.raises(ConfigError) as err:
        correct_imu(tel, model(sections))
    assert words in str(err.value)


def test_navigate_refuses_levers_and_model_together(records):
    tel, _ = records["tumbling", "increments"]
    with pytest.raises(ConfigError, match="--levers and --model"):
        navigate(tel, NavConfig(levers="levers.json", model=model(MODEL)))


# --------------------------------------------------------------------------- command line


@pytest.fixture(scope="module")
def sim_with_model(tmp_path_factory, short_turntable_plan):
    """A 40 s turntable record (rates) with every effect of MODEL_TOML, noise off, and the model file."""
    from sizefx.simulate import SimulateConfig, run

    folder = tmp_path_factory.mktemp("correct")
    sim, model_path = folder / "tt.h5", folder / "model.toml"
    run(SimulateConfig("turntable", sim, plan=short_turntable_plan, ideal=True, overrides=MODEL))
    model_path.write_text(MODEL_TOML)
    return sim, model_path


def test_compensate_and_navigate_take_a_model(tmp_path, sim_with_model):
    sim, model_path = sim_with_model
    runner = CliRunner()
    out = tmp_path / "corrected.h5"
    r = runner.invoke(main, ["compensate", str(sim), "--model", str(model_path), "-o", str(out), "--mode", "center"])
    assert r.exit_code == 0, r.output
    assert "corrected with" in r.output and "gyro_g_sensitivity" in r.output
    written = read_telemetry(out)
    expected = correct_imu(read_telemetry(sim), load_model(model_path), mode="center")
    np.testing.assert_array_equal(written.accel_mps2, expected.accel_mps2)
    np.testing.assert_array_equal(written.gyro_rad_s, expected.gyro_rad_s)
    assert written.source.correction["mode"] == "center"

    def horizontal_error_m(*extra):
        js = tmp_path / "nav.json"
        r = runner.invoke(main, ["navigate", str(sim), "--json", str(js), "--force", *extra])
        assert r.exit_code == 0, r.output
        return json.loads(js.read_text())["max_horizontal_error_m"], r.output

    raw_m, _ = horizontal_error_m()
    corrected_m, text = horizontal_error_m("--model", str(model_path), "--mode", "center")
    assert "IMU corrected with the effect model" in text
    # measured: 2.8 m uncorrected (the table's rotation averages part of the biases out), 1.0e-6 m
    # corrected (savgol floor; the ideal record gives 1.4e-8 m)
    assert raw_m > 1.0 and corrected_m < 1e-4, (raw_m, corrected_m)


@pytest.mark.parametrize(
    "text,words",
    [
        ("[accel_bias]\nbias_ug = [1.0, 2.0]\n", "[accel_bias] bias_ug has shape [2]"),
        ("[accel_bias\nbias_ug = 1\n", "not valid TOML"),
        ("[wobble]\nenabled = true\n", "unknown section [wobble]"),
    ],
)
@pytest.mark.parametrize("command", ["navigate", "compensate"])
def test_a_bad_model_file_exits_2_with_one_line(tmp_path, sim_with_model, command, text, words):
    sim, _ = sim_with_model
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    out = tmp_path / "out.h5"
    args = [command, str(sim), "--model", str(bad)] + (["-o", str(out)] if command == "compensate" else [])
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 2, r.output
    lines = r.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("sizefx: error: ") and words in lines[0], r.output
    assert not out.exists()


@pytest.mark.parametrize("command", ["navigate", "compensate"])
def test_levers_and_model_together_exit_2_with_one_line(tmp_path, sim_with_model, command):
    sim, model_path = sim_with_model
    args = [command, str(sim), "--model", str(model_path), "--levers", str(tmp_path / "levers.json")]
    r = CliRunner().invoke(main, args + (["-o", str(tmp_path / "out.h5")] if command == "compensate" else []))
    assert r.exit_code == 2
    lines = r.output.strip().splitlines()
    assert len(lines) == 1 and "--levers and --model" in lines[0], r.output
