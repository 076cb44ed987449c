"""What ``sizefx plan`` is asked (:class:`PlanConfig`): the request (:class:`PlanRequest`), the
table's limits (:class:`TableLimits`) and the plan file to write; the stage is :mod:`sizefx.plan`,
which re-exports these and :class:`PlanError`."""

from __future__ import annotations

from dataclasses import MISSING, dataclass

from ..constants import MAX_PLAN_S
from ..errors import ConfigError
from ..options import check_options, force, group, number, path, text

__all__ = ["PlanError", "TableLimits", "PlanRequest", "PlanConfig", "SWAY_AXES"]

#: The delay's sway axes: body X swung is a roll, body Y a pitch.
SWAY_AXES = {"X": "roll", "Y": "pitch"}


class PlanError(ConfigError):
    """A plan the table cannot run, or a request no plan can meet (one line, exit code 2)."""


@dataclass(frozen=True)
class TableLimits:
    """What the table can do: its largest rate and angular acceleration, the body axes it can make
    vertical, and the time it takes to turn the IMU to the next axis and let it settle. The axes
    are read in capitals."""

    max_rate_dps: float = number(20.0, unit="deg/s", low=0.01, high=5000.0, help="The table's largest rate [deg/s].")
    max_accel_dps2: float = number(
        10.0, unit="deg/s^2", low=0.01, high=1e5, help="The table's largest angular acceleration [deg/s^2]."
    )
    axes: str = text("XYZ", flags=("--vertical-axes",), help="Body axes the table can turn vertical (letters X, Y, Z).")
    reposition_s: float = number(10.0, unit="s", low=0.1, high=3600.0, help="Time to turn the next axis vertical [s].")
    settle_s: float = number(10.0, unit="s", low=0.1, high=3600.0, help="Rest after each turn [s].")
    #: body axes the table can swing about while they lie level (X: roll, Y: pitch; "": none), for the delay
    sway_axes: str = text(
        "", help="Level body axes the table can swing about, for the delay's sway (X: roll, Y: pitch)."
    )

    def __post_init__(self):
        check_options(self)
        axes, sway_axes = self.axes.upper(), self.sway_axes.upper()
        if not axes or any(a not in "XYZ" for a in axes) or len(set(axes)) != len(axes):
            raise PlanError(
                f"--vertical-axes '{self.axes}' (the table axes): give the body axes the table can make vertical, "
                "each once (letters X, Y, Z, e.g. XYZ)"
            )
        if any(a not in SWAY_AXES for a in sway_axes) or len(set(sway_axes)) != len(sway_axes):
            raise PlanError(
                f"--sway-axes '{self.sway_axes}' (the table sway axes): give the level body axes the table can "
                "swing about, each once (X for roll, Y for pitch, e.g. XY)"
            )
        object.__setattr__(self, "axes", axes)
        object.__setattr__(self, "sway_axes", sway_axes)

    def check(self):
        """The limits (checked when they were made)."""
        return self


@dataclass(frozen=True)
class PlanRequest:
    """``sizefx plan``'s question: the accelerometers' white noise, the table, and either a time
    budget (the best plan in it) or a wanted largest arm sigma (the shortest plan that reaches it).
    ``static_s``: a fixed lead-in at rest (None: the search picks one of
    :data:`sizefx.plan.search.LEAD_IN_S`). ``target_delay_sigma_us``: add the shortest sway (within
    the budget) that determines the accelerometers' delay to this sigma; the table must have
    ``sway_axes``."""

    noise_ug_per_sqrt_hz: float = number(
        MISSING,
        flags=("--noise-ug",),
        unit="ug/sqrt(Hz)",
        low=0.0,
        low_open=True,
        high=1e6,
        help="Accelerometer white noise density [ug/sqrt(Hz)] (e.g. 2.96).",
    )
    table: TableLimits = group(TableLimits)
    budget_s: float | None = number(
        unit="s",
        low=1.0,
        high=MAX_PLAN_S,
        help="Time budget [s]: the plan with the smallest largest arm sigma (at most the longest record "
        "calibrate reads whole at 1600 Hz).",
    )
    target_sigma_mm: float | None = number(
        unit="mm",
        low=0.0,
        low_open=True,
        high=1000.0,
        help="Wanted largest arm sigma [mm]: the shortest plan that reaches it.",
    )
    static_s: float | None = number(
        unit="s", low=1.0, high=86400.0, help="Fix the static lead-in [s] (default: the search picks it)."
    )
    target_delay_sigma_us: float | None = number(
        flags=("--delay-sigma-us",),
        unit="us",
        low=0.0,
        low_open=True,
        high=1e6,
        help="Add the shortest sway that determines the accelerometers' delay to this sigma [us] (needs --sway-axes).",
    )

    def __post_init__(self):
        check_options(self)
        if (self.budget_s is None) == (self.target_sigma_mm is None):
            raise PlanError(
                "give either a time budget (--budget-s) or a wanted largest sigma (--target-sigma-mm), one of the two"
            )
        if self.target_delay_sigma_us is not None and not self.table.sway_axes:
            raise PlanError(
                f"--delay-sigma-us {self.target_delay_sigma_us:g}: the delay needs a sway about a level "
                "axis, and the table has none; give the axes it can swing about (--sway-axes X, Y or XY)"
            )

    def check(self):
        """The request (checked when it was made)."""
        return self


@dataclass(frozen=True)
class PlanConfig:
    """``sizefx plan``: the request and the plan file to write (``-o``, ``sizefx/plan/1``)."""

    request: PlanRequest = group(PlanRequest, required=True)
    output: str | None = path(
        flags=("-o", "--output"), help="Write the plan (TOML, sizefx/plan/1) for sizefx simulate turntable --plan."
    )
    force: bool = force()

    def __post_init__(self):
        check_options(self)

    def inputs(self) -> dict:
        return {}

    def outputs(self) -> dict:
        return {"-o": self.output}
