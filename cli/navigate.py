"""``sizefx navigate FILE``: its options are :class:`~sizefx.configs.navigate.NavigateConfig`'s (and its
run's, :class:`~sizefx.configs.navigate.NavConfig`)."""

from __future__ import annotations

import click

from sizefx.configs.navigate import NavigateConfig

from .options import Progress, quiet_option, stage_command


@stage_command(NavigateConfig)
@quiet_option
def navigate(config, quiet):
    """Whole-record strapdown navigation on WGS-84 (Numba).

    Prints the errors against /reference when the file has one: final and
    maximum horizontal error [m], drift [nmi/h], final velocity error [m/s],
    attitude error [deg]. A record with IMU gaps is navigated one continuous
    segment at a time (--segment K): the integration cannot bridge a gap.
    """
    from sizefx.navigate import run

    click.echo(run(config, progress=Progress("navigate", quiet)).report())
