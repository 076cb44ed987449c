"""The three built-in motions: turntable calibration plan, sway, helicopter flight.

Each builder returns a :class:`~sizefx.motion.Trajectory` of the reference
point (the table's rotation centre, or the vehicle's navigation point) and a
dict of the parameters used, which the simulator stores in ``/simulation``.
The plans and the site, with their options declared, are :mod:`sizefx.configs.scenarios`
(without numpy, for the command line's help); they are re-exported here.
"""

from __future__ import annotations

from dataclasses import asdict

import numpy as np

from .configs.scenarios import (
    PAPER_AIRFIELD,
    TABLE_ORIENTATIONS_DEG,
    FlightPlan,
    SiteSpec,
    SwayPlan,
    TumblePlan,
    TurntablePlan,
)
from .constants import DEG, SECONDS_PER_HOUR, STANDARD_GRAVITY_MPS2
from .errors import ConfigError
from .motion import (
    ConstantProfile,
    FlightPath,
    Profile,
    ProfileBuilder,
    RateOf,
    RotationChain,
    Scaled,
    Sinusoids,
    StaticSite,
    SumProfile,
    SwayProfile,
    Trajectory,
)

__all__ = [
    "SiteSpec",
    "TurntablePlan",
    "SwayPlan",
    "FlightPlan",
    "TumblePlan",
    "turntable",
    "sway",
    "flight",
    "tumble",
    "PAPER_AIRFIELD",
]

E_NORTH = np.array([1.0, 0.0, 0.0])
E_EAST = np.array([0.0, 1.0, 0.0])
E_DOWN = np.array([0.0, 0.0, 1.0])


# --------------------------------------------------------------------------- turntable


def turntable(plan: TurntablePlan, site: SiteSpec = PAPER_AIRFIELD) -> tuple[Trajectory, dict]:
    half, cruise = plan.check()
    peak = plan.peak_rate_dps * DEG
    acc = plan.accel_dps2 * DEG
    outer = ProfileBuilder(0.0)
    mid = ProfileBuilder(0.0)
    inner = ProfileBuilder(0.0)
    segments = [("static", 0.0, plan.static_s)]
    t = plan.static_s
    for b in (outer, mid, inner):
        b.hold(plan.static_s)
    first = TABLE_ORIENTATIONS_DEG[plan.axes[0]]
    for k, axis in enumerate(plan.axes):
        start = t
        for _ in range(plan.cycles):
            for sign in (1.0, -1.0):
                outer.hold(plan.dwell_s).change_rate(sign * peak, accel=acc, ramp_s=plan.ramp_s)
                outer.hold(cruise).change_rate(-sign * peak, accel=acc, ramp_s=plan.ramp_s).hold(plan.dwell_s)
        t += plan.seconds_per_axis
        for b in (mid, inner):
            b.hold(plan.seconds_per_axis)
        segments.append((f"rotate {axis}", start, t))
        if k + 1 < len(plan.axes):
            nxt = TABLE_ORIENTATIONS_DEG[plan.axes[k + 1]]
            cur = TABLE_ORIENTATIONS_DEG[axis]
            outer.hold(plan.reposition_s + plan.settle_s)
            for b, c0, c1 in ((mid, cur[0], nxt[0]), (inner, cur[1], nxt[1])):
                if c1 != c0:
                    b.move(plan.reposition_s, (c1 - c0) * DEG)
                else:
                    b.hold(plan.reposition_s)
                b.hold(plan.settle_s)
            segments.append((f"reposition {axis}->{plan.axes[k + 1]}", t, t + plan.reposition_s))
            segments.append(("static", t + plan.reposition_s, t + plan.reposition_s + plan.settle_s))
            t += plan.reposition_s + plan.settle_s
    for b in (outer, mid, inner):
        b.hold(plan.settle_s)
    segments.append(("static", t, t + plan.settle_s))
    t += plan.settle_s
    chain = RotationChain(
        [E_DOWN, E_NORTH, E_EAST],
        [outer.build(), mid.build(first[0] * DEG), inner.build(first[1] * DEG)],
    )
    lat, lon, h = site.radians()
    traj = Trajectory(StaticSite(lat, lon, h), chain, t, name="turntable", segments=segments)
    return traj, {
        "plan": asdict(plan),
        "site": asdict(site),
        "gimbals": "mat_nb = Rz(outer) Rx(middle) Ry(inner) (NED axes)",
    }


