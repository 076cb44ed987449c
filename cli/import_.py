"""``sizefx import FORMAT SOURCE -o OUT.h5``."""

from __future__ import annotations

import click

from sizefx.constants import BROAD_SITE_DEG
from sizefx.options import NO_UNITS_CHECK_HELP

from .options import force_option, parse_vector, span

#: Where --no-units-check and --drop-invalid-rows leave their values for :func:`run_import` (click's
#: per-invocation ``meta``).
NO_UNITS_CHECK = "sizefx.import.no_units_check"
DROP_INVALID_ROWS = "sizefx.import.drop_invalid_rows"


def run_import(fmt, source, output, *, force, **options):
    """Build the stage's config from the options, run it, print its report (the library is imported
    when a command runs, not for ``--help``)."""
    from sizefx.importers import ImportConfig, run

    ctx = click.get_current_context(silent=True)
    check_units = not (ctx is not None and ctx.meta.get(NO_UNITS_CHECK, False))
    drop = ctx is not None and ctx.meta.get(DROP_INVALID_ROWS, False)
    result = run(
        ImportConfig(fmt, source, output, force=force, check_units=check_units, drop_invalid_rows=drop, options=options)
    )
    click.echo(result.report())


def output_option(f):
    return click.option(
        "-o",
        "--output",
        required=True,
        type=click.Path(dir_okay=False),
        help="Telemetry file to write (HDF5, sizefx/telemetry/1).",
    )(f)


def source_argument(f):
    return click.argument("source", type=click.Path(dir_okay=False))(f)


@click.group(name="import")
def import_():
    """Convert other telemetry formats into sizefx/telemetry/1 (body FRD, NED, SI).

    Each importer records in /source where the data came from (file, SHA-256,
    credits) and writes the file atomically; the result is validated before
    the command returns.
    """


@import_.command()
@source_argument
@output_option
@click.option(
    "--site-deg",
    default=",".join(map(str, BROAD_SITE_DEG)),
    show_default=True,
    metavar="LAT,LON,H",
    help="Assumed site (latitude [deg], longitude [deg], height [m]); BROAD gives none.",
)
@force_option
def broad(source, output, site_deg, force):
    """BROAD benchmark trial (.mat, 285.7 Hz): IMU FLU -> FRD, motion capture ENU -> NED."""
    run_import("broad", source, output, force=force, site_deg=parse_vector(site_deg, "--site-deg"))


@import_.command("psins-imu")
@source_argument
@output_option
@force_option
def psins_imu(source, output, force):
    """PSINS text log of integer increments (RFU -> FRD; header site and attitude kept)."""
    run_import("psins-imu", source, output, force=force)


@import_.command("psins-mat")
@source_argument
@output_option
@force_option
def psins_mat(source, output, force):
    """PSINS MEMS + FOG-INS record (.mat): increments, reference attitude, velocity, position, biases."""
    run_import("psins-mat", source, output, force=force)


def _names(text):
    """``"a,b,c"`` -> ``("a", "b", "c")``; None stays None (the library counts and checks them)."""
    return None if text is None else tuple(text.split(","))


