"""The reference against the IMU, step by step: what :mod:`.integrity` judges.

Each reference step ``k`` (rows ``k`` and ``k+1``) is compared with the IMU over the same interval:

- attitude: the reference's body-frame increment ``C_{b_k b_{k+1}} = C_nb,k^T C_nb,k+1`` against the
  gyro's, ``exp(int omega_ib_b dt - C_bn,k omega_ie_n dt)`` (Earth rate removed; transport rate
  neglected: < 1e-6 rad/s at walking speed). The mismatch ``e_k`` is the rotation vector of
  ``exp(gyro)^T C_{b_k b_{k+1}}`` [rad]. Within a normal step the gyro's rotation vector is the integral
  of the rate (the coning term is second order: < 1e-6 rad for 10 ms at 5 rad/s); over a long step
  (a dropout) the IMU's sub-interval rotations are composed exactly.
- velocity (a reference with position): the reference's velocity increment against
  ``C_nb,k (dv_b + 1/2 dtheta_b x dv_b) + g_n dt`` (``dv_b`` the integrated specific force,
  :func:`sizefx.earth.gravity_n`; Coriolis neglected: < 1e-4 m/s^2 per m/s). Without ``velocity_n``
  the reference velocity is the position difference over each step, at the step's midpoint, and the
  IMU's increment runs midpoint to midpoint (steps next to a gap are left out: the mean velocity over a
  dropout is not the velocity at its midpoint).

Each comparison also gives what the record's ordinary errors explain of the mismatch over the step
(:data:`SCALE_TOLERANCE` of its rotation or velocity change, :data:`DELAY_TOLERANCE_S` times its
change of rate) and the absolute floor below which no mismatch of its quantity is suspect.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from .. import earth
from ..constants import DEG
from ..io.telemetry import Telemetry
from ..rotation import quat_conjugate, quat_multiply

__all__ = [
    "SCALE_TOLERANCE",
    "DELAY_TOLERANCE_S",
    "ATTITUDE_FLOOR_RAD",
    "VELOCITY_FLOOR_MPS",
    "POSITION_FLOOR_M",
    "LONG_STEP_FACTOR",
]

#: Absolute floors below which no mismatch is suspect. Attitude [rad]: half the smallest
#: motion-capture glitch worth masking (0.5 deg), above the largest isolated mismatch steps of the
#: clean BROAD trials (0.3-0.6 deg during 800 deg/s rotation, which the local scale also covers) and far
#: above the simulated records' (~1e-6 rad: a 2 ms delay times the tumble's angular acceleration
#: times a step). Velocity [m/s] (a reference with velocity): far above a 2 ms delay's term
#: (tau * jerk * dt) and gravity modelling errors. Position [m] (positions only, compared as velocity
#: over a step, so the floor is this over the step): motion-capture position noise is ~0.1 mm per row.
ATTITUDE_FLOOR_RAD = 0.25 * DEG
VELOCITY_FLOOR_MPS = 0.05
POSITION_FLOOR_M = 0.5e-3
#: What a step's mismatch may hold without alarm, on top of the threshold, as a fraction of the step's
#: rotation (or velocity change) and as a delay times the change of rate over the step: MEMS scale
#: factors and misalignments of up to 1 % each, and a reference delay up to 10 ms (motion capture:
#: 4 ms on BROAD). They matter over a dropout (BROAD 21: 300 ms at 5 rad/s), where no high-pass helps.
SCALE_TOLERANCE = 0.02
DELAY_TOLERANCE_S = 0.01
#: Steps at most this many median periods long are integrated as one rotation vector; longer ones
#: (up to gaps) compose the IMU's sub-interval rotations exactly.
LONG_STEP_FACTOR = 1.5


class _ImuIntegrals:
    """Cumulative integrals of the gyro [rad] and accelerometer [m/s] readings, at any time by linear
    interpolation (trapezoids for rates, sums for increments, which cover ``(t[k-1], t[k]]``)."""

    def __init__(self, tel: Telemetry):
        self.t = np.asarray(tel.time_s, dtype=float)
        g, a = tel.imu_arrays()
        self.ta = self.t if tel.accel_time_s is None else np.asarray(tel.accel_time_s, dtype=float)
        self.phi = self._cumulative(self.t, g, tel.form)
        self.psi = self._cumulative(self.ta, a, tel.form)
        self.gaps = [(gap.time_s, gap.time_s + gap.duration_s) for gap in tel.gaps if gap.dataset.startswith("/imu")]

    @staticmethod
    def _cumulative(t, x, form):
        out = np.zeros((t.size, 3))
        if form == "rates":
            np.cumsum(0.5 * (x[1:] + x[:-1]) * np.diff(t)[:, None], axis=0, out=out[1:])
        else:
            np.cumsum(x[1:], axis=0, out=out[1:])
        return out

    @staticmethod
    def _at(t, cum, s):
        return np.column_stack([np.interp(s, t, cum[:, i]) for i in range(3)])

    def gyro(self, s):
        return self._at(self.t, self.phi, s)

    def accel(self, s):
        return self._at(self.ta, self.psi, s)

    def covers(self, a, b):
        """Which intervals ``[a, b]`` lie within the IMU's span and across no IMU gap."""
        ok = (a >= max(self.t[0], self.ta[0])) & (b <= min(self.t[-1], self.ta[-1]))
        for g0, g1 in self.gaps:
            ok &= (b <= g0) | (a >= g1)
        return ok

    def rate_at(self, s):
        """Angular rate [n, 3] rad/s at the times ``s``: the gyro integral's slope over the IMU step."""
        k = np.clip(np.searchsorted(self.t, s), 1, self.t.size - 1)
        return (self.phi[k] - self.phi[k - 1]) / (self.t[k] - self.t[k - 1])[:, None]

    def rotation(self, a, b) -> Rotation:
        """The body rotation over ``[a, b]`` composed from the IMU's sub-intervals (log-depth product)."""
        inside = self.t[(self.t > a) & (self.t < b)]
        incs = np.diff(self.gyro(np.concatenate([[a], inside, [b]])), axis=0)
        rots = Rotation.from_rotvec(incs)
        while len(rots) > 1:  # bounded: halves each pass
            if len(rots) % 2:
                rots = Rotation.concatenate([rots, Rotation.identity()])
            rots = rots[0::2] * rots[1::2]  # C_{b0 b1} C_{b1 b2}: earlier on the left
        return rots


