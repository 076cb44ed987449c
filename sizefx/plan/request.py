"""What ``sizefx plan`` is asked and what it answers: the table's limits (:class:`TableLimits`), the
request (:class:`PlanRequest`), the standard errors a plan gives (:class:`Prediction`), the design
(:class:`PlanDesign`), and the one error (:class:`PlanError`). The request, the limits and the error
are :mod:`sizefx.configs.plan`'s (their options declared there, without numpy for the command line's
help), re-exported here."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import scenarios
from ..configs.plan import SWAY_AXES, PlanError, PlanRequest, TableLimits

__all__ = ["PlanError", "TableLimits", "PlanRequest", "Prediction", "PlanDesign", "SWAY_AXES"]


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
