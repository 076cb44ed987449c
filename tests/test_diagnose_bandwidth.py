"""diagnose's automatic bandwidth: where the record's reference stops being trustworthy.

Records: the tumble scenario at 400 Hz for 30 s with navigation-grade noise, as in
tests/test_diagnose.py, with its exact reference and with motion-capture-like noise added to
the reference (attitude and position white noise at 200 Hz, no velocity: both differentiated
as for motion capture); and BROAD trial 07 (a hand-held IMU tracked by motion capture).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.interpolate import CubicSpline
from scipy.spatial.transform import Rotation
from support import real_data

from sizefx import diagnose as D
from sizefx import scenarios
from sizefx.diagnose.bandwidth import (
    BandChoice,
    choose_bandwidth,
    readable_ceil,
    readable_floor,
    spline_derivative_error,
)
from sizefx.effects import IDEAL, load_effects
from sizefx.simulate import simulate_in_memory

RATE_HZ = 400.0
DURATION_S = 30.0
BASE = {
    "lever_arm": {"enabled": True, "preset": "high-precision"},
    "accel_noise": {"enabled": True},
    "gyro_noise": {"enabled": True},
}
NOMINAL = D.theta_from_model(load_effects(base=IDEAL, overrides={"lever_arm": {"enabled": True}}))
#: A hand-held rotation: the tumble's three sinusoids at 1.1-2.3 Hz and 20-30 deg, the band where
#: motion capture tracks a hand (BROAD: 1-8 Hz). The default table tumble (0.05-0.12 Hz) has no
#: motion above 0.2 Hz, so a noisy reference is untrustworthy from below 1 Hz there
#: (test_a_slow_motion_keeps_its_band).
HAND = {"freqs_hz": (1.1, 1.7, 2.3), "amplitudes_deg": (30.0, 20.0, 25.0)}
#: Motion capture at 200 Hz: 0.3 deg of attitude noise and 0.5 mm of position noise per row (BROAD's
#: markers give ~0.5 mm; the attitude from a marker body a few cm wide, a few tenths of a degree).
MOCAP_EVERY = 2
MOCAP_ATTITUDE_DEG = 0.3
MOCAP_POSITION_M = 5e-4
EARTH_RADIUS_M = 6.371e6  # metres to radians of latitude and longitude for the position noise


def record(motion: dict | None = None):
    fx = load_effects(base=IDEAL, overrides=BASE)
    return simulate_in_memory(scenarios.tumble(DURATION_S, **(motion or {})), fx, rate_hz=RATE_HZ, form="rates", seed=2)


def with_mocap_noise(tel, *, seed=0):
    """``tel`` with its reference thinned to 200 Hz and white noise added to attitude and position."""
    rng = np.random.default_rng(seed)
    ref = tel.reference
    rows = slice(None, None, MOCAP_EVERY)
    m = ref.time_s[rows].size
    noise = Rotation.from_rotvec(rng.normal(0.0, np.radians(MOCAP_ATTITUDE_DEG), (m, 3)))
    quat = (Rotation.from_quat(ref.quat_nb[rows][:, [1, 2, 3, 0]]) * noise).as_quat()[:, [3, 0, 1, 2]]
    lat = ref.lat_rad[rows] + rng.normal(0.0, MOCAP_POSITION_M, m) / EARTH_RADIUS_M
    lon = ref.lon_rad[rows] + rng.normal(0.0, MOCAP_POSITION_M, m) / (EARTH_RADIUS_M * np.cos(ref.lat_rad[rows]))
    h = ref.height_m[rows] + rng.normal(0.0, MOCAP_POSITION_M, m)
    noisy = dataclasses.replace(
        ref, time_s=ref.time_s[rows], quat_nb=quat, lat_rad=lat, lon_rad=lon, height_m=h, velocity_n_mps=None
    )
    return dataclasses.replace(tel, reference=noisy)


def choose(tel, theta0=NOMINAL, rows=False) -> BandChoice:
    """The band of ``tel``; ``rows``: with the reference's row spacing, as diagnose asks for it."""
    pred = D.Predictor(tel)
    spacing = float(np.median(np.diff(tel.reference.time_s))) if rows else None
    return choose_bandwidth(pred.t, pred.measured, pred.predict(theta0), pred.mask, pred.dt, reference_dt_s=spacing)


@pytest.mark.parametrize("motion", [None, HAND], ids=["table", "hand"])
def test_an_exact_reference_leaves_the_full_band(motion):
    choice = choose(record(motion))
    assert choice.bandwidth_hz is None, choice.reason
    assert set(choice.per_channel) == set(D.CHANNELS)
    assert all(v is None for v in choice.per_channel.values()), choice.per_channel
    assert "full band" in choice.reason


