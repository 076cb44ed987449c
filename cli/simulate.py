"""``sizefx simulate turntable | sway | flight | tumble``."""

from __future__ import annotations

import click

from sizefx.constants import PAPER_AIRFIELD_DEG

from .options import SEED, Progress, force_option, parse_overrides, parse_vector, quiet_option, span

#: Help of simulate's --no-units-check: what it writes, and which readers then refuse the record
#: (inspect by the whole check unless told; the others by the reader's median magnitudes, always).
NO_UNITS_CHECK_HELP = (
    "Write the record even if the physics check of sizefx inspect would refuse it (median specific force "
    "or rate outside what an IMU on Earth reads, specific force at rest far from gravity, gyros that "
    "disagree with the reference): for records that test the checkers. sizefx inspect then needs "
    "--no-units-check too; navigate, calibrate, compensate, diagnose and compare refuse such a record "
    "when its median specific force or rate is implausible (they have no such option), and read it otherwise."
)


def common_options(f):
    """Options every scenario shares (applied bottom-up, shown top-down)."""
    opts = [
        click.option(
            "-o",
            "--output",
            required=True,
            type=click.Path(dir_okay=False),
            help="Telemetry file to write (HDF5, sizefx/telemetry/1).",
        ),
        click.option("--rate-hz", default=1600.0, show_default=True, type=span(1.0, 1e5), help="IMU sample rate [Hz]."),
        click.option(
            "--form",
            type=click.Choice(["rates", "increments"]),
            default="rates",
            show_default=True,
            help="Output rates (gyro [rad/s], accel [m/s^2]) or increments (dtheta [rad], dvel [m/s]).",
        ),
        click.option("--seed", default=0, show_default=True, type=SEED, help="Seed of every noise stream."),
        click.option(
            "--effects",
            "effects_path",
            type=click.Path(exists=True, dir_okay=False),
            help="Effect model (TOML, sizefx/effects/1); see 'sizefx simulate --print-effects'.",
        ),
        click.option(
            "--ideal",
            is_flag=True,
            help="Start from a point IMU with perfect, noiseless sensors (then --effects, --set).",
        ),
        click.option(
            "--set",
            "overrides",
            multiple=True,
            metavar="SECTION.KEY=VALUE",
            help="Override one effect parameter, e.g. --set accel_delay.enabled=true "
            "--set accel_delay.tau_s=0.0005 (repeatable; units as in the key name).",
        ),
        click.option(
            "--geometry",
            type=click.Choice(["high-precision", "compact", "none"]),
            help="Accelerometer arms d_i: a preset of the paper [default: from the effects, high-precision].",
        ),
        click.option(
            "--offset-mm",
            metavar="X,Y,Z",
            help="Offset r from the rotation centre to the triad point, body axes [mm] (sets lever_arm.r_vehicle_m).",
        ),
        click.option(
            "--reference-rate-hz",
            type=span(1.0, 1e5),
            help="Rate of /reference [Hz]; must divide the IMU rate [default: turntable and tumble the IMU rate; sway, flight 100].",
        ),
        click.option(
            "--latitude-deg",
            default=PAPER_AIRFIELD_DEG[0],
            show_default=True,
            type=span(-89.5, 89.5),
            help="Site or start latitude [deg].",
        ),
        click.option(
            "--longitude-deg",
            default=PAPER_AIRFIELD_DEG[1],
            show_default=True,
            type=span(-180.0, 360.0),
            help="Site or start longitude [deg].",
        ),
        click.option(
            "--height-m",
            default=PAPER_AIRFIELD_DEG[2],
            show_default=True,
            type=span(-12000.0, 100000.0),
            help="Site or start height above the WGS-84 ellipsoid [m].",
        ),
        click.option("--no-units-check", is_flag=True, help=NO_UNITS_CHECK_HELP),
        force_option,
        quiet_option,
    ]
    for opt in reversed(opts):
        f = opt(f)
    return f


