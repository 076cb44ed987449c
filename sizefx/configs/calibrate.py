"""What ``sizefx calibrate RECORDS`` is asked (:class:`CalibrateConfig`); the stage is
:mod:`sizefx.calibrate`."""

from __future__ import annotations

from dataclasses import dataclass

from ..options import allow_gaps, check_options, choice, force, path, switch, text

__all__ = ["CalibrateConfig", "TRIAD_POINTS"]

#: ``--triad-point``: where the split r_i = r + d_i puts the triad point.
TRIAD_POINTS = ("normals", "x-accelerometer")


@dataclass(frozen=True)
class CalibrateConfig:
    """``sizefx calibrate RECORDS``: the records, the options, the outputs.

    ``nominal``: a preset (high-precision, compact, none) or a ``sizefx/levers/1`` file to
    compare with. ``with_tilt``, ``with_delay``: estimate the table's tilt, the accelerometers'
    delay. ``triad``: the triad point of the split r_i = r + d_i (:data:`TRIAD_POINTS`).
    ``json_path`` (``--json``): the lever arms; ``plot`` (``--plot``): the paper's Fig. 6.
    """

    records: tuple = path(
        argument="RECORDS", many=True, help="The records, fitted jointly; each needs /reference attitude."
    )
    nominal: str = text(
        "high-precision",
        help="Nominal geometry to compare with: high-precision, compact, or a sizefx/levers/1 file.",
    )
    json_path: str | None = path(
        flags=("--json",), metavar="FILE", help="Write the lever arms to FILE (JSON, sizefx/levers/1)."
    )
    with_tilt: bool = switch(
        True, flags=("--tilt/--no-tilt",), help="Estimate the table's tilt about north and east [arcsec]."
    )
    with_delay: bool = switch(
        False,
        flags=("--delay/--no-delay",),
        help="Estimate the accelerometers' delay behind the gyros [us] (needs rotation about horizontal axes).",
    )
    triad: str = choice(
        "normals",
        TRIAD_POINTS,
        flags=("--triad-point",),
        help="Triad point for the split r_i = r + d_i: where the accelerometer normals meet, or accelerometer x.",
    )
    plot: str | None = path(
        metavar="FILE",
        help="Write the paper's Fig. 6 to FILE (one PNG): horizontal channels before and after compensation.",
    )
    allow_gaps: bool = allow_gaps()
    force: bool = force("Replace the --json and --plot files if they exist (never an input).")

    def __post_init__(self):
        check_options(self)

    def inputs(self) -> dict:
        from ..geometry import PRESETS  # numpy: loaded when the stage runs, not for --help

        files = {f"RECORDS ({k + 1})" if len(self.records) > 1 else "RECORDS": p for k, p in enumerate(self.records)}
        return {**files, "--nominal": None if self.nominal in PRESETS else self.nominal}

    def outputs(self) -> dict:
        return {"--json": self.json_path, "--plot": self.plot}
