"""Physics of the simulator, each against a closed form or an independent computation.

Tolerances are per quantity, with the reason next to each.
"""

from __future__ import annotations

import numpy as np
import pytest

from sizefx import scenarios
from sizefx.constants import ARCSEC, DEG, MICRO_G, OMEGA_EARTH_RAD_S
from sizefx.effects import IDEAL, load_effects
from sizefx.errors import OutputError
from sizefx.io.telemetry import read_telemetry
from sizefx.motion import ProfileBuilder, RotationChain, StaticSite, Trajectory
from sizefx.rotation import quat_to_mat
from sizefx.simulate import GAUSS_NODES, ImuSynthesizer, SimulateConfig, kinematics, run, simulate_to_file

SITE0 = scenarios.SiteSpec(57.9825, 55.7089, 0.0)  # height 0: pure Somigliana gravity


def somigliana(lat):
    """Normal gravity on the WGS-84 ellipsoid, written out independently (NIMA TR8350.2 eq. 4-1)."""
    s2 = np.sin(lat) ** 2
    return 9.7803253359 * (1 + 0.00193185265241 * s2) / np.sqrt(1 - 0.00669437999014 * s2)


def ideal(**sections):
    """Ideal model plus the named sections (``lever_arm={"enabled": True, ...}``)."""
    return load_effects(overrides=sections, base=IDEAL)


# --------------------------------------------------------------------------- closed forms


def test_static_record_reads_normal_gravity_and_earth_rate(tmp_path, short_turntable_plan):
    path = tmp_path / "static.h5"
    run(SimulateConfig("turntable", path, plan=short_turntable_plan, site=SITE0, ideal=True))
    tel = read_telemetry(path)
    static = tel.time_s < short_turntable_plan.static_s
    lat = np.radians(SITE0.latitude_deg)
    # Z-down, heading 0: body axes = NED axes
    f_expected = np.array([0.0, 0.0, -somigliana(lat)])
    w_expected = OMEGA_EARTH_RAD_S * np.array([np.cos(lat), 0.0, -np.sin(lat)])
    # float64 arithmetic on ~10 m/s^2 and ~1e-4 rad/s: a few ulp
    np.testing.assert_allclose(tel.accel_mps2[static], np.tile(f_expected, (static.sum(), 1)), rtol=0, atol=1e-13)
    np.testing.assert_allclose(tel.gyro_rad_s[static], np.tile(w_expected, (static.sum(), 1)), rtol=0, atol=1e-18)


def test_constant_rotation_about_vertical_gives_minus_omega_squared_r():
    omega = 20 * DEG
    arms = {"d_x_m": [0.031, 0.004, -0.012], "d_y_m": [-0.007, 0.022, 0.009], "d_z_m": [0.002, -0.003, 0.027]}
    spin = ProfileBuilder(0.0).hold(30.0).build(rate0=omega)
    lat = np.radians(45.0)
    traj = Trajectory(StaticSite(lat, 0.3, 0.0), RotationChain([[0, 0, 1]], [spin]), 30.0)
    t = np.linspace(1.0, 29.0, 500)
    with_arms = kinematics(traj, t, ideal(lever_arm={"enabled": True, "preset": "none", **arms}))
    point = kinematics(traj, t, ideal())
    extra = with_arms.accel_input - point.accel_input
    w_z = omega - OMEGA_EARTH_RAD_S * np.sin(lat)  # body z is down: the table rate plus Earth's down component
    for i, key in ((0, "d_x_m"), (1, "d_y_m")):
        expected = -(w_z**2) * arms[key][i]
        # Neglected: Earth-rate cross terms, bounded by Omega_E (2 omega + Omega_E) |r_i| < 2e-6 m/s^2
        np.testing.assert_allclose(extra[:, i], expected, rtol=0, atol=2e-6)
    # the vertical channel feels no centripetal term from a vertical spin (only those cross terms)
    assert np.abs(extra[:, 2]).max() < 2e-6