@pytest.mark.parametrize("f_hz", [2.0, 8.0, 20.0])
def test_the_splines_error_is_the_cubic_splines_own(f_hz):
    """The closed form against scipy's CubicSpline through 100 Hz samples of a sinusoid, away from its
    ends: the largest relative error of the derivative at the knots (1.4e-6, 3.7e-4, 1.7e-2)."""
    h, w = 0.01, 2.0 * np.pi * f_hz
    t = np.arange(0.0, 20.0, h)
    inside = slice(200, -200)
    slope = CubicSpline(t, np.sin(w * t))(t, 1)[inside] / w
    worst = np.max(np.abs(slope - np.cos(w * t)[inside]))
    assert worst == pytest.approx(float(spline_derivative_error(w * h)), rel=1e-6)


def test_a_fast_line_the_rows_cannot_resolve_is_cut_away():
    """A table tumble at 100 Hz with a small 25 Hz roll line (0.03 deg, 4.7 deg/s: 2 % of the rate's
    power, so the motion's band stays low): the splines through four rows a period read the line 4.5 %
    short, a gyro error 2000 times the noise. Without the row spacing the noise test keeps the full band;
    with it the band ends below the line, and diagnose there finds nothing, where the full band's fit
    selects gyro terms it then rejects as implausible."""
    traj = scenarios.tumble(DURATION_S, amplitudes_deg=(120.0, 70.0, 0.03), freqs_hz=(0.05, 0.083, 25.0))
    tel = simulate_in_memory(traj, load_effects(base=IDEAL, overrides=BASE), rate_hz=100.0, form="rates", seed=2)
    assert choose(tel).bandwidth_hz is None
    choice = choose(tel, rows=True)
    assert choice.bandwidth_hz is not None and choice.bandwidth_hz < 10.0, choice.reason
    assert "100 Hz rows resolve the motion above it too coarsely" in choice.reason
    cut = D.diagnose(tel, NOMINAL, keep_series=False)
    assert cut.bandwidth_hz == choice.bandwidth_hz
    assert not cut.effects and not cut.rejected, (cut.effects, cut.rejected)
    full = D.diagnose(tel, NOMINAL, keep_series=False, auto_bandwidth=False)
    assert any(r.id.startswith("gyro_") for r in full.rejected), full.rejected


@pytest.mark.slow
def test_a_helicopter_record_at_400_hz_is_cut_below_its_rotor_lines():
    """The long twin of the test above, the case inside the motion's band: a helicopter flight logged
    at 400 Hz, its rotor lines at 8, 16 and 32 Hz carrying most of the rates' power, no effect hidden.
    The splines misread the 16 and 32 Hz lines by far more than the noise (a full-band fit selects
    gyro scale factors and lever arms that are not there); the band is cut below the lines, the
    manoeuvres are kept, and nothing is found."""
    plan = scenarios.FlightPlan(
        duration_s=500.0,
        align_s=60.0,
        speed_mps=20.0,
        turn_rate_dps=10.0,
        altitude_m=100.0,
        weave_deg=0.0,
        climb_step_m=0.0,
    )
    tel = simulate_in_memory(
        scenarios.flight(plan)[0], load_effects(base=IDEAL, overrides=BASE), rate_hz=400.0, form="rates", seed=5
    )
    d = D.diagnose(tel, NOMINAL, keep_series=False)
    assert d.bandwidth_hz is not None and d.bandwidth_hz < 8.0, d.bandwidth_reason
    assert "what lies above the cut-off is left out" in d.bandwidth_reason
    assert not d.effects, [(e.id, e.channel) for e in d.effects]


def test_a_motion_capture_reference_is_cut_above_the_motion():
    exact = record(HAND)
    choice = choose(with_mocap_noise(exact))
    assert choice.bandwidth_hz is not None, choice.reason
    assert 2.0 <= choice.bandwidth_hz <= 30.0, choice.reason
    # the band keeps the motion (its fastest line is at 2.3 Hz) and says where the noise crossed
    assert choice.bandwidth_hz >= 2.3 or "motion's band" in choice.reason
    assert any(v is not None for v in choice.per_channel.values())
    assert f"{choice.bandwidth_hz:g} Hz" in choice.reason
    assert choice.motion_hz is not None and 1.0 < choice.motion_hz < 5.0  # 90 % of the power below, lines at 1-2.3 Hz


def test_a_slow_motion_keeps_its_band():
    """A table tumbling at 0.05-0.12 Hz under a noisy reference: the noise wins from below 1 Hz, the band
    follows the motion down but not below it."""
    choice = choose(with_mocap_noise(record()))
    assert choice.bandwidth_hz is not None and choice.bandwidth_hz <= 1.5, choice.reason
    assert choice.bandwidth_hz >= choice.motion_hz * 0.999, choice  # 0.999: the rounding is upwards here


