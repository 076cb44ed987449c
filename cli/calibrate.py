"""``sizefx calibrate RECORD [RECORD ...]``."""

from __future__ import annotations

import click

from .options import allow_gaps_option, force_option


@click.command()
@click.argument("records", nargs=-1, required=True, type=click.Path(dir_okay=False))
@click.option(
    "--nominal",
    default="high-precision",
    show_default=True,
    help="Nominal geometry to compare with: high-precision, compact, or a sizefx/levers/1 file.",
)
@click.option(
    "--json",
    "json_path",
    type=click.Path(dir_okay=False),
    metavar="FILE",
    help="Write the lever arms to FILE (JSON, sizefx/levers/1).",
)
@click.option(
    "--tilt/--no-tilt", default=True, show_default=True, help="Estimate the table's tilt about north and east [arcsec]."
)
@click.option(
    "--delay/--no-delay",
    default=False,
    show_default=True,
    help="Estimate the accelerometers' delay behind the gyros [us] (needs rotation about horizontal axes).",
)
@click.option(
    "--triad-point",
    type=click.Choice(["normals", "x-accelerometer"]),
    default="normals",
    show_default=True,
    help="Triad point for the split r_i = r + d_i: where the accelerometer normals meet, or accelerometer x.",
)
@click.option(
    "--plot",
    type=click.Path(dir_okay=False),
    metavar="FILE",
    help="Write the paper's Fig. 6 to FILE (one PNG): horizontal channels before and after compensation.",
)
@allow_gaps_option
@force_option(text="Replace the --json and --plot files if they exist (never an input).")
def calibrate(records, nominal, json_path, tilt, delay, triad_point, plot, allow_gaps, force):
    """Lever arms of each accelerometer from turntable rotations (least squares).

    RECORDS need /reference attitude (what the table reports). Several records
    (e.g. the turntable plan and a roll sway) are fitted jointly: shared arms,
    tilt and delay, a bias per record. Prints the joint estimates with standard
    errors [mm], the difference from the nominal, the paper's per-rotation fit,
    tilt [arcsec] and delay [us].
    """
    from sizefx.calibrate import run

    click.echo(run(config_of(records, nominal, json_path, tilt, delay, triad_point, plot, allow_gaps, force)).report())


def config_of(records, nominal, json_path, tilt, delay, triad_point, plot, allow_gaps, force):
    """The stage's config from the command's options (also ``sizefx batch calibrate``'s, a record at a time)."""
    from sizefx.calibrate import CalibrateConfig

    return CalibrateConfig(
        records=tuple(records),
        nominal=nominal,
        with_tilt=tilt,
        with_delay=delay,
        triad=triad_point,
        allow_gaps=allow_gaps,
        json_path=json_path,
        plot=plot,
        force=force,
    )
