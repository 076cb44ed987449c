"""``sizefx compensate IN.h5 --levers LEVERS.json -o OUT.h5`` (or ``--model MODEL.toml``): its options
are :class:`~sizefx.configs.compensate.CompensateConfig`'s."""

from __future__ import annotations

import click

from sizefx.configs.compensate import CompensateConfig

from .options import stage_command


@stage_command(CompensateConfig)
def compensate(config):
    """Remove the size effect (centripetal and tangential terms) from the accelerometers.

    Separately stamped accelerometers (/imu/accel_time) and a known delay are
    brought onto the gyro time base first. The output keeps the input's form and
    records what was applied in /source. With --model, the model's sensor errors
    are removed as well (see sizefx.correct). A record with IMU gaps is compensated
    one continuous segment at a time (--segment K), or across its gaps with
    --allow-gaps (the estimates next to each gap are then wrong).
    """
    from sizefx.compensate import run

    click.echo(run(config).report())
