"""``sizefx plan``: design a turntable calibration plan (and the delay's sway) from the Fisher information;
its options are :class:`~sizefx.configs.plan.PlanConfig`'s (the request's and the table's)."""

from __future__ import annotations

import click

from sizefx.configs.plan import PlanConfig

from .options import stage_command


@stage_command(PlanConfig)
def plan(config):
    """Design a turntable calibration plan for the lever arms.

    From the accelerometers' noise and the table's limits, the plan (axes,
    rate, acceleration, cycles, durations) with the smallest largest arm
    sigma in --budget-s, or the shortest one reaching --target-sigma-mm,
    from the Fisher information of the calibration model (what sizefx
    calibrate will state). Prints the predicted sigmas beside the paper's
    plan; -o writes the plan for sizefx simulate turntable --plan.
    --delay-sigma-us adds a sway about a level axis for the accelerometers'
    delay (a record of its own: sizefx simulate sway --plan).
    """
    from sizefx.plan import run

    click.echo(run(config).report())