# --------------------------------------------------------------------------- sway


def sway(plan: SwayPlan, site: SiteSpec = PAPER_AIRFIELD) -> tuple[Trajectory, dict]:
    plan.check()
    n = len(plan.amplitudes_dps)
    starts = plan.static_s + plan.segment_s * np.arange(n)
    prof = SwayProfile(starts, [plan.segment_s] * n, np.asarray(plan.amplitudes_dps) * DEG, plan.frequency_hz)
    heading: Profile = ConstantProfile(plan.heading_deg * DEG)
    pitch: Profile = ConstantProfile(0.0)
    roll: Profile = ConstantProfile(0.0)
    if plan.axis == "heading":
        heading = SumProfile(heading, prof)
    elif plan.axis == "pitch":
        pitch = prof
    else:
        roll = prof
    chain = RotationChain([E_DOWN, E_EAST, E_NORTH], [heading, pitch, roll])  # z-y-x Euler angles
    duration = plan.duration_s
    segments = [("static", 0.0, plan.static_s)] + [
        (f"sway {a:g} deg/s", s, s + plan.segment_s) for a, s in zip(plan.amplitudes_dps, starts)
    ]
    lat, lon, h = site.radians()
    traj = Trajectory(StaticSite(lat, lon, h), chain, duration, name="sway", segments=segments)
    return traj, {"plan": {**asdict(plan), "amplitudes_dps": list(plan.amplitudes_dps)}, "site": asdict(site)}


# --------------------------------------------------------------------------- flight


def _flat_plan(speed, track, t_end, dt=0.5):
    """Flat-Earth north/east position from speed and track profiles (for planning only)."""
    t = np.arange(0.0, t_end + dt, dt)
    v, _, _ = speed.evaluate(t)
    psi, _, _ = track.evaluate(t)
    vn, ve = v * np.cos(psi), v * np.sin(psi)
    n = np.concatenate([[0.0], np.cumsum(0.5 * (vn[1:] + vn[:-1]) * dt)])
    e = np.concatenate([[0.0], np.cumsum(0.5 * (ve[1:] + ve[:-1]) * dt)])
    return n[-1], e[-1]


