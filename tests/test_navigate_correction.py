"""One correction path through navigate: a levers file and an effect model remove the size effect alike.

Both are resolved once into a :class:`sizefx.sensor_model.Correction`, and both take the lever
terms from the increments the strapdown integrates (edge rates). Checked on a vibrating flight (a
rotor at 8 Hz: angular vibration at 8, 16 and 32 Hz) whose IMU sits 0.5 m from the vehicle's
reference point, sampled at 200 Hz with ideal sensors: only the arms are wrong, so a model holding
just the arms and the levers file of the same arms must give the same solution, in both modes.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from sizefx.correct import load_model
from sizefx.io.telemetry import read_telemetry
from sizefx.navigate import NavConfig, navigate
from sizefx.scenarios import FlightPlan
from sizefx.sensor_model import Correction
from sizefx.simulate import SimulateConfig, run

ARMS_TOML = """\
schema = "sizefx/effects/1"

[lever_arm]
enabled = true
d_x_m = [0.0249, 0.0, 0.0]
d_y_m = [0.0, 0.0279, 0.0]
d_z_m = [0.0, 0.0, 0.0249]
r_vehicle_m = [0.5, 0.1, -0.2]
"""


@pytest.fixture(scope="module")
def flight(tmp_path_factory):
    """(record, model, levers file): an 1100 s flight at 200 Hz, ideal but for the arms."""
    folder = tmp_path_factory.mktemp("correction")
    model_path, levers_path, record = folder / "arms.toml", folder / "levers.json", folder / "flight.h5"
    model_path.write_text(ARMS_TOML)
    plan = FlightPlan(duration_s=1100.0, align_s=30.0)
    run(SimulateConfig("flight", record, plan=plan, rate_hz=200.0, ideal=True, effects_path=str(model_path)))
    model = load_model(model_path)
    p = model.sensor_params()
    center, triad = p.arms("center"), p.arms("triad")
    levers = {"schema": "sizefx/levers/1", "reference_point": "rotation-center", "offset": (center - triad)[0].tolist()}
    for i, axis in enumerate("xyz"):
        levers |= {f"r_{axis}": center[i].tolist(), f"sigma_{axis}": None, f"d_{axis}": triad[i].tolist()}
    levers |= {"tilt_arcsec": None, "accel_delay_s": None, "source": "the simulation's arms"}
    levers_path.write_text(json.dumps(levers))
    return read_telemetry(record), model, str(levers_path)


def _max_error_m(result) -> float:
    return result.summary["max_horizontal_error_m"]


@pytest.mark.parametrize("mode", ["triad", "center"])
def test_a_model_and_a_levers_file_of_the_same_arms_navigate_alike(flight, mode):
    tel, model, levers = flight
    by_model = navigate(tel, NavConfig(model=model, mode=mode, output_rate_hz=None))
    by_levers = navigate(tel, NavConfig(levers=levers, mode=mode, output_rate_hz=None))
    # the same arms through the same calls: equal but for the rounding of the arms' two spellings
    # (the model's sum r0 + r_plate + r_vehicle + d_i, the file's decimal r_i)
    np.testing.assert_allclose(by_model.lat_rad, by_levers.lat_rad, rtol=0, atol=1e-13)
    np.testing.assert_allclose(by_model.lon_rad, by_levers.lon_rad, rtol=0, atol=1e-13)
    assert by_model.config["correction"]["estimator"] == "increments"


def test_the_model_removes_the_size_effect_of_a_vibrating_vehicle(flight):
    """With the arms from the vehicle's reference point (``center``, half a metre) the vibration's
    lever terms are large; taken from the increments they go. Measured on this flight: 3.9 m without
    a correction, 0.71 m corrected (what stays is the 200 Hz integration of 32 Hz vibration; 0.05 m
    at 400 Hz). The rates corrected with a Savitzky-Golay derivative (``sizefx compensate --model``,
    whose output is a record of rates) leave about 22 m on such a flight (21.7 m on 1080 s of it)."""
    tel, model, _ = flight
    plain = _max_error_m(navigate(tel, NavConfig()))
    corrected = _max_error_m(navigate(tel, NavConfig(model=model, mode="center")))
    assert plain > 3.0 and corrected < 1.0, (plain, corrected)


def test_the_correction_is_resolved_once_with_the_models_arms_and_axes(flight):
    _, model, _ = flight
    p = model.sensor_params()
    c = Correction.of_model(p, "center", {})
    np.testing.assert_array_equal(c.arms_m, p.arms("center"))
    np.testing.assert_array_equal(c.axes, p.accel_axes())
    g, a = np.ones((8, 3)), np.full((8, 3), 2.0)
    omega, accel = Correction.of_arms(p.arms("triad"), np.eye(3), None, "triad", {}).channels(
        g, a, form="rates", dt=0.01
    )
    assert omega is g and accel is a  # the size effect alone: nothing before the increments
