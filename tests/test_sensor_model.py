"""The sensor model (sizefx.sensor_model): its table against the schema, its Jacobian against finite
differences of its forward map, and inverse(forward(x)) = x for random effect sets.

Tolerances are per quantity, with the reason next to each.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sizefx import sensor_model as sm
from sizefx.effects import EFFECTS_SCHEMA, IDEAL, load_effects
from sizefx.errors import ConfigError
from sizefx.io.schema import load_schema
from sizefx.io.telemetry import Telemetry
from sizefx.rotation import rotvec_to_mat
from sizefx.sync import sync_accelerometers

RATE_HZ = 1600.0
DT = 1.0 / RATE_HZ


class Sines:
    """A smooth, closed-form motion for the sensor model (per instant it needs no physics: any
    omega(t) and f_b(t) will do). ``omega_k(t) = sum_j A_kj sin(w_kj t + p_kj)``, likewise ``f_b``
    around ``f0``; every time derivative the Jacobian's delay columns need is exact."""

    def __init__(self, rng, *, rate_amp=1.0, force_amp=2.0, max_hz=0.5, terms=2):
        self.w_amp = rng.uniform(-rate_amp, rate_amp, (3, terms)) / terms
        self.w_freq = 2 * np.pi * rng.uniform(0.1, max_hz, (3, terms))
        self.w_phase = rng.uniform(0, 2 * np.pi, (3, terms))
        self.f_amp = rng.uniform(-force_amp, force_amp, (3, terms)) / terms
        self.f_freq = 2 * np.pi * rng.uniform(0.1, max_hz, (3, terms))
        self.f_phase = rng.uniform(0, 2 * np.pi, (3, terms))
        self.f0 = np.array([0.3, -0.5, -9.8])

    @staticmethod
    def _series(amp, freq, phase, t, order):
        arg = freq[None] * t[:, None, None] + phase[None]
        # d^k/dt^k sin(x) = sin(x + k pi / 2)
        return np.sum(amp[None] * freq[None] ** order * np.sin(arg + order * np.pi / 2), axis=2)

    def __call__(self, t) -> sm.Motion:
        t = np.asarray(t, dtype=float)
        w = [self._series(self.w_amp, self.w_freq, self.w_phase, t, k) for k in range(3)]
        f = self.f0 + self._series(self.f_amp, self.f_freq, self.f_phase, t, 0)
        fdot = self._series(self.f_amp, self.f_freq, self.f_phase, t, 1)
        return sm.Motion(w[0], w[1], f, fdot_b=fdot, omegaddot_ib_b=w[2])

    def max_jerk(self):
        """Bound on |d^3 omega / dt^3| per axis [rad/s^4]: the central difference's error term."""
        return np.sum(np.abs(self.w_amp) * self.w_freq**3, axis=1)


def a_model(rng, scale=1.0) -> sm.SensorParams:
    """Every deterministic effect on, at tens of times realistic sizes (so that a wrong term shows)."""
    s = scale
    return sm.SensorParams(
        accel_bias=s * rng.uniform(-1e-2, 1e-2, 3),
        accel_scale_factor=s * rng.uniform(-1e-3, 1e-3, 3),
        accel_misalignment=s * rng.uniform(-1e-3, 1e-3, (3, 3)),
        accel_quadratic=s * rng.uniform(-1e-4, 1e-4, 3),
        lever_arm=rng.uniform(-0.1, 0.1, (3, 3)),
        accel_delay=5e-4,
        reference_delay=2e-3,
        level_tilt=s * rng.uniform(-1e-4, 1e-4, 2),
        gyro_bias=s * rng.uniform(-1e-4, 1e-4, 3),
        gyro_scale_factor=s * rng.uniform(-1e-3, 1e-3, 3),
        gyro_misalignment=s * rng.uniform(-1e-3, 1e-3, (3, 3)),
        gyro_g_sensitivity=s * rng.uniform(-1e-5, 1e-5, (3, 3)),
        reference_mount=s * rng.uniform(-1e-3, 1e-3, 3),
    )


# --------------------------------------------------------------------------- the table