def flight(plan: FlightPlan, site: SiteSpec = PAPER_AIRFIELD) -> tuple[Trajectory, dict]:
    V = plan.speed_mps
    psi0 = plan.heading_deg * DEG
    accel_s = 60.0  # speed change 0 <-> V, smootherstep: peak 1.875 V / 60 s
    climb_s = 120.0
    t_to = plan.align_s
    t_cruise = t_to + 20.0 + accel_s  # at speed
    weave_T = 40.0
    land_tail = climb_s + 60.0  # descend after stopping, then sit with the rotor running down

    def build(t_out, turn_deg, weave):
        speed = ProfileBuilder(0.0).hold(t_to + 20.0).move(accel_s, V)
        track = ProfileBuilder(0.0).hold(t_cruise)
        t = t_cruise
        if weave:
            track.hold(60.0).move(weave_T / 2, plan.weave_deg * DEG)
            for _ in range(2):
                track.move(weave_T, -2 * plan.weave_deg * DEG).move(weave_T, 2 * plan.weave_deg * DEG)
            track.move(weave_T / 2, -plan.weave_deg * DEG)
            t += 60.0 + 5 * weave_T
        track.hold(t_out - (t - t_cruise))
        t = t_cruise + t_out
        turn_s = 1.875 * turn_deg / plan.turn_rate_dps
        track.move(turn_s, turn_deg * DEG)
        t_turn_end = t + turn_s
        return speed, track, t_turn_end

    weave = plan.weave_deg > 0.0

    def plan_return(t_out):
        turn = 180.0
        for _ in range(8):
            speed, track, t_turn_end = build(t_out, turn, weave)
            track.hold(1.0)
            n, e = _flat_plan(speed.build(), track.build(psi0), t_turn_end)
            bearing = np.degrees(np.arctan2(-e, -n))
            turn = (bearing - plan.heading_deg) % 360.0
        dist = np.hypot(n, e)
        t_return = (dist - V * accel_s / 2.0) / V
        return turn, t_turn_end, t_return

    def end_time(t_out):
        _, t_turn_end, t_return = plan_return(t_out)
        return t_turn_end + t_return + accel_s + land_tail

    t_out_min = (60.0 + 5 * weave_T if weave else 0.0) + 30.0
    if end_time(t_out_min) > plan.duration_s:
        raise ConfigError(
            f"flight: {plan.duration_s:.0f} s (--duration-h {plan.duration_s / SECONDS_PER_HOUR:g}) is too short for "
            f"{plan.align_s:g} s of alignment (--align-s), take-off, a turn and landing (at least "
            f"{end_time(t_out_min):.0f} s in all); lengthen --duration-h or shorten --align-s"
        )
    from scipy.optimize import brentq  # here: scipy.optimize costs 0.3 s at start-up

    t_out = brentq(lambda x: end_time(x) - plan.duration_s, t_out_min, plan.duration_s, xtol=1e-6)
    turn_deg, t_turn_end, t_return = plan_return(t_out)
    speed, track, _ = build(t_out, turn_deg, weave)
    t_stop = t_turn_end + t_return
    track.hold(plan.duration_s + 10.0 - t_turn_end)
    speed.hold(t_stop - (t_to + 20.0 + accel_s)).move(accel_s, -V).hold(1.0)
    height = ProfileBuilder(0.0).hold(t_to).move(climb_s, plan.altitude_m)
    t_h = t_to + climb_s
    if plan.climb_step_m and t_return > 4 * climb_s:
        mid = t_turn_end + t_return / 2.0 - climb_s
        height.hold(mid - t_h).move(climb_s, plan.climb_step_m).move(climb_s, -plan.climb_step_m)
        t_h = mid + 2 * climb_s
    t_land = t_stop + accel_s
    height.hold(t_land - t_h).move(climb_s, -plan.altitude_m).hold(1.0)
    lat, lon, h0 = site.radians()
    speed_p, track_p, height_p = speed.build(), track.build(psi0), height.build(h0)

    # Rotor envelope: fades in before take-off, out after touchdown.
    env = ProfileBuilder(0.0).hold(max(t_to - 120.0, 1.0)).move(20.0, 1.0)
    t_env = max(t_to - 120.0, 1.0) + 20.0
    env.hold(t_land + climb_s + 10.0 - t_env).move(20.0, -1.0).hold(1.0)
    env_p = env.build()
    f1 = plan.rotor_hz
    freqs = [f1, 2 * f1, 4 * f1]

    def ang_vib(rate_amp_dps, phase):
        amps = [rate_amp_dps * DEG / (2 * np.pi * f) * s for f, s in zip(freqs, (1.0, 0.5, 0.25))]
        return Sinusoids(amps, freqs, [phase, 2 * phase + 0.5, 3 * phase + 1.0], envelope=env_p)

    def lin_vib(acc_amp):
        f = 2 * f1
        return Sinusoids([acc_amp / (2 * np.pi * f) ** 2], [f], [0.3], envelope=env_p)

    heading = SumProfile(track_p, ang_vib(plan.vib_rate_dps[2], 2.1))
    pitch = SumProfile(Scaled(speed_p, plan.cruise_pitch_deg * DEG / V), ang_vib(plan.vib_rate_dps[1], 1.3))
    roll = SumProfile(RateOf(track_p, V / STANDARD_GRAVITY_MPS2), ang_vib(plan.vib_rate_dps[0], 0.7))
    chain = RotationChain([E_DOWN, E_EAST, E_NORTH], [heading, pitch, roll])
    path = FlightPath(
        speed_p,
        track_p,
        height_p,
        lat,
        lon,
        plan.duration_s,
        vibration_n=[(k, lin_vib(a)) for k, a in enumerate(plan.vib_accel_mps2)],
    )
    segments = [
        ("static alignment", 0.0, t_to),
        ("take-off", t_to, t_cruise),
        ("outbound", t_cruise, t_cruise + t_out),
        ("turn", t_cruise + t_out, t_turn_end),
        ("return", t_turn_end, t_stop),
        ("landing", t_stop, t_land + climb_s),
        ("on ground", t_land + climb_s, plan.duration_s),
    ]
    traj = Trajectory(path, chain, plan.duration_s, name="flight", segments=segments)
    info = {
        "plan": {**asdict(plan), "vib_rate_dps": list(plan.vib_rate_dps), "vib_accel_mps2": list(plan.vib_accel_mps2)},
        "site": asdict(site),
        "turn_deg": float(turn_deg),
        "outbound_cruise_s": float(t_out),
        "return_cruise_s": float(t_return),
    }
    return traj, info


