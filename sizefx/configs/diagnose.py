"""What ``sizefx diagnose MEASURED`` is asked (:class:`DiagnoseConfig`); the stage is :mod:`sizefx.diagnose`."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..constants import GRADES
from ..errors import ConfigError
from ..options import allow_gaps, check_options, choice, force, number, path, segment, switch, text

__all__ = ["DiagnoseConfig", "PLOT_FILES", "one_start_model"]

#: The files a diagnosis writes into the ``--plots`` folder.
PLOT_FILES = ("residuals.png", "spectra.png")


def one_start_model(nominal, model) -> None:
    """The one refusal of a nominal geometry beside a start model (the config, and
    :func:`sizefx.diagnose.start_model` for its callers)."""
    if model is not None and nominal is not None:
        raise ConfigError("give --nominal or --model, not both: a model file carries its own lever arms")


@dataclass(frozen=True)
class DiagnoseConfig:
    """``sizefx diagnose MEASURED``: the record, the start model, the fit's options, the outputs.

    Options that contradict each other (``--nominal`` with ``--model``, ``--segment`` with
    ``--from-s/--to-s``, an empty span) are refused here, when the config is made; the files are
    checked by :func:`sizefx.diagnose.run`'s pre-flight. ``grade`` "auto" (or None): inferred from
    the noise, and None once made; ``model_out`` None: MEASURED with ``.model.toml``.
    """

    input: str | Path = path(
        argument="MEASURED", help="The record (sizefx/telemetry/1 with /reference), real or simulated."
    )
    nominal: str | None = text(
        help="Geometry the prediction starts from: high-precision (default), compact, none, or a "
        "sizefx/levers/1 file; lever arms from the reference point of the motion.",
    )
    model: str | Path | None = path(
        help="Start from this effect model instead (sizefx/effects/1 TOML, e.g. a previous diagnosis); "
        "sections it omits are off."
    )
    json_path: str | Path | None = path(
        flags=("--json",), metavar="FILE", help="Write the report to FILE (JSON, sizefx/diagnosis/2)."
    )
    plots: str | Path | None = path(
        kind="folder",
        metavar="DIR",
        help="Write residual time series and spectra, before and after, into the folder DIR (created if "
        "missing): residuals.png, spectra.png; existing ones are replaced only with --force.",
    )
    model_out: str | Path | None = path(
        metavar="FILE",
        help="Where to write the extended model (TOML, sizefx/effects/1) [default: MEASURED with .model.toml].",
    )
    bandwidth_hz: float | None = number(
        unit="Hz",
        low=0.01,
        high=1e5,
        help="Fit the residual low-passed at this frequency [Hz] (zero-phase, applied to the regressors "
        "alike). Without it, the band is measured: where the reference's own differentiated noise "
        "(motion capture) overtakes the IMU's, or the full band for a table's or simulation's "
        "reference; the report says which.",
    )
    grade: str | None = choice(
        "auto",
        ("auto", *GRADES),
        allow_none=True,
        help="Sensor grade whose plausible ranges an estimate must lie in to be a finding (auto: inferred "
        "from the noise, and reported).",
    )
    from_s: float | None = number(
        unit="s", low=-1e10, high=1e10, help="Diagnose the record from this time on [s] (IMU clock)."
    )
    to_s: float | None = number(
        unit="s",
        low=-1e10,
        high=1e10,
        help="Diagnose the record up to this time [s] (IMU clock). The file is read whole first: at most 12 "
        "million IMU rows (2 h at 1600 Hz; a longer file is refused), and memory grows with its length "
        "(docs/diagnose.md, Memory against length).",
    )
    navigation: bool = switch(
        True,
        flags=("--navigation/--no-navigation",),
        help="On records of 10 minutes or more with reference position, also navigate with the start "
        "and the extended model and report the horizontal error.",
    )
    validate_on: tuple = path(
        (),
        many=True,
        metavar="RECORD",
        help="Another record of the same IMU (repeat for more) to measure the extended model on: its "
        "residual RMS per channel with the start and the extended model, and its navigation error "
        "when it is long enough to navigate. The record diagnosed is cross-validated in any case.",
    )
    segment: int | None = segment()
    allow_gaps: bool = allow_gaps()
    force: bool = force(
        "Replace the --json report, the extended model (--model-out or its default) and the PNGs in --plots "
        "if they exist (never an input)."
    )

    def __post_init__(self):
        check_options(self)
        one_start_model(self.nominal, self.model)
        if self.segment is not None and (self.from_s is not None or self.to_s is not None):
            raise ConfigError(
                f"{self.input}: --segment {self.segment} and --from-s/--to-s both choose the span; "
                "give one (sizefx inspect lists each segment's times)"
            )
        if self.grade == "auto":
            object.__setattr__(self, "grade", None)  # inferred from the noise
        if self.from_s is not None and self.to_s is not None and not self.from_s < self.to_s:
            raise ConfigError(
                f"--from-s {self.from_s:g} and --to-s {self.to_s:g}: the span is empty; give --from-s before --to-s"
            )

    @property
    def model_out_path(self) -> Path:
        """``--model-out``, or MEASURED with its suffix replaced by ``.model.toml``."""
        if self.model_out is not None:
            return Path(self.model_out)
        return Path(str(Path(self.input).with_suffix("")) + ".model.toml")

    def inputs(self) -> dict:
        from ..geometry import PRESETS  # numpy: loaded when the stage runs, not for --help

        levers_file = self.nominal if self.nominal is not None and self.nominal not in PRESETS else None
        return {
            "MEASURED": self.input,
            "--model": self.model,
            "--nominal": levers_file,
            **{f"--validate-on {p}": p for p in self.validate_on},
        }

    def outputs(self) -> dict:
        """Every file :func:`sizefx.diagnose.run` writes, by option: each plot too, once its folder
        exists (a folder still to be made holds nothing to collide with)."""
        out = {"--json": self.json_path, "--model-out": self.model_out_path}
        if self.plots and Path(self.plots).is_dir():
            out.update({f"--plots {name}": Path(self.plots) / name for name in PLOT_FILES})
        return out
