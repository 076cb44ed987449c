"""Size-effect compensation of a record: ``sizefx compensate`` and ``navigate --levers``.

The stage: :class:`CompensateConfig` -> :func:`run` -> :class:`CompensateResult`
(:mod:`sizefx.stage`); with ``--model`` it corrects by :func:`sizefx.correct.correct_imu`.

Steps:

1. Sync (:mod:`sizefx.sync`). Accelerometers
   stamped apart (``/imu/accel_time``) or late by a known delay are brought onto
   the gyro time base by a not-a-knot cubic spline.
2. Compensation in the record's own domain, by the sensor model's
   :func:`sizefx.sensor_model.remove_lever_terms` (the one place the lever terms are removed):
   - Rates: ``a_i - u_i . (omegadot x r_i + omega x (omega x r_i))``, with omegadot
     from the chosen estimator (:mod:`sizefx.omegadot`).
   - Increments: the tangential term as a difference of edge rates (no derivative).
   Mode ``triad`` uses d_i and brings the three accelerometers to the triad point.
   Mode ``center`` uses r_i = r + d_i and brings them to the rotation centre.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .configs.compensate import CompensateConfig
from .correct import correct_imu, load_model
from .errors import ConfigError
from .io.telemetry import Provenance, Telemetry, read_telemetry, refuse_gaps, write_telemetry
from .levers import Levers, read_levers
from .omegadot import SAVGOL_WINDOW
from .sensor_model import check_estimator, remove_lever_terms
from .stage import preflight
from .sync import sync_accelerometers

__all__ = [
    "compensate",
    "read_continuous",
    "segment_note",
    "GAPS_WHY",
    "CompensateConfig",
    "CompensateResult",
    "run",
]


def _arms(levers: Levers, mode: str):
    return np.ascontiguousarray(levers.arms_for(mode)), np.ascontiguousarray(levers.axes)


def compensate(
    tel: Telemetry,
    levers: Levers,
    mode: str = "triad",
    *,
    estimator: str | None = None,
    centripetal: bool = True,
    tangential: bool = True,
    accel_delay_s: float | None = None,
) -> Telemetry:
    """A copy of ``tel`` with size-effect-free accelerometers on the gyro time base."""
    if estimator is None:
        estimator = "increments" if tel.form == "increments" else "savgol"
    check_estimator(tel.form, estimator)
    if tel.n_samples < 4 * SAVGOL_WINDOW:
        raise ConfigError(f"{tel.path}: {tel.n_samples} samples; compensation needs at least {4 * SAVGOL_WINDOW}")
    tau = levers.accel_delay_s if accel_delay_s is None else accel_delay_s
    tau = 0.0 if tau is None else float(tau)
    tel_in, tel = tel, sync_accelerometers(tel, tau)
    dt = tel.sample_period_s
    arms, axes = _arms(levers, mode)
    gyro_like, accel_like = tel.imu_arrays()
    out = remove_lever_terms(
        accel_like,
        gyro_like,
        arms,
        axes,
        form=tel.form,
        dt=dt,
        estimator=estimator,
        centripetal=centripetal,
        tangential=tangential,
    )
    applied = {
        "mode": mode,
        "estimator": estimator,
        "centripetal": centripetal,
        "tangential": tangential,
        "accel_delay_s": tau,
        "arms_m": arms.tolist(),
        "axes": axes.tolist(),
        **segment_note(tel_in),
    }
    return replace(
        tel,
        **{"accel_mps2" if tel.form == "rates" else "dvel_mps": out},
        source=replace(tel_in.source or Provenance(), compensation=applied),
        description=(tel_in.description + " | " if tel_in.description else "")
        + f"size effect compensated ({mode}, {estimator}, delay {tau * 1e6:.1f} us)",
    )


#: Why compensation refuses a record with IMU gaps unless told to bridge them (--allow-gaps).
GAPS_WHY = "estimates angular acceleration and increment edges from neighbouring samples, which a gap separates"


def read_continuous(path, *, allow_gaps: bool, segment: int | None, command: str) -> Telemetry:
    """A record for a command that works on neighbouring samples: segment ``segment`` of ``path``, or
    the whole record if it has no IMU gaps, or (``allow_gaps``) across its gaps; else a one-line refusal
    that offers ``--segment``. Shared by ``compensate --levers`` and ``compensate --model``."""
    tel = read_telemetry(path, allow_gaps=allow_gaps, segment=segment)
    if not allow_gaps:
        refuse_gaps(path, tel.gaps, command=command, why=GAPS_WHY, bridge=True)
    return tel


def segment_note(tel: Telemetry) -> dict:
    """What ``/source`` records of the segment a record was cut to (empty for a whole record)."""
    return {} if tel.segment is None else tel.segment.note()


@dataclass(frozen=True)
class CompensateResult:
    """What :func:`run` wrote: the output, its samples, and what was applied (as ``/source``
    records it: :attr:`~sizefx.io.provenance.Provenance.compensation` for levers,
    :attr:`~sizefx.io.provenance.Provenance.correction` for a model)."""

    output: str
    samples: int
    applied: dict  #: mode, estimator, accel_delay_s, ... (model: model, corrected, ignored)
    with_model: bool = False

    def report(self) -> str:
        """The lines ``sizefx compensate`` prints."""
        a = self.applied
        delay = f"delay {a['accel_delay_s'] * 1e6:.1f} us"
        if not self.with_model:
            return (
                f"wrote {self.output}: {self.samples} samples, mode {a['mode']}, estimator {a['estimator']}, "
                f"tangential {'on' if a['tangential'] else 'off'}, {delay}"
            )
        lines = [
            f"wrote {self.output}: {self.samples} samples corrected with {a['model']}, mode {a['mode']}, "
            f"estimator {a['estimator']}, {delay}; corrected: "
            f"{', '.join(a['corrected']) or 'nothing (every section off)'}"
        ]
        if a["ignored"]:
            lines.append(f"not IMU output errors, left alone: {', '.join(a['ignored'])}")
        return "\n".join(lines)

    def to_json(self) -> dict:
        return {"path": self.output, "samples": self.samples, **self.applied}


#: What the result keeps of a model's correction record (the effects themselves are in the model file).
_MODEL_SUMMARY = ("model", "mode", "estimator", "corrected", "ignored", "accel_delay_s")


def run(config: CompensateConfig, *, progress=None) -> CompensateResult:
    """Read ``config.input``, remove the size effect (``levers``) or every deterministic IMU
    error of the model (``model``, :func:`sizefx.correct.correct_imu`), write ``config.output``
    in the input's form. ``progress(done, total)`` is called after reading, compensating and
    writing (total 3)."""
    preflight(inputs=config.inputs(), outputs=config.outputs(), force=config.force)
    tel = read_continuous(config.input, allow_gaps=config.allow_gaps, segment=config.segment, command="compensate")
    if progress is not None:
        progress(1, 3)
    extra: str | None  # the model or the levers file: an input of the output
    if config.model:
        new = correct_imu(tel, load_model(config.model), mode=config.mode, estimator=config.estimator)
        extra = config.model
    else:
        new = compensate(
            tel,
            read_levers(config.levers),
            config.mode,
            estimator=config.estimator,
            centripetal=config.centripetal,
            tangential=config.tangential,
            accel_delay_s=config.accel_delay_s,
        )
        extra = config.levers
    if progress is not None:
        progress(2, 3)
    write_telemetry(config.output, new, inputs=[config.input, extra], force=config.force)
    if progress is not None:
        progress(3, 3)
    # correct_imu and compensate record what they did (with the segment) in the copy's provenance
    assert new.source is not None
    done = new.source.correction if config.model else new.source.compensation
    assert done is not None
    applied = {k: done[k] for k in _MODEL_SUMMARY} if config.model else dict(done)
    return CompensateResult(str(config.output), new.n_samples, applied, with_model=bool(config.model))