def test_turntable_profile_has_the_papers_rate_acceleration_cycles_and_duration():
    plan = scenarios.TurntablePlan()
    traj, _ = scenarios.turntable(plan)
    blocks = [s for s in traj.segments if s[0].startswith("rotate")]
    assert [b[0] for b in blocks] == ["rotate Y", "rotate X", "rotate Z"]
    for name, t0, t1 in blocks:
        assert t1 - t0 == pytest.approx(120.0)  # two minutes per axis
        t = np.arange(t0, t1, 1e-3)
        mat, w, wd = traj.attitude.evaluate(t)
        axis = "XYZ".index(name[-1])
        # the rotation axis is vertical (body axis along NED down) throughout the block; the
        # gimbal angles reach 90 deg through polynomial pieces: rounding of order 1e-13 rad
        np.testing.assert_allclose(mat[:, :, axis], np.tile([0, 0, 1.0], (t.size, 1)), atol=1e-12)
        rate = w[:, axis]
        assert np.abs(rate).max() == pytest.approx(20 * DEG, rel=1e-9)
        assert wd[:, axis].max() == pytest.approx(10 * DEG, rel=1e-9)
        assert wd[:, axis].min() == pytest.approx(-10 * DEG, rel=1e-9)
        # the other two body axes stay in the horizontal plane: no rate about them (beyond
        # the 1e-13-rad rounding of the gimbal angles times the 0.35 rad/s table rate)
        assert np.abs(np.delete(w, axis, axis=1)).max() < 1e-12
        moving = np.sign(rate) * (np.abs(rate) > 1 * DEG)
        starts = np.flatnonzero(np.diff(moving) != 0)
        signs = moving[starts + 1]
        assert (signs > 0).sum() == 5 and (signs < 0).sum() == 5  # five positive and five negative rotations
        assert np.trapezoid(rate, t) == pytest.approx(0.0, abs=1e-9)  # back where it started
    # smooth: jerk bounded (jerk-limited transitions, no steps in angular acceleration)
    # (a 1 ms grid: a step of 10 deg/s^2 would read 175 rad/s^3 on it, the ramps 0.65)
    t = np.arange(0.0, traj.duration_s, 1e-3)
    _, _, wd = traj.attitude.evaluate(t)
    jerk = np.abs(np.diff(wd, axis=0)).max() / 1e-3
    assert jerk < 1.0  # rad/s^3; ramps of 10 deg/s^2 in 0.5 s peak at 1.875 * 0.1745 / 0.5 = 0.65


# --------------------------------------------------------------------------- consistency of outputs and truth


def test_increments_are_integrals_of_the_rates(short_turntable_plan):
    traj, _ = scenarios.turntable(short_turntable_plan)
    fx = ideal(lever_arm={"enabled": True})
    syn = ImuSynthesizer(traj, fx, form="increments")
    t, dtheta, dvel = syn.next_chunk(syn.n_samples)
    # independent quadrature: 20-point Gauss-Legendre on a subset of intervals
    x, wts = np.polynomial.legendre.leggauss(20)
    dt = 1 / 1600
    for k in range(0, t.size, 997):
        nodes = t[k] - dt / 2 + dt / 2 * x
        kin = kinematics(traj, nodes, fx)
        # 3-point Gauss on content below a few Hz at 1600 Hz: error far below 1e-15 of the increment
        np.testing.assert_allclose(dtheta[k], dt / 2 * wts @ kin.omega_ib_b, rtol=0, atol=1e-16)
        np.testing.assert_allclose(dvel[k], dt / 2 * wts @ kin.accel_input, rtol=0, atol=1e-15)
    assert GAUSS_NODES.size == 3


def test_gyros_agree_with_the_derivative_of_the_reference_attitude(tmp_path, short_turntable_plan):
    path = tmp_path / "tt.h5"
    run(SimulateConfig("turntable", path, plan=short_turntable_plan, site=SITE0, ideal=True))
    tel = read_telemetry(path)
    mat = quat_to_mat(tel.reference.quat_nb)
    h = tel.time_s[1] - tel.time_s[0]
    skew = np.einsum("nji,njk->nik", mat[1:-1], (mat[2:] - mat[:-2]) / (2 * h))
    w_nb = np.stack([skew[:, 2, 1], skew[:, 0, 2], skew[:, 1, 0]], axis=1)
    lat = np.radians(SITE0.latitude_deg)
    w_ie_n = OMEGA_EARTH_RAD_S * np.array([np.cos(lat), 0.0, -np.sin(lat)])
    w_ib = w_nb + np.einsum("nji,j->ni", mat[1:-1], w_ie_n)
    # central difference error h^2/6 |omega'''| with jerk-limited motion: < 1e-7 rad/s
    np.testing.assert_allclose(tel.gyro_rad_s[1:-1], w_ib, rtol=0, atol=1e-7)


