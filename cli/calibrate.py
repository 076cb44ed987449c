"""``sizefx calibrate RECORD [RECORD ...]``: its options are :class:`~sizefx.configs.calibrate.CalibrateConfig`'s."""

from __future__ import annotations

import click

from sizefx.configs.calibrate import CalibrateConfig

from .options import stage_command


@stage_command(CalibrateConfig)
def calibrate(config):
    """Lever arms of each accelerometer from turntable rotations (least squares).

    RECORDS need /reference attitude (what the table reports). Several records
    (e.g. the turntable plan and a roll sway) are fitted jointly: shared arms,
    tilt and delay, a bias per record. Prints the joint estimates with standard
    errors [mm], the difference from the nominal, the paper's per-rotation fit,
    tilt [arcsec] and delay [us].
    """
    from sizefx.calibrate import run

    click.echo(run(config).report())
