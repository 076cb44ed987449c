"""Simulated IMU telemetry with known truth: ``sizefx simulate``.

The ideal outputs follow exactly from the analytic motion (:mod:`sizefx.motion`):

* gyros read ``omega_ib_b = omega_nb_b + mat_bn (omega_ie_n + omega_en_n)``;
* the reference point feels ``f_b = mat_bn (vdot_n + (2 omega_ie_n + omega_en_n) x v_n - g_n)``
  (the NED velocity equation, Groves eq. 5.54, solved for f);
* accelerometer i at ``r_i`` from the reference point reads
  ``u_i . (f_b + omegadot_ib_b x r_i + omega_ib_b x (omega_ib_b x r_i))``
  (rigid-body kinematics; the gravity gradient over ``r_i``, about 3e-6 s^-2
  times a few cm, i.e. < 0.01 ug, is neglected);
* increments are the integrals of these over each sample interval by
  three-point Gauss-Legendre quadrature (error below 1e-12 of the signal for
  motion content under 100 Hz at 1600 Hz sampling).

The sensor model, applied per instant (before integration) in this order:
gyro ``(1 + s_g) (u_g . omega) + b_g + G f_b``; accelerometer
``(1 + s_a) a + K2 a^2 + b_a`` with ``a = u_i . f_i``; then per sample white
noise, bias random walks and quantisation. Noise streams are drawn from one
seed, each stream in sample order, so the output does not depend on the chunk
size and switching one effect on does not change another's noise.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import __version__, earth, scenarios
from .effects import IDEAL, EffectModel, load_effects
from .errors import ConfigError
from .motion import Trajectory
from .rotation import mat_to_quat, rotvec_to_mat
from .io.telemetry import Reference, Site, Telemetry, TelemetryWriter

__all__ = ["ImuKinematics", "kinematics", "ImuSynthesizer", "simulate_to_file", "GAUSS_NODES", "GAUSS_WEIGHTS"]

#: Three-point Gauss-Legendre rule on [-1, 1].
GAUSS_NODES = np.array([-np.sqrt(0.6), 0.0, np.sqrt(0.6)])
GAUSS_WEIGHTS = np.array([5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0])

#: Default IMU samples per chunk: 2^16 samples keeps the working set of the
#: vectorised kinematics (about 40 arrays of [3 * 65536, 3]) near 100 MB.
CHUNK_SAMPLES = 1 << 16


@dataclass
class ImuKinematics:
    """Ideal inertial quantities at ``n`` instants."""

    omega_ib_b: np.ndarray  #: [n,3] rad/s
    omegadot_ib_b: np.ndarray  #: [n,3] rad/s^2
    f_b: np.ndarray  #: [n,3] m/s^2, specific force at the reference point
    accel_input: np.ndarray  #: [n,3] m/s^2, u_i . f_i: what ideal accelerometer i at r_i reads


def kinematics(traj: Trajectory, t, effects: EffectModel) -> ImuKinematics:
    """Ideal gyro rates and accelerometer inputs at times ``t`` (true attitude includes the level tilt)."""
    st = traj.evaluate(t)
    mat_nb = rotvec_to_mat(effects.tilt_rad()) @ st.mat_nb
    mat_bn = np.swapaxes(mat_nb, -1, -2)
    w_ie = earth.omega_ie_n(st.lat_rad)
    w_en = earth.omega_en_n(st.lat_rad, st.height_m, st.v_n)
    w_in_b = np.einsum("nij,nj->ni", mat_bn, w_ie + w_en)
    wdot_in_n = earth.omegadot_in_n(st.lat_rad, st.height_m, st.v_n, st.vdot_n)
    omega = st.omega_nb_b + w_in_b
    omegadot = st.omegadot_nb_b - np.cross(st.omega_nb_b, w_in_b) + np.einsum("nij,nj->ni", mat_bn, wdot_in_n)
    f_n = st.vdot_n + np.cross(2.0 * w_ie + w_en, st.v_n) - earth.gravity_n(st.lat_rad, st.height_m)
    f_b = np.einsum("nij,nj->ni", mat_bn, f_n)
    arms = effects.arms_total_m()
    axes = effects.accel_axes()
    accel_input = np.empty_like(f_b)
    for i in range(3):
        r = arms[i]
        f_i = f_b + np.cross(omegadot, r) + np.cross(omega, np.cross(omega, r))
        accel_input[:, i] = f_i @ axes[i]
    return ImuKinematics(omega, omegadot, f_b, accel_input)


class ImuSynthesizer:
    """Turn a trajectory and an effect model into IMU samples, chunk by chunk.

    Parameters
    ----------
    traj : Trajectory
    effects : EffectModel
    rate_hz : float
        IMU sample rate.
    form : {"rates", "increments"}
        Rates are sampled at ``k / rate_hz``, k = 0 .. N-1; increments cover
        ``((k - 1) / rate_hz, k / rate_hz]``, k = 1 .. N.
    seed : int
    """

    def __init__(self, traj: Trajectory, effects: EffectModel, *, rate_hz: float = 1600.0,
                 form: str = "rates", seed: int = 0):
        if form not in ("rates", "increments"):
            raise ValueError(f"form must be 'rates' or 'increments', got {form!r}")
        self.traj = traj
        self.fx = effects
        self.rate_hz = float(rate_hz)
        self.dt = 1.0 / self.rate_hz
        self.form = form
        self.seed = int(seed)
        if form == "rates":
            self.n_samples = int(np.floor(traj.duration_s * self.rate_hz + 1e-9)) + 1
            self.first_index = 0
        else:
            self.n_samples = int(np.floor(traj.duration_s * self.rate_hz + 1e-9))
            self.first_index = 1
        fx = effects
        self.tau_accel = fx.get("accel_delay", "tau_s") if fx.enabled("accel_delay") else 0.0
        self.gyro_matrix = np.diag(1.0 + fx.value_or_zero("gyro_scale_factor", "scale_factor")) @ fx.gyro_axes()
        self.gyro_bias = fx.value_or_zero("gyro_bias", "bias_rad_s")
        self.gyro_g = fx.value_or_zero("gyro_g_sensitivity", "rad_s_per_mps2", (3, 3))
        self.accel_scale = 1.0 + fx.value_or_zero("accel_scale_factor", "scale_factor")
        self.accel_k2 = fx.value_or_zero("accel_quadratic", "k2_per_mps2")
        self.accel_bias = fx.value_or_zero("accel_bias", "bias_mps2")
        streams = np.random.SeedSequence(self.seed).spawn(4)
        self._rng = {name: np.random.default_rng(s)
                     for name, s in zip(("gyro_white", "accel_white", "gyro_rw", "accel_rw"), streams)}
        self._gyro_rw = np.zeros(3)
        self._accel_rw = np.zeros(3)
        self._carry = {"gyro": np.zeros(3), "accel": np.zeros(3)}
        self._next = 0

    def sample_times(self, k0: int, k1: int) -> np.ndarray:
        return (np.arange(k0, k1) + self.first_index) * self.dt

    def _gyro_out(self, kin: ImuKinematics):
        return kin.omega_ib_b @ self.gyro_matrix.T + self.gyro_bias + kin.f_b @ self.gyro_g.T

    def _accel_out(self, kin: ImuKinematics):
        a = kin.accel_input
        return self.accel_scale * a + self.accel_k2 * a * a + self.accel_bias

    def deterministic(self, t: np.ndarray):
        """Error-model outputs (no noise) at times t: rates, or increments over (t - dt, t]."""
        if self.form == "rates":
            nodes = t
        else:
            nodes = (t[:, None] - 0.5 * self.dt + 0.5 * self.dt * GAUSS_NODES).ravel()
        kin_g = kinematics(self.traj, nodes, self.fx)
        kin_a = kin_g if self.tau_accel == 0.0 else kinematics(self.traj, nodes - self.tau_accel, self.fx)
        gyro = self._gyro_out(kin_g)
        accel = self._accel_out(kin_a)
        if self.form == "increments":
            w = 0.5 * self.dt * GAUSS_WEIGHTS
            gyro = np.einsum("nkj,k->nj", gyro.reshape(-1, 3, 3), w)
            accel = np.einsum("nkj,k->nj", accel.reshape(-1, 3, 3), w)
        return gyro, accel

    def _random_walk(self, name: str, q: float, n: int, state: np.ndarray):
        steps = self._rng[name].standard_normal((n, 3)) * (q * np.sqrt(self.dt))
        # Summing from the carried state in one sequential cumsum gives bit-identical
        # results whatever the chunk size (state + cumsum(steps) would not).
        walk = np.cumsum(np.vstack([state, steps]), axis=0)[1:]
        return walk, walk[-1].copy()

    def _quantise(self, name: str, values: np.ndarray, lsb_increment: float):
        if self.form == "rates":
            lsb = lsb_increment / self.dt
            return np.round(values / lsb) * lsb
        # Counters carry the remainder: the sum of outputs tracks the true sum.
        total = np.cumsum(np.vstack([self._carry[name], values]), axis=0)[1:]
        counts = np.round(total / lsb_increment)
        prev = np.vstack([np.round(self._carry[name] / lsb_increment), counts[:-1]])
        self._carry[name] = total[-1]
        return (counts - prev) * lsb_increment

    def next_chunk(self, n: int):
        """The next ``n`` samples (fewer at the end): ``(time_s, gyro_like, accel_like)``."""
        k0 = self._next
        k1 = min(self.n_samples, k0 + n)
        self._next = k1
        n = k1 - k0
        t = self.sample_times(k0, k1)
        gyro, accel = self.deterministic(t)
        fx = self.fx
        per_sample = 1.0 if self.form == "rates" else self.dt  # bias -> increment
        white = 1.0 / np.sqrt(self.dt) if self.form == "rates" else np.sqrt(self.dt)
        if fx.enabled("gyro_noise"):
            gyro += self._rng["gyro_white"].standard_normal((n, 3)) * (fx.get("gyro_noise", "arw_rad_per_sqrt_s") * white)
            walk, self._gyro_rw = self._random_walk("gyro_rw", fx.get("gyro_noise", "rrw_rad_s_per_sqrt_s"),
                                                    n, self._gyro_rw)
            gyro += walk * per_sample
        if fx.enabled("accel_noise"):
            accel += self._rng["accel_white"].standard_normal((n, 3)) * (
                fx.get("accel_noise", "density_mps2_per_sqrt_hz") * white)
            walk, self._accel_rw = self._random_walk("accel_rw", fx.get("accel_noise", "bias_rw_mps2_per_sqrt_s"),
                                                     n, self._accel_rw)
            accel += walk * per_sample
        if fx.enabled("quantisation"):
            gyro = self._quantise("gyro", gyro, fx.get("quantisation", "gyro_lsb_rad"))
            accel = self._quantise("accel", accel, fx.get("quantisation", "accel_lsb_m_per_s"))
        return t, gyro, accel

    def reference_rows(self, t_ref: np.ndarray):
        """Reported motion at reference time stamps (reference delay applied; no tilt: it is what the table says)."""
        tau = self.fx.get("reference_delay", "tau_s") if self.fx.enabled("reference_delay") else 0.0
        st = self.traj.evaluate(t_ref - tau)
        return mat_to_quat(st.mat_nb), st.lat_rad, st.lon_rad, st.height_m, st.v_n


def simulate_to_file(traj: Trajectory, scenario_info: dict, effects: EffectModel, out, *,
                     rate_hz: float = 1600.0, form: str = "rates", seed: int = 0,
                     reference_rate_hz: float | None = None, force: bool = False,
                     chunk_samples: int = CHUNK_SAMPLES, inputs=(), progress=None) -> dict:
    """Simulate ``traj`` and stream it into a ``sizefx/telemetry/1`` file; return a summary.

    ``reference_rate_hz`` defaults to the IMU rate; it must divide it.
    ``progress(done, total)`` is called after each chunk when given.
    """
    started = time.perf_counter()
    syn = ImuSynthesizer(traj, effects, rate_hz=rate_hz, form=form, seed=seed)
    ref_rate = rate_hz if reference_rate_hz is None else float(reference_rate_hz)
    stride = rate_hz / ref_rate
    if abs(stride - round(stride)) > 1e-9 or stride < 1:
        raise ConfigError(f"--reference-rate-hz {ref_rate:g} must divide the IMU rate {rate_hz:g} Hz "
                          "(e.g. 100, 200, 400, 800 for 1600 Hz)")
    n_ref = int(np.floor(traj.duration_s * ref_rate + 1e-9)) + 1
    st0 = traj.evaluate(np.array([0.0]))
    site = Site(float(st0.lat_rad[0]), float(st0.lon_rad[0]), float(st0.height_m[0]))
    truth = {
        "scenario": traj.name,
        "seed": int(seed),
        "rate_hz": float(rate_hz),
        "form": form,
        "reference_rate_hz": ref_rate,
        "duration_s": traj.duration_s,
        "segments": [[name, float(a), float(b)] for name, a, b in traj.segments],
        "scenario_parameters": scenario_info,
        "effects": effects.truth(),
        "effects_source": effects.source,
        "sizefx_version": __version__,
        "model": "see sizefx.simulate: gyro (1+s)(u.omega_ib)+b+G f; accel (1+s)a+K2 a^2+b, "
                 "a = u_i.(f + omegadot x r_i + omega x (omega x r_i)); gravity gradient neglected",
    }
    description = (f"sizefx {__version__} simulation: {traj.name}, {rate_hz:g} Hz {form}, seed {seed}; "
                   "truth in /simulation")
    writer = TelemetryWriter(out, n_samples=syn.n_samples, form=form, n_reference=n_ref,
                             reference_position=True, reference_velocity=True, site=site,
                             description=description, simulation=truth, inputs=inputs, force=force)
    ref_per_chunk = max(1, int(chunk_samples / stride))
    with writer as w:
        done = 0
        while done < syn.n_samples:
            t, g, a = syn.next_chunk(chunk_samples)
            w.write_imu(t, g, a)
            done += t.shape[0]
            if progress is not None:
                progress(done, syn.n_samples)
        for j0 in range(0, n_ref, ref_per_chunk):
            t_ref = np.arange(j0, min(n_ref, j0 + ref_per_chunk)) / ref_rate
            w.write_reference(t_ref, *syn.reference_rows(t_ref))
    return {
        "path": str(out),
        "scenario": traj.name,
        "samples": syn.n_samples,
        "rate_hz": rate_hz,
        "form": form,
        "duration_s": traj.duration_s,
        "reference_samples": n_ref,
        "file_bytes": Path(out).stat().st_size,
        "wall_s": time.perf_counter() - started,
    }


#: Reference rate of the navigation-length records (sway, flight) when none is
#: given: the 1.8 h flight at 1600 Hz would add 900 MB of reference, and 100 Hz
#: resolves their 1 Hz sway and manoeuvres. The turntable keeps the IMU rate,
#: which calibration and diagnosis use sample by sample.
NAVIGATION_REFERENCE_RATE_HZ = 100.0


def run(scenario: str, out, *, plan=None, site=None, effects_path=None, overrides: dict | None = None,
        ideal: bool = False, rate_hz: float = 1600.0, form: str = "rates", seed: int = 0,
        reference_rate_hz: float | None = None, force: bool = False, progress=None) -> dict:
    """Entry point of ``sizefx simulate``: build the scenario and the effect model, write ``out``.

    ``ideal`` switches every effect off before the effects file and
    ``overrides`` are applied, so ``ideal`` plus ``overrides`` gives a record
    with exactly the named effects.
    """
    builders = {"turntable": (scenarios.turntable, scenarios.TurntablePlan),
                "sway": (scenarios.sway, scenarios.SwayPlan),
                "flight": (scenarios.flight, scenarios.FlightPlan),
                "tumble": (scenarios.tumble_scenario, scenarios.TumblePlan)}
    if scenario not in builders:
        raise ValueError(f"unknown scenario {scenario!r}")
    build, plan_cls = builders[scenario]
    traj, info = build(plan or plan_cls(), site or scenarios.PAPER_AIRFIELD)
    fx = load_effects(effects_path, overrides=overrides, base=IDEAL if ideal else None)
    if reference_rate_hz is None and scenario in ("sway", "flight"):
        reference_rate_hz = NAVIGATION_REFERENCE_RATE_HZ
    inputs = [effects_path] if effects_path else []
    return simulate_to_file(traj, info, fx, out, rate_hz=rate_hz, form=form, seed=seed,
                            reference_rate_hz=reference_rate_hz, force=force, inputs=inputs, progress=progress)


def simulate_in_memory(traj: Trajectory, effects: EffectModel | None = None, *, rate_hz: float = 1600.0,
                       form: str = "increments", seed: int = 0):
    """A whole record as a :class:`~sizefx.io.telemetry.Telemetry` in memory, reference at the IMU rate.

    For short records (algorithm checks, diagnosis experiments); files go through
    :func:`simulate_to_file`.
    """
    fx = effects if effects is not None else load_effects(base=IDEAL)
    syn = ImuSynthesizer(traj, fx, rate_hz=rate_hz, form=form, seed=seed)
    t, g, a = syn.next_chunk(syn.n_samples)
    t_ref = np.arange(0, int(np.floor(traj.duration_s * rate_hz + 1e-9)) + 1) / rate_hz
    q, lat, lon, h, v = syn.reference_rows(t_ref)
    tel = Telemetry(time_s=t, form=form, reference=Reference(t_ref, q, lat, lon, h, v),
                    site=Site(float(lat[0]), float(lon[0]), float(h[0])))
    if form == "rates":
        tel.gyro_rad_s, tel.accel_mps2 = g, a
    else:
        tel.dtheta_rad, tel.dvel_mps = g, a
    return tel
