"""What ``sizefx plan`` is asked and what it answers: the table's limits (:class:`TableLimits`), the
request (:class:`PlanRequest`), the standard errors a plan gives (:class:`Prediction`), the design
(:class:`PlanDesign`), and the one error (:class:`PlanError`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from .. import scenarios
from ..constants import MAX_PLAN_S
from ..errors import ConfigError

__all__ = ["PlanError", "TableLimits", "PlanRequest", "Prediction", "PlanDesign", "SWAY_AXES"]

#: The delay's sway axes: body X swung is a roll, body Y a pitch.
SWAY_AXES = {"X": "roll", "Y": "pitch"}


class PlanError(ConfigError):
    """A plan the table cannot run, or a request no plan can meet (one line, exit code 2)."""


@dataclass(frozen=True)
class TableLimits:
    """What the table can do: its largest rate and angular acceleration, the body axes it can make
    vertical, and the time it takes to turn the IMU to the next axis and let it settle."""

    max_rate_dps: float = 20.0
    max_accel_dps2: float = 10.0
    axes: str = "XYZ"
    reposition_s: float = 10.0
    settle_s: float = 10.0
    #: body axes the table can swing about while they lie level (X: roll, Y: pitch; "": none), for the delay
    sway_axes: str = ""

    def check(self):
        axes, sway_axes = self.axes.upper(), self.sway_axes.upper()
        if not axes or any(a not in "XYZ" for a in axes) or len(set(axes)) != len(axes):
            raise PlanError(
                f"--vertical-axes '{self.axes}' (the table axes): give the body axes the table can make vertical, each once "
                "(letters X, Y, Z, e.g. XYZ)"
            )
        if any(a not in SWAY_AXES for a in sway_axes) or len(set(sway_axes)) != len(sway_axes):
            raise PlanError(
                f"table sway axes '{self.sway_axes}': give the level body axes the table can swing "
                "about, each once (X for roll, Y for pitch, e.g. XY)"
            )
        for name in ("max_rate_dps", "max_accel_dps2", "reposition_s", "settle_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise PlanError(f"table {name} = {value!r}: give a positive, finite number")
        return replace(self, axes=axes, sway_axes=sway_axes)


@dataclass(frozen=True)
class PlanRequest:
    """``sizefx plan``'s question: the accelerometers' white noise, the table, and either a time
    budget (the best plan in it) or a wanted largest arm sigma (the shortest plan that reaches it).
    ``static_s``: a fixed lead-in at rest (None: the search picks one of :data:`LEAD_IN_S`).
    ``target_delay_sigma_us``: add the shortest sway (within the budget) that determines the
    accelerometers' delay to this sigma; the table must have ``sway_axes``."""

    noise_ug_per_sqrt_hz: float
    table: TableLimits = field(default_factory=TableLimits)
    budget_s: float | None = None
    target_sigma_mm: float | None = None
    static_s: float | None = None
    target_delay_sigma_us: float | None = None

    def check(self):
        if not (math.isfinite(self.noise_ug_per_sqrt_hz) and self.noise_ug_per_sqrt_hz > 0):
            raise PlanError(
                f"noise {self.noise_ug_per_sqrt_hz!r} ug/sqrt(Hz): give the accelerometers' white noise "
                "density, positive and finite"
            )
        if (self.budget_s is None) == (self.target_sigma_mm is None):
            raise PlanError(
                "give either a time budget (--budget-s) or a wanted largest sigma (--target-sigma-mm), one of the two"
            )
        for name in ("budget_s", "target_sigma_mm", "static_s", "target_delay_sigma_us"):
            value = getattr(self, name)
            if value is not None and not (math.isfinite(value) and value > 0):
                raise PlanError(f"{name} = {value!r}: give a positive, finite number")
        if self.budget_s is not None and self.budget_s > MAX_PLAN_S:
            raise PlanError(
                f"--budget-s {self.budget_s:g}: longer than the {MAX_PLAN_S:g} s a plan may take (calibrate reads "
                f"a turntable record whole, at most {MAX_PLAN_S:g} s at 1600 Hz); give at most {MAX_PLAN_S:g} s, "
                "or plan a longer calibration as several records"
            )
        table = self.table.check()
        if self.target_delay_sigma_us is not None and not table.sway_axes:
            raise PlanError(
                f"--delay-sigma-us {self.target_delay_sigma_us:g}: the delay needs a sway about a level "
                "axis, and the table has none; give the axes it can swing about (--sway-axes X, Y or XY)"
            )
        return replace(self, table=table)


@dataclass
class Prediction:
    """The standard errors a calibration on a plan will state (the inverse Fisher information)."""

    sigma_arms_m: np.ndarray  #: [3, 3]
    sigma_tilt_rad: np.ndarray  #: [2]
    duration_s: float  #: the turntable's and the sway's records together
    sigma_delay_s: float | None = None  #: with a sway: the accelerometers' delay

    @property
    def max_sigma_mm(self) -> float:
        return float(self.sigma_arms_m.max() * 1e3)


@dataclass
class PlanDesign:
    """The plan chosen, its prediction, and the paper's plan under the same noise and table."""

    plan: scenarios.TurntablePlan
    prediction: Prediction
    request: PlanRequest
    paper: Prediction | None = None
    paper_plan: scenarios.TurntablePlan | None = None
    tried: int = 0
    sway: scenarios.SwayPlan | None = None  #: the delay's sway (a record of its own), if asked for
