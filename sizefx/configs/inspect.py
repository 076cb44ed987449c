"""What ``sizefx inspect FILE`` is asked (:class:`InspectConfig`); the stage is :mod:`sizefx.inspect`."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..options import allow_gaps, check_options, force, path, units_check

__all__ = ["InspectConfig"]


@dataclass(frozen=True)
class InspectConfig:
    """What ``sizefx inspect FILE`` is asked to do (see :mod:`sizefx.stage`). ``check_units``:
    check the units against physics (:mod:`sizefx.sanity`) and refuse data that look like another
    unit; ``json_path`` ``"-"`` is stdout, which the command prints."""

    file: str | Path = path(argument="FILE", help="The sizefx/telemetry/1 file.")
    allow_gaps: bool = allow_gaps()
    check_units: bool = units_check()
    json_path: str | Path | None = path(
        flags=("--json",),
        metavar="FILE",
        dash=True,
        help="Write the summary to FILE (JSON); '-' prints it to stdout instead of the text.",
    )
    force: bool = force("Replace the --json file if it exists (never an input).")

    def __post_init__(self):
        check_options(self)

    def inputs(self) -> dict:
        return {"FILE": self.file}

    def outputs(self) -> dict:
        return {"--json": self.json_path} if self.json_path not in (None, "-") else {}