# --------------------------------------------------------------------------- algorithm checks


def coning(freq_hz: float, half_angle_rad: float, duration_s: float, site: SiteSpec = PAPER_AIRFIELD) -> Trajectory:
    """Classical coning on a static site: ``mat_nb = Rz(W t) Rx(beta) Rz(-W t)``, W = 2 pi f."""
    w = 2 * np.pi * freq_hz
    spin = ProfileBuilder(0.0).hold(duration_s).build(rate0=w)
    back = ProfileBuilder(0.0).hold(duration_s).build(rate0=-w)
    chain = RotationChain([E_DOWN, E_NORTH, E_DOWN], [spin, ConstantProfile(half_angle_rad), back])
    lat, lon, h = site.radians()
    return Trajectory(
        StaticSite(lat, lon, h),
        chain,
        duration_s,
        name="coning",
        segments=[(f"coning {freq_hz:g} Hz", 0.0, duration_s)],
    )


def sculling(
    freq_hz: float, angle_amp_rad: float, accel_amp_mps2: float, duration_s: float, site: SiteSpec = PAPER_AIRFIELD
) -> Trajectory:
    """Classical sculling without gravity coupling: heading A sin(W t) with north acceleration B sin(W t).

    The rotation axis is vertical, so gravity (along it) does not enter the rectification;
    the rectified error of a sculling algorithm then appears in the east velocity.
    """
    w = 2 * np.pi * freq_hz
    still = ProfileBuilder(0.0).hold(duration_s).build()
    lat, lon, h = site.radians()
    height = ProfileBuilder(0.0).hold(duration_s).build(value0=h)
    north = Sinusoids([-accel_amp_mps2 / w**2], [freq_hz], [0.0])  # displacement with acceleration B sin(W t)
    path = FlightPath(still, still, height, lat, lon, duration_s, vibration_n=[(0, north)])
    chain = RotationChain(
        [E_DOWN, E_EAST, E_NORTH],
        [Sinusoids([angle_amp_rad], [freq_hz], [0.0]), ConstantProfile(0.0), ConstantProfile(0.0)],
    )
    return Trajectory(
        path, chain, duration_s, name="sculling", segments=[(f"sculling {freq_hz:g} Hz", 0.0, duration_s)]
    )


def tumble(
    duration_s: float = 120.0,
    site: SiteSpec = PAPER_AIRFIELD,
    *,
    amplitudes_deg=(120.0, 70.0, 80.0),
    freqs_hz=(0.05, 0.083, 0.117),
    axes: str = "zyx",
) -> Trajectory:
    """Heading, pitch and roll sinusoids on a static site (a three-axis table tumbling).

    ``mat_nb = Rz(psi) Ry(theta) Rx(phi)`` with ``psi, theta, phi = A_k sin(2 pi f_k t + k)``:
    gravity sweeps every body axis with both signs, and the rates (up to about 0.7 rad/s)
    and angular accelerations excite every lever-arm component, delay and sensor error.
    ``axes`` keeps a subset: ``"z"`` turns about the vertical only, the case in which
    the accelerometer delay and most sensor errors stay hidden.
    """
    chain_axes, profiles = [], []
    for k, (name, axis) in enumerate(zip("zyx", (E_DOWN, E_EAST, E_NORTH))):
        amp = amplitudes_deg[k] * DEG if name in axes else 0.0
        chain_axes.append(axis)
        profiles.append(Sinusoids([amp], [freqs_hz[k]], [float(k)]))
    lat, lon, h = site.radians()
    return Trajectory(
        StaticSite(lat, lon, h),
        RotationChain(chain_axes, profiles),
        duration_s,
        name="tumble",
        segments=[(f"tumble about {axes}", 0.0, duration_s)],
    )


def tumble_scenario(plan: TumblePlan, site: SiteSpec = PAPER_AIRFIELD):
    """:func:`tumble` from a plan, with the plan as the scenario's parameters."""
    plan.check()
    traj = tumble(plan.duration_s, site, amplitudes_deg=plan.amplitudes_deg, freqs_hz=plan.freqs_hz, axes=plan.axes)
    return traj, asdict(plan)
