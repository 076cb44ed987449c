"""sizefx diagnose on records built to fool it: each hides a trap, and the diagnosis must
name the trap and still find what is really there.

Records: the tumble (tests/test_diagnose.py's sizes and noise) or a sway, 24-60 s at 100-400 Hz,
corrupted in memory the way real test set-ups corrupt them: motion-capture glitches, a re-mount
between runs, spikes in the IMU, a motion without rotation, a wrong unit, a vibration line.

Each record runs at the lowest of 100, 200 and 400 Hz at which its trap is the same and the IMU's
noise is still inferred as navigation grade (the noise is a density: the rate changes the cost, not
what the record shows; a tumble of fewer than ~5 000 samples leaks enough motion into the noise
plateau to pass for tactical grade, so a short tumble stays at 200 or 400 Hz).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from test_diagnose import BASE, HIDDEN, NOMINAL, RATE_HZ, assert_within_3_sigma, found, record
from test_diagnose_integrity import remount

from sizefx import diagnose as D
from sizefx import scenarios
from sizefx.constants import DEG
from sizefx.effects import IDEAL, load_effects
from sizefx.errors import ConfigError
from sizefx.scenarios import SwayPlan, sway
from sizefx.simulate import simulate_in_memory


def simulated(traj, hidden, *, seed=3, rate_hz=100.0):
    overrides = {k: dict(v) for k, v in BASE.items()}
    for name, values in hidden.items():
        overrides.setdefault(name, {}).update(values)
    fx = load_effects(base=IDEAL, overrides=overrides)
    return simulate_in_memory(traj, fx, rate_hz=rate_hz, form="rates", seed=seed), D.theta_from_model(fx)


def pitch_sway(duration_s=60.0, amplitude_dps=10.0):
    traj, _ = sway(
        SwayPlan(
            axis="pitch", amplitudes_dps=(amplitude_dps,), frequency_hz=1.0, static_s=1.0, segment_s=duration_s - 1.0
        )
    )
    return traj


def ids(d):
    return {i for i, _ in found(d)}


def test_reference_glitches_are_named_masked_and_move_nothing():
    """Motion capture drops a handful of bad attitude rows, which a plain fit turns into
    scale factors of -1e6 ppm. Each glitch is a warning, the rows are dropped, and the lever arm
    comes out as on the clean record (within a tenth of its standard error)."""
    tel, truth = record({"lever_arm": HIDDEN["lever_arm"]}, seed=21, rate_hz=200.0, duration_s=40.0)
    clean = D.diagnose(tel, NOMINAL, keep_series=False)
    ref = tel.reference
    q = ref.quat_nb.copy()
    rows = [1500, 3500, 4500, 6172]  # 7.5, 17.5, 22.5 and 30.86 s
    for row, deg in zip(rows, (0.7, 2.0, 5.0, 1.2)):
        bad = Rotation.from_quat(q[row, [1, 2, 3, 0]]) * Rotation.from_rotvec([0.0, deg * DEG, 0.0])
        q[row] = bad.as_quat()[[3, 0, 1, 2]]
    from dataclasses import replace

    tel.reference = replace(ref, quat_nb=q)
    d = D.diagnose(tel, NOMINAL, keep_series=False)
    glitches = [w for w in d.warnings if w.kind == "reference_glitch"]
    assert len(glitches) == len(rows), d.warnings
    assert ids(d) == {"lever_arm"}, d.log
    assert_within_3_sigma(d, truth, {"lever_arm"})
    for j in D.LEVER[3:6]:
        assert abs(d.theta[j] - clean.theta[j]) < 0.1 * clean.sigma_theta[j]
    text = D.format_report(d, "test")
    assert text.index("WARNINGS") < text.index("found 1 effect")  # what may be wrong comes first


def test_the_issues_glitchy_sway_finds_the_arm_and_nothing_unexplained():
    """The glitchy sway: a heading sway (the paper's test) with accelerometer y further out than
    nominal and five single-row attitude glitches. The glitches are named, the arm comes out exactly as
    on the clean record, and with white noise only nothing is left unexplained (the structure tests'
    regressors are the predicted motion: regressed on the measured gyros, the residual would follow
    their noise)."""
    traj, _ = sway(SwayPlan(axis="heading", amplitudes_dps=(20.0,), frequency_hz=1.0, static_s=1.0, segment_s=39.0))
    tel, truth = simulated(traj, {"lever_arm": HIDDEN["lever_arm"]}, seed=31)
    clean = D.diagnose(tel, NOMINAL, keep_series=False)
    from dataclasses import replace

    q = tel.reference.quat_nb.copy()
    for row, deg in zip([500, 1250, 2250, 3000, 3500], (0.7, 2.0, 5.0, 1.2, 3.0)):  # 5 to 35 s at 100 Hz
        bad = Rotation.from_quat(q[row, [1, 2, 3, 0]]) * Rotation.from_rotvec([deg * DEG, 0.0, 0.0])
        q[row] = bad.as_quat()[[3, 0, 1, 2]]
    tel.reference = replace(tel.reference, quat_nb=q)
    d = D.diagnose(tel, NOMINAL, keep_series=False)
    assert [w.kind for w in d.warnings] == ["reference_glitch"] * 5, d.warnings
    assert ids(d) == {"lever_arm"} and not d.rejected, (found(d), d.rejected)
    assert_within_3_sigma(d, truth, {"lever_arm"})
    for j, s in clean.sigma_theta.items():
        assert abs(d.theta[j] - clean.theta[j]) < 0.1 * s
    assert clean.unexplained == [] and d.unexplained == [], (clean.unexplained, d.unexplained)


def test_imu_spikes_cannot_move_an_estimate_by_its_standard_error():
    """Ten single-sample spikes of 0.5 m/s^2 (2000 times the noise at 100 Hz) in the accelerometers: Huber's
    weights cap each one's pull, so every estimate stays within one standard error of the clean fit (the
    largest pull is a tenth of it; at 400 Hz a twentieth). At 100 Hz the spikes raise the noise plateau to
    tactical grade, whose wider ranges reject nothing a navigation grade would keep: no finding is hidden."""
    tel, truth = record({"lever_arm": HIDDEN["lever_arm"], "accel_delay": HIDDEN["accel_delay"]}, seed=22)
    clean = D.diagnose(tel, NOMINAL, keep_series=False)
    rng = np.random.default_rng(5)
    spiky = tel.accel_mps2.copy()
    for k in rng.choice(np.arange(1000, tel.time_s.size - 1000), 10, replace=False):
        spiky[k, rng.integers(3)] += 0.5
    tel.accel_mps2 = spiky
    d = D.diagnose(tel, NOMINAL, keep_series=False)
    assert ids(d) == {"lever_arm", "accel_delay"}, d.log
    for j, s in clean.sigma_theta.items():
        assert abs(d.theta[j] - clean.theta[j]) < s, (D.PARAMS[j].label, d.theta[j], clean.theta[j], s)


def test_a_remount_splits_the_record_and_says_the_segments_share_one_model():
    """The IMU moved to another face at 12 s and the reference followed, in one file: one spline
    through the jump gave a gyro residual of 1.8 rad/s and "consistent with sensor noise". Now the
    jump is a warning, the motion is split there (the gyros fit to the noise on both sides), and a
    second warning says that the segments share one model, which a re-mount breaks (the arms turn
    with the IMU). Diagnosed alone, the segment before the jump gives the arm within 3 sigma."""
    tel, truth = record({"lever_arm": HIDDEN["lever_arm"]}, seed=23, rate_hz=400.0, duration_s=24.0)
    tel = remount(tel, 12.0)
    d = D.diagnose(tel, NOMINAL, keep_series=True)
    kinds = [w.kind for w in d.warnings]
    assert kinds[:2] == ["reference_discontinuity", "segments_share_model"], d.warnings
    assert "--from-s/--to-s" in d.warnings[1].message
    t = d.t[d.mask]
    assert (t < 11.0).any() and (t > 13.0).any()
    assert not ((t > 11.95) & (t < 12.05)).any()  # the jump itself is left out
    for c in ("gyro_x", "gyro_y", "gyro_z"):  # at the noise, not the rad/s of a spline through the jump
        assert d.rms_after[c] < 2.0 * d.white_sigma[c], (c, d.rms_after[c], d.white_sigma[c])
    assert "consistent with sensor noise" not in D.format_report(d, "test")
    before = D.diagnose(D.crop(tel, None, 11.5), NOMINAL, keep_series=False)
    assert not before.warnings and ids(before) == {"lever_arm"}, (before.warnings, found(before))
    assert_within_3_sigma(before, truth, {"lever_arm"})


def test_lever_arms_without_rotation_are_not_revealed():
    """Translation only (north acceleration of 2 m/s^2 at 1 Hz, no rotation): the arms have nothing to
    act through, whatever the noise makes of them. A fit without that judgement reports
    arms of -28..+34 mm as found on BROAD's translation trial."""
    traj = scenarios.sculling(1.0, 0.0, 2.0, 30.0)
    tel, _ = simulated(traj, {"lever_arm": HIDDEN["lever_arm"]}, seed=24)
    d = D.diagnose(tel, NOMINAL, keep_series=False)
    assert "lever_arm" not in ids(d), d.log
    hidden = {(u.id, u.channel) for u in d.unrevealed}
    assert {("lever_arm", f"accel_{a}") for a in "xyz"} <= hidden


