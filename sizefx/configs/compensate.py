"""What ``sizefx compensate FILE -o OUT`` is asked (:class:`CompensateConfig`); the stage is
:mod:`sizefx.compensate`."""

from __future__ import annotations

from dataclasses import dataclass

from ..constants import CORRECTION_MODES, ESTIMATORS
from ..errors import ConfigError
from ..options import allow_gaps, check_options, choice, force, number, path, segment, switch
from . import refuse_levers_and_model

__all__ = ["CompensateConfig"]


@dataclass(frozen=True)
class CompensateConfig:
    """``sizefx compensate FILE -o OUT --levers L`` (or ``--model M``): the record, exactly one
    of a levers file and an effect-model file, the options and the output.

    ``centripetal``/``tangential``: the terms to remove, and ``accel_delay_s``: the
    accelerometers' known delay behind the gyros [s] (None: the levers file's) apply to
    ``levers``; a model removes both terms and takes its delay from ``[accel_delay]``.
    ``estimator``: the angular acceleration (None: ``savgol`` for rates, ``increments`` for
    increments). ``segment``: one continuous segment (1-based) of a record with IMU gaps;
    ``allow_gaps``: compensate across them instead.
    """

    input: str = path(argument="FILE", help="The record to compensate.")
    output: str = path(required=True, flags=("-o", "--output"), help="Compensated telemetry (HDF5).")
    levers: str | None = path(help="Lever arms (sizefx/levers/1 JSON, e.g. from sizefx calibrate).")
    model: str | None = path(
        help="Instead of --levers: an effect model (sizefx/effects/1 TOML, e.g. from sizefx diagnose); "
        "corrects delay, biases, scale factors, misalignments, quadratic term, g-sensitivity and "
        "lever arms. Sections the file omits are off."
    )
    mode: str = choice(
        "triad",
        CORRECTION_MODES,
        help="triad: bring the accelerometers to the triad point (d_i); center: to the rotation centre (r_i).",
    )
    estimator: str | None = choice(
        None,
        ESTIMATORS,
        help="Angular acceleration: central or savgol for rates, increments for increments [default: "
        "savgol for rates, increments for increments].",
    )
    centripetal: bool = True  #: remove the centripetal term (Python only: the command line always does)
    tangential: bool = switch(
        True,
        flags=("--centripetal-only",),
        help="Drop the tangential term (the paper: it does not accumulate). Only with --levers.",
    )
    accel_delay_s: float | None = number(
        unit="us",
        low=-1e5,
        high=1e5,
        scale=1e-6,
        flags=("--accel-delay-us",),
        help="Known delay of the accelerometers behind the gyros [us] (default: from the levers file). "
        "Only with --levers; a model gives it in [accel_delay].",
    )
    segment: int | None = segment()
    allow_gaps: bool = allow_gaps()
    force: bool = force()

    def __post_init__(self):
        check_options(self)
        refuse_levers_and_model(self.levers, self.model)
        if not self.levers and not self.model:
            raise ConfigError("give the lever arms (--levers LEVERS.json) or an effect model (--model MODEL.toml)")
        if self.model and (not self.centripetal or not self.tangential or self.accel_delay_s is not None):
            raise ConfigError(
                "--centripetal-only and --accel-delay-us apply to --levers; with --model the "
                "delay comes from the model's [accel_delay] and both terms are removed"
            )

    def inputs(self) -> dict:
        return {"FILE": self.input, "--levers": self.levers, "--model": self.model}

    def outputs(self) -> dict:
        return {"-o": self.output}
