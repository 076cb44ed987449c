"""``sizefx compensate IN.h5 --levers LEVERS.json -o OUT.h5``."""

from __future__ import annotations

import click

from sizefx.compensate import run

from .options import allow_gaps_option, force_option


@click.command()
@click.argument("file", type=click.Path(dir_okay=False))
@click.option("--levers", "levers_path", required=True, type=click.Path(dir_okay=False),
              help="Lever arms (sizefx/levers/1 JSON, e.g. from sizefx calibrate).")
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False), help="Compensated telemetry (HDF5).")
@click.option("--mode", type=click.Choice(["triad", "center"]), default="triad", show_default=True,
              help="triad: bring the accelerometers to the triad point (d_i); center: to the rotation centre (r_i).")
@click.option("--estimator", type=click.Choice(["central", "savgol", "increments"]),
              help="Angular acceleration: central or savgol for rates, increments for increments [default: "
                   "savgol for rates, increments for increments].")
@click.option("--centripetal-only", is_flag=True, help="Drop the tangential term (the paper: it does not accumulate).")
@click.option("--accel-delay-us", type=float,
              help="Known delay of the accelerometers behind the gyros [us] (default: from the levers file).")
@allow_gaps_option
@force_option
def compensate(file, levers_path, output, mode, estimator, centripetal_only, accel_delay_us, allow_gaps, force):
    """Remove the size effect (centripetal and tangential terms) from the accelerometers.

    Separately stamped accelerometers (/imu/accel_time) and a known delay are
    brought onto the gyro time base first. The output keeps the input's form and
    records what was applied in /source.
    """
    summary = run(file, levers_path, output, mode=mode, estimator=estimator, centripetal=True,
                  tangential=not centripetal_only,
                  accel_delay_s=None if accel_delay_us is None else accel_delay_us * 1e-6,
                  allow_gaps=allow_gaps, force=force)
    click.echo(f"wrote {summary['path']}: {summary['samples']} samples, mode {summary['mode']}, estimator "
               f"{summary['estimator']}, tangential {'on' if summary['tangential'] else 'off'}, "
               f"delay {summary['accel_delay_s'] * 1e6:.1f} us")
