"""Forward: the true motion -> what the IMU reads, per instant (the table's "enters" column)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .table import Motion, SensorParams, cross

__all__ = ["forward", "sample", "gyro_readings", "accel_inputs", "accel_readings", "specific_force_at"]


def gyro_readings(p: SensorParams, m: Motion) -> np.ndarray:
    """``g = diag(1 + s_g) U_g omega + b_g + G f`` [n, 3] rad/s."""
    return m.omega_ib_b @ p.gyro_matrix().T + p.gyro_bias + m.f_b @ p.gyro_g_sensitivity.T


def specific_force_at(m: Motion, r: np.ndarray) -> np.ndarray:
    """``f + omegadot x r + omega x (omega x r)`` [n, 3]: the specific force at ``r`` (rigid body; the
    gravity gradient over a few cm, under 0.01 ug, is neglected)."""
    if not np.any(r):  # at the reference point: the terms below are zeros, adding them changes no bit
        return m.f_b
    return m.f_b + cross(m.omegadot_ib_b, r) + cross(m.omega_ib_b, cross(m.omega_ib_b, r))


def accel_inputs(p: SensorParams, m: Motion) -> np.ndarray:
    """``a_i = u_i . f_i`` [n, 3] m/s^2: what ideal accelerometer i at ``r_i`` along ``u_i`` reads."""
    axes = p.accel_axes()
    out = np.empty_like(m.f_b)
    for i in range(3):
        out[:, i] = specific_force_at(m, p.lever_arm[i]) @ axes[i]
    return out


def accel_readings(p: SensorParams, a: np.ndarray) -> np.ndarray:
    """``m_i = (1 + s_i) a_i + K2_i a_i^2 + b_i`` [n, 3] m/s^2 from the inputs ``a`` [n, 3]."""
    return (1.0 + p.accel_scale_factor) * a + p.accel_quadratic * a * a + p.accel_bias


def forward(p: SensorParams, at_gyro: Motion, at_accel: Motion | None = None):
    """Readings ``(gyro [n, 3] rad/s, accel [n, 3] m/s^2)`` of the true motion, per instant.

    ``at_accel`` is the motion at the accelerometers' sampling instants (``tau_a`` earlier than
    the gyros'; :func:`sample` evaluates both); None: the same instants (no delay).
    """
    return gyro_readings(p, at_gyro), accel_readings(p, accel_inputs(p, at_gyro if at_accel is None else at_accel))


def sample(p: SensorParams, motion_at: Callable[[np.ndarray], Motion], t: np.ndarray):
    """:func:`forward` at the IMU's time stamps ``t`` [n]: the gyros sample ``motion_at(t)``, the
    accelerometers ``motion_at(t - tau_a)`` (the accelerometer delay)."""
    at_gyro = motion_at(t)
    at_accel = at_gyro if p.accel_delay == 0.0 else motion_at(t - p.accel_delay)
    return forward(p, at_gyro, at_accel)
