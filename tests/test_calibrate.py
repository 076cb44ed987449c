"""Calibration fails fast and warns honestly.

- Every refusal that needs no fit comes before the first record is read whole: outputs,
  nominal geometry, reference, site, and the motion's excitation of the arms.
- A reference slower than the IMU is interpolated by a rotation spline, so the arms do not
  depend on the reference rate.

The estimator's accuracy (z-scores, tilt, delay) is tested in test_sizeeffect.py.
"""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from click.testing import CliRunner
from support import write_raw

import sizefx.calibrate as calibrate
from sizefx import scenarios
from sizefx.calibrate import CalibrateConfig, CalibrationError, excitation, joint_fit, preflight, prepare
from sizefx.effects import load_effects
from sizefx.errors import ConfigError, OutputError
from sizefx.rotation import quat_interp, quat_to_mat
from sizefx.simulate import SimulateConfig, simulate_in_memory
from sizefx.simulate import run as simulate
from sizefx_cli.main import main

OFFSET_M = [0.0010, -0.0005, 0.0008]
#: The paper's plan shortened to 214 s (as in test_sizeeffect.py): all nine arms observable.
SHORT_PLAN = scenarios.TurntablePlan(static_s=20.0, seconds_per_axis=48.0, cycles=2)


@pytest.fixture(scope="module")
def turntable_h5(tmp_path_factory):
    path = tmp_path_factory.mktemp("cal") / "turntable.h5"
    simulate(SimulateConfig("turntable", path, plan=SHORT_PLAN, rate_hz=400.0, seed=3))
    return path


@pytest.fixture(scope="module")
def turntable_calibration(tmp_path_factory, turntable_h5):
    """The calibration of turntable_h5 with its levers file, run once for the module: ``(result, path)``."""
    out = tmp_path_factory.mktemp("cal") / "levers.json"
    return calibrate_run(turntable_h5, json_path=out), out


@pytest.fixture(scope="module")
def one_axis_h5(tmp_path_factory):
    path = tmp_path_factory.mktemp("cal") / "one_axis.h5"
    simulate(
        SimulateConfig(
            "turntable",
            path,
            rate_hz=400.0,
            plan=scenarios.TurntablePlan(axes="Z", static_s=5.0, seconds_per_axis=24.0, cycles=1),
        )
    )
    return path


@pytest.fixture
def no_fit(monkeypatch):
    """Make reading a record whole, or fitting, an error: a refusal must come before either."""

    def forbidden(*args, **kwargs):
        raise AssertionError("calibrate read a record whole or fitted before refusing")

    monkeypatch.setattr(calibrate, "read_telemetry", forbidden)
    monkeypatch.setattr(calibrate, "joint_fit", forbidden)


def calibrate_run(*records, **options):
    return calibrate.run(CalibrateConfig(records=records, **options))


def test_outputs_are_checked_before_any_work(tmp_path, turntable_h5, no_fit):
    existing = tmp_path / "levers.json"
    existing.write_text("{}")
    cases = [
        (dict(json_path=existing), "output exists; pass --force"),
        (dict(json_path=tmp_path / "x.json", plot=tmp_path / "x.json"), "given to both --json and --plot"),
        (dict(json_path=turntable_h5, force=True), "would overwrite the input"),
        (dict(plot=tmp_path / "missing-folder" / "fig.png"), "does not exist; create it first"),
    ]
    for kwargs, message in cases:
        with pytest.raises(OutputError, match=message):
            calibrate_run(turntable_h5, **kwargs)
    with pytest.raises(CalibrationError, match="given twice"):
        calibrate_run(turntable_h5, turntable_h5)
    with pytest.raises(ConfigError, match="missing.h5: RECORDS .2.: no such file"):
        calibrate_run(turntable_h5, tmp_path / "missing.h5")
    with pytest.raises(OutputError, match="would overwrite the input"):  # a nominal levers file is an input too
        calibrate_run(turntable_h5, nominal=str(existing), json_path=existing, force=True)
    assert existing.read_text() == "{}"


def test_missing_reference_and_site_are_refused_before_reading(tmp_path, no_fit):
    no_ref = write_raw(tmp_path / "no_ref.h5", reference=False)
    with pytest.raises(CalibrationError, match="needs /reference attitude"):
        calibrate_run(no_ref)

    def drop_site(h5):
        for key in ("latitude_deg", "longitude_deg", "height_m"):
            del h5.attrs[key]

    no_site = write_raw(tmp_path / "no_site.h5", mutate=drop_site)
    with pytest.raises(CalibrationError, match="no site"):
        calibrate_run(no_site)


def test_unobservable_arms_are_named_before_fitting(one_axis_h5, no_fit):
    with pytest.raises(CalibrationError) as info:
        calibrate_run(one_axis_h5)
    msg = str(info.value)
    # rotation about body z only: the z components of each arm, and all of r_z, are not seen
    assert "r_x[z]" in msg and "r_y[z]" in msg and "r_z[z]" in msg and "r_x[x]" not in msg
    assert "RMS rate about body z" in msg and "before fitting" in msg


def test_the_command_refuses_unobservable_arms_in_one_line(one_axis_h5):
    result = CliRunner().invoke(main, ["calibrate", str(one_axis_h5)])
    assert result.exit_code == 2 and result.output.count("\n") == 1 and "r_z[z]" in result.output


