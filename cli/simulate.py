"""``sizefx simulate turntable | sway | flight | tumble``: each scenario's command is made from
:class:`~sizefx.configs.simulate.SimulateConfig` with the scenario fixed, its own options those of its
plan (:mod:`sizefx.configs.scenarios`)."""

from __future__ import annotations

import click

from sizefx.configs.simulate import PLAN_FILE_SCENARIOS, SimulateConfig

from .options import Progress, quiet_option, variant_command


@click.group(invoke_without_command=True)
@click.option("--print-effects", is_flag=True, help="Print the full effect model (TOML, all defaults) and exit.")
@click.pass_context
def simulate(ctx, print_effects):
    """Write telemetry with known truth and hidden effects (turntable, sway, flight or tumble).

    Deterministic given --seed. /reference holds the true (for a turntable:
    the reported) motion; /simulation the true value of every injected
    effect. Default effects: the paper's high-precision lever arms and
    navigation-grade noise (gyro ARW 0.00035 deg/sqrt(h)).
    """
    if print_effects:
        from sizefx.effects import effects_template

        click.echo(effects_template())
        ctx.exit(0)
    if ctx.invoked_subcommand is None:
        click.echo(ctx.get_help())


def _scenario(f):
    """The command of the scenario named like ``f``, registered with the group: the config's options
    with the scenario fixed (and no --plan where a plan file holds no such plan), then --quiet."""
    name = f.__name__
    fixed = {"scenario": name, **({} if name in PLAN_FILE_SCENARIOS else {"plan_path": None})}
    return variant_command(simulate, SimulateConfig, fixed, name)(quiet_option(f))


def _run(config, quiet):
    from sizefx.simulate import run

    click.echo(run(config, progress=Progress(f"simulate {config.scenario}", quiet)).report())


@_scenario
def turntable(config, quiet):
    """The paper's turntable calibration plan: rotations about body Y, X, then Z, each vertical.

    Each axis: --cycles positive and negative rotations at --peak-rate-dps with
    +-accel in --seconds-per-axis; smooth repositioning between axes. --plan runs
    a designed plan (sizefx plan) instead.
    """
    _run(config, quiet)


@_scenario
def sway(config, quiet):
    """The paper's sway test: static, then harmonic sway at each amplitude in turn.

    --plan runs the accelerometer delay's sway of a designed plan (sizefx plan) instead.
    """
    _run(config, quiet)


@_scenario
def flight(config, quiet):
    """A helicopter flight from the paper's airfield: align, take off, out, turn, back, land."""
    _run(config, quiet)


@_scenario
def tumble(config, quiet):
    """A record for sizefx diagnose: heading, pitch and roll sinusoids on a static site.

    Gravity sweeps every body axis and the rates reach about 0.7 rad/s, so every
    effect sizefx diagnose knows is observable (with --gimbals zyx).
    """
    _run(config, quiet)