@import_.command()
@source_argument
@output_option
@click.option("--time", "time_col", required=True, metavar="COLUMN", help="Time column of the file.")
@click.option(
    "--time-units",
    type=click.Choice(["s", "ms", "us", "ns", "samples"]),
    default="s",
    show_default=True,
    help="Units of the time column; 'samples' for a counter (needs --rate-hz).",
)
@click.option("--rate-hz", type=span(1.0, 1e5), help="Sample rate [Hz] when time is a sample counter.")
@click.option(
    "--form",
    type=click.Choice(["rates", "increments"]),
    default="rates",
    show_default=True,
    help="Rates (gyro, accel) or increments (dtheta, dvel) in the columns.",
)
@click.option("--gyro", required=True, metavar="X,Y,Z", help="Gyro (or dtheta) column names.")
@click.option("--gyro-units", default="rad/s", show_default=True, help="rad/s or deg/s (increments: rad or deg).")
@click.option("--accel", required=True, metavar="X,Y,Z", help="Accelerometer (or dvel) column names.")
@click.option("--accel-units", default="m/s^2", show_default=True, help="m/s^2 or g (increments: m/s).")
@click.option(
    "--axes",
    default="x,y,z",
    show_default=True,
    help="Body FRD axes in sensor axes, e.g. y,x,-z for a right-forward-up sensor, x,-y,-z for "
    "forward-left-up. Applies to the reference attitude too.",
)
@click.option("--delimiter", default=",", show_default=True, help="Field separator.")
@click.option("--site-deg", metavar="LAT,LON,H", help="Site: latitude [deg], longitude [deg], height [m].")
@click.option(
    "--reference-file",
    type=click.Path(dir_okay=False),
    metavar="FILE",
    help="Read the reference columns from this CSV (same delimiter), with its own time column at its "
    "own rate; without it they are read from SOURCE.",
)
@click.option(
    "--reference-time",
    metavar="COLUMN",
    help="Time column of the reference, on the IMU clock [default: --time]. In SOURCE, the reference is "
    "read from the rows where it is filled (empty cells elsewhere); without it, from the rows "
    "where the reference columns are filled, at the IMU time.",
)
@click.option("--reference-time-units", metavar="UNITS", help="s, ms, us or ns [default: --time-units].")
@click.option(
    "--reference-quaternion",
    metavar="W,X,Y,Z",
    help="Reference attitude: quaternion columns in scalar-first order, rotating sensor-axis vectors "
    "into the reference frame (--reference-frame).",
)
@click.option(
    "--reference-euler",
    metavar="ROLL,PITCH,HEADING",
    help="Reference attitude: z-y-x Euler angles of the sensor axes in NED, "
    "mat = Rz(heading) Ry(pitch) Rx(roll) (NED only).",
)
@click.option("--reference-euler-units", default="deg", show_default=True, metavar="UNITS", help="deg or rad.")
@click.option(
    "--reference-velocity",
    metavar="X,Y,Z",
    help="Reference velocity [m/s] in the frame's axis order: north,east,down (ned) or east,north,up (enu).",
)
@click.option(
    "--reference-position",
    metavar="LAT,LON,H",
    help="Reference latitude, longitude and height above the WGS-84 ellipsoid [m].",
)
@click.option(
    "--reference-position-units",
    default="deg",
    show_default=True,
    metavar="UNITS",
    help="Units of latitude and longitude: deg or rad.",
)
@click.option(
    "--reference-frame",
    default="ned",
    show_default=True,
    metavar="ned|enu",
    help="Navigation frame of the reference quaternion and velocity; enu (East-North-Up, as ROS and "
    "motion capture write it) is converted to NED.",
)
@force_option
def csv(
    source,
    output,
    time_col,
    time_units,
    rate_hz,
    form,
    gyro,
    gyro_units,
    accel,
    accel_units,
    axes,
    delimiter,
    site_deg,
    reference_file,
    reference_time,
    reference_time_units,
    reference_quaternion,
    reference_euler,
    reference_euler_units,
    reference_velocity,
    reference_position,
    reference_position_units,
    reference_frame,
    force,
):
    """Generic CSV with a column map and units, and optionally a reference.

    \b
    The reference (attitude, and optionally velocity and position) makes the
    record usable by calibrate, diagnose and compare. Its attitude describes the
    same sensor axes as the IMU columns (--axes maps both into body FRD). Rows
    with an empty or NaN reference cell are dropouts: left out and reported.
    """
    run_import(
        "csv",
        source,
        output,
        force=force,
        time=time_col,
        time_units=time_units,
        rate_hz=rate_hz,
        form=form,
        gyro=_names(gyro),
        gyro_units=gyro_units,
        accel=_names(accel),
        accel_units=accel_units,
        axes=_names(axes),
        delimiter=delimiter,
        site_deg=parse_vector(site_deg, "--site-deg") if site_deg else None,
        reference_file=reference_file,
        reference_time=reference_time,
        reference_time_units=reference_time_units,
        reference_quaternion=_names(reference_quaternion),
        reference_euler=_names(reference_euler),
        reference_euler_units=reference_euler_units,
        reference_velocity=_names(reference_velocity),
        reference_position=_names(reference_position),
        reference_position_units=reference_position_units,
        reference_frame=reference_frame,
    )


