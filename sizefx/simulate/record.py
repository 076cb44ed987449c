"""A simulated record: streamed into a ``sizefx/telemetry/1`` file chunk by chunk, checked before it
is published (:func:`simulate_to_file`), or made whole in memory (:func:`simulate_in_memory`)."""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from .. import __version__
from ..configs.simulate import CHUNK_SAMPLES, reference_rate
from ..effects import IDEAL, EffectModel, load_effects
from ..errors import ConfigError
from ..io.telemetry import Reference, Site, Telemetry, TelemetryWriter
from ..motion import Trajectory
from .refusals import _refuse_implausible, _refuse_invalid, _Sample
from .synthesizer import ImuSynthesizer

__all__ = ["simulate_to_file", "simulate_in_memory", "SimulateResult", "CHUNK_SAMPLES"]


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
    ref_rate = reference_rate(rate_hz, reference_rate_hz)
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