def test_the_table_is_the_schema():
    """Every section of the effects schema has one row, and each row's SI key is the schema's."""
    schema = load_schema(EFFECTS_SCHEMA)["sections"]
    assert sorted(e.name for e in sm.EFFECTS) == sorted(schema)
    for e in sm.EFFECTS:
        if e.si_key is not None:
            si_keys = {rule.get("si_key", key) for key, rule in schema[e.name]["keys"].items()}
            assert e.si_key in si_keys, e.name
        for key in e.toml.split(" [")[0].split(", "):
            assert key in schema[e.name]["keys"], (e.name, key)
        size = 6 if len(e.labels) == 6 else int(np.prod(e.shape))
        assert len(e.labels) == (size if e.deterministic else 0), e.name
    assert sm.NP == 52 and [p.index for p in sm.PARAMS] == list(range(sm.NP))
    # what inverse() undoes and what it leaves alone together cover the table, once
    assert sorted(sm.INVERTED + sm.NOT_INVERTED) == sorted(e.name for e in sm.EFFECTS)


def test_an_effects_file_and_the_model_vector_give_the_same_parameters():
    fx = load_effects(
        base=IDEAL,
        overrides={
            "lever_arm": {"enabled": True, "preset": "compact", "r_vehicle_m": [0.1, -0.2, 0.3]},
            "accel_misalignment": {"enabled": True},
            "gyro_g_sensitivity": {"enabled": True},
            "accel_delay": {"enabled": True},
            "level_tilt": {"enabled": True},
            "accel_quadratic": {"enabled": True},
        },
    )
    p = fx.sensor_params()
    np.testing.assert_array_equal(p.lever_arm, fx.arms_total_m())
    np.testing.assert_array_equal(p.accel_axes(), fx.accel_axes())
    np.testing.assert_array_equal(p.level_tilt, fx.tilt_rad()[:2])
    assert p.accel_delay == 0.0005 and p.reference_delay == 0.0 and not np.any(p.gyro_bias)
    theta = p.vector()
    back = sm.SensorParams.from_vector(theta, triad_offset=p.triad_offset)
    np.testing.assert_array_equal(back.vector(), theta)
    np.testing.assert_array_equal(back.accel_axes(), p.accel_axes())  # the misalignment's diagonal is ignored
    k = sm.param_index("gyro_g_sensitivity")
    np.testing.assert_array_equal(theta[k], fx.get("gyro_g_sensitivity", "rad_s_per_mps2").ravel())
    np.testing.assert_allclose(p.arms("triad"), fx.arms_d_m(), rtol=0, atol=1e-17)  # r_i - r = d_i, rounding


# --------------------------------------------------------------------------- the Jacobian


def _fd(f, x0: float, h: float):
    return (f(x0 + h) - f(x0 - h)) / (2.0 * h)


def _readings(p, motion, t, *, tilted=None):
    """All six channels [n, 6] of the motion ``motion(t)`` (or of ``tilted(p)`` for the tilt)."""
    if tilted is not None:
        return np.hstack(sm.forward(p, tilted(p)))
    return np.hstack(sm.sample(p, lambda tt: motion(tt + p.reference_delay), t))