def _attitude_mismatch(tel, rt, mat_nb, imu):
    """Per step: the rotation vector of the reference's increment against the gyro's [M-1, 3] rad, and
    the part of it that the record's ordinary errors explain [M-1] rad (see :data:`SCALE_TOLERANCE`)."""
    a, b = rt[:-1], rt[1:]
    dt = b - a
    ok = imu.covers(a, b)
    ref = tel.reference
    lat = ref.lat_rad[0] if ref.has_position else tel.site.lat_rad if tel.site else 0.0
    q_nb = ref.quat_nb / np.linalg.norm(ref.quat_nb, axis=1, keepdims=True)
    w_ie_b = mat_nb[:-1].inv().apply(earth.omega_ie_n(lat))  # Earth rate in body axes at each step's start
    dth = imu.gyro(b) - imu.gyro(a)
    q_gyro = _quat_from_rotvec(dth - w_ie_b * dt[:, None])
    period = float(np.median(dt))
    long_steps = np.flatnonzero(ok & (dt > LONG_STEP_FACTOR * period))
    if long_steps.size:  # compose the sub-interval rotations exactly (bounded: one per long step)
        exact = Rotation.concatenate([imu.rotation(a[k], b[k]) for k in long_steps]).as_quat()[:, [3, 0, 1, 2]]
        q_gyro[long_steps] = quat_multiply(exact, _quat_from_rotvec(-w_ie_b[long_steps] * dt[long_steps, None]))
    q_ref = quat_multiply(quat_conjugate(q_nb[:-1]), q_nb[1:])  # C_{b_k n} C_{n b_k+1}
    e = _rotvec_from_quat(quat_multiply(quat_conjugate(q_gyro), q_ref))
    e[~ok] = 0.0
    rate = imu.rate_at(rt)
    allowance = SCALE_TOLERANCE * np.linalg.norm(dth, axis=1) + DELAY_TOLERANCE_S * np.linalg.norm(
        np.diff(rate, axis=0), axis=1
    )
    # step k lies between rows k and k+1
    return e, ok, np.arange(rt.size - 1), ATTITUDE_FLOOR_RAD, allowance