def test_a_static_record_never_rotates(tmp_path, no_fit):
    static = write_raw(tmp_path / "static.h5", n=2000)
    with pytest.raises(CalibrationError, match="never rotates"):
        calibrate_run(static)


def test_preflight_bound_is_optimistic_and_close_on_the_papers_plan(turntable_h5):
    """The pre-flight information leaves out the tilt and the delay: its sigma may only be smaller
    than the fit's (so it never refuses what the fit accepts), and on the turntable, where those
    barely couple to the arms, close to it."""
    exc = excitation(turntable_h5)
    res = joint_fit([prepare(calibrate.read_telemetry(turntable_h5), str(turntable_h5))])
    bound = np.array(
        [np.sqrt(np.diag(np.linalg.inv(exc.arm_information[i] / exc.noise_mps2[i] ** 2))) for i in range(3)]
    )
    assert np.all(bound <= res.sigma_arms * 1.02), (bound, res.sigma_arms)  # 2 %: the noise estimates differ
    assert np.all(bound >= 0.7 * res.sigma_arms), (bound, res.sigma_arms)
    # the noise estimate from second differences is the simulated white noise (residual RMS)
    np.testing.assert_allclose(exc.noise_mps2, res.residual_rms, rtol=0.05)
    assert preflight([turntable_h5])[0].samples == exc.samples


def test_a_calibration_writes_its_levers_file(turntable_calibration):
    res, out = turntable_calibration
    doc = json.loads(out.read_text())
    assert doc["schema"] == "sizefx/levers/1" and len(doc["r_x"]) == 3
    assert res.to_json()["levers"] == doc and res.report().endswith(f"lever arms -> {out}")
    np.testing.assert_array_equal(res.levers.arms_total, res.fit.arms)
    assert calibrate.format_report(res) == res.report().rsplit("\n", 1)[0]


# long tier: two calibrations of a turntable record (3 s); fast twin: the single-reference calibrations of this module
@pytest.mark.slow
def test_slow_reference_gives_the_same_arms():
    """Slerp through a 100 Hz reference on a 1600 Hz sway biases the arms by 0.08 mm (40-100 sigma).
    With the rotation spline the arms agree with the 1600 Hz reference's to 0.01 mm; slerp on
    the same 100 Hz reference (the old interpolation) is shown to miss by far more."""
    fx = load_effects(overrides={"lever_arm": {"r_vehicle_m": OFFSET_M}})
    table = prepare(simulate_in_memory(scenarios.turntable(SHORT_PLAN)[0], fx, form="rates", seed=1), "table")
    sway_plan = scenarios.SwayPlan(axis="roll", amplitudes_dps=(30.0,), static_s=10.0, segment_s=60.0)
    sway = simulate_in_memory(scenarios.sway(sway_plan)[0], fx, form="rates", seed=2)
    ref = sway.reference
    every = 16  # 1600 Hz -> 100 Hz
    slow = replace(
        sway,
        reference=replace(
            ref,
            time_s=ref.time_s[::every],
            quat_nb=ref.quat_nb[::every],
            lat_rad=ref.lat_rad[::every],
            lon_rad=ref.lon_rad[::every],
            height_m=ref.height_m[::every],
            velocity_n_mps=ref.velocity_n_mps[::every],
        ),
    )
    fast_rec, slow_rec = prepare(sway, "sway"), prepare(slow, "sway")
    slerp_rec = replace(
        slow_rec, mat_nb=quat_to_mat(quat_interp(slow.reference.time_s, slow.reference.quat_nb, slow_rec.t))
    )
    full, spline, slerp = (joint_fit([table, rec]) for rec in (fast_rec, slow_rec, slerp_rec))
    assert np.abs(spline.arms - full.arms).max() < 0.01e-3
    assert np.abs(slerp.arms - full.arms).max() > 0.05e-3  # what the spline removes
    assert np.abs(slerp.arms - full.arms).max() > 10 * full.sigma_arms.min()


def test_a_record_with_declared_gaps_is_fitted_segment_by_segment(tmp_path, turntable_h5, turntable_calibration):
    """Gaps an importer declared are a property of the record. Calibration
    estimates the angular acceleration within each continuous segment (never across a gap) and
    fits the segments jointly; the arms agree with the gapless record's (the module's turntable
    record and its calibration)."""
    from sizefx.io.telemetry import find_imu_gaps, read_telemetry, write_telemetry

    tel = read_telemetry(turntable_h5)
    drop = np.r_[20_000:20_050, 50_000:50_007]  # two dropouts: 125 ms and 17.5 ms
    keep = np.setdiff1d(np.arange(tel.n_samples), drop)
    cut = replace(tel, time_s=tel.time_s[keep], gyro_rad_s=tel.gyro_rad_s[keep], accel_mps2=tel.accel_mps2[keep])
    cut.gaps = find_imu_gaps(cut.time_s, declared=True)
    assert len(cut.gaps) == 2
    gappy = tmp_path / "gappy.h5"
    write_telemetry(gappy, cut)
    ref = turntable_calibration[0].fit
    out = calibrate_run(gappy)  # declared: no --allow-gaps needed
    res = out.fit
    assert [r.name.split()[-1] for r in out.records] == ["1/3", "2/3", "3/3"]
    assert np.abs((res.arms - ref.arms) / ref.sigma_arms).max() < 1.0  # the same data less 57 samples
    assert "3 segments used" in out.report()