def test_the_jacobian_is_the_derivative_of_the_forward_map():
    """Every column of d(readings)/d(theta), at a model with every effect on, against central
    differences of forward() (sample() for the delays, true_attitude() and mount_matrix() for the
    tilt and the mount, which move the true motion itself)."""
    rng = np.random.default_rng(7)
    p = a_model(rng)
    motion = Sines(rng, max_hz=2.0)
    t = np.linspace(1.0, 3.0, 200)
    # The tilt moves the true attitude, and with it f_b and omega_ib (through the rate of the
    # navigation frame): a random attitude, f_n and omega_in_n at each instant. The mount turns
    # the whole motion (the reference's body rates too) into the IMU's axes.
    mat_ref = rotvec_to_mat(rng.uniform(-2.0, 2.0, (t.size, 3)))
    f_n = np.array([0.5, -0.3, -9.8]) + rng.uniform(-1.0, 1.0, (t.size, 3))
    w_in_n = np.array([4.0e-5, 1.0e-5, -6.0e-5])
    base = motion(t)

    def tilted(q):
        mat_nb = sm.true_attitude(q, mat_ref)
        w_in_b = np.einsum("nji,j->ni", mat_nb, w_in_n)
        mount = sm.mount_matrix(q)
        return replace(
            base,
            omega_ib_b=base.omega_ib_b @ mount.T + w_in_b,
            omegadot_ib_b=base.omegadot_ib_b @ mount.T,
            f_b=np.einsum("nji,nj->ni", mat_nb, f_n),
            mat_nb=mat_nb,
            omega_in_b=w_in_b,
        )

    reference_side = ("level_tilt", "reference_mount")
    at = motion(t + p.reference_delay)
    others = [e.name for e in sm.EFFECTS if e.deterministic and e.name not in reference_side]
    jac = sm.jacobian(p, at, motion(t + p.reference_delay - p.accel_delay), effects=others)
    jac_tilt = sm.jacobian(p, tilted(p), effects=reference_side)
    theta = p.vector()
    assert set(jac) == set(range(sm.NP)) - {j for e in reference_side for j in sm.param_index(e)}
    for j, param in enumerate(sm.PARAMS):
        by_tilt = param.effect in reference_side
        channels, cols = (jac_tilt if by_tilt else jac)[j]
        full = np.zeros((t.size, 6))
        full[:, channels] = cols
        # steps: 1e-6 of the parameter's own scale (rounding 1e-16 / 1e-6 of the readings, truncation
        # h^2 times the third derivative, both far below the tolerance)
        h = {"lever_arm": 1e-6, "accel_delay": 1e-6, "reference_delay": 1e-6}.get(param.effect, 1e-7)

        def at_theta(x, j=j, by_tilt=by_tilt):
            th = theta.copy()
            th[j] = x
            q = sm.SensorParams.from_vector(th)
            return _readings(q, motion, t, tilted=tilted if by_tilt else None)

        numeric = _fd(at_theta, theta[j], h)
        scale = np.abs(numeric).max()
        assert scale > 0, param  # forward() moves with every parameter
        # Tolerance: 1e-7 of the column's scale, the finite difference's own error (rounding of
        # ~10 m/s^2 over 2h, truncation h^2/6 times the third derivative). The tilt's: 2e-5, because
        # its analytic column leaves out how the lever terms move with the tilt (through omega_in:
        # 2 |omega| |r| |omega_in| ~ 2e-5 m/s^2 per rad here, against g ~ 10 m/s^2 per rad: 2e-6).
        # The mount's columns are exact (the whole motion turns, lever terms included): 1e-7.
        rel = 2e-5 if param.effect == "level_tilt" else 1e-7
        np.testing.assert_allclose(full, numeric, rtol=0, atol=rel * scale, err_msg=f"{param}")


def test_the_jacobian_can_be_asked_for_some_effects_and_one_sensor():
    rng = np.random.default_rng(3)
    p = a_model(rng)
    m = Sines(rng)(np.linspace(0.0, 1.0, 50))
    part = sm.jacobian(p, m, effects=["lever_arm", "accel_bias"], sensors=("accel",))
    whole = sm.jacobian(p, m, effects=["lever_arm", "accel_bias", "accel_delay"])
    assert set(part) == set(sm.param_index("lever_arm")) | set(sm.param_index("accel_bias"))
    for j, (channels, cols) in part.items():
        np.testing.assert_array_equal(channels, whole[j][0])
        np.testing.assert_array_equal(cols, whole[j][1])
    block = part.block(4, sm.param_index("lever_arm")[3:6])  # accelerometer y, its arm r_y
    assert block.shape == (50, 3) and np.all(part.block(3, sm.param_index("lever_arm")[3:6]) == 0.0)
    with pytest.raises(ValueError, match="fdot_b"):  # a delay column needs the specific force's rate
        sm.jacobian(p, replace(m, fdot_b=None), effects=["accel_delay"])


# --------------------------------------------------------------------------- inverse(forward(x)) = x


