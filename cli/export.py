"""``sizefx export csv|rosbag RECORD -o OUT``."""

from __future__ import annotations

import click

from .options import force_option


def run_export(fmt, record, output, *, force, **options):
    """Build the stage's config, run it, print its report (the library is imported when a command
    runs, not for ``--help``)."""
    from sizefx.exporters import ExportConfig, run

    click.echo(run(ExportConfig(fmt, record, output, force=force, options=options)).report())


def record_argument(f):
    return click.argument("record", type=click.Path(dir_okay=False))(f)


@click.group(name="export")
def export():
    """Write a record's IMU for other tools: CSV, or a ROS 2 bag of sensor_msgs/Imu.

    The IMU as recorded, or corrected (the output of sizefx compensate); the
    reference is not exported. Outputs are written atomically and never
    replace an input.
    """


@export.command()
@record_argument
@click.option(
    "-o", "--output", required=True, type=click.Path(dir_okay=False), help="CSV file to write (one header line)."
)
@force_option
def csv(record, output, force):
    """time_s, gyro_x..z [rad/s], accel_x..z [m/s^2] (increments: dtheta [rad], dvel [m/s]), body FRD.

    The columns sizefx import csv reads; the report prints the command that
    imports the file back.
    """
    run_export("csv", record, output, force=force)


@export.command()
@record_argument
@click.option(
    "-o",
    "--output",
    required=True,
    type=click.Path(),
    help="ROS 2 bag folder to write (metadata.yaml and one storage file); --force replaces only a bag.",
)
@click.option(
    "--storage",
    type=click.Choice(["mcap", "sqlite3"]),
    default="mcap",
    show_default=True,
    help="Storage plug-in of the ROS 2 bag (as ros2 bag record --storage).",
)
@click.option(
    "--imu-topic", "topic", metavar="TOPIC", help="Topic [default: the source bag's IMU topic, else /imu/data]."
)
@click.option("--frame-id", metavar="FRAME", help="header.frame_id [default: the source bag's, else imu_link].")
@click.option(
    "--frame",
    "axes",
    type=click.Choice(["flu", "frd"]),
    help="Axes of the messages: flu (REP 103, forward-left-up) or frd (REP 103's *_ned frames) [default: the "
    "source bag's, else flu].",
)
@force_option(
    text="Replace the -o folder if it exists and is a ROS 2 bag (never an input; any other folder is refused)."
)
def rosbag(record, output, storage, topic, frame_id, axes, force):
    """sensor_msgs/Imu in the source bag's frames, topic and stamps (needs pip install 'sizefx[ros]').

    \b
    header.stamp is the record's time after the source bag's first stamp,
    so bag -> sizefx import -> sizefx compensate -> sizefx export gives a
    ROS estimator the corrected stream on the clock it came with. No
    orientation (orientation_covariance[0] = -1, REP 145). Rates only.
    """
    run_export("rosbag", record, output, force=force, storage=storage, topic=topic, frame_id=frame_id, axes=axes)