@import_.command()
@source_argument
@output_option
@click.option(
    "--site-deg",
    metavar="LAT,LON,H",
    help="Site: latitude [deg], longitude [deg], height [m] (a log has none; navigation needs one).",
)
@force_option
def ulog(source, output, site_deg, force):
    """PX4 ULog (sensor_combined, via pyulog): FRD already; dropouts are declared as gaps (/imu/gaps)."""
    run_import("ulog", source, output, force=force, site_deg=parse_vector(site_deg, "--site-deg") if site_deg else None)


@import_.command()
@click.argument("source", type=click.Path())
@output_option
@click.option(
    "--imu-topic",
    "imu",
    metavar="TOPIC",
    help="The sensor_msgs/Imu topic [default: the bag's only one; the bag's are listed when it has none or several].",
)
@click.option(
    "--reference-topic",
    "reference",
    metavar="TOPIC|tf:PARENT/CHILD",
    help="Reference attitude: a geometry_msgs/PoseStamped (or PoseWithCovarianceStamped) or nav_msgs/Odometry "
    "topic (an Odometry's twist gives the velocity), or the transforms of /tf from frame PARENT to CHILD.",
)
@click.option(
    "--body-frame",
    metavar="FRAME",
    help="The frame the reference must describe [default: the IMU messages' frame_id]; name another only "
    "when its axes are the IMU's (a base_link the IMU is aligned with).",
)
@click.option(
    "--stamps",
    type=click.Choice(["header", "receive"]),
    default="header",
    show_default=True,
    help="Times from each message's header.stamp, or the time the recorder received it.",
)
@click.option(
    "--frame",
    "axes",
    type=click.Choice(["flu", "frd"]),
    default="flu",
    show_default=True,
    help="Axes of the messages: flu (REP 103: body forward-left-up, world east-north-up) or frd (REP 103's "
    "*_ned frames: forward-right-down, north-east-down). Converted to body FRD and NED.",
)
@click.option(
    "--site-deg",
    "site_deg",
    metavar="LAT,LON,H",
    help="Site: latitude [deg], longitude [deg], height [m] (navigation needs one).",
)
@click.option(
    "--navsat-topic",
    "navsat",
    metavar="TOPIC",
    help="Take the site from the first fix of this sensor_msgs/NavSatFix topic.",
)
@force_option
def rosbag(source, output, imu, reference, body_frame, stamps, axes, site_deg, navsat, force):
    """ROS bag (ROS 1 .bag, ROS 2 folder, .mcap or .db3; via rosbags): REP 103 frames -> FRD, NED.

    \b
    Reads only the chosen topics, in bounded memory. Stamps that repeat or
    go back are refused, naming the topic and the message; gaps are declared
    (/imu/gaps). Needs pip install 'sizefx[ros]'.
    """
    run_import(
        "rosbag",
        source,
        output,
        force=force,
        imu=imu,
        reference=reference,
        body_frame=body_frame,
        stamps=stamps,
        frame=axes,
        site_deg=parse_vector(site_deg, "--site-deg") if site_deg else None,
        navsat=navsat,
    )