@settings(max_examples=20, deadline=None, derandomize=True)
@given(
    seed=st.integers(0, 2**32 - 1),
    arms_m=st.floats(0.0, 0.12),
    errors=st.floats(0.0, 1.0),
    delay_s=st.sampled_from([0.0, 2.5e-4, 1e-3]),
)
def test_inverse_undoes_forward(seed, arms_m, errors, delay_s):
    """Random effect sets (arms up to 12 cm, biases, scale factors, misalignments, K2, G and the
    accelerometer delay, up to tens of times realistic), a random smooth motion: the readings
    corrected by sync_accelerometers (step 1) and inverse() give back omega_ib_b and f_b."""
    rng = np.random.default_rng(seed)
    p = replace(
        a_model(rng, scale=errors),
        lever_arm=rng.uniform(-arms_m, arms_m, (3, 3)),
        accel_delay=delay_s,
        reference_delay=0.0,
        level_tilt=np.zeros(2),
    )
    motion = Sines(rng)
    t = np.arange(int(1.0 * RATE_HZ)) * DT
    gyro, accel = sm.sample(p, motion, t)
    tel = sync_accelerometers(Telemetry(time_s=t, form="rates", gyro_rad_s=gyro, accel_mps2=accel), p.accel_delay)
    omega, f = sm.inverse(p, tel.gyro_rad_s, tel.accel_mps2, form="rates", dt=DT, estimator="central")
    truth = motion(t)
    inner = slice(16, -16)  # the central difference is one-sided at the ends; the spline extrapolates the last tau
    # The one estimate inside inverse(): omegadot by central differences, off by h^2/6 |omega'''|,
    # times the arms |r| (the tangential term); twice that for margin, plus rounding of the
    # ~10 m/s^2 readings through three solves (1e-13). Misalignments, scale factors, K2 and the
    # biases invert in closed form. The delay's cubic spline: (5/384) h^4 |a''''|, 1e-17 here.
    tol_f = 2.0 * np.abs(p.lever_arm).sum(axis=1).max() * DT**2 / 6.0 * motion.max_jerk().max() + 1e-12
    np.testing.assert_allclose(f[inner], truth.f_b[inner], rtol=0, atol=tol_f)
    # The gyros see that error through G f (one pass, see sizefx.correct), plus rounding of ~1 rad/s.
    tol_w = 2.0 * np.abs(p.gyro_g_sensitivity).sum(axis=1).max() * tol_f + 1e-14
    np.testing.assert_allclose(omega[inner], truth.omega_ib_b[inner], rtol=0, atol=tol_w)


def test_inverse_refuses_what_it_cannot_invert():
    rng = np.random.default_rng(1)
    x = rng.normal(size=(400, 3))
    with pytest.raises(ConfigError, match=r"\[gyro_scale_factor\]"):
        sm.inverse(sm.SensorParams(gyro_scale_factor=np.array([0.0, -1.5, 0.0])), x, x, form="rates", dt=DT)
    with pytest.raises(ConfigError, match="accelerometer z reads .* in sample"):
        sm.inverse(sm.SensorParams(accel_quadratic=np.array([0.0, 0.0, -1.0])), x, x + 10.0, form="rates", dt=DT)
    with pytest.raises(ConfigError, match="increment data"):
        sm.inverse(sm.SensorParams(), x, x, form="increments", dt=DT, estimator="savgol")


# --------------------------------------------------------------------------- the reference's mount


def test_the_mount_turns_the_imu_by_psi():
    """The sign of ``reference_mount`` (sizefx.sensor_model.mount_matrix): psi turns the reference's
    body axes into the IMU's; a positive z angle yaws the IMU right, so a vector along the
    reference's x reads ``(1, -psi_z, 0)`` in IMU axes and the IMU's heading is the reference's
    plus psi_z. First order: ``C_b_b' = I - [psi x]``."""
    from sizefx.rotation import mat_to_euler, skew

    psi_z = 1e-3  # rad: large enough that the first-order check below is not lost in rounding
    p = sm.SensorParams(reference_mount=np.array([0.0, 0.0, psi_z]))
    np.testing.assert_allclose(sm.mount_matrix(p) @ [1.0, 0.0, 0.0], [1.0, -psi_z, 0.0], rtol=0, atol=psi_z**2)
    mat_nb_ref = rotvec_to_mat(np.array([0.0, 0.0, 0.7]))  # the reference heads 0.7 rad
    heading = mat_to_euler(sm.true_attitude(p, mat_nb_ref))[2]
    assert heading == pytest.approx(0.7 + psi_z, abs=1e-12)  # rounding of two matrix products
    psi = np.array([2e-4, -1e-4, 3e-4])  # rad, a few tens of arcsec
    # |psi|^2 / 2 is the second-order term that I - [psi x] leaves out
    np.testing.assert_allclose(
        sm.mount_matrix(sm.SensorParams(reference_mount=psi)), np.eye(3) - skew(psi), rtol=0, atol=np.dot(psi, psi)
    )
    np.testing.assert_array_equal(sm.true_attitude(sm.SensorParams(), mat_nb_ref), mat_nb_ref)  # off: untouched
