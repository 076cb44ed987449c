"""Simulated IMU telemetry with known truth: the ``simulate`` stage.

The ideal outputs follow exactly from the analytic motion (:mod:`sizefx.motion`):

* gyros read ``omega_ib_b = omega_nb_b + mat_bn (omega_ie_n + omega_en_n)``;
* the reference point feels ``f_b = mat_bn (vdot_n + (2 omega_ie_n + omega_en_n) x v_n - g_n)``
  (the NED velocity equation, Groves eq. 5.54, solved for f);
* ``mat_nb`` is the true attitude of the IMU: the trajectory's, tilted by ``[level_tilt]`` and
  turned by ``[reference_mount]`` (:func:`sizefx.sensor_model.true_attitude`; ``omega_nb_b``
  turns with it, :func:`sizefx.sensor_model.mount_matrix`); ``/reference`` reports the
  trajectory's own (untilted, the reference's body axes), late by ``[reference_delay]``
  (:func:`sizefx.sensor_model.reported_time`);
* what the sensors make of this true motion is the sensor model's forward map
  (:func:`sizefx.sensor_model.sample`: lever arms, accelerometer delay, biases, scale factors,
  misalignments, quadratic term, g-sensitivity), per instant, before integration;
* increments are the integrals of these over each sample interval by
  three-point Gauss-Legendre quadrature (error below 1e-12 of the signal for
  motion content under 100 Hz at 1600 Hz sampling).

Then per sample white noise, bias random walks and quantisation. Noise streams are drawn
from one seed, each stream in sample order, so the output does not depend on the chunk size
and switching one effect on does not change another's noise.

The stage: :class:`SimulateConfig` -> :func:`run` -> :class:`SimulateResult`, as ``sizefx
simulate`` calls it::

    from sizefx.simulate import SimulateConfig, run
    res = run(SimulateConfig("turntable", "tt.h5", plan=scenarios.TurntablePlan(axes="Z"), seed=3))
    print(res.report())
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from . import __version__, earth, scenarios
from .effects import IDEAL, EffectModel, load_effects
from .errors import ConfigError
from .io.telemetry import Reference, Site, Telemetry, TelemetryWriter
from .motion import Trajectory
from .rotation import mat_to_quat
from .sensor_model import Motion, SensorParams, accel_inputs, mount_matrix, reported_time, sample, true_attitude
from .stage import preflight

__all__ = [
    "ImuKinematics",
    "kinematics",
    "true_motion",
    "ImuSynthesizer",
    "simulate_to_file",
    "simulate_in_memory",
    "SimulateConfig",
    "SimulateResult",
    "run",
    "SCENARIOS",
    "GAUSS_NODES",
    "GAUSS_WEIGHTS",
    "CHUNK_SAMPLES",
]

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


def _params(effects) -> SensorParams:
    return effects if isinstance(effects, SensorParams) else effects.sensor_params()


def true_motion(traj: Trajectory, t, params: SensorParams) -> Motion:
    """The true motion of the reference point at times ``t`` [n], IMU axes: the trajectory with the
    level tilt and the reference's mount.

    Carries ``mat_nb`` and ``omega_in_b`` as well, for :func:`sizefx.sensor_model.jacobian`'s tilt columns.
    """
    st = traj.evaluate(t)
    mat_nb = true_attitude(params, st.mat_nb)
    mat_bn = np.swapaxes(mat_nb, -1, -2)
    w_ie = earth.omega_ie_n(st.lat_rad)
    w_en = earth.omega_en_n(st.lat_rad, st.height_m, st.v_n)
    w_in_b = np.einsum("nij,nj->ni", mat_bn, w_ie + w_en)
    wdot_in_n = earth.omegadot_in_n(st.lat_rad, st.height_m, st.v_n, st.vdot_n)
    w_nb, wdot_nb = st.omega_nb_b, st.omegadot_nb_b  # the trajectory's body axes: the reference's
    if np.any(params.reference_mount):  # a constant mount turns them into the IMU's (C (a x b) = Ca x Cb)
        mount = mount_matrix(params)
        w_nb, wdot_nb = w_nb @ mount.T, wdot_nb @ mount.T
    omega = w_nb + w_in_b
    omegadot = wdot_nb - np.cross(w_nb, w_in_b) + np.einsum("nij,nj->ni", mat_bn, wdot_in_n)
    f_n = st.vdot_n + np.cross(2.0 * w_ie + w_en, st.v_n) - earth.gravity_n(st.lat_rad, st.height_m)
    f_b = np.einsum("nij,nj->ni", mat_bn, f_n)
    return Motion(omega, omegadot, f_b, mat_nb=mat_nb, omega_in_b=w_in_b)


def kinematics(traj: Trajectory, t, effects: EffectModel | SensorParams) -> ImuKinematics:
    """Ideal gyro rates and accelerometer inputs at times ``t`` (true attitude includes the level tilt)."""
    p = _params(effects)
    m = true_motion(traj, t, p)
    return ImuKinematics(m.omega_ib_b, m.omegadot_ib_b, m.f_b, accel_inputs(p, m))


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


def _reference_rate(rate_hz: float, reference_rate_hz: float | None) -> float:
    """The reference rate, checked: it must divide the IMU rate (default: the IMU rate)."""
    ref_rate = rate_hz if reference_rate_hz is None else float(reference_rate_hz)
    stride = rate_hz / ref_rate
    if abs(stride - round(stride)) > 1e-9 or stride < 1:
        raise ConfigError(
            f"--reference-rate-hz {ref_rate:g} must divide the IMU rate {rate_hz:g} Hz "
            "(e.g. 100, 200, 400, 800 for 1600 Hz)"
        )
    return ref_rate


@dataclass
class SimulateResult:
    """What :func:`run` wrote."""

    path: str
    scenario: str
    samples: int
    rate_hz: float
    form: str
    duration_s: float
    reference_samples: int
    file_bytes: int
    wall_s: float

    def report(self) -> str:
        """The line ``sizefx simulate`` prints."""
        return (
            f"wrote {self.path}: {self.samples} samples ({self.duration_s:.1f} s at {self.rate_hz:g} Hz, "
            f"{self.form}), {self.file_bytes / 2**20:.1f} MiB in {self.wall_s:.1f} s"
        )

    def to_json(self) -> dict:
        return asdict(self)


def _differs(value, default) -> bool:
    """An effect key's value (as given: a number, a list, an array, a text) is not its default."""
    if isinstance(value, str) or isinstance(default, str) or value is None or default is None:
        return value != default
    return not np.array_equal(np.asarray(value, dtype=float), np.asarray(default, dtype=float))