@pytest.fixture(scope="module")
def short_flight():
    plan = scenarios.FlightPlan(duration_s=2400.0, align_s=300.0, weave_deg=8.0, climb_step_m=0.0)
    return scenarios.flight(plan)


def test_flight_specific_force_and_position_agree_with_the_reference_velocity(short_flight):
    from sizefx import earth

    traj, _ = short_flight
    fx = ideal()
    for t0 in (250.0, 400.0, 700.0, 1500.0, 2100.0):  # static, take-off, cruise, turn/return, landing
        t = np.array([t0])
        kin = kinematics(traj, t, fx)
        st = traj.evaluate(t)
        h = 1e-5
        vdot_fd = (traj.evaluate(t + h).v_n - traj.evaluate(t - h).v_n) / (2 * h)
        w_ie = earth.omega_ie_n(st.lat_rad)
        w_en = earth.omega_en_n(st.lat_rad, st.height_m, st.v_n)
        vdot = (
            np.einsum("nij,nj->ni", st.mat_nb, kin.f_b)
            + earth.gravity_n(st.lat_rad, st.height_m)
            - np.cross(2 * w_ie + w_en, st.v_n)
        )
        # FD truncation on 1 m/s^2 vibration at 16 Hz with h = 1e-5 s: ~2e-7 m/s^2
        np.testing.assert_allclose(vdot, vdot_fd, rtol=0, atol=1e-6)
        # position: lat' = v_N / (R_M + h), lon' = v_E / ((R_T + h) cos lat), h' = -v_D
        h = 1e-3
        a, b = traj.evaluate(t - h), traj.evaluate(t + h)
        r_mer, r_tr = earth.radii_m(st.lat_rad)
        v_from_pos = np.array(
            [
                (b.lat_rad - a.lat_rad)[0] / (2 * h) * (r_mer + st.height_m)[0],
                (b.lon_rad - a.lon_rad)[0] / (2 * h) * ((r_tr + st.height_m) * np.cos(st.lat_rad))[0],
                -(b.height_m - a.height_m)[0] / (2 * h),
            ]
        )
        # FD truncation on 0.1 mm vibration at 16 Hz with h = 1 ms: 1e-4 * (2 pi 16)^3 h^2 / 6 ~ 2e-5 m/s
        np.testing.assert_allclose(v_from_pos, st.v_n[0], rtol=0, atol=5e-5)


def test_flight_plan_goes_out_turns_and_lands_back_at_the_start(short_flight):
    from sizefx import earth

    traj, info = short_flight
    assert 170.0 < info["turn_deg"] < 190.0
    t = np.linspace(0, traj.duration_s, 4801)
    st = traj.evaluate(t)
    speed = np.hypot(st.v_n[:, 0], st.v_n[:, 1])
    assert speed.max() == pytest.approx(40.0, abs=0.05)  # plus sub-mm/s vibration
    assert st.height_m.max() == pytest.approx(SITE0.height_m + 120.0 + 300.0, abs=0.01)
    r_mer, r_tr = earth.radii_m(st.lat_rad[0])
    north = (st.lat_rad[-1] - st.lat_rad[0]) * r_mer
    east = (st.lon_rad[-1] - st.lon_rad[0]) * r_tr * np.cos(st.lat_rad[0])
    far = np.hypot((st.lat_rad - st.lat_rad[0]) * r_mer, (st.lon_rad - st.lon_rad[0]) * r_tr * np.cos(st.lat_rad[0]))
    assert far.max() > 10_000.0  # it went somewhere
    assert np.hypot(north, east) < 0.01 * far.max()  # and came back (planning is flat-Earth: ~1 %)
    assert st.height_m[-1] == pytest.approx(st.height_m[0], abs=1e-6)


