"""``sizefx plan``: design a turntable calibration plan (and the delay's sway) from the Fisher information."""

from __future__ import annotations

import click

from sizefx.constants import MAX_PLAN_S

from .options import force_option, span


@click.command()
@click.option(
    "-o",
    "--output",
    type=click.Path(dir_okay=False),
    help="Write the plan (TOML, sizefx/plan/1) for sizefx simulate turntable --plan.",
)
@click.option(
    "--noise-ug",
    "noise_ug",
    required=True,
    type=span(0.0, 1e6, low_open=True),
    help="Accelerometer white noise density [ug/sqrt(Hz)] (e.g. 2.96).",
)
@click.option(
    "--max-rate-dps", default=20.0, show_default=True, type=span(0.01, 5000.0), help="The table's largest rate [deg/s]."
)
@click.option(
    "--max-accel-dps2",
    default=10.0,
    show_default=True,
    type=span(0.01, 1e5),
    help="The table's largest angular acceleration [deg/s^2].",
)
@click.option(
    "--vertical-axes",
    "axes",
    default="XYZ",
    show_default=True,
    help="Body axes the table can turn vertical (letters X, Y, Z).",
)
@click.option(
    "--reposition-s",
    default=10.0,
    show_default=True,
    type=span(0.1, 3600.0),
    help="Time to turn the next axis vertical [s].",
)
@click.option("--settle-s", default=10.0, show_default=True, type=span(0.1, 3600.0), help="Rest after each turn [s].")
@click.option(
    "--budget-s",
    type=span(1.0, MAX_PLAN_S),
    help="Time budget [s]: the plan with the smallest largest arm sigma (at most the longest record "
    "calibrate reads whole at 1600 Hz).",
)
@click.option(
    "--target-sigma-mm",
    type=span(0.0, 1000.0, low_open=True),
    help="Wanted largest arm sigma [mm]: the shortest plan that reaches it.",
)
@click.option("--static-s", type=span(1.0, 86400.0), help="Fix the static lead-in [s] (default: the search picks it).")
@click.option(
    "--delay-sigma-us",
    "delay_sigma_us",
    type=span(0.0, 1e6, low_open=True),
    help="Add the shortest sway that determines the accelerometers' delay to this sigma [us] (needs --sway-axes).",
)
@click.option(
    "--sway-axes",
    default="",
    show_default=True,
    help="Level body axes the table can swing about, for the delay's sway (X: roll, Y: pitch).",
)
@force_option
def plan(
    output,
    noise_ug,
    max_rate_dps,
    max_accel_dps2,
    axes,
    reposition_s,
    settle_s,
    budget_s,
    target_sigma_mm,
    static_s,
    delay_sigma_us,
    sway_axes,
    force,
):
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
    from sizefx.plan import PlanConfig, PlanRequest, TableLimits, run

    req = PlanRequest(
        noise_ug,
        TableLimits(max_rate_dps, max_accel_dps2, axes, reposition_s, settle_s, sway_axes),
        budget_s=budget_s,
        target_sigma_mm=target_sigma_mm,
        static_s=static_s,
        target_delay_sigma_us=delay_sigma_us,
    )
    click.echo(run(PlanConfig(req, output=output, force=force)).report())