def _changed_effects(effects: EffectModel, sensor: str) -> list[str]:
    """The effects on ``sensor`` ("accel" or "gyro"; the quantisation acts on both, the reference's
    effects count for the gyros, which are checked against the reference) that are on and differ from
    their defaults: ``section.key`` for each key set away from its default, ``section`` for one only
    switched on. What ``--set``, ``--effects``, ``--offset-mm`` and ``--geometry`` changed."""
    from .effects import EFFECTS_SCHEMA
    from .io.schema import load_schema
    from .sensor_model import EFFECTS

    sensors = {"accel": ("accel", "both"), "gyro": ("gyro", "both", "reference")}[sensor]
    sections = load_schema(EFFECTS_SCHEMA)["sections"]
    named = []
    for effect in EFFECTS:
        if effect.sensor not in sensors or not effects.enabled(effect.name):
            continue
        raw = effects.raw.get(effect.name, {})
        keys = [
            k
            for k, rule in sections[effect.name]["keys"].items()
            if k != "enabled" and k in raw and _differs(raw[k], rule["default"])
        ]
        if keys:
            named += [f"{effect.name}.{k}" for k in keys]
        elif not sections[effect.name]["keys"]["enabled"]["default"]:
            named.append(effect.name)
    return named


def _blame(scenario: str, effects: EffectModel, sensor: str) -> str:
    """Which of the user's choices make the ``sensor`` readings what they are, for a refusal."""
    changed = _changed_effects(effects, sensor)
    if not changed:
        return f"the {scenario} motion's options with the default {sensor} effects (effects: {effects.source})"
    return f"the {scenario} motion with {', '.join(changed)} (effects: {effects.source})"


