"""``sizefx compensate IN.h5 --levers LEVERS.json -o OUT.h5`` (or ``--model MODEL.toml``)."""

from __future__ import annotations

import click

from .options import allow_gaps_option, force_option, segment_option, span


@click.command()
@click.argument("file", type=click.Path(dir_okay=False))
@click.option(
    "--levers",
    "levers_path",
    type=click.Path(dir_okay=False),
    help="Lever arms (sizefx/levers/1 JSON, e.g. from sizefx calibrate).",
)
@click.option(
    "--model",
    "model_path",
    type=click.Path(dir_okay=False),
    help="Instead of --levers: an effect model (sizefx/effects/1 TOML, e.g. from sizefx diagnose); "
    "corrects delay, biases, scale factors, misalignments, quadratic term, g-sensitivity and "
    "lever arms. Sections the file omits are off.",
)
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False), help="Compensated telemetry (HDF5).")
@click.option(
    "--mode",
    type=click.Choice(["triad", "center"]),
    default="triad",
    show_default=True,
    help="triad: bring the accelerometers to the triad point (d_i); center: to the rotation centre (r_i).",
)
@click.option(
    "--estimator",
    type=click.Choice(["central", "savgol", "increments"]),
    help="Angular acceleration: central or savgol for rates, increments for increments [default: "
    "savgol for rates, increments for increments].",
)
@click.option(
    "--centripetal-only",
    is_flag=True,
    help="Drop the tangential term (the paper: it does not accumulate). Only with --levers.",
)
@click.option(
    "--accel-delay-us",
    type=span(-1e5, 1e5),
    help="Known delay of the accelerometers behind the gyros [us] (default: from the levers file). "
    "Only with --levers; a model gives it in [accel_delay].",
)
@segment_option
@allow_gaps_option
@force_option
def compensate(
    file, levers_path, model_path, output, mode, estimator, centripetal_only, accel_delay_us, segment, allow_gaps, force
):
    """Remove the size effect (centripetal and tangential terms) from the accelerometers.

    Separately stamped accelerometers (/imu/accel_time) and a known delay are
    brought onto the gyro time base first. The output keeps the input's form and
    records what was applied in /source. With --model, the model's sensor errors
    are removed as well (see sizefx.correct). A record with IMU gaps is compensated
    one continuous segment at a time (--segment K), or across its gaps with
    --allow-gaps (the estimates next to each gap are then wrong).
    """
    from sizefx.compensate import run

    click.echo(
        run(
            config_of(
                file,
                levers_path,
                model_path,
                output,
                mode,
                estimator,
                centripetal_only,
                accel_delay_us,
                segment,
                allow_gaps,
                force,
            )
        ).report()
    )


def config_of(
    file, levers_path, model_path, output, mode, estimator, centripetal_only, accel_delay_us, segment, allow_gaps, force
):
    """The stage's config from the command's options (also ``sizefx batch compensate``'s, per record)."""
    from sizefx.compensate import CompensateConfig

    return CompensateConfig(
        input=file,
        output=output,
        levers=levers_path,
        model=model_path,
        mode=mode,
        estimator=estimator,
        tangential=not centripetal_only,
        accel_delay_s=None if accel_delay_us is None else accel_delay_us * 1e-6,
        allow_gaps=allow_gaps,
        segment=segment,
        force=force,
    )