def test_a_tilt_the_sway_cannot_tell_from_the_biases_is_no_finding():
    """Pitch sway with an accelerometer delay and biases: the delay is found; the level tilt and the
    horizontal biases explain the same constant and are named as indistinguishable, not as found."""
    tel, truth = simulated(
        pitch_sway(), {"accel_delay": HIDDEN["accel_delay"], "accel_bias": HIDDEN["accel_bias"]}, seed=4
    )
    d = D.diagnose(tel, NOMINAL, keep_series=False)
    assert ids(d) == {"accel_delay"}, (found(d), d.log)
    assert_within_3_sigma(d, truth, {"accel_delay"})
    confused = {u.id for u in d.unrevealed if "on this motion" in u.reason}
    assert {"level_tilt", "accel_bias"} <= confused, d.unrevealed
    # the model still carries what the record shows: the residual is at the noise
    for c in ("accel_x", "accel_y", "accel_z"):
        assert d.rms_after[c] < 1.1 * d.white_sigma[c]


def test_an_accelerometer_in_the_wrong_unit_is_rejected_not_reported():
    """accel_z scaled by 1.1 (a wrong range setting): 100 000 ppm is no navigation-grade scale factor.
    It is rejected with the reason and a warning saying what is more likely."""
    tel, _ = record({}, seed=25, duration_s=30.0)  # the grade is given: 100 Hz will do
    tel.accel_mps2 = tel.accel_mps2 * np.array([1.0, 1.0, 1.1])
    d = D.diagnose(tel, NOMINAL, keep_series=False, grade="navigation")
    assert "accel_scale_factor" not in ids(d)
    rejected = [r for r in d.rejected if r.id == "accel_scale_factor" and r.channel == "accel_z"]
    assert rejected and "navigation-grade" in rejected[0].reason, d.rejected
    assert any(w.kind == "implausible_estimate" and "unit" in w.message for w in d.warnings)