def _refuse_invalid(out, scenario: str, effects: EffectModel, form: str, t, gyro, accel):
    """The last guard of the contract on each chunk: every sample finite (no NaN or inf in /imu) and
    within the schema's ``sample_limits``, which the reader refuses with or without
    ``--no-units-check``. Every in-range effect value is meant to give finite readings
    (tests/test_consistent_inputs.py sweeps them); one that does not, or a motion and effects that
    reach beyond the limits, are refused here, naming the effects, and the atomic writer leaves
    nothing behind."""
    from .io.contract import invalid_rows
    from .io.schema import TELEMETRY_SCHEMA, load_schema

    schema = load_schema(TELEMETRY_SCHEMA)
    for name, dataset, values in zip(("gyro", "accel"), schema["forms"][form]["datasets"], (gyro, accel)):
        bad = invalid_rows(schema, dataset, values)
        if not np.any(bad):
            continue
        k, column = (int(v) for v in np.argwhere(bad)[0])
        if not np.isfinite(values[k, column]):
            raise ConfigError(
                f"{out}: the effects ({effects.source}) make {name} readings that are not finite at "
                f"t = {t[k]:.6g} s; nothing was written: choose smaller or other values (sizefx simulate "
                "--print-effects lists every key and its range)"
            )
        raise ConfigError(
            f"{out}: {dataset} would read {values[k, column]:.6g} (SI) at t = {t[k]:.6g} s, axis {'xyz'[column]}, "
            f"beyond the telemetry contract's physical limit (+-{schema['sample_limits'][dataset]:g}) that every "
            f"reader refuses; this comes from {_blame(scenario, effects, name)}; nothing was written: choose "
            "smaller values or a gentler motion (sizefx simulate --print-effects lists every key and its range)"
        )


def _refuse_implausible(out, scenario: str, effects: EffectModel, tel: Telemetry):
    """Refuse a record that ``sizefx inspect`` would refuse by default (:func:`sizefx.sanity.implausible`
    on the rows of :func:`sizefx.sanity.sample_blocks`), naming what makes it so; the atomic writer
    leaves nothing behind."""
    from .sanity import implausible

    found = implausible(tel)
    if found is None:
        return
    raise ConfigError(
        f"{out}: sizefx inspect would refuse this record by its physics check: {found.dataset} {found.detail}; "
        f"this comes from {_blame(scenario, effects, found.what)}; nothing was written: choose smaller values or "
        "a gentler motion (sizefx simulate --print-effects lists every key and its range), or pass --no-units-check "
        "to write it anyway for tests of the checkers (sizefx inspect then needs --no-units-check too)"
    )


