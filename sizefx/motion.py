"""Analytic motion of the reference point: attitude, rates, position, velocity.

A simulated record is defined by closed-form functions of time, so the ideal
sensor outputs follow exactly from it: angular rate and angular acceleration
by analytic differentiation of a chain of rotations, specific force from the
analytic velocity derivative. Nothing here is integrated numerically except
latitude and longitude of a moving vehicle (an ODE solved to 1e-13 relative,
see :class:`FlightPath`).

Profiles
    :class:`SmoothProfile` is a scalar ``value(t)`` whose second derivative is a
    piecewise polynomial built from jerk-limited steps (quintic "smootherstep"
    transitions: acceleration and jerk are continuous at the joins except where
    a :meth:`ProfileBuilder.move` begins or ends, where jerk steps by a bounded
    amount). :class:`Sinusoids` and :class:`SwayProfile` are periodic motions;
    :class:`SumProfile` adds profiles.
Attitude
    :class:`RotationChain` is ``mat_nb(t) = mat_0 @ R(a_1, theta_1(t)) @ ... @
    R(a_K, theta_K(t))`` with fixed unit axes ``a_j``. It covers a three-axis
    turntable (outer, middle, inner gimbal) and z-y-x Euler angles of a vehicle.
    Rates: ``omega_nb_b = sum_j P_j^T a_j thetadot_j`` with ``P_j = R_{j+1} ...
    R_K``; angular acceleration ``sum_j P_j^T a_j thetaddot_j - w_j x (P_j^T a_j)
    thetadot_j`` with ``w_j`` the rate of the sub-chain ``j+1 .. K``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from . import earth
from .rotation import axis_angle_mat

__all__ = [
    "Profile",
    "ProfileBuilder",
    "SmoothProfile",
    "Sinusoids",
    "SwayProfile",
    "SumProfile",
    "ConstantProfile",
    "RateOf",
    "Scaled",
    "RotationChain",
    "MotionState",
    "StaticSite",
    "FlightPath",
    "Trajectory",
]


# --------------------------------------------------------------------------- scalar profiles


class Profile(Protocol):
    """What every scalar profile below offers (:class:`RotationChain` takes any of them)."""

    def evaluate(self, t):
        """``(value, rate, acceleration)`` at the times ``t``, each shaped like ``t``."""


class ConstantProfile:
    """``value(t) = value0`` (a fixed gimbal angle, a fixed heading)."""

    def __init__(self, value0: float = 0.0):
        self.value0 = float(value0)

    def evaluate(self, t):
        t = np.asarray(t, dtype=float)
        return np.full(t.shape, self.value0), np.zeros(t.shape), np.zeros(t.shape)


class SmoothProfile:
    """``value(t) = value0 + rate0 (t - t0) + double integral of a piecewise-polynomial acceleration``.

    Build it with :class:`ProfileBuilder`. Before the first and after the last
    breakpoint the acceleration is zero (constant rate).
    """

    def __init__(self, accel, t0: float, value0: float, rate0: float):
        self.t0 = t0
        self.value0 = value0
        self.rate0 = rate0
        self._acc = accel
        self._rate = accel.antiderivative(1)
        self._val = accel.antiderivative(2)
        self._jerk = accel.derivative(1)
        self.t_end = float(accel.x[-1])

    def evaluate(self, t):
        """Return ``(value, rate, acceleration)`` at times ``t`` (arrays of the shape of ``t``)."""
        t = np.asarray(t, dtype=float)
        lo, hi = self._acc.x[0], self._acc.x[-1]
        tc = np.clip(t, lo, hi)
        acc = self._acc(tc)
        rate = self._rate(tc)
        val = self._val(tc) + rate * (t - tc)  # constant-rate extension past the ends
        acc = np.where((t < lo) | (t > hi), 0.0, acc)
        return self.value0 + self.rate0 * (t - self.t0) + val, self.rate0 + rate, acc

    def jerk(self, t):
        """Third derivative of the value (zero outside the breakpoints)."""
        t = np.asarray(t, dtype=float)
        lo, hi = self._acc.x[0], self._acc.x[-1]
        return np.where((t < lo) | (t > hi), 0.0, self._jerk(np.clip(t, lo, hi)))

    @property
    def breakpoints(self):
        return self._acc.x


class RateOf:
    """``value(t) = k * d/dt profile(t)`` (bank angle proportional to turn rate, pitch to speed change)."""

    def __init__(self, profile: SmoothProfile, k: float):
        self.profile = profile
        self.k = float(k)

    def evaluate(self, t):
        _, rate, acc = self.profile.evaluate(t)
        return self.k * rate, self.k * acc, self.k * self.profile.jerk(t)


class Scaled:
    """``value(t) = k * profile(t)``."""

    def __init__(self, profile, k: float):
        self.profile = profile
        self.k = float(k)

    def evaluate(self, t):
        v, r, a = self.profile.evaluate(t)
        return self.k * v, self.k * r, self.k * a


class ProfileBuilder:
    """Compose a :class:`SmoothProfile` from jerk-limited segments, in time order.

    Examples
    --------
    >>> b = ProfileBuilder(t0=0.0)
    >>> b.hold(1.0).change_rate(0.35, accel=0.17, ramp_s=0.5).hold(6.0)  # doctest: +ELLIPSIS
    <...>
    """

    def __init__(self, t0: float = 0.0):
        self.t0 = float(t0)
        self.t = float(t0)
        self.acc = 0.0
        self.rate = 0.0  # tracked for change_rate/stop bookkeeping
        self._x = [self.t0 - 1.0, self.t0]
        self._c = [np.zeros(6)]  # a 1 s zero-acceleration piece before t0: zero value and rate at t0

    def _append(self, duration: float, coeffs_high_first):
        if duration <= 0.0:
            raise ValueError(f"segment duration must be positive, got {duration}")
        c = np.zeros(6)
        coeffs = np.asarray(coeffs_high_first, dtype=float)
        c[6 - coeffs.size :] = coeffs
        self._c.append(c)
        self.t += duration
        self._x.append(self.t)

    def hold(self, duration: float):
        """Keep the current acceleration for ``duration`` seconds."""
        self._append(duration, [self.acc])
        self.rate += self.acc * duration
        return self

    def ramp(self, duration: float, to: float):
        """Move the acceleration from its current value to ``to`` along a smootherstep."""
        d = to - self.acc
        T = duration
        # a(t) = a0 + d * (10 x^3 - 15 x^4 + 6 x^5), x = (t - ts) / T
        self._append(T, [6.0 * d / T**5, -15.0 * d / T**4, 10.0 * d / T**3, 0.0, 0.0, self.acc])
        self.rate += (self.acc + 0.5 * d) * T
        self.acc = float(to)
        return self

    def change_rate(self, delta: float, *, accel: float, ramp_s: float):
        """Change the rate by ``delta`` with peak acceleration ``accel`` and jerk-limited ramps.

        The acceleration ramps to ``+-accel`` in ``ramp_s``, holds, and ramps back to
        zero in ``ramp_s``. A change too small for the hold uses a lower peak.
        """
        if self.acc != 0.0:
            raise ValueError("change_rate starts from zero acceleration")
        if delta == 0.0:
            return self
        sign = np.sign(delta)
        hold = abs(delta) / accel - ramp_s
        if hold > 0.0:
            self.ramp(ramp_s, sign * accel).hold(hold).ramp(ramp_s, 0.0)
        else:
            peak = abs(delta) / ramp_s
            self.ramp(ramp_s, sign * peak).ramp(ramp_s, 0.0)
        return self

    def move(self, duration: float, delta: float):
        """Change the value by ``delta`` from rest to rest: ``value = v0 + delta * s(x)``, s the smootherstep."""
        if self.acc != 0.0 or abs(self.rate) > 1e-12:
            raise ValueError("move starts at rest (zero rate and acceleration)")
        T = duration
        # s''(x) = 60 x - 180 x^2 + 120 x^3; acceleration = delta * s''(x) / T^2
        self._append(T, [120.0 * delta / T**5, -180.0 * delta / T**4, 60.0 * delta / T**3, 0.0])
        return self

    def build(self, value0: float = 0.0, rate0: float = 0.0) -> SmoothProfile:
        if abs(self.acc) > 0.0:
            raise ValueError("a profile must end with zero acceleration")
        x = np.asarray(self._x + [self.t + 1.0])
        c = np.column_stack(self._c + [np.zeros(6)])
        from scipy.interpolate import (
            PPoly,  # here: scipy.interpolate costs 0.45 s at start-up
        )

        return SmoothProfile(PPoly(c, x), self.t0, value0, rate0)


class Sinusoids:
    """``value(t) = env(t) * sum_k amp_k sin(2 pi f_k t + phase_k)``, env a :class:`SmoothProfile` or None."""

    def __init__(self, amps, freqs_hz, phases_rad, envelope: SmoothProfile | None = None):
        self.amps = np.asarray(amps, dtype=float)
        self.w = 2.0 * np.pi * np.asarray(freqs_hz, dtype=float)
        self.phases = np.asarray(phases_rad, dtype=float)
        self.envelope = envelope

    def evaluate(self, t):
        t = np.asarray(t, dtype=float)
        arg = t[..., None] * self.w + self.phases
        s = np.sin(arg) @ self.amps
        c = (np.cos(arg) * self.w) @ self.amps
        s2 = -(np.sin(arg) * self.w**2) @ self.amps
        if self.envelope is None:
            return s, c, s2
        e, ed, edd = self.envelope.evaluate(t)
        return e * s, ed * s + e * c, edd * s + 2.0 * ed * c + e * s2


class SwayProfile:
    """Harmonic sway of the rate: ``rate = A_j sin(2 pi f (t - t_j))`` on segment j.

    Each segment lasts a whole number of periods, so the angle
    ``A_j / (2 pi f) (1 - cos(2 pi f (t - t_j)))`` returns to its start value at
    every segment end and the segments join continuously in angle and rate.
    """

    def __init__(self, starts_s, durations_s, amplitudes, frequency_hz: float):
        self.starts = np.asarray(starts_s, dtype=float)
        self.durations = np.asarray(durations_s, dtype=float)
        self.amps = np.asarray(amplitudes, dtype=float)
        self.f = float(frequency_hz)
        cycles = self.durations * self.f
        if np.any(np.abs(cycles - np.round(cycles)) > 1e-9):
            raise ValueError("each sway segment must last a whole number of periods")

    def evaluate(self, t):
        t = np.asarray(t, dtype=float)
        w = 2.0 * np.pi * self.f
        val = np.zeros(t.shape)
        rate = np.zeros(t.shape)
        acc = np.zeros(t.shape)
        for t0, dur, amp in zip(self.starts, self.durations, self.amps):
            inside = (t > t0) & (t <= t0 + dur)
            tau = t[inside] - t0
            val[inside] = amp / w * (1.0 - np.cos(w * tau))
            rate[inside] = amp * np.sin(w * tau)
            acc[inside] = amp * w * np.cos(w * tau)
        return val, rate, acc


class SumProfile:
    """Sum of profiles (a manoeuvre plus vibration)."""

    def __init__(self, *parts):
        self.parts = parts

    def evaluate(self, t):
        t = np.asarray(t, dtype=float)
        out = [np.zeros(t.shape) for _ in range(3)]
        for p in self.parts:
            for acc, new in zip(out, p.evaluate(t)):
                acc += new
        return tuple(out)


# --------------------------------------------------------------------------- attitude


class RotationChain:
    """``mat_nb(t) = mat_0 @ R(a_1, theta_1(t)) @ ... @ R(a_K, theta_K(t))``.

    Parameters
    ----------
    axes : sequence of [3] unit vectors
        Fixed axis of each rotation, in the frame that rotation acts in.
    profiles : sequence of profiles
        Angle of each rotation [rad] as a profile object (``evaluate(t)``).
    mat_0 : [3, 3]
        Constant leading rotation (e.g. the table's azimuth zero).
    """

    def __init__(self, axes, profiles, mat_0=None):
        self.axes = [np.asarray(a, dtype=float) / np.linalg.norm(a) for a in axes]
        self.profiles = list(profiles)
        self.mat_0 = np.eye(3) if mat_0 is None else np.asarray(mat_0, dtype=float)

    def evaluate(self, t):
        """Return ``mat_nb [n,3,3]``, ``omega_nb_b [n,3]`` [rad/s], ``omegadot_nb_b [n,3]`` [rad/s^2]."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        n = t.shape[0]
        p_mat = np.broadcast_to(np.eye(3), (n, 3, 3)).copy()
        w = np.zeros((n, 3))
        omegadot = np.zeros((n, 3))
        for axis, profile in zip(reversed(self.axes), reversed(self.profiles)):
            theta, rate, acc = profile.evaluate(t)
            u = np.einsum("nji,j->ni", p_mat, axis)  # P^T a: this axis in the final (body) frame
            omegadot += u * acc[:, None] - np.cross(w, u) * rate[:, None]
            w += u * rate[:, None]
            p_mat = axis_angle_mat(axis, theta) @ p_mat
        return self.mat_0 @ p_mat, w, omegadot


# --------------------------------------------------------------------------- position


@dataclass
class MotionState:
    """Motion of the reference point at ``n`` instants (arrays with time on axis 0)."""

    t_s: np.ndarray  #: [n] s
    lat_rad: np.ndarray  #: [n]
    lon_rad: np.ndarray  #: [n]
    height_m: np.ndarray  #: [n]
    v_n: np.ndarray  #: [n,3] NED velocity, m/s
    vdot_n: np.ndarray  #: [n,3] time derivative of the NED velocity components, m/s^2
    mat_nb: np.ndarray  #: [n,3,3] reference (reported) attitude, body to NED
    omega_nb_b: np.ndarray  #: [n,3] rad/s
    omegadot_nb_b: np.ndarray  #: [n,3] rad/s^2


class StaticSite:
    """A reference point at rest on the Earth (turntable centre, sway rig)."""

    def __init__(self, lat_rad: float, lon_rad: float, height_m: float):
        self.lat_rad = float(lat_rad)
        self.lon_rad = float(lon_rad)
        self.height_m = float(height_m)

    def evaluate(self, t):
        n = np.shape(t)[0]
        zeros = np.zeros((n, 3))
        return (np.full(n, self.lat_rad), np.full(n, self.lon_rad), np.full(n, self.height_m), zeros, zeros.copy())


class FlightPath:
    """A vehicle's path: ground speed, track and height as smooth profiles, plus linear vibration.

    ``v_n = [V cos(track), V sin(track), -hdot] + vibration``. Latitude and
    longitude of the smooth path come from the WGS-84 kinematic ODE
    ``lat' = v_N / (R_M + h)``, ``lon' = v_E / ((R_T + h) cos lat)`` solved with
    DOP853 at rtol 1e-13 (position consistent with velocity to well below 1e-6 m
    over hours). The vibration displacement (sub-millimetre, zero mean) is added
    in metres via the local radii, which is exact to the order
    ``displacement * distance / R`` (< 1e-9 m).
    """

    def __init__(
        self,
        speed: SmoothProfile,
        track: SmoothProfile,
        height: SmoothProfile,
        lat0_rad: float,
        lon0_rad: float,
        t_end: float,
        vibration_n: list | None = None,
    ):
        self.speed = speed
        self.track = track
        self.height = height
        self.vibration_n = vibration_n or []  # [(axis 0..2, Sinusoids of displacement in m)]
        self.t_end = float(t_end)

        def rhs(t, y):
            v, _, _ = speed.evaluate(t)
            psi, _, _ = track.evaluate(t)
            h, _, _ = height.evaluate(t)
            r_mer, r_tr = earth.radii_m(y[0])
            return [v * np.cos(psi) / (r_mer + h), v * np.sin(psi) / ((r_tr + h) * np.cos(y[0]))]

        # Breakpoints of the profiles are where the RHS is least smooth: stop there.
        breaks = np.unique(np.concatenate([speed.breakpoints, track.breakpoints, [0.0, self.t_end]]))
        breaks = breaks[(breaks >= 0.0) & (breaks <= self.t_end)]
        self._segments = []
        y = np.array([lat0_rad, lon0_rad])
        from scipy.integrate import (
            solve_ivp,  # here: scipy.integrate costs 0.4 s at start-up
        )

        for a, b in zip(breaks[:-1], breaks[1:]):
            sol = solve_ivp(rhs, (a, b), y, method="DOP853", rtol=1e-13, atol=1e-15, dense_output=True)
            if not sol.success:
                raise RuntimeError(f"flight path integration failed: {sol.message}")
            self._segments.append(sol.sol)
            y = sol.y[:, -1]
        self._starts = breaks[:-1]

    def _latlon(self, t):
        idx = np.clip(np.searchsorted(self._starts, t, side="right") - 1, 0, len(self._segments) - 1)
        out = np.empty((2, t.shape[0]))
        for k in np.unique(idx):
            sel = idx == k
            out[:, sel] = self._segments[k](t[sel])
        return out[0], out[1]

    def evaluate(self, t):
        t = np.asarray(t, dtype=float)
        v, vdot, _ = self.speed.evaluate(t)
        psi, psidot, _ = self.track.evaluate(t)
        h, hdot, hddot = self.height.evaluate(t)
        lat, lon = self._latlon(t)
        v_n = np.column_stack([v * np.cos(psi), v * np.sin(psi), -hdot])
        vdot_n = np.column_stack(
            [vdot * np.cos(psi) - v * psidot * np.sin(psi), vdot * np.sin(psi) + v * psidot * np.cos(psi), -hddot]
        )
        if self.vibration_n:
            disp = np.zeros((t.shape[0], 3))
            for axis, sins in self.vibration_n:
                d, dd, ddd = sins.evaluate(t)
                disp[:, axis] += d
                v_n[:, axis] += dd
                vdot_n[:, axis] += ddd
            r_mer, r_tr = earth.radii_m(lat)
            lat = lat + disp[:, 0] / (r_mer + h)
            lon = lon + disp[:, 1] / ((r_tr + h) * np.cos(lat))
            h = h - disp[:, 2]
        return lat, lon, h, v_n, vdot_n


class Trajectory:
    """Reference-point motion: a position model and an attitude model over ``[0, duration_s]``."""

    def __init__(
        self, position, attitude: RotationChain, duration_s: float, name: str = "custom", segments: list | None = None
    ):
        self.position = position
        self.attitude = attitude
        self.duration_s = float(duration_s)
        self.name = name
        #: [(name, t_start, t_end)] phases of the record, for summaries and tests
        self.segments = segments or []

    def evaluate(self, t) -> MotionState:
        t = np.atleast_1d(np.asarray(t, dtype=float))
        lat, lon, h, v_n, vdot_n = self.position.evaluate(t)
        mat_nb, omega, omegadot = self.attitude.evaluate(t)
        return MotionState(t, lat, lon, h, v_n, vdot_n, mat_nb, omega, omegadot)