@import_.command("table-log")
@source_argument
@output_option
@click.option(
    "--imu",
    "imu_record",
    required=True,
    type=click.Path(dir_okay=False),
    metavar="RECORD.h5",
    help="The IMU: a sizefx record made by any importer (e.g. sizefx import csv), on the log's clock.",
)
@click.option(
    "--axes",
    required=True,
    metavar="A1[,A2[,A3]]",
    help="The table's axes, outer to inner, as axes x, y, z of the level table frame (x the zero direction, "
    "z down), a minus where the encoder angle grows turning the other way: z for a single-axis table whose "
    "angle grows clockwise seen from above, -z if anticlockwise; z,x,y for a three-axis one.",
)
@click.option("--time", "time_col", required=True, metavar="COLUMN", help="Time column of the log.")
@click.option(
    "--time-units",
    type=click.Choice(["s", "ms", "us", "ns"]),
    default="s",
    show_default=True,
    help="Units of the time column.",
)
@click.option(
    "--time-offset-s",
    type=span(-1e10, 1e10),
    default=0.0,
    show_default=True,
    help="Added to the log's time to put it on the IMU's clock [s]; both loggers must share one clock.",
)
@click.option("--angles", required=True, metavar="COL1[,COL2[,COL3]]", help="Encoder angle columns, one per axis.")
@click.option(
    "--angle-units",
    type=click.Choice(["deg", "rad", "counts"]),
    default="deg",
    show_default=True,
    help="Units of the angles; counts need --counts-per-rev. Wraps (a jump of over half a turn) are undone.",
)
@click.option("--counts-per-rev", type=span(2.0, 1e15), metavar="N", help="Encoder counts per turn.")
@click.option(
    "--counter-modulus",
    type=span(2.0, 1e20),
    metavar="N",
    help="The count at which the counter rolls over to 0 [default: --counts-per-rev], e.g. 4294967296 for a "
    "32-bit counter.",
)
@click.option("--rates", metavar="COL1[,COL2[,COL3]]", help="Encoder rate columns, one per axis (optional).")
@click.option(
    "--rate-units",
    type=click.Choice(["deg/s", "rad/s", "counts/s"]),
    help="Units of the rates [default: the angle units per second].",
)
@click.option(
    "--table-heading-deg",
    type=span(-360.0, 360.0),
    default=0.0,
    show_default=True,
    help="Heading of the table's zero direction (its x axis), east of north [deg].",
)
@click.option(
    "--mount-deg",
    default="0,0,0",
    show_default=True,
    metavar="ROLL,PITCH,YAW",
    help="The IMU's body axes on the inner platform: mat_pb = Rz(yaw) Ry(pitch) Rx(roll) [deg].",
)
@click.option(
    "--site-deg",
    metavar="LAT,LON,H",
    help="Site: latitude [deg], longitude [deg], height [m] [default: the IMU record's; one is needed].",
)
@click.option("--delimiter", default=",", show_default=True, help="Field separator of the log.")
@force_option
def table_log(
    source,
    output,
    imu_record,
    axes,
    time_col,
    time_units,
    time_offset_s,
    angles,
    angle_units,
    counts_per_rev,
    counter_modulus,
    rates,
    rate_units,
    table_heading_deg,
    mount_deg,
    site_deg,
    delimiter,
    force,
):
    """A turntable controller's log (CSV of encoder angles) as /reference beside an IMU record.

    \b
    Writes the IMU of --imu with the reference attitude the log implies,
      mat_nb = Rz(heading) R(a1, theta1) R(a2, theta2) R(a3, theta3) mat_pb,
    at the log's rows (docs/import.md). Encoder rates, when logged, are checked
    against the angles; the attitude against gravity and the gyros.
    """
    run_import(
        "table-log",
        source,
        output,
        force=force,
        imu_record=imu_record,
        axes=_names(axes),
        time=time_col,
        time_units=time_units,
        time_offset_s=time_offset_s,
        angles=_names(angles),
        angle_units=angle_units,
        counts_per_rev=counts_per_rev,
        counter_modulus=counter_modulus,
        rates=_names(rates),
        rate_units=rate_units,
        table_heading_deg=table_heading_deg,
        mount_deg=parse_vector(mount_deg, "--mount-deg"),
        site_deg=parse_vector(site_deg, "--site-deg") if site_deg else None,
        delimiter=delimiter,
    )


def _remember(key):
    """A click callback that leaves a flag's value in the context's ``meta`` under ``key``."""

    def callback(ctx, param, value):
        ctx.meta[key] = value

    return callback


# Every importer takes --no-units-check and --drop-invalid-rows. They are added here, once, to each
# command of the group (a new importer gets them too), and reach run_import through the context, so
# the commands keep their own signatures.
for _command in import_.commands.values():
    click.option(
        "--no-units-check",
        is_flag=True,
        expose_value=False,
        callback=_remember(NO_UNITS_CHECK),
        help=NO_UNITS_CHECK_HELP,
    )(_command)
    click.option(
        "--drop-invalid-rows",
        is_flag=True,
        expose_value=False,
        callback=_remember(DROP_INVALID_ROWS),
        help="Drop IMU rows holding NaN, inf or values beyond the physical limits (docs/reliability.md) "
        "instead of refusing the source; they become declared gaps, and the report counts them "
        "and names the first.",
    )(_command)