class _Sample:
    """The rows of a record being written that :func:`_refuse_implausible` judges it on (the whole
    record, or the blocks of a long one: :func:`sizefx.sanity.sample_blocks`), copied from the
    chunks as they pass, so that the check never reads the file back: memory bounded by
    :data:`sizefx.sanity.SAMPLE_ROWS` rows of time, gyro and accel, and the reference rows
    (time, attitude) within the blocks' time spans.

    ``reference(time_s) -> quat_nb``: the reference attitude, known before any row is written,
    where the blocks look for the stretches that turn.
    """

    def __init__(self, n_samples: int, rate_hz: float, reference=None):
        from .sanity import sample_blocks

        blocks = np.array(sample_blocks(n_samples, rate_hz, reference), dtype=np.int64).reshape(-1, 2)
        self.starts, self.stops = blocks[:, 0], blocks[:, 1]
        self.offsets = np.r_[0, np.cumsum(self.stops - self.starts)]  #: where each block's rows go
        self.half_period_s = 0.5 / rate_hz
        rows = int(self.offsets[-1])
        self.time_s = np.empty(rows)
        self.gyro = np.empty((rows, 3))
        self.accel = np.empty((rows, 3))
        self.reference: list[tuple[np.ndarray, np.ndarray]] = []

    def add_imu(self, first_row: int, t, gyro, accel):
        """Keep the rows of a chunk (rows ``first_row ...``) that fall in a block."""
        stop = first_row + t.shape[0]
        # only the blocks the chunk meets (a slow record has thousands of short blocks)
        for i in range(np.searchsorted(self.stops, first_row, side="right"), np.searchsorted(self.starts, stop)):
            b0, b1, at = self.starts[i], self.stops[i], self.offsets[i]
            lo, hi = max(b0, first_row), min(b1, stop)
            into = slice(at + lo - b0, at + hi - b0)
            self.time_s[into] = t[lo - first_row : hi - first_row]
            self.gyro[into] = gyro[lo - first_row : hi - first_row]
            self.accel[into] = accel[lo - first_row : hi - first_row]

    def add_reference(self, t_ref, quat_nb):
        """Keep the reference rows within a block's time span (once every IMU row is in). A reference
        stamp is an IMU stamp (the rates divide) computed apart: half a sample period's slack."""
        first = self.time_s[self.offsets[:-1]] - self.half_period_s
        last = self.time_s[self.offsets[1:] - 1] + self.half_period_s
        block = np.searchsorted(first, t_ref, side="right") - 1
        keep = (block >= 0) & (t_ref <= last[np.maximum(block, 0)])
        if np.any(keep):
            self.reference.append((t_ref[keep], quat_nb[keep]))

    def telemetry(self, form: str, site: Site) -> Telemetry:
        """The sample as a record in memory, the breaks between blocks as declared gaps."""
        from .io.gaps import find_imu_gaps

        ref = None
        if self.reference:
            ref = Reference(*(np.concatenate([piece[k] for piece in self.reference]) for k in range(2)))
            self.reference = []
        t = self.time_s
        tel = Telemetry(time_s=t, form=form, reference=ref, site=site, gaps=find_imu_gaps(t, declared=True))
        if form == "rates":
            tel.gyro_rad_s, tel.accel_mps2 = self.gyro, self.accel
        else:
            tel.dtheta_rad, tel.dvel_mps = self.gyro, self.accel
        return tel


def simulate_to_file(
    traj: Trajectory,
    scenario_info: dict,
    effects: EffectModel,
    out,
    *,
    rate_hz: float = 1600.0,
    form: str = "rates",
    seed: int = 0,
    reference_rate_hz: float | None = None,
    force: bool = False,
    chunk_samples: int = CHUNK_SAMPLES,
    inputs=(),
    progress=None,
    check_units: bool = True,
) -> SimulateResult:
    """Simulate ``traj`` and stream it into a ``sizefx/telemetry/1`` file.

    ``reference_rate_hz`` defaults to the IMU rate; it must divide it.
    ``progress(done, total)`` is called after each chunk when given.

    Every chunk is checked against the contract's sample limits before it is written; with
    ``check_units`` the record is then judged as ``sizefx inspect`` judges it by default
    (:func:`sizefx.sanity.implausible`, on :func:`sizefx.sanity.sample_blocks` of it) before it is
    published. A refusal is a :class:`~sizefx.errors.ConfigError` naming the effects, and leaves
    nothing behind.
    """
    started = time.perf_counter()
    syn = ImuSynthesizer(traj, effects, rate_hz=rate_hz, form=form, seed=seed)
    if syn.n_samples < 2:  # the reader needs two stamps to know the rate (a 1 s tumble at 1 Hz has one increment)
        raise ConfigError(
            f"{out}: {traj.duration_s:g} s at {rate_hz:g} Hz make {syn.n_samples} {form} sample; a record needs at "
            "least 2 (its sample rate is read from them): lengthen the record or raise --rate-hz"
        )
    ref_rate = _reference_rate(rate_hz, reference_rate_hz)
    stride = rate_hz / ref_rate
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
        # the wording is stored in every record (and examples/tumble_truth.json must regenerate bit for bit);
        # sizefx.simulate's docstring points on to sizefx.sensor_model
        "model": "see sizefx.simulate: gyro (1+s)(u.omega_ib)+b+G f; accel (1+s)a+K2 a^2+b, "
        "a = u_i.(f + omegadot x r_i + omega x (omega x r_i)); gravity gradient neglected",
    }
    description = (
        f"sizefx {__version__} simulation: {traj.name}, {rate_hz:g} Hz {form}, seed {seed}; truth in /simulation"
    )
    writer = TelemetryWriter(
        out,
        n_samples=syn.n_samples,
        form=form,
        n_reference=n_ref,
        reference_position=True,
        reference_velocity=True,
        site=site,
        description=description,
        simulation=truth,
        inputs=inputs,
        force=force,
    )
    ref_per_chunk = max(1, int(chunk_samples / stride))
    sample = _Sample(syn.n_samples, rate_hz, lambda t: syn.reference_rows(t)[0]) if check_units else None
    with writer as w:
        done = 0
        while done < syn.n_samples:
            t, g, a = syn.next_chunk(chunk_samples)
            _refuse_invalid(out, traj.name, effects, form, t, g, a)
            w.write_imu(t, g, a)
            if sample is not None:
                sample.add_imu(done, t, g, a)
            done += t.shape[0]
            if progress is not None:
                progress(done, syn.n_samples)
        for j0 in range(0, n_ref, ref_per_chunk):
            t_ref = np.arange(j0, min(n_ref, j0 + ref_per_chunk)) / ref_rate
            rows = syn.reference_rows(t_ref)
            w.write_reference(t_ref, *rows)
            if sample is not None:
                sample.add_reference(t_ref, rows[0])
        if sample is not None:  # inside the writer: a refusal removes the temporary file
            _refuse_implausible(out, traj.name, effects, sample.telemetry(form, site))
    return SimulateResult(
        path=str(out),
        scenario=traj.name,
        samples=syn.n_samples,
        rate_hz=rate_hz,
        form=form,
        duration_s=traj.duration_s,
        reference_samples=n_ref,
        file_bytes=Path(out).stat().st_size,
        wall_s=time.perf_counter() - started,
    )