def test_sway_rate_is_a_sine_with_the_given_amplitudes():
    traj, _ = scenarios.sway(scenarios.SwayPlan(static_s=10.0, segment_s=5.0, amplitudes_dps=(10.0, 30.0)))
    t = np.arange(0.0, traj.duration_s, 1e-3)
    _, w, _ = traj.attitude.evaluate(t)
    expected = np.where((t > 10) & (t <= 15), 10 * DEG * np.sin(2 * np.pi * (t - 10)), 0.0)
    expected = np.where(t > 15, 30 * DEG * np.sin(2 * np.pi * (t - 15)), expected)
    np.testing.assert_allclose(w[:, 2], expected, atol=1e-12)
    mat, _, _ = traj.attitude.evaluate(np.array([0.0, 15.0, 20.0]))
    np.testing.assert_allclose(mat[1], mat[0], atol=1e-12)  # heading back at each segment end


# --------------------------------------------------------------------------- effects appear as specified


@pytest.fixture(scope="module")
def z_plan_traj():
    plan = scenarios.TurntablePlan(axes="Z", static_s=5.0, seconds_per_axis=24.0, cycles=1, settle_s=5.0)
    return scenarios.turntable(plan, SITE0)[0]


def _chunk(traj, fx, form="rates", seed=0):
    syn = ImuSynthesizer(traj, fx, form=form, seed=seed)
    return syn.next_chunk(syn.n_samples)


def test_level_tilt_reads_g_times_the_tilt_on_the_horizontal_accelerometers(z_plan_traj):
    t, _, accel = _chunk(z_plan_traj, ideal(level_tilt={"enabled": True, "north_arcsec": -11.0, "east_arcsec": -6.0}))
    static = t < 5.0
    g = somigliana(np.radians(SITE0.latitude_deg))
    # f_b = -C_bn g_n with C_nb = R(phi): f_x = g phi_E, f_y = -g phi_N (Z down, heading 0)
    np.testing.assert_allclose(accel[static, 0], g * (-6.0 * ARCSEC), rtol=1e-6)
    np.testing.assert_allclose(accel[static, 1], -g * (-11.0 * ARCSEC), rtol=1e-6)
    assert accel[static, 0].mean() / MICRO_G == pytest.approx(-29.1, abs=0.1)  # the paper's "29 ug" (east)
    assert accel[static, 1].mean() / MICRO_G == pytest.approx(53.4, abs=0.1)  # the paper's "53 ug" (north)


def test_accel_delay_shifts_the_accelerometers_in_time(z_plan_traj):
    tau = 5e-4
    fx = ideal(lever_arm={"enabled": True}, accel_delay={"enabled": True, "tau_s": tau})
    t, gyro, accel = _chunk(z_plan_traj, fx)
    late = kinematics(z_plan_traj, t - tau, fx)
    now = kinematics(z_plan_traj, t, fx)
    np.testing.assert_array_equal(accel, late.accel_input)
    np.testing.assert_array_equal(gyro, now.omega_ib_b)
    assert np.abs(accel - now.accel_input).max() > 1e-6  # the delay is visible during rotation


def test_biases_scale_factors_quadratic_and_misalignment(z_plan_traj):
    fx = ideal(
        accel_bias={"enabled": True, "bias_ug": [30.0, -20.0, 50.0]},
        accel_scale_factor={"enabled": True, "ppm": [100.0, 0.0, -200.0]},
        accel_quadratic={"enabled": True, "ug_per_g2": [0.0, 0.0, 20.0]},
        gyro_bias={"enabled": True, "deg_per_h": [0.01, 0.0, -0.02]},
        gyro_scale_factor={"enabled": True, "ppm": [0.0, 0.0, 1000.0]},
    )
    t, gyro, accel = _chunk(z_plan_traj, fx)
    _, gyro0, accel0 = _chunk(z_plan_traj, ideal())
    f = accel0[:, 2]
    expected_z = (1 - 200e-6) * f + 20e-6 / 9.80665 * f * f + 50 * MICRO_G
    np.testing.assert_allclose(accel[:, 2], expected_z, rtol=1e-14)
    np.testing.assert_allclose(accel[:, 1], accel0[:, 1] - 20 * MICRO_G, atol=1e-15)
    np.testing.assert_allclose(gyro[:, 2], 1.001 * gyro0[:, 2] - 0.02 * DEG / 3600, rtol=1e-13)

    mis = ideal(accel_misalignment={"enabled": True, "arcsec": [[0, 100.0, 0], [0, 0, 0], [0, 0, 0]]})
    _, _, accel_m = _chunk(z_plan_traj, mis)
    # x's sensitive axis tilted 100 arcsec towards y: reads cos(a) f_x + sin(a) f_y
    a = np.arctan(100 * ARCSEC)
    np.testing.assert_allclose(accel_m[:, 0], np.cos(a) * accel0[:, 0] + np.sin(a) * accel0[:, 1], atol=1e-15)