def _run(
    scenario,
    plan,
    output,
    rate_hz,
    form,
    seed,
    effects_path,
    ideal,
    overrides,
    geometry,
    offset_mm,
    reference_rate_hz,
    latitude_deg,
    longitude_deg,
    height_m,
    no_units_check,
    force,
    quiet,
    plan_path=None,
):
    from sizefx import scenarios
    from sizefx.simulate import SimulateConfig, run

    sets = parse_overrides(overrides)
    if geometry:
        sets.setdefault("lever_arm", {})["preset"] = geometry
        sets["lever_arm"].setdefault("enabled", True)
    if offset_mm:
        sets.setdefault("lever_arm", {})["r_vehicle_m"] = [v / 1000.0 for v in parse_vector(offset_mm, "--offset-mm")]
        sets["lever_arm"].setdefault("enabled", True)
    site = scenarios.SiteSpec(latitude_deg, longitude_deg, height_m)
    config = SimulateConfig(
        scenario,
        output,
        plan=plan,
        site=site,
        effects_path=effects_path,
        overrides=sets,
        ideal=ideal,
        rate_hz=rate_hz,
        form=form,
        seed=seed,
        reference_rate_hz=reference_rate_hz,
        force=force,
        plan_path=plan_path,
        check_units=not no_units_check,
    )
    click.echo(run(config, progress=Progress(f"simulate {scenario}", quiet)).report())


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


def _refuse_plan_options(ctx, plan_path, plan_options):
    """--plan holds the plan: refuse the scenario's own plan options given beside it."""
    from click.core import ParameterSource

    flags = {p.name: p.opts[0] for p in ctx.command.params}
    given = [flags[name] for name in plan_options if ctx.get_parameter_source(name) is ParameterSource.COMMANDLINE]
    if given:
        raise click.UsageError(
            f"--plan {plan_path} holds the plan; leave out {', '.join(given)} (or edit the plan file)"
        )


@simulate.command()
@common_options
@click.option(
    "--vertical-axes",
    "axes",
    default="YXZ",
    show_default=True,
    help="The body axes turned vertical, in the order the table turns about them (letters X, Y, Z).",
)
@click.option(
    "--seconds-per-axis",
    default=120.0,
    show_default=True,
    type=span(1.0, 86400.0),
    help="Duration of the rotations about each axis [s].",
)
@click.option(
    "--cycles",
    default=5,
    show_default=True,
    type=click.IntRange(1, 10000),
    help="Positive-and-negative rotation cycles per axis.",
)
@click.option(
    "--peak-rate-dps", default=20.0, show_default=True, type=span(0.01, 5000.0), help="Peak table rate [deg/s]."
)
@click.option(
    "--accel-dps2",
    default=10.0,
    show_default=True,
    type=span(0.01, 1e5),
    help="Angular acceleration of the table [deg/s^2] (jerk-limited).",
)
@click.option("--static-s", default=60.0, show_default=True, type=span(1.0, 86400.0), help="Static lead-in [s].")
@click.option(
    "--plan",
    "plan_path",
    type=click.Path(dir_okay=False),
    help="Run the plan in this file (sizefx/plan/1, written by sizefx plan) instead of the options above.",
)
@click.pass_context
def turntable(ctx, axes, seconds_per_axis, cycles, peak_rate_dps, accel_dps2, static_s, plan_path, **common):
    """The paper's turntable calibration plan: rotations about body Y, X, then Z, each vertical.

    Each axis: --cycles positive and negative rotations at --peak-rate-dps with
    +-accel in --seconds-per-axis; smooth repositioning between axes. --plan runs
    a designed plan (sizefx plan) instead.
    """
    from sizefx import scenarios

    if plan_path:
        _refuse_plan_options(
            ctx, plan_path, ("axes", "seconds_per_axis", "cycles", "peak_rate_dps", "accel_dps2", "static_s")
        )
        _run("turntable", None, plan_path=plan_path, **common)
        return
    plan = scenarios.TurntablePlan(
        axes=axes.upper(),
        static_s=static_s,
        seconds_per_axis=seconds_per_axis,
        cycles=cycles,
        peak_rate_dps=peak_rate_dps,
        accel_dps2=accel_dps2,
    )
    _run("turntable", plan, **common)