def test_unusable_samples_are_left_out_of_the_spectra():
    """A second of garbage (100 m/s^2, 100 rad/s) in the measured record: masked out, or not finite, the band
    stays within one readable step (the segments change, and this band sits on the motion's edge); used, its
    power passes for the IMU's own noise and moves the band far up (25 Hz instead of 2.5 Hz)."""
    pred = D.Predictor(with_mocap_noise(record(HAND)))
    p = pred.predict(NOMINAL)
    clean = choose_bandwidth(pred.t, pred.measured, p, pred.mask, pred.dt)
    measured = pred.measured.copy()
    bad = (pred.t > 10.0) & (pred.t < 11.0)
    measured[bad] = np.random.default_rng(1).normal(0.0, 100.0, (bad.sum(), 6))
    used = choose_bandwidth(pred.t, measured, p, pred.mask, pred.dt).bandwidth_hz  # the mask matters:
    assert used is None or used > readable_ceil(1.3 * clean.bandwidth_hz), used  # the garbage hides the noise
    masked = choose_bandwidth(pred.t, measured, p, pred.mask & ~bad, pred.dt)
    measured[bad] = np.nan  # non-finite samples are never used, masked or not
    unfinite = choose_bandwidth(pred.t, measured, p, pred.mask, pred.dt)
    step_down, step_up = readable_floor(clean.bandwidth_hz / 1.3), readable_ceil(1.3 * clean.bandwidth_hz)
    for choice in (masked, unfinite):  # 1.3: one readable step (2.5 -> 3, 10 -> 12)
        assert choice.bandwidth_hz is not None, choice.reason
        assert step_down <= choice.bandwidth_hz <= step_up, (choice.reason, clean.reason)


def test_a_record_too_short_for_spectra_keeps_the_full_band_and_says_why():
    tel = record(HAND)
    pred = D.Predictor(tel)
    n = 600  # 1.5 s at 400 Hz: fewer than 8 half-overlapping segments of 128 samples
    choice = choose_bandwidth(pred.t[:n], pred.measured[:n], pred.predict(NOMINAL)[:n], pred.mask[:n], pred.dt)
    assert choice.bandwidth_hz is None and "fewer than" in choice.reason


@pytest.mark.parametrize(
    "f_hz, down, up",
    [
        (10.08, 10.0, 12.0),
        (12.7, 12.0, 15.0),
        (10.0, 10.0, 10.0),
        (0.63, 0.6, 0.8),
        (2.26, 2.0, 2.5),
        (97.0, 80.0, 100.0),
    ],
)
def test_readable_values(f_hz, down, up):
    assert readable_floor(f_hz) == pytest.approx(down, rel=1e-12)  # 1e-12: float powers of ten
    assert readable_ceil(f_hz) == pytest.approx(up, rel=1e-12)


def test_broad_trial_07_band_lies_where_the_hand_chosen_one_does(tmp_path):
    """The hand-held rotation of BROAD trial 07 under motion capture: tests/test_diagnose.py fits it below
    a hand-chosen 10 Hz; the automatic band must lie in 5-20 Hz (measured: 10 Hz, the specific force's
    reference noise crossing at 10.1 Hz on accel_z; trials 09, 16, 21: 10, 12, 6 Hz)."""
    trial = real_data("broad/07_undisturbed_fast_rotation_B.mat")
    from sizefx.importers import run_import
    from sizefx.io.telemetry import read_telemetry

    h5 = tmp_path / "broad07.h5"
    run_import("broad", trial, h5)
    theta0, _ = D.start_model("none")
    choice = choose(read_telemetry(h5), theta0)
    assert choice.bandwidth_hz is not None and 5.0 <= choice.bandwidth_hz <= 20.0, choice.reason
    for c in ("accel_x", "accel_y", "accel_z"):  # the position twice differentiated: noisy from 10-16 Hz
        assert choice.per_channel[c] is not None and choice.per_channel[c] < 20.0, choice.per_channel


def test_a_record_without_motion_says_so_instead_of_failing():
    """No band where the motion dominates (a part of a record where nothing moves, its reference noisy):
    the band still comes out, and the reason says there is no motion band (it once failed formatting
    a missing motion frequency)."""
    rng = np.random.default_rng(3)
    dt_s, n = 1.0 / 286.0, 286 * 40
    t_s = np.arange(n) * dt_s
    measured = 1e-3 * rng.normal(size=(n, 6))
    noise = np.cumsum(rng.normal(size=(n, 6)), axis=0)
    rising = np.gradient(np.gradient(noise, axis=0), axis=0)  # differentiated twice: power ~ f^4
    predicted = 1e-2 * rising  # nothing the IMU sees: no motion at all
    choice = choose_bandwidth(t_s, measured, predicted, np.ones(n, bool), dt_s)
    assert choice.motion_hz is None
    assert choice.bandwidth_hz is None or "no band where the motion dominates" in choice.reason, choice