#: Reference rate of the navigation-length records (sway, flight) when none is
#: given: the 1.8 h flight at 1600 Hz would add 900 MB of reference, and 100 Hz
#: resolves their 1 Hz sway and manoeuvres. The turntable keeps the IMU rate,
#: which calibration and diagnosis use sample by sample.
NAVIGATION_REFERENCE_RATE_HZ = 100.0

#: scenario -> (builder, its plan's class): the motions ``sizefx simulate`` knows.
#: scenario -> (its builder, taking a plan and a site; its plan class, whose defaults make the plan)
SCENARIOS: dict[str, tuple[Callable[..., tuple[Trajectory, dict]], type]] = {
    "turntable": (scenarios.turntable, scenarios.TurntablePlan),
    "sway": (scenarios.sway, scenarios.SwayPlan),
    "flight": (scenarios.flight, scenarios.FlightPlan),
    "tumble": (scenarios.tumble_scenario, scenarios.TumblePlan),
}


@dataclass(frozen=True)
class SimulateConfig:
    """``sizefx simulate SCENARIO -o OUTPUT``: the motion, the effects, the sampling, the output.

    ``plan``: the scenario's plan (:class:`sizefx.scenarios.TurntablePlan`, ``SwayPlan``,
    ``FlightPlan``, ``TumblePlan``; None: its defaults). ``effects_path``: an effects TOML
    (``--effects``); ``overrides``: ``--set`` values in the TOML's layout
    (``{"accel_delay": {"enabled": True}}``); ``ideal`` switches every effect off before both,
    so ``ideal`` plus ``overrides`` gives a record with exactly the named effects.
    ``reference_rate_hz`` None: the IMU rate for turntable and tumble,
    :data:`NAVIGATION_REFERENCE_RATE_HZ` for sway and flight.
    """

    scenario: str
    output: str | Path
    plan: object | None = None
    site: scenarios.SiteSpec | None = None
    effects_path: str | None = None
    overrides: Mapping | None = None
    ideal: bool = False
    rate_hz: float = 1600.0
    form: str = "rates"
    seed: int = 0
    reference_rate_hz: float | None = None
    force: bool = False
    chunk_samples: int = CHUNK_SAMPLES  #: IMU rows per chunk (memory; the output does not depend on it)
    #: a sizefx/plan/1 file (``sizefx plan``): its turntable plan (or, for the sway scenario, its
    #: delay sway), instead of ``plan``
    plan_path: str | None = None
    #: refuse a record ``sizefx inspect`` would refuse by its physics check (``--no-units-check``: write it
    #: anyway, to test the checkers)
    check_units: bool = True

    def inputs(self) -> dict:
        return {"--effects": self.effects_path, "--plan": self.plan_path}

    def outputs(self) -> dict:
        return {"-o": self.output}