@simulate.command()
@common_options
@click.option(
    "--axis",
    type=click.Choice(["heading", "roll", "pitch"]),
    default="heading",
    show_default=True,
    help="Sway axis: heading (about the vertical), roll (body x) or pitch (body y).",
)
@click.option(
    "--amplitudes-dps",
    default="10,20,30",
    show_default=True,
    help="Rate amplitude A of each segment [deg/s]; rate = A sin(2 pi f t).",
)
@click.option("--frequency-hz", default=1.0, show_default=True, type=span(0.01, 100.0), help="Sway frequency f [Hz].")
@click.option("--static-s", default=600.0, show_default=True, type=span(1.0, 86400.0), help="Static lead-in [s].")
@click.option(
    "--segment-s", default=600.0, show_default=True, type=span(1.0, 86400.0), help="Duration of each amplitude [s]."
)
@click.option(
    "--plan",
    "plan_path",
    type=click.Path(dir_okay=False),
    help="Run the delay's sway in this plan file (sizefx/plan/1, written by sizefx plan --delay-sigma-us) "
    "instead of the options above.",
)
@click.pass_context
def sway(ctx, axis, amplitudes_dps, frequency_hz, static_s, segment_s, plan_path, **common):
    """The paper's sway test: static, then harmonic sway at each amplitude in turn.

    --plan runs the accelerometer delay's sway of a designed plan (sizefx plan) instead.
    """
    if plan_path:
        _refuse_plan_options(ctx, plan_path, ("axis", "amplitudes_dps", "frequency_hz", "static_s", "segment_s"))
        _run("sway", None, plan_path=plan_path, **common)
        return
    try:
        amps = tuple(float(a) for a in amplitudes_dps.split(","))
    except ValueError:
        raise click.BadParameter(
            f"'{amplitudes_dps}' is not a list of numbers", param_hint="--amplitudes-dps"
        ) from None
    if not all(0.0 < a <= 5000.0 for a in amps):  # NaN fails every comparison
        raise click.BadParameter(
            f"'{amplitudes_dps}': each amplitude must be in (0, 5000] deg/s", param_hint="--amplitudes-dps"
        )
    from sizefx import scenarios

    plan = scenarios.SwayPlan(
        axis=axis, amplitudes_dps=amps, frequency_hz=frequency_hz, static_s=static_s, segment_s=segment_s
    )
    _run("sway", plan, **common)


@simulate.command()
@common_options
@click.option("--duration-h", default=1.8, show_default=True, type=span(0.05, 24.0), help="Flight record length [h].")
@click.option(
    "--align-s", default=600.0, show_default=True, type=span(1.0, 86400.0), help="Static alignment before take-off [s]."
)
@click.option("--speed-mps", default=40.0, show_default=True, type=span(1.0, 1000.0), help="Cruise ground speed [m/s].")
@click.option(
    "--altitude-m", default=300.0, show_default=True, type=span(0.0, 20000.0), help="Cruise height above the start [m]."
)
@click.option("--heading-deg", default=45.0, show_default=True, type=span(-360.0, 360.0), help="Outbound track [deg].")
@click.option(
    "--rotor-hz",
    default=8.0,
    show_default=True,
    type=span(1.0, 200.0),
    help="Main rotor rate [Hz]; vibration at 1, 2 and 4 times it.",
)
def flight(duration_h, align_s, speed_mps, altitude_m, heading_deg, rotor_hz, **common):
    """A helicopter flight from the paper's airfield: align, take off, out, turn, back, land."""
    from sizefx import scenarios

    plan = scenarios.FlightPlan(
        duration_s=duration_h * 3600.0,
        align_s=align_s,
        speed_mps=speed_mps,
        altitude_m=altitude_m,
        heading_deg=heading_deg,
        rotor_hz=rotor_hz,
    )
    _run("flight", plan, **common)


@simulate.command()
@common_options
@click.option("--duration-s", default=120.0, show_default=True, type=span(1.0, 86400.0), help="Record length [s].")
@click.option(
    "--gimbals",
    "axes",
    default="zyx",
    show_default=True,
    help="Gimbals that move: z heading, y pitch, x roll (z alone: rotation about the vertical only).",
)
def tumble(duration_s, axes, **common):
    """A record for sizefx diagnose: heading, pitch and roll sinusoids on a static site.

    Gravity sweeps every body axis and the rates reach about 0.7 rad/s, so every
    effect sizefx diagnose knows is observable (with --gimbals zyx).
    """
    from sizefx import scenarios

    plan = scenarios.TumblePlan(duration_s=duration_s, axes=axes.lower())
    _run("tumble", plan, **common)