def test_effects_outside_the_candidates_are_named_on_their_channel():
    """A 37 Hz vibration line on accel_y and a drifting gyro_z bias, neither a candidate: both appear
    in ``unexplained`` on their channel, and the summary does not call the residual noise."""
    tel, _ = record({}, seed=26, rate_hz=200.0, duration_s=30.0)
    t = tel.time_s
    accel = tel.accel_mps2.copy()
    accel[:, 1] += 3e-3 * np.sin(2 * np.pi * 37.0 * t)  # 300 ug, eight times the per-sample noise
    tel.accel_mps2 = accel
    gyro = tel.gyro_rad_s.copy()
    gyro[:, 2] += 2e-5 * (t - t[0]) / (t[-1] - t[0])  # a 4 deg/h drift over the record, bias not constant
    tel.gyro_rad_s = gyro
    d = D.diagnose(tel, NOMINAL, keep_series=False)
    lines = [u for u in d.unexplained if u["kind"] == "spectral_line"]
    assert any(u["channel"] == "accel_y" and abs(u["frequency_hz"] - 37.0) < 0.5 for u in lines), d.unexplained
    assert not [u for u in lines if u["channel"] != "accel_y"], d.unexplained
    assert any(u["channel"] == "gyro_z" and u["kind"] in ("trend", "step") for u in d.unexplained), d.unexplained
    text = D.format_report(d, "test")
    assert "consistent with sensor noise" not in text and "UNEXPLAINED" in text


def test_coloured_noise_widens_the_errors_honestly():
    """A bias random walk far above the white noise (a drifting MEMS-like accelerometer), on a lever
    arm record: the block-sandwich errors grow above the white ones and still cover the truth."""
    tel, truth = record({"lever_arm": HIDDEN["lever_arm"]}, seed=27)
    white = D.diagnose(tel, NOMINAL, keep_series=False)
    rng = np.random.default_rng(27)
    step = 4e-4 / np.sqrt(RATE_HZ)  # a walk of 4e-4 m/s^2/sqrt(s), whatever the rate: ~3 mg wander in a minute
    walk = np.cumsum(rng.normal(0.0, step, size=tel.accel_mps2.shape), axis=0)
    tel.accel_mps2 = tel.accel_mps2 + walk
    d = D.diagnose(tel, NOMINAL, keep_series=False)
    assert "lever_arm" in ids(d)
    assert_within_3_sigma(d, truth, {"lever_arm"})
    ratios = [d.sigma_theta[j] / white.sigma_theta[j] for j in D.LEVER[3:6]]
    assert min(ratios) > 1.2, ratios  # the colour is accounted for, not called white