def test_noise_levels_match_their_densities(z_plan_traj):
    fx = ideal(
        gyro_noise={"enabled": True, "rrw_deg_per_h_per_sqrt_h": 0.0},
        accel_noise={"enabled": True, "bias_rw_ug_per_sqrt_h": 0.0},
    )
    _, gyro, accel = _chunk(z_plan_traj, fx, seed=3)
    _, gyro0, accel0 = _chunk(z_plan_traj, ideal())
    n = gyro.size
    # sample sigma = density * sqrt(rate); relative standard error of a std over n samples ~ 1/sqrt(2n)
    tol = 4 / np.sqrt(2 * n)
    assert np.std(gyro - gyro0) == pytest.approx(0.00035 * DEG / 60 * 40.0, rel=tol)
    assert np.std(accel - accel0) == pytest.approx(2.5 * MICRO_G * 40.0, rel=tol)


def test_quantised_increments_carry_the_remainder(z_plan_traj):
    lsb = 0.1 * ARCSEC
    fx = ideal(quantisation={"enabled": True, "gyro_lsb_rad": lsb})
    _, dtheta, _ = _chunk(z_plan_traj, fx, form="increments")
    _, exact, _ = _chunk(z_plan_traj, ideal(), form="increments")
    counts = dtheta / lsb
    np.testing.assert_allclose(counts, np.round(counts), atol=1e-6)
    drift = np.abs(np.cumsum(dtheta - exact, axis=0)).max()
    assert drift <= 0.5 * lsb * (1 + 1e-9)  # never more than half a count behind the truth


def test_reference_delay_stamps_the_reference_late(z_plan_traj):
    tau = 2e-3
    syn = ImuSynthesizer(z_plan_traj, ideal(reference_delay={"enabled": True, "tau_s": tau}))
    t = np.linspace(6.0, 20.0, 50)
    q_late = syn.reference_rows(t)[0]
    q_true = ImuSynthesizer(z_plan_traj, ideal()).reference_rows(t - tau)[0]
    np.testing.assert_allclose(q_late, q_true, atol=1e-15)


def test_output_is_deterministic_and_independent_of_chunk_size(tmp_path, short_turntable_plan):
    traj, info = scenarios.turntable(short_turntable_plan)
    fx = load_effects()
    # at 400 Hz: 16 001 samples, one chunk of 2^16 or 21 of 777 (at 1600 Hz: one or 83)
    a = simulate_to_file(traj, info, fx, tmp_path / "a.h5", rate_hz=400.0, seed=5, chunk_samples=1 << 16)
    b = simulate_to_file(traj, info, fx, tmp_path / "b.h5", rate_hz=400.0, seed=5, chunk_samples=777)
    c = simulate_to_file(traj, info, fx, tmp_path / "c.h5", rate_hz=400.0, seed=6)
    ta, tb, tc = (read_telemetry(x.path) for x in (a, b, c))
    np.testing.assert_array_equal(ta.accel_mps2, tb.accel_mps2)
    np.testing.assert_array_equal(ta.gyro_rad_s, tb.gyro_rad_s)
    np.testing.assert_array_equal(ta.reference.quat_nb, tb.reference.quat_nb)
    assert np.abs(ta.accel_mps2 - tc.accel_mps2).max() > 0  # another seed, other noise


