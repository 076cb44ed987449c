"""``sizefx diagnose MEASURED.h5``: its options are :class:`~sizefx.configs.diagnose.DiagnoseConfig`'s."""

from __future__ import annotations

import click

from sizefx.configs.diagnose import DiagnoseConfig

from .options import stage_command


@stage_command(DiagnoseConfig)
def diagnose(config):
    """What the sensor model gets wrong about a recording: named, fixed, the gain measured.

    For a real recording (imported, with its reference system in /reference)
    or a simulated one alike. Checks the record's /reference against the IMU
    first (glitches are dropped, the motion split at jumps, every finding a
    warning), predicts the IMU from it under the start model, selects the physical effects the
    residual supports (lever arms, accelerometer and reference delays, table
    tilt, reference mount, biases, scale factors, misalignments, quadratic
    term, g-sensitivity) with robust tests and honest errors, rejects what is
    implausible for the sensor grade or cannot be told apart on this motion,
    names what the model still cannot explain, writes the extended model and
    reports the residual RMS per channel before and after, in sample and on
    blocked folds held out in time (and on --validate-on records).
    """
    from sizefx.diagnose import run

    click.echo(run(config).report())
