"""The reference's mount (``reference_mount``): simulate hides it, diagnose finds it.

The IMU's axes are the reference's body axes turned by three small angles (a motion-capture
marker body, a turntable fixture); :func:`sizefx.sensor_model.mount_matrix` states the sign.
Records as in ``tests/test_diagnose.py``: the tumble at 100 Hz for 60 s (the noise is a density:
the mount shows as far above its errors as at 400 Hz, in a quarter of the samples), navigation-grade
noise, the paper's high-precision arms, the start model with the same arms.
"""

from __future__ import annotations

import numpy as np
import pytest

from sizefx import diagnose as D
from sizefx import scenarios
from sizefx import sensor_model as sm
from sizefx.constants import ARCSEC
from sizefx.diagnose.theta import MOUNT  # not (yet) re-exported by sizefx.diagnose, whose __init__ the lead owns
from sizefx.effects import IDEAL, load_effects
from sizefx.simulate import simulate_in_memory, true_motion

RATE_HZ = 100.0
DURATION_S = 60.0
BASE = {
    "lever_arm": {"enabled": True, "preset": "high-precision"},
    "accel_noise": {"enabled": True},
    "gyro_noise": {"enabled": True},
}
NOMINAL = D.theta_from_model(load_effects(base=IDEAL, overrides={"lever_arm": {"enabled": True}}))
MOUNT_ARCSEC = [30.0, -20.0, 45.0]
#: The HIDDEN pattern of tests/test_diagnose.py, for the one effect this file adds.
HIDDEN = {"reference_mount": {"enabled": True, "arcsec": MOUNT_ARCSEC}}


def record(hidden: dict, *, seed=2, axes="zyx", rate_hz=RATE_HZ, duration_s=DURATION_S, noise=True):
    overrides = {k: dict(v) for k, v in BASE.items()}
    if not noise:
        overrides["accel_noise"]["enabled"] = overrides["gyro_noise"]["enabled"] = False
    for name, values in hidden.items():
        overrides.setdefault(name, {}).update(values)
    fx = load_effects(base=IDEAL, overrides=overrides)
    tel = simulate_in_memory(scenarios.tumble(duration_s, axes=axes), fx, rate_hz=rate_hz, form="rates", seed=seed)
    return tel, D.theta_from_model(fx)


def test_simulate_turns_the_whole_motion_into_the_imus_axes():
    """With a mount the true rates, angular accelerations and specific force are the reference's
    times C_b_b', and the IMU's attitude is the reference's times C_b'_b."""
    traj = scenarios.tumble(5.0)
    t = np.linspace(0.5, 4.5, 200)
    psi = np.array(MOUNT_ARCSEC) * ARCSEC
    plain = true_motion(traj, t, sm.SensorParams())
    mounted = true_motion(traj, t, sm.SensorParams(reference_mount=psi))
    c = sm.mount_matrix(sm.SensorParams(reference_mount=psi))
    # rounding of rates ~1 rad/s, accelerations ~10 rad/s^2 and ~10 m/s^2 through two products
    np.testing.assert_allclose(mounted.omega_ib_b, plain.omega_ib_b @ c.T, rtol=0, atol=1e-14)
    np.testing.assert_allclose(mounted.omegadot_ib_b, plain.omegadot_ib_b @ c.T, rtol=0, atol=1e-13)
    np.testing.assert_allclose(mounted.f_b, plain.f_b @ c.T, rtol=0, atol=1e-13)
    np.testing.assert_allclose(mounted.mat_nb, plain.mat_nb @ c.T, rtol=0, atol=1e-15)
    # and the mount is not lost in rounding: it moves the specific force by g psi, ~4e-3 m/s^2
    assert np.abs(mounted.f_b - plain.f_b).max() > 1e-3


def test_prediction_with_the_mount_reproduces_the_simulation_and_the_jacobian_its_twin():
    """Noise-free, mount and arms on: the prediction from the reference (whose body axes are not
    the IMU's) reproduces the simulation, which it does not without the mount; the analytic
    mount columns match central differences of the prediction.

    Floors as in tests/test_diagnose.py: the reference splines for the gyros (1e-8 rad/s), the
    Savitzky-Golay gyro derivative in the lever terms for the accelerometers (1e-9 m/s^2).
    """
    tel, truth = record(HIDDEN, duration_s=10.0, rate_hz=200.0, noise=False)
    pred = D.Predictor(tel)
    m = pred.mask
    r = (pred.measured - pred.predict(truth))[m]
    assert np.abs(r[:, :3]).max() < 1e-8 and np.abs(r[:, 3:]).max() < 1e-9
    without = truth.copy()
    without[MOUNT] = 0.0
    r0 = (pred.measured - pred.predict(without))[m]
    assert np.abs(r0[:, :3]).max() > 100 * 1e-8 and np.abs(r0[:, 3:]).max() > 100 * 1e-9
    fast = D.jacobian_columns(truth, pred.terms(truth), pred.t)
    slow = D.numeric_jacobian(pred.predict, truth, m)
    for j in MOUNT:
        ch, col = fast[j]
        assert list(ch) == list(range(6))  # the mount acts on every channel
        full_slow = np.zeros((m.size, 6))
        full_slow[:, slow[j][0]] = slow[j][1]
        scale = np.abs(full_slow[m]).max()
        # exact columns; the difference is the twin's own error (steps of 1e-5 rad: truncation
        # h^2/6 of the second-order terms, 2e-11 relative) and the 1e-8 pull of G on the lever
        # terms the analytic columns leave out
        assert np.abs(col[m] - full_slow[m]).max() <= 1e-7 * scale, D.PARAMS[j]


