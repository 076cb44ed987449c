"""sizefx.diagnose.integrity: a broken reference is found, named and split; a clean one is left alone.

Records: the tumble (every axis turning, up to ~0.7 rad/s) at 400 Hz with navigation-grade noise,
20-30 s, and the reference decimated to 200 Hz (two IMU samples per reference step), corrupted in
memory the way motion capture and re-mounted fixtures corrupt it.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from support import real_data

from sizefx import scenarios
from sizefx.constants import DEG
from sizefx.diagnose import integrity as I
from sizefx.diagnose.reference import ReferenceMotion, usable_mask
from sizefx.effects import IDEAL, load_effects
from sizefx.simulate import simulate_in_memory

RATE_HZ = 400.0
REF_DECIMATION = 2  # reference at 200 Hz
BASE = {"accel_noise": {"enabled": True}, "gyro_noise": {"enabled": True}}
#: Small sensor errors and a 2 ms reference delay: what every real record carries, never an alarm.
ORDINARY = {
    "reference_delay": {"enabled": True, "tau_s": 0.002},
    "accel_bias": {"enabled": True, "bias_ug": [300.0, -200.0, 500.0]},
    "gyro_bias": {"enabled": True, "deg_per_h": [5.0, -4.0, 3.0]},
    "gyro_scale_factor": {"enabled": True, "ppm": [500.0, -300.0, 400.0]},
    "accel_scale_factor": {"enabled": True, "ppm": [500.0, -300.0, 200.0]},
}


def record(extra=None, *, seed=3, duration_s=30.0, decimation=REF_DECIMATION, traj=None):
    overrides = {k: dict(v) for k, v in BASE.items()}
    overrides.update(extra or {})
    fx = load_effects(base=IDEAL, overrides=overrides)
    tel = simulate_in_memory(traj or scenarios.tumble(duration_s), fx, rate_hz=RATE_HZ, form="rates", seed=seed)
    ref = tel.reference
    keep = slice(None, None, decimation)
    tel.reference = replace(
        ref,
        **{
            k: getattr(ref, k)[keep]
            for k in ("time_s", "quat_nb", "lat_rad", "lon_rad", "height_m", "velocity_n_mps")
            if getattr(ref, k) is not None
        },
    )
    return tel


def kinds(check):
    return [w.kind for w in check.warnings]


def test_clean_records_raise_nothing():
    """Tumble and sway, with a 2 ms reference delay and sensor errors far above navigation grade."""
    sway = scenarios.sway(
        scenarios.SwayPlan(axis="pitch", amplitudes_dps=(20.0,), frequency_hz=1.0, static_s=2.0, segment_s=18.0)
    )[0]
    for tel in (
        record(),
        record(ORDINARY, seed=5),
        record(ORDINARY, traj=sway, seed=6),
        record(ORDINARY, decimation=1, seed=7),
    ):
        check = I.check_reference(tel)
        assert check.warnings == [], check.warnings
        assert check.bad_rows.size == 0 and check.breaks_s == ()


def test_single_row_attitude_glitches_are_found_at_their_times_and_masked():
    tel = record(ORDINARY, seed=11)
    ref = tel.reference
    rng = np.random.default_rng(1)
    sizes_deg = [0.5, 1.0, 2.0, 5.0]
    rows = [737, 1501, 2460, 4999]  # 3.7 s ... 25 s at 200 Hz
    q = ref.quat_nb.copy()
    for row, size in zip(rows, sizes_deg):
        axis = rng.normal(size=3)
        glitch = Rotation.from_rotvec(size * DEG * axis / np.linalg.norm(axis))
        r = Rotation.from_quat(q[row, [1, 2, 3, 0]]) * glitch  # a marker-body error: body side
        q[row] = r.as_quat()[[3, 0, 1, 2]]
    tel.reference = replace(ref, quat_nb=q)
    check = I.check_reference(tel)
    assert kinds(check) == ["reference_glitch"] * len(rows), check.warnings
    assert check.bad_rows.tolist() == rows
    assert check.breaks_s == ()
    for w, row, size in zip(check.warnings, rows, sizes_deg):
        assert w.time_s == pytest.approx(ref.time_s[row])
        assert w.unit == "rad" and w.quantity == "attitude"
        assert w.size == pytest.approx(size * DEG, rel=0.05)  # one 5 ms step of rotation at most
        assert "masked" in w.message and "deg" in w.message
    cleaned = I.without_bad_rows(tel, check)
    assert cleaned.reference.time_s.size == ref.time_s.size - len(rows)
    assert I.check_reference(cleaned).warnings == []


def remount(tel, t_remount_s, angle_deg=90.0):
    """From ``t_remount_s`` on, the IMU sits on another face (90 deg about body x) and the reference follows it."""
    mount = Rotation.from_rotvec([angle_deg * DEG, 0.0, 0.0])  # C_b_old_b_new
    ref = tel.reference
    after = ref.time_s >= t_remount_s
    q = ref.quat_nb.copy()
    q[after] = (Rotation.from_quat(q[after][:, [1, 2, 3, 0]]) * mount).as_quat()[:, [3, 0, 1, 2]]
    tel.reference = replace(ref, quat_nb=q)
    late = tel.time_s >= t_remount_s
    m_new_old = mount.inv().as_matrix()
    tel.gyro_rad_s = tel.gyro_rad_s.copy()
    tel.accel_mps2 = tel.accel_mps2.copy()
    tel.gyro_rad_s[late] = tel.gyro_rad_s[late] @ m_new_old.T
    tel.accel_mps2[late] = tel.accel_mps2[late] @ m_new_old.T
    return tel


def test_a_remount_is_one_discontinuity_and_the_split_motion_reproduces_the_gyros():
    t_remount_s = 12.0
    tel = remount(record(ORDINARY, seed=12, duration_s=24.0), t_remount_s)
    check = I.check_reference(tel)
    assert kinds(check) == ["reference_discontinuity"], check.warnings
    period_s = 1.0 / (RATE_HZ / REF_DECIMATION)
    assert len(check.breaks_s) == 1 and abs(check.breaks_s[0] - t_remount_s) <= period_s
    assert check.warnings[0].size == pytest.approx(90.0 * DEG, rel=0.01)  # the mount, plus one step's noise
    assert check.bad_rows.size == 0

    def gyro_error_rad_s(tel, breaks_s):
        motion = ReferenceMotion(tel, breaks_s=breaks_s)
        mask = usable_mask(tel.time_s, tel, window=5, dt=1.0 / RATE_HZ, breaks_s=breaks_s)
        t = tel.time_s[mask]
        kin = motion.evaluate(t)
        w_ib_b = kin["w_nb"] + np.einsum("nij,nj->ni", kin["C_bn"], kin["w_in"])
        return np.abs(w_ib_b - tel.gyro_rad_s[mask]).max(), t

    split_error, t = gyro_error_rad_s(tel, check.breaks_s)
    assert (t < t_remount_s - 1.0).any() and (t > t_remount_s + 1.0).any()  # both sides are used
    # as well as the same record never re-mounted: its error is ORDINARY's biases, scale factors and
    # 2 ms delay (~2e-3 rad/s); the split adds only the end conditions' pull near the break (< 1e-4 rad/s
    # beyond the edge margin)
    unbroken_error, _ = gyro_error_rad_s(record(ORDINARY, seed=12, duration_s=24.0), ())
    assert split_error < unbroken_error + 1e-4, (split_error, unbroken_error)
    through_error, _ = gyro_error_rad_s(tel, ())
    assert through_error > 0.3, through_error  # one spline through the jump: of order rad/s near it


def test_a_dropout_is_reported_as_a_gap():
    tel = record(seed=13, duration_s=20.0)
    ref = tel.reference
    keep = ~((ref.time_s > 8.0) & (ref.time_s < 8.25))
    tel.reference = replace(
        ref,
        **{k: getattr(ref, k)[keep] for k in ("time_s", "quat_nb", "lat_rad", "lon_rad", "height_m", "velocity_n_mps")},
    )
    check = I.check_reference(tel)
    assert kinds(check) == ["reference_gap"], check.warnings
    w = check.warnings[0]
    assert w.time_s == pytest.approx(8.0) and w.size == pytest.approx(0.25) and w.unit == "s"
    assert "ms" in w.message


def test_a_rate_change_is_reported():
    tel = record(seed=14, duration_s=20.0, decimation=1)
    ref = tel.reference
    keep = (ref.time_s < 10.0) | (np.arange(ref.time_s.size) % 2 == 0)  # 400 Hz, then 200 Hz
    tel.reference = replace(
        ref,
        **{k: getattr(ref, k)[keep] for k in ("time_s", "quat_nb", "lat_rad", "lon_rad", "height_m", "velocity_n_mps")},
    )
    check = I.check_reference(tel)
    assert kinds(check) == ["reference_rate_change"], check.warnings
    w = check.warnings[0]
    assert abs(w.time_s - 10.0) < 0.05  # within a running-median window (25 rows)
    assert w.size == pytest.approx(2.5e-3)  # the period grows from 2.5 to 5 ms


def test_a_velocity_glitch_is_found():
    tel = record(seed=15, duration_s=20.0)
    ref = tel.reference
    v = ref.velocity_n_mps.copy()
    v[1234] += [0.3, -0.2, 0.1]  # m/s, one row
    tel.reference = replace(ref, velocity_n_mps=v)
    check = I.check_reference(tel)
    assert kinds(check) == ["reference_velocity_glitch"], check.warnings
    assert check.bad_rows.tolist() == [1234] and check.warnings[0].unit == "m/s"


def test_without_breaks_the_motion_is_the_single_spline():
    tel = record(seed=16, duration_s=10.0)
    t = tel.time_s[100:-100]
    one, split = ReferenceMotion(tel).evaluate(t), ReferenceMotion(tel, breaks_s=()).evaluate(t)
    for key in one:
        np.testing.assert_array_equal(one[key], split[key])


# --------------------------------------------------------------------------- real data: BROAD


def test_broad_07_has_no_glitch_or_discontinuity(tmp_path):
    trial = real_data("broad/07_undisturbed_fast_rotation_B.mat")
    from sizefx.importers import run_import
    from sizefx.io.telemetry import read_telemetry

    h5 = tmp_path / "broad07.h5"
    run_import("broad", trial, h5)
    check = I.check_reference(read_telemetry(h5, allow_gaps=True))
    bad = [w for w in check.warnings if "glitch" in w.kind or "discontinuity" in w.kind]
    assert bad == [] and check.breaks_s == (), bad
