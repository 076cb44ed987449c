"""IMU samples from a trajectory and an effect model, chunk by chunk (:class:`ImuSynthesizer`): the
sensor model's forward map at each instant, increments by Gauss-Legendre quadrature over each sample
interval, then white noise, bias random walks, the Gauss-Markov part and quantisation, each stream
drawn in sample order so that the output does not depend on the chunk size."""

from __future__ import annotations

import numpy as np

from ..effects import EffectModel
from ..motion import Trajectory
from ..rotation import mat_to_quat
from ..sensor_model import reported_time, sample
from .truth import true_motion

__all__ = ["ImuSynthesizer", "GAUSS_NODES", "GAUSS_WEIGHTS"]

#: Three-point Gauss-Legendre rule on [-1, 1].
GAUSS_NODES = np.array([-np.sqrt(0.6), 0.0, np.sqrt(0.6)])
GAUSS_WEIGHTS = np.array([5.0 / 9.0, 8.0 / 9.0, 5.0 / 9.0])


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

    def __init__(
        self, traj: Trajectory, effects: EffectModel, *, rate_hz: float = 1600.0, form: str = "rates", seed: int = 0
    ):
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
        self.params = effects.sensor_params()  #: the deterministic effects (sizefx.sensor_model)
        # a new stream goes last: SeedSequence.spawn gives the earlier ones the same numbers
        streams = np.random.SeedSequence(self.seed).spawn(5)
        self._rng = {
            name: np.random.default_rng(s)
            for name, s in zip(("gyro_white", "accel_white", "gyro_rw", "accel_rw", "accel_markov"), streams)
        }
        # the coloured part's last value, drawn from its stationary law at the start
        self._accel_markov: np.ndarray | None = None
        self._gyro_rw = np.zeros(3)
        self._accel_rw = np.zeros(3)
        self._carry = {"gyro": np.zeros(3), "accel": np.zeros(3)}
        self._next = 0

    def sample_times(self, k0: int, k1: int) -> np.ndarray:
        return (np.arange(k0, k1) + self.first_index) * self.dt

    def _motion_at(self, t):
        return true_motion(self.traj, t, self.params)

    def deterministic(self, t: np.ndarray):
        """Error-model outputs (no noise) at times t: rates, or increments over (t - dt, t]."""
        if self.form == "rates":
            nodes = t
        else:
            nodes = (t[:, None] - 0.5 * self.dt + 0.5 * self.dt * GAUSS_NODES).ravel()
        gyro, accel = sample(self.params, self._motion_at, nodes)
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
        """``values`` [n, 3] on a grid of ``lsb_increment`` (an increment's step; rates: over dt).

        A step of 0 quantises nothing, as a noise density of 0 adds no noise (the contract allows
        both, "not negative"). A step so fine that a value divided by it overflows is far below the
        float spacing of that value, where quantising would change nothing either: such values are
        kept as they are instead of becoming inf and NaN.
        """
        if lsb_increment == 0.0:
            return values
        with np.errstate(over="ignore", invalid="ignore"):
            if self.form == "rates":
                lsb = lsb_increment / self.dt
                out = np.round(values / lsb) * lsb
            else:
                # Counters carry the remainder: the sum of outputs tracks the true sum.
                total = np.cumsum(np.vstack([self._carry[name], values]), axis=0)[1:]
                counts = np.round(total / lsb_increment)
                prev = np.vstack([np.round(self._carry[name] / lsb_increment), counts[:-1]])
                self._carry[name] = total[-1]
                out = (counts - prev) * lsb_increment
        return np.where(np.isfinite(out), out, values)

    def _markov(self, n: int, density: float, correlation_s: float) -> np.ndarray:
        """The next ``n`` values [n, 3] of the first-order Gauss-Markov part of the accelerometer
        noise: exact discretisation ``x[k+1] = phi x[k] + w``, ``phi = exp(-dt / T)``, stationary
        variance ``density^2 / (2 T)`` (its spectrum below ``1 / (2 pi T)`` is white noise of that
        density), carried over chunks by one sequential filter (the same values whatever the chunk size)."""
        from scipy.signal import lfilter

        rng = self._rng["accel_markov"]
        variance = density**2 / (2.0 * correlation_s)
        phi = float(np.exp(-self.dt / correlation_s))
        if self._accel_markov is None:
            self._accel_markov = rng.standard_normal(3) * np.sqrt(variance)
        w = rng.standard_normal((n, 3)) * np.sqrt(variance * (1.0 - phi * phi))
        x = lfilter([1.0], [1.0, -phi], w, axis=0, zi=(phi * self._accel_markov)[None, :])[0]
        self._accel_markov = x[-1].copy()
        return x

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
            gyro += self._rng["gyro_white"].standard_normal((n, 3)) * (
                fx.get("gyro_noise", "arw_rad_per_sqrt_s") * white
            )
            walk, self._gyro_rw = self._random_walk(
                "gyro_rw", fx.get("gyro_noise", "rrw_rad_s_per_sqrt_s"), n, self._gyro_rw
            )
            gyro += walk * per_sample
        if fx.enabled("accel_noise"):
            accel += self._rng["accel_white"].standard_normal((n, 3)) * (
                fx.get("accel_noise", "density_mps2_per_sqrt_hz") * white
            )
            walk, self._accel_rw = self._random_walk(
                "accel_rw", fx.get("accel_noise", "bias_rw_mps2_per_sqrt_s"), n, self._accel_rw
            )
            accel += walk * per_sample
            if fx.get("accel_noise", "markov_density_mps2_per_sqrt_hz") > 0:
                accel += (
                    self._markov(
                        n,
                        fx.get("accel_noise", "markov_density_mps2_per_sqrt_hz"),
                        fx.get("accel_noise", "markov_correlation_s"),
                    )
                    * per_sample
                )
        if fx.enabled("quantisation"):
            gyro = self._quantise("gyro", gyro, fx.get("quantisation", "gyro_lsb_rad"))
            accel = self._quantise("accel", accel, fx.get("quantisation", "accel_lsb_m_per_s"))
        return t, gyro, accel

    def reference_rows(self, t_ref: np.ndarray):
        """Reported motion at reference time stamps (reference delay applied; no tilt: it is what the table says)."""
        st = self.traj.evaluate(reported_time(self.params, t_ref))
        return mat_to_quat(st.mat_nb), st.lat_rad, st.lon_rad, st.height_m, st.v_n
