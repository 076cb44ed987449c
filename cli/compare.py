"""``sizefx compare A B [--reference REF]``."""

from __future__ import annotations

import click

from .options import force_option


@click.command()
@click.argument("a", type=click.Path(dir_okay=False))
@click.argument("b", type=click.Path(dir_okay=False))
@click.option(
    "--reference",
    type=click.Path(dir_okay=False),
    help="The truth (a navigation file or telemetry with /reference/position): report A and B against "
    "it, and A against B.",
)
@click.option(
    "--json",
    "json_path",
    type=click.Path(dir_okay=False),
    metavar="FILE",
    help="Write the figures to FILE (JSON, sizefx/comparison/1).",
)
@click.option(
    "--plots",
    "plots_dir",
    type=click.Path(file_okay=False),
    metavar="DIR",
    help="Write PNG figures into the folder DIR (created if missing): trajectories.png, "
    "horizontal_error.png, velocity.png and, when attitude is compared, attitude.png.",
)
@force_option(text="Replace the --json file and the PNGs in --plots if they exist (never an input).")
def compare(a, b, reference, json_path, plots_dir, force):
    """Compare two navigation solutions (or a solution and a telemetry reference).

    A and B are sizefx/navigation/1 files (sizefx navigate -o) or telemetry
    files with /reference/position. A is compared with B on A's time stamps
    where both have data; every difference is A - B. Prints the horizontal
    distance [m] (chord on the WGS-84 surface), its along- and cross-track
    parts [m] (ahead and right of B's track positive), the drift [nmi/h],
    height [m], velocity [m/s] and attitude [deg] differences.
    """
    from sizefx.compare import run

    click.echo(run(config_of(a, b, reference, json_path, plots_dir, force)).report())


def config_of(a, b, reference, json_path, plots_dir, force):
    """The stage's config from the command's options (also ``sizefx run ... compare``'s)."""
    from sizefx.compare import CompareConfig

    return CompareConfig(a, b, reference=reference, json_path=json_path, plots_dir=plots_dir, force=force)
