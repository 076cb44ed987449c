"""``sizefx import FORMAT SOURCE -o OUT.h5``: each format's command is made from
:class:`~sizefx.configs.import_.ImportConfig` with the format fixed, its own options those of
:data:`~sizefx.configs.import_.IMPORT_OPTIONS`."""

from __future__ import annotations

import click

from sizefx.configs.import_ import ImportConfig

from .options import variant_command


@click.group(name="import")
def import_():
    """Convert other telemetry formats into sizefx/telemetry/1 (body FRD, NED, SI).

    Each importer records in /source where the data came from (file, SHA-256,
    credits) and writes the file atomically; the result is validated before
    the command returns.
    """


def _format(name: str):
    """The command of the format ``name``, registered with the group."""
    return variant_command(import_, ImportConfig, {"format": name}, name)


def _run(config):
    """Run the stage, print its report (the library is imported when a command runs, not for ``--help``)."""
    from sizefx.importers import run

    click.echo(run(config).report())


@_format("broad")
def broad(config):
    """BROAD benchmark trial (.mat, 285.7 Hz): IMU FLU -> FRD, motion capture ENU -> NED."""
    _run(config)


@_format("psins-imu")
def psins_imu(config):
    """PSINS text log of integer increments (RFU -> FRD; header site and attitude kept)."""
    _run(config)


@_format("psins-mat")
def psins_mat(config):
    """PSINS MEMS + FOG-INS record (.mat): increments, reference attitude, velocity, position, biases."""
    _run(config)


@_format("csv")
def csv(config):
    """Generic CSV with a column map and units, and optionally a reference.

    \b
    The reference (attitude, and optionally velocity and position) makes the
    record usable by calibrate, diagnose and compare. Its attitude describes the
    same sensor axes as the IMU columns (--axes maps both into body FRD). Rows
    with an empty or NaN reference cell are dropouts: left out and reported.
    """
    _run(config)


@_format("ulog")
def ulog(config):
    """PX4 ULog (sensor_combined, via pyulog): FRD already; dropouts are declared as gaps (/imu/gaps)."""
    _run(config)


@_format("rosbag")
def rosbag(config):
    """ROS bag (ROS 1 .bag, ROS 2 folder, .mcap or .db3; via rosbags): REP 103 frames -> FRD, NED.

    \b
    Reads only the chosen topics, in bounded memory. Stamps that repeat or
    go back are refused, naming the topic and the message; gaps are declared
    (/imu/gaps). Needs pip install 'sizefx[ros]'.
    """
    _run(config)


@_format("table-log")
def table_log(config):
    """A turntable controller's log (CSV of encoder angles) as /reference beside an IMU record.

    \b
    Writes the IMU of --imu with the reference attitude the log implies,
      mat_nb = Rz(heading) R(a1, theta1) R(a2, theta2) R(a3, theta3) mat_pb,
    at the log's rows (docs/import.md). Encoder rates, when logged, are checked
    against the angles; the attitude against gravity and the gyros.
    """
    _run(config)