def test_truth_is_stored_in_si(tmp_path, short_turntable_plan):
    # the default effects (lever arms and noise), seed 0, as the full paper plan at 1600 Hz would
    # store them: the truth written does not depend on the plan's length or the rate
    path = tmp_path / "tt.h5"
    run(SimulateConfig("turntable", path, plan=short_turntable_plan, rate_hz=400.0, seed=0))
    tel = read_telemetry(path)
    fx = tel.simulation["effects"]
    assert fx["lever_arm"]["r_m"] == [[0.0249, 0, 0], [0, 0.0249, 0], [0, 0, 0.0249]]
    assert fx["gyro_noise"]["arw_rad_per_sqrt_s"] == pytest.approx(0.00035 * DEG / 60)
    assert tel.simulation["scenario"] == "turntable" and tel.simulation["seed"] == 0


def test_integrating_ideal_increments_reproduces_the_reference_attitude(tmp_path):
    """End to end: file -> strapdown attitude integration -> the file's own /reference.

    A two-sample coning algorithm (Savage 1998, eq. for phi = a1 + a2 + 2/3 a1 x a2) at
    800 Hz, with the Earth-fixed NED frame rotating at Omega_E. Its residual for this motion
    (fixed-axis spins and gentle two-gimbal repositioning) is far below the tolerance.
    """
    from sizefx.earth import omega_ie_n
    from sizefx.rotation import mat_to_quat, quat_multiply, rotvec_to_mat

    # 16 s per axis: a turn each way about both axes (the loop below is Python: its time goes with the record)
    plan = scenarios.TurntablePlan(axes="YX", static_s=2.0, seconds_per_axis=16.0, cycles=1, settle_s=2.0)
    path = tmp_path / "inc.h5"
    run(
        SimulateConfig(
            "turntable", path, plan=plan, site=SITE0, ideal=True, form="increments", reference_rate_hz=1600.0
        )
    )
    tel = read_telemetry(path)
    lat = tel.site.lat_rad
    a = tel.dtheta_rad
    n_pairs = a.shape[0] // 2
    a1, a2 = a[0 : 2 * n_pairs : 2], a[1 : 2 * n_pairs : 2]
    phi = a1 + a2 + 2.0 / 3.0 * np.cross(a1, a2)
    q_body = mat_to_quat(rotvec_to_mat(phi))
    zeta = omega_ie_n(lat) * (2.0 / 1600.0)
    q_nav = mat_to_quat(rotvec_to_mat(-zeta))
    q = tel.reference.quat_nb[0].copy()  # reference row 0 is t = 0, the start of the first increment
    worst = 0.0
    for k in range(n_pairs):
        q = quat_multiply(quat_multiply(q_nav, q), q_body[k])
        if k % 400 == 399 or k == n_pairs - 1:
            ref = tel.reference.quat_nb[2 * (k + 1)]
            err = quat_multiply(np.r_[q[0], -q[1:]], ref)
            worst = max(worst, 2.0 * np.linalg.norm(err[1:]))
    # 1e-9 rad = 0.2 milliarcsec: rounding over 30 000 updates plus the algorithm residual
    assert worst < 1e-9, worst


# --------------------------------------------------------------------------- the stage


def test_the_stage_refuses_before_any_work_and_reports_what_it_wrote(tmp_path, short_turntable_plan):
    effects = tmp_path / "fx.toml"
    effects.write_text("[accel_bias]\nenabled = true\n")
    with pytest.raises(OutputError, match="would overwrite the input"):
        run(SimulateConfig("turntable", effects, effects_path=effects, force=True))
    assert effects.read_text() == "[accel_bias]\nenabled = true\n"
    res = run(
        SimulateConfig(
            "turntable", tmp_path / "tt.h5", plan=short_turntable_plan, effects_path=effects, rate_hz=400.0, seed=2
        )
    )
    assert res.samples == 13601 and res.reference_samples == 13601 and res.form == "rates"
    assert res.report().startswith(f"wrote {tmp_path / 'tt.h5'}: 13601 samples (34.0 s at 400 Hz, rates), ")
    assert res.to_json()["file_bytes"] == (tmp_path / "tt.h5").stat().st_size
    tel = read_telemetry(tmp_path / "tt.h5")
    assert tel.simulation["effects"]["accel_bias"]["enabled"] and tel.simulation["seed"] == 2