def run(config: SimulateConfig, *, progress=None) -> SimulateResult:
    """The ``simulate`` stage: build the scenario and the effect model, write ``config.output``.

    Options first (scenario, form, rates), then the files (:func:`sizefx.stage.preflight`),
    then the work. ``progress(done, total)`` is called after each chunk.
    """
    if config.scenario not in SCENARIOS:
        raise ConfigError(f"scenario '{config.scenario}': use one of {', '.join(SCENARIOS)}")
    if config.form not in ("rates", "increments"):
        raise ConfigError(f"--form {config.form}: use rates or increments")
    reference_rate_hz = config.reference_rate_hz
    if reference_rate_hz is None and config.scenario in ("sway", "flight"):
        reference_rate_hz = NAVIGATION_REFERENCE_RATE_HZ
    _reference_rate(config.rate_hz, reference_rate_hz)
    if config.plan_path and config.scenario not in ("turntable", "sway"):
        raise ConfigError(
            f"--plan {config.plan_path}: a plan file holds a turntable plan and a sway; the "
            f"{config.scenario} scenario takes its own options"
        )
    preflight(inputs=config.inputs(), outputs=config.outputs(), force=config.force)
    build, plan_cls = SCENARIOS[config.scenario]
    plan = config.plan
    if config.plan_path:
        from .io.plan_file import read_plan_document

        doc = read_plan_document(config.plan_path)
        if config.scenario == "turntable":
            plan = scenarios.TurntablePlan(**doc["turntable"])
        elif "sway" not in doc:
            raise ConfigError(
                f"{config.plan_path}: the plan has no [sway] (the accelerometers' delay's); design one "
                "with sizefx plan --delay-sigma-us and --sway-axes"
            )
        else:
            w = doc["sway"]
            plan = scenarios.SwayPlan(
                axis=w["axis"],
                amplitudes_dps=(w["amplitude_dps"],),
                frequency_hz=w["frequency_hz"],
                static_s=w["static_s"],
                segment_s=w["segment_s"],
            )
        try:
            plan.check()
        except ConfigError as exc:
            raise ConfigError(f"{config.plan_path}: {exc}") from None
    traj, info = build(plan or plan_cls(), config.site or scenarios.PAPER_AIRFIELD)
    fx = load_effects(config.effects_path, overrides=dict(config.overrides or {}), base=IDEAL if config.ideal else None)
    inputs = [p for p in (config.effects_path, config.plan_path) if p]
    return simulate_to_file(
        traj,
        info,
        fx,
        config.output,
        rate_hz=config.rate_hz,
        form=config.form,
        seed=config.seed,
        reference_rate_hz=reference_rate_hz,
        force=config.force,
        chunk_samples=config.chunk_samples,
        inputs=inputs,
        progress=progress,
        check_units=config.check_units,
    )


def simulate_in_memory(
    traj: Trajectory,
    effects: EffectModel | None = None,
    *,
    rate_hz: float = 1600.0,
    form: str = "increments",
    seed: int = 0,
):
    """A whole record as a :class:`~sizefx.io.telemetry.Telemetry` in memory, reference at the IMU rate.

    For short records (algorithm checks, diagnosis experiments); files go through
    :func:`simulate_to_file`.
    """
    fx = effects if effects is not None else load_effects(base=IDEAL)
    syn = ImuSynthesizer(traj, fx, rate_hz=rate_hz, form=form, seed=seed)
    t, g, a = syn.next_chunk(syn.n_samples)
    t_ref = np.arange(0, int(np.floor(traj.duration_s * rate_hz + 1e-9)) + 1) / rate_hz
    q, lat, lon, h, v = syn.reference_rows(t_ref)
    tel = Telemetry(
        time_s=t,
        form=form,
        reference=Reference(t_ref, q, lat, lon, h, v),
        site=Site(float(lat[0]), float(lon[0]), float(h[0])),
    )
    if form == "rates":
        tel.gyro_rad_s, tel.accel_mps2 = g, a
    else:
        tel.dtheta_rad, tel.dvel_mps = g, a
    return tel
