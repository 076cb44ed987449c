"""What ``sizefx navigate FILE`` is asked: the stage's :class:`NavigateConfig` (the record, the
outputs) and the navigation run's :class:`NavConfig` (its options, which ``sizefx.navigate.navigate``
takes on its own for a record in memory); the stage is :mod:`sizefx.navigate`."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from ..constants import CORRECTION_MODES, MAX_WHOLE_READ_ROWS
from ..errors import ConfigError
from ..options import allow_gaps, check_options, choice, force, group, integer, number, path, segment
from . import refuse_levers_and_model

if TYPE_CHECKING:  # the options are read without loading the effect model's code (Numba)
    from ..effects import EffectModel

__all__ = ["NavConfig", "NavigateConfig", "CHUNK_SAMPLES", "MIN_OUTPUT_RATE_HZ"]

#: Default IMU rows per chunk (2^20: 24 MiB of rates, a few hundred MiB of working set).
CHUNK_SAMPLES = 1 << 20
#: Slowest solution rate [Hz] but 0 (every interval): a row every 17 minutes.
MIN_OUTPUT_RATE_HZ = 1e-3


@dataclass(frozen=True)
class NavConfig:
    """The options of a navigation run (the file and the outputs are the stage's, :class:`NavigateConfig`).

    ``model``: an effect model (:func:`sizefx.correct.load_model`) whose IMU errors and size effect
    are undone before navigating; not together with ``levers`` (both become one
    :class:`sizefx.sensor_model.Correction`). ``output_rate_hz`` None (or 0): every navigation interval.
    """

    subsamples: int = integer(
        4,
        low=1,
        high=4,
        help="IMU samples per navigation interval (coning/sculling sub-samples); 4 at 1600 Hz -> 400 Hz.",
    )
    init: str = choice(
        "auto",
        ("auto", "reference", "align"),
        help="Initial attitude from /reference, or by static alignment over --align-s "
        "(auto: the reference when it covers the start and is not approximate).",
    )
    align_s: float = number(
        300.0,
        unit="s",
        low=0.0,
        high=86400.0,
        low_open=True,
        help="Alignment window from the start of the record [s]; the vehicle must be at rest.",
    )
    vertical: str = choice(
        "auto",
        ("auto", "held", "reference", "free"),
        help="Vertical channel: held at the known height, replaced by the reference "
        "height, or free (auto: held at rest, reference when moving).",
    )
    output_rate_hz: float | None = number(
        10.0,
        unit="Hz",
        low=0.0,
        high=1e5,
        allow_none=True,
        help="Rate of the written solution [Hz] (0: every navigation interval).",
    )
    levers: str | None = path(help="Compensate the size effect first with these lever arms (sizefx/levers/1).")
    mode: str = choice(
        "triad",
        CORRECTION_MODES,
        help="With --levers or --model: bring the accelerometers to the triad point or to the rotation centre.",
    )
    segment: int | None = segment()
    allow_gaps: bool = allow_gaps()
    #: an effect model, loaded (Python only: the command line's ``--model`` is the stage's file)
    model: EffectModel | None = None

    def __post_init__(self):
        check_options(self)
        rate = self.output_rate_hz
        if rate is not None and 0.0 < rate < MIN_OUTPUT_RATE_HZ:
            raise ConfigError(
                f"--output-rate-hz: {rate:g} Hz is below {MIN_OUTPUT_RATE_HZ:g} Hz; give 0 for every "
                "interval, or 0.001 to 100000 Hz"
            )
        if rate == 0.0:
            object.__setattr__(self, "output_rate_hz", None)  # every interval, as None says it
        refuse_levers_and_model(self.levers, self.model)


@dataclass(frozen=True)
class NavigateConfig:
    """``sizefx navigate FILE``: the record, the options, the outputs.

    ``model``: an effect-model file (``sizefx/effects/1`` TOML), loaded by
    :func:`sizefx.navigate.run` into ``options.model``. ``chunk_samples``: IMU rows per chunk
    (memory is bounded by it; results are identical); 0 reads the whole record into memory first.
    """

    input: str = path(argument="FILE", help="The record to navigate.")
    output: str | None = path(flags=("-o", "--output"), help="Write the solution (HDF5, sizefx/navigation/1).")
    json_path: str | None = path(flags=("--json",), metavar="FILE", help="Write the summary to FILE (JSON).")
    plot: str | None = path(metavar="FILE", help="Write the position error versus time to FILE (one PNG).")
    options: NavConfig = group(NavConfig)
    model: str | None = path(
        help="Correct the IMU first with this effect model (sizefx/effects/1 TOML, e.g. from sizefx "
        "diagnose): delay, biases, scale factors, misalignments, quadratic term, g-sensitivity, "
        "lever arms. Sections the file omits are off. Not with --levers."
    )
    chunk_samples: int = integer(
        CHUNK_SAMPLES,
        low=0,
        high=MAX_WHOLE_READ_ROWS,
        help="IMU rows read and processed at a time (memory is bounded by the chunk, results are identical); "
        "0 reads the whole record into memory.",
    )
    force: bool = force("Replace the -o, --json and --plot files if they exist (never an input).")

    def __post_init__(self):
        check_options(self)
        refuse_levers_and_model(self.options.levers, self.model or self.options.model)

    def inputs(self) -> dict:
        return {"FILE": self.input, "--levers": self.options.levers, "--model": self.model}

    def outputs(self) -> dict:
        return {"--json": self.json_path, "-o": self.output, "--plot": self.plot}