def test_the_mount_is_found_within_3_sigma_and_not_taken_for_misalignments():
    tel, truth = record(HIDDEN)
    d = D.diagnose(tel, NOMINAL, keep_series=False)
    ids = {e.id for e in d.effects}
    assert ids == {"reference_mount"}, d.log
    assert not ids & {"gyro_misalignment", "accel_misalignment"}
    checked = 0
    for j in MOUNT:
        z = (d.theta[j] - truth[j]) / d.sigma_theta[j]
        label = D.PARAMS[j].label
        assert abs(z) < 3.0, f"{label}: {d.theta[j] / ARCSEC:.3f} arcsec vs {truth[j] / ARCSEC}, z = {z:.2f}"
        checked += 1
    assert checked == 3
    mount = next(e for e in d.effects if e.id == "reference_mount")
    assert mount.params["arcsec"] == pytest.approx(MOUNT_ARCSEC, abs=3 * max(mount.sigma["arcsec"]))
    assert mount.sentence.startswith("the IMU sits rotated against the reference's body frame by ")
    assert "arcsec about z" in mount.sentence and "(marker body or fixture alignment)" in mount.sentence
    assert 0.0 < mount.explained_fraction <= 1.0
    # the tumble reveals all three angles; what it shows only nearly collinear with the mount (a gyro
    # misalignment) is fitted beside it and named, never the mount itself
    assert all("fitted beside it" in u.reason and u.id != "reference_mount" for u in d.unrevealed), d.unrevealed
    # the extended model carries it, in arcsec, and loads back as the same vector
    doc = D.model_document(d.theta)
    assert doc["reference_mount"]["enabled"]
    np.testing.assert_allclose(doc["reference_mount"]["arcsec"], d.theta[MOUNT] / ARCSEC, rtol=1e-15)
    back = D.theta_from_model(load_effects(base=IDEAL, overrides=doc))
    np.testing.assert_allclose(back[MOUNT], d.theta[MOUNT], rtol=1e-12)  # arcsec -> rad and back


def test_rotation_about_the_vertical_cannot_tell_the_mount_from_misalignments_and_biases():
    """Turning about z only: a mount about z is a heading offset, which neither the gyros
    (omega x e_z = 0) nor the accelerometers (gravity along z) can see. About x and y the gyros see
    the rate about z leak into them (omega x e_x, omega x e_y) exactly as their own misalignments
    x->z and y->z would (canonical correlation above 0.99), and the accelerometers see a tilt of
    gravity as their biases would. Fitted beside those misalignments the mount is no finding: it is
    named indistinguishable, and the extended model still carries it, within 3 sigma of the truth."""
    tel, truth = record(HIDDEN, axes="z", duration_s=30.0, rate_hz=200.0)
    d = D.diagnose(tel, NOMINAL, keep_series=False)
    assert "reference_mount" not in {e.id for e in d.effects}, d.log
    mount = {tuple(u.parameters): u.reason for u in d.unrevealed if u.id == "reference_mount"}
    assert "indistinguishable" in mount.get(("x", "y"), ""), d.unrevealed
    assert "does not excite" in mount.get(("z",), ""), d.unrevealed  # named apart, for its own reason
    beside = {u.channel for u in d.unrevealed if u.id == "gyro_misalignment" and "fitted beside it" in u.reason}
    assert beside == {"gyro_x", "gyro_y"}, d.unrevealed
    for j in MOUNT[:2]:
        assert abs(d.theta[j] - truth[j]) < 3.0 * d.sigma_theta[j], D.PARAMS[j]


def test_the_json_report_carries_the_mount():
    tel, _ = record(HIDDEN, duration_s=20.0, rate_hz=200.0)
    d = D.diagnose(tel, NOMINAL, keep_series=False)
    doc = D.to_json(d, "test")  # checks the document against its schema
    assert [e["id"] for e in doc["effects"]] == ["reference_mount"]
    assert len(doc["effects"][0]["parameters"]["arcsec"]) == 3
