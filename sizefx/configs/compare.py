"""What ``sizefx compare A B`` is asked (:class:`CompareConfig`); the stage is :mod:`sizefx.compare`."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..options import check_options, force, path

__all__ = ["CompareConfig", "PLOT_NAMES"]

#: The figures a run may write into ``--plots`` (``attitude.png`` only when attitude is compared).
PLOT_NAMES = ("trajectories.png", "horizontal_error.png", "velocity.png", "attitude.png")


@dataclass(frozen=True)
class CompareConfig:
    """Everything ``sizefx compare`` needs; the options of the command line, by their names.

    A and B are tracks (``sizefx/navigation/1`` or telemetry with ``/reference/position``); A is
    compared with B on A's time stamps, every difference is A - B. With ``reference``: A vs REF,
    B vs REF and A vs B.
    """

    a: Path | str = path(argument="A", help="The first track; every difference is A - B.")
    b: Path | str = path(argument="B", help="The second track.")
    reference: Path | str | None = path(
        help="The truth (a navigation file or telemetry with /reference/position): report A and B against "
        "it, and A against B."
    )
    json_path: Path | str | None = path(
        flags=("--json",), metavar="FILE", help="Write the figures to FILE (JSON, sizefx/comparison/1)."
    )
    plots_dir: Path | str | None = path(
        kind="folder",
        flags=("--plots",),
        metavar="DIR",
        help="Write PNG figures into the folder DIR (created if missing): trajectories.png, "
        "horizontal_error.png, velocity.png and, when attitude is compared, attitude.png.",
    )
    force: bool = force("Replace the --json file and the PNGs in --plots if they exist (never an input).")

    def __post_init__(self):
        check_options(self)

    def inputs(self) -> dict:
        """The files read, by the argument or option that named them."""
        return {"A": self.a, "B": self.b, "--reference": self.reference}

    def outputs(self) -> dict:
        """The files written, by option: ``--json`` and, in an existing ``--plots`` folder, every
        PNG a run may write there (a new folder holds nothing to replace). ``attitude.png`` is
        among them although it is drawn only when attitude is compared: that is known only after
        reading, and pre-flight comes before it."""
        out = {"--json": self.json_path}
        if self.plots_dir and Path(self.plots_dir).is_dir():
            out.update({f"--plots {name}": Path(self.plots_dir) / name for name in PLOT_NAMES})
        return out
