"""Design a turntable calibration plan from the Fisher information of the calibration model: ``sizefx plan``.

What a calibration can reach is known before anything is recorded. The joint fit
(:func:`sizefx.calibrate.joint_fit`) is a least squares whose design depends only on the motion
(the rates, the angular acceleration, gravity's direction) and whose noise is the accelerometers';
so for a candidate plan the inverse of :func:`sizefx.calibrate.joint.information` on the plan's
noise-free motion is the covariance of the arms, the biases and the tilt the fit will state
(the Cramer-Rao bound, which the fit reaches on white noise: benchmarks/accuracy_calibrate.py).

The plan is the paper's kind (:class:`sizefx.scenarios.TurntablePlan`: each reachable body axis
vertical in turn, the table swinging it through whole positive and negative rotations, dwells
and jerk-limited changes of rate), and the search is over what the table's limits leave free:

- the peak rate and the angular acceleration (fractions of the table's limits);
- the number of rotation cycles per axis (how the time is shared between accelerating, which
  shows the arms through the tangential term, and cruising, which shows them through the
  centripetal term);
- the time per axis: the budget's share (``objective="min-sigma"``: the smallest largest arm
  sigma in the time), or the least that reaches the wanted sigma (``objective="least-time"``).

With a wanted delay sigma (``target_delay_sigma_us``) the plan gains a sway for the
accelerometers' delay, which rotations about vertical axes barely show (gravity stays put in the
body): a level body axis swung harmonically, gravity turning in the body at the sway's rate, as
long as the delay's sigma needs (:func:`_least_sway`).

A plan is a TOML document (``data-schemas/plan-1.json``) that ``sizefx simulate turntable --plan``
runs (and ``sizefx simulate sway --plan``, its sway). Conventions: SI inside; the file and the options in the table's own units (deg/s, deg/s^2,
s, ug/sqrt(Hz), mm).

The package, from the bottom up:

- :mod:`.request`: the table's limits, the request, the prediction and the design
  (:class:`TableLimits`, :class:`PlanRequest`, :class:`Prediction`, :class:`PlanDesign`), and
  :class:`PlanError`;
- :mod:`.fisher`: the Fisher information on a plan's motion and the standard errors it gives
  (:func:`predict`);
- :mod:`.search`: the search for the turntable plan, in a time budget or for a wanted sigma;
- :mod:`.sway`: the delay's sway (:func:`sway_shape`);
- :mod:`.design`: :func:`design_plan`, the two together, the paper's plan beside them;
- :mod:`.document`: the ``sizefx/plan/1`` document (:func:`plan_document`) and the printed lines;
- here: the stage, :class:`PlanConfig` -> :func:`run` -> :class:`PlanResult`, as ``sizefx plan``
  calls it (the config, the request and the table's limits, their options declared, are
  :mod:`sizefx.configs.plan`'s).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..configs.plan import PlanConfig
from ..constants import MAX_PLAN_S
from ..io.plan_file import PLAN_SCHEMA

# the submodules' names; those imported `as` themselves are not in __all__ but importable from here as
# before the split (the search's and the sway's other constants, and two helpers
# tests/test_consistent_inputs.py checks)
from .design import design_plan
from .document import plan_document, report_lines
from .fisher import PLAN_RATE_HZ, predict
from .fisher import _fisher as _fisher
from .request import SWAY_AXES, PlanDesign, PlanError, PlanRequest, Prediction, TableLimits
from .search import ACCEL_FRACTIONS, BLOCK_MAX_S, FINALISTS, RATE_FRACTIONS
from .search import CRUISE_FACTORS as CRUISE_FACTORS
from .search import CYCLE_CHOICES as CYCLE_CHOICES
from .search import DWELL_S as DWELL_S
from .search import LEAD_IN_S as LEAD_IN_S
from .search import MAX_CYCLES as MAX_CYCLES
from .search import _one_bias_per_channel as _one_bias_per_channel
from .sway import MAX_SWAY_PERIODS as MAX_SWAY_PERIODS
from .sway import SWAY_LEAD_IN_S as SWAY_LEAD_IN_S
from .sway import SWAY_MAX_ANGLE_DEG, SWAY_MAX_HZ, sway_shape

__all__ = [
    "TableLimits",
    "PlanRequest",
    "Prediction",
    "PlanDesign",
    "PlanConfig",
    "PlanResult",
    "run",
    "predict",
    "design_plan",
    "plan_document",
    "PlanError",
    "PLAN_SCHEMA",
    "PLAN_RATE_HZ",
    "RATE_FRACTIONS",
    "ACCEL_FRACTIONS",
    "sway_shape",
    "SWAY_MAX_HZ",
    "SWAY_MAX_ANGLE_DEG",
    "SWAY_AXES",
    "MAX_PLAN_S",
    "BLOCK_MAX_S",
    "FINALISTS",
]


@dataclass
class PlanResult:
    """The plan designed (:attr:`design`) and the file written (:attr:`written`)."""

    design: PlanDesign
    written: dict = field(default_factory=dict)

    def report(self) -> str:
        lines = report_lines(self.design)
        if "-o" in self.written:
            lines.append(f"plan -> {self.written['-o']}")
        return "\n".join(lines)

    def to_json(self) -> dict:
        return {"plan": plan_document(self.design), "written": dict(self.written)}


def run(config: PlanConfig, *, progress=None) -> PlanResult:
    """The ``plan`` stage: the request checked, the output's pre-flight, the search, the file."""
    from ..io.toml import write_toml
    from ..stage import preflight

    request = config.request  # checked when it was made
    preflight(inputs=config.inputs(), outputs=config.outputs(), force=config.force)
    out = PlanResult(design_plan(request, progress=progress))
    if config.output:
        write_toml(
            config.output,
            plan_document(out.design),
            force=config.force,
            header="sizefx plan: a turntable calibration plan\n"
            "run it with: sizefx simulate turntable --plan THIS_FILE -o turntable.h5"
            + (
                "\nand its delay sway with: sizefx simulate sway --plan THIS_FILE -o sway.h5"
                if out.design.sway is not None
                else ""
            ),
        )
        out.written["-o"] = str(config.output)
    return out