def test_report_version_2_validates_and_version_1_still_reads(tmp_path):
    tel, _ = record({"accel_delay": HIDDEN["accel_delay"]}, seed=28, rate_hz=400.0, duration_s=20.0)
    d = D.diagnose(tel, NOMINAL, keep_series=False)
    doc = D.to_json(d, "test")
    assert doc["schema"] == "sizefx/diagnosis/2"
    for key in ("warnings", "unexplained", "rejected", "not_revealed", "consistency", "grade", "bandwidth_reason"):
        assert key in doc
    assert all(0.0 <= e["explained_fraction"] <= 1.0 for e in doc["effects"])
    v1 = {
        "schema": "sizefx/diagnosis/1",
        "record": "old.h5",
        "start_model": "nominal",
        "effects": [],
        "not_revealed": [],
        "residual_rms_before": dict.fromkeys(D.CHANNELS, 1.0),
        "residual_rms_after": dict.fromkeys(D.CHANNELS, 1.0),
        "model": None,
        "samples": 10,
        "noise_sigma": dict.fromkeys(D.CHANNELS, 1.0),
        "kappa": dict.fromkeys(D.CHANNELS, 1.0),
        "passes": 1,
    }
    path = tmp_path / "old.json"
    path.write_text(json.dumps(v1))
    assert D.read_diagnosis(path)["schema"] == "sizefx/diagnosis/1"
    path.write_text(json.dumps({**v1, "schema": "sizefx/diagnosis/9"}))
    with pytest.raises(ConfigError, match="not a diagnosis report"):
        D.read_diagnosis(path)


def test_the_grade_is_inferred_from_the_imus_own_noise_not_the_residual():
    """A hand-held motion (rad/s at 1-3 Hz) on top of white noise of known density: the density comes
    out within 10 % (Welch, octave medians above the motion, 40 s at 286 Hz), whatever the motion, and
    within 15 % behind an anti-alias filter; the grades follow the limits."""
    from sizefx.diagnose.plausibility import infer_grade, noise_density

    rng = np.random.default_rng(9)
    dt_s, n = 1.0 / 286.0, 286 * 40
    t = np.arange(n) * dt_s
    density = np.array([1e-5, 2e-5, 3e-5, 2e-4, 3e-4, 4e-4])  # rad/s*sqrt(s), m/s^2*sqrt(s)
    motion = 3.0 * np.sin(2 * np.pi * 1.3 * t)[:, None] + 2.0 * np.sin(2 * np.pi * 2.9 * t)[:, None]
    measured = motion + rng.normal(size=(n, 6)) * density / np.sqrt(dt_s)
    got = noise_density(measured, np.ones(n, bool), dt_s)
    assert np.allclose(got, density, rtol=0.1), got / density
    assert infer_grade(got)[0] == "tactical"  # gyro 0.034 deg/sqrt(h), accelerometer 20 ug/sqrt(Hz)
    # an anti-alias low-pass at a quarter of the sample rate leaves the plateau below it
    from scipy.signal import butter, sosfiltfilt

    filtered = sosfiltfilt(butter(6, 0.5, output="sos"), measured, axis=0)
    assert np.allclose(noise_density(filtered, np.ones(n, bool), dt_s), density, rtol=0.15)
    assert infer_grade(got * 100)[0] == "industrial"
    assert infer_grade(got / 100)[0] == "navigation"


def test_a_slow_motion_does_not_leak_into_the_noise_plateau_at_100_hz():
    """A tumble-like motion (1 rad/s at 0.05-0.16 Hz) over a navigation gyro's white noise (0.00035
    deg/sqrt(h)) at 100 Hz, where the plateau is looked for from 5 Hz: the density within 10 %. The
    window's leakage from the motion, about 1e11 times the noise's power, put four times the noise
    into the octave above 5 Hz before the spectrum was taken of the first differences."""
    from sizefx.diagnose.plausibility import noise_density

    rng = np.random.default_rng(4)
    dt_s, n = 0.01, 12000
    t = np.arange(n) * dt_s
    arw = 0.00035 * np.pi / 180 / 60  # rad/sqrt(s)
    motion = sum(
        a * np.sin(2 * np.pi * f * t + p) for a, f, p in ((1.0, 0.05, 0.3), (0.6, 0.11, 1.1), (0.4, 0.16, 2.0))
    )
    measured = motion[:, None] + rng.normal(size=(n, 6)) * arw / np.sqrt(dt_s)
    got = noise_density(measured, np.ones(n, bool), dt_s)
    np.testing.assert_allclose(got, arw, rtol=0.1)