def _quat_from_rotvec(phi):
    """Scalar-first unit quaternions of rotation vectors [n, 3] rad (series below 1e-4 rad)."""
    angle = np.linalg.norm(phi, axis=1)
    small = angle < 1e-4
    with np.errstate(invalid="ignore", divide="ignore"):
        k = np.where(small, 0.5 - angle**2 / 48.0, np.sin(0.5 * angle) / angle)
    return np.column_stack([np.cos(0.5 * angle), phi * k[:, None]])


def _rotvec_from_quat(q):
    """Rotation vectors [n, 3] rad of scalar-first unit quaternions (the shorter way round)."""
    q = q * np.where(q[:, :1] < 0.0, -1.0, 1.0)
    s = np.linalg.norm(q[:, 1:], axis=1)
    angle = 2.0 * np.arctan2(s, q[:, 0])
    with np.errstate(invalid="ignore", divide="ignore"):
        scale = np.where(s < 1e-12, 2.0, angle / s)
    return q[:, 1:] * scale[:, None]


def _velocity_mismatch(tel, rt, mat_nb, imu):
    """Per step: the reference's velocity increment against the IMU's [.., 3] m/s, with the quantity."""
    ref = tel.reference
    lat, h = ref.lat_rad, ref.height_m
    g_n = earth.gravity_n(lat, h)
    if ref.velocity_n_mps is not None:
        quantity, tau, v = "velocity", rt, ref.velocity_n_mps
        start = mat_nb[:-1]
        ok = imu.covers(rt[:-1], rt[1:])
        row_of_step = np.arange(rt.size - 1)  # step k: rows k -> k+1
        g_step = g_n[:-1]
    else:  # velocities at step midpoints from the positions (local NED about each step)
        rn, re = earth.radii_m(lat)
        dt_rows = np.diff(rt)
        d_ned = np.column_stack(
            [
                np.diff(lat) * (rn[:-1] + h[:-1]),
                np.diff(np.unwrap(ref.lon_rad)) * (re[:-1] + h[:-1]) * np.cos(lat[:-1]),
                -np.diff(h),
            ]
        )
        quantity, tau, v = "position", 0.5 * (rt[:-1] + rt[1:]), d_ned / dt_rows[:, None]
        start = mat_nb[1:-1]  # the row at the centre of each midpoint-to-midpoint interval
        period = float(np.median(dt_rows))
        regular = dt_rows <= LONG_STEP_FACTOR * period
        ok = imu.covers(tau[:-1], tau[1:]) & regular[:-1] & regular[1:]
        row_of_step = np.arange(rt.size - 2)  # step j: midpoints j -> j+1, i.e. centred on row j+1
        g_step = g_n[1:-1]
    dt = np.diff(tau)
    dv_b = imu.accel(tau[1:]) - imu.accel(tau[:-1])
    dth_b = imu.gyro(tau[1:]) - imu.gyro(tau[:-1])
    if quantity == "velocity":
        dv_n = start.apply(dv_b + 0.5 * np.cross(dth_b, dv_b))
    else:  # centred attitude: the first-order rotation terms cancel
        dv_n = start.apply(dv_b)
    dv_imu_n = dv_n + g_step * dt[:, None]
    e = np.diff(v, axis=0) - dv_imu_n
    e[~ok] = 0.0
    floor = VELOCITY_FLOOR_MPS if quantity == "velocity" else POSITION_FLOOR_M / float(np.median(dt))
    # what the record's ordinary errors explain (from the IMU, never from the reference under test):
    # accelerometer scale and misalignment, and a reference delay times the change of acceleration
    accel_n = dv_imu_n / np.maximum(dt, 1e-12)[:, None]
    allowance = SCALE_TOLERANCE * np.linalg.norm(dv_b, axis=1) + DELAY_TOLERANCE_S * np.linalg.norm(
        np.diff(accel_n, axis=0, prepend=accel_n[:1]), axis=1
    )
    return quantity, e, ok, row_of_step, floor, allowance
