"""``sizefx compare A B [--reference REF]``: its options are :class:`~sizefx.configs.compare.CompareConfig`'s."""

from __future__ import annotations

import click

from sizefx.configs.compare import CompareConfig

from .options import stage_command


@stage_command(CompareConfig)
def compare(config):
    """Compare two navigation solutions (or a solution and a telemetry reference).

    A and B are sizefx/navigation/1 files (sizefx navigate -o) or telemetry
    files with /reference/position. A is compared with B on A's time stamps
    where both have data; every difference is A - B. Prints the horizontal
    distance [m] (chord on the WGS-84 surface), its along- and cross-track
    parts [m] (ahead and right of B's track positive), the drift [nmi/h],
    height [m], velocity [m/s] and attitude [deg] differences.
    """
    from sizefx.compare import run

    click.echo(run(config).report())
