"""``sizefx export csv|rosbag RECORD -o OUT``: each format's command is made from
:class:`~sizefx.configs.export.ExportConfig` with the format fixed, its own options those of
:data:`~sizefx.configs.export.EXPORT_OPTIONS`."""

from __future__ import annotations

import click

from sizefx.configs.export import ExportConfig

from .options import variant_command


@click.group(name="export")
def export():
    """Write a record's IMU for other tools: CSV, or a ROS 2 bag of sensor_msgs/Imu.

    The IMU as recorded, or corrected (the output of sizefx compensate); the
    reference is not exported. Outputs are written atomically and never
    replace an input.
    """


def _format(name: str):
    """The command of the format ``name``, registered with the group."""
    return variant_command(export, ExportConfig, {"format": name}, name)


def _run(config):
    from sizefx.exporters import run

    click.echo(run(config).report())


@_format("csv")
def csv(config):
    """time_s, gyro_x..z [rad/s], accel_x..z [m/s^2] (increments: dtheta [rad], dvel [m/s]), body FRD.

    The columns sizefx import csv reads; the report prints the command that
    imports the file back.
    """
    _run(config)


@_format("rosbag")
def rosbag(config):
    """sensor_msgs/Imu in the source bag's frames, topic and stamps (needs pip install 'sizefx[ros]').

    \b
    header.stamp is the record's time after the source bag's first stamp,
    so bag -> sizefx import -> sizefx compensate -> sizefx export gives a
    ROS estimator the corrected stream on the clock it came with. No
    orientation (orientation_covariance[0] = -1, REP 145). Rates only.
    """
    _run(config)
