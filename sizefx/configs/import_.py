"""What ``sizefx import FORMAT SOURCE -o OUTPUT`` is asked (:class:`ImportConfig`), and each format's
own options (:data:`IMPORT_OPTIONS`), declared once; the stage is :mod:`sizefx.importers`, whose
readers take these options by name (``load(path, **options)``).

The options say what the source holds (columns, units, topics, the site); whether the file holds
it is the reader's to judge, with the file at hand (a column that is not there, three names where
four are needed), and so are the rules a reader alone can apply (a quaternion beside Euler angles).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import MISSING, dataclass, fields
from pathlib import Path

from ..constants import BROAD_SITE_DEG, ROS_AXES_NAMES
from ..errors import ConfigError
from ..options import (
    NO_UNITS_CHECK_HELP,
    check_options,
    choice,
    declared,
    force,
    number,
    numbers,
    one_of,
    path,
    switch,
    text,
    words,
)
from . import NoOptions, format_options

__all__ = [
    "ImportConfig",
    "BroadOptions",
    "CsvOptions",
    "UlogOptions",
    "RosbagOptions",
    "TableLogOptions",
    "IMPORT_OPTIONS",
    "FOLDER_FORMATS",
]

#: Formats whose SOURCE may be a folder: a ROS 2 bag is one (``metadata.yaml`` and its storage files).
FOLDER_FORMATS = ("rosbag",)
#: The time units of a table's time column (``--time-units``; a CSV's also 'samples', a counter).
TIME_UNITS = ("s", "ms", "us", "ns")


def site(help: str = "Site: latitude [deg], longitude [deg], height [m] (navigation needs one).", default=None):
    """``--site-deg LAT,LON,H``, which the stage checks against the contract's range before any file is read."""
    return numbers(default, unit=None, count=3, metavar="LAT,LON,H", help=help)


@dataclass(frozen=True)
class BroadOptions:
    """``sizefx import broad``'s own options."""

    site_deg: tuple = site(
        "Assumed site (latitude [deg], longitude [deg], height [m]); BROAD gives none.", default=BROAD_SITE_DEG
    )

    def __post_init__(self):
        check_options(self)


@dataclass(frozen=True, kw_only=True)
class CsvOptions:
    """``sizefx import csv``'s own options: the column map, the units and the reference's columns
    (:func:`sizefx.importers.table.load`)."""

    time: str = text(MISSING, metavar="COLUMN", help="Time column of the file.")
    time_units: str = choice(
        "s", (*TIME_UNITS, "samples"), help="Units of the time column; 'samples' for a counter (needs --rate-hz)."
    )
    rate_hz: float | None = number(unit="Hz", low=1.0, high=1e5, help="Sample rate [Hz] when time is a sample counter.")
    form: str = choice(
        "rates", ("rates", "increments"), help="Rates (gyro, accel) or increments (dtheta, dvel) in the columns."
    )
    gyro: tuple = words(MISSING, metavar="X,Y,Z", help="Gyro (or dtheta) column names.")
    gyro_units: str = text("rad/s", help="rad/s or deg/s (increments: rad or deg).")
    accel: tuple = words(MISSING, metavar="X,Y,Z", help="Accelerometer (or dvel) column names.")
    accel_units: str = text("m/s^2", help="m/s^2 or g (increments: m/s).")
    axes: tuple = words(
        ("x", "y", "z"),
        help="Body FRD axes in sensor axes, e.g. y,x,-z for a right-forward-up sensor, x,-y,-z for "
        "forward-left-up. Applies to the reference attitude too.",
    )
    delimiter: str = text(",", help="Field separator.")
    site_deg: tuple | None = site("Site: latitude [deg], longitude [deg], height [m].")
    reference_file: str | Path | None = path(
        metavar="FILE",
        help="Read the reference columns from this CSV (same delimiter), with its own time column at its "
        "own rate; without it they are read from SOURCE.",
    )
    reference_time: str | None = text(
        metavar="COLUMN",
        help="Time column of the reference, on the IMU clock [default: --time]. In SOURCE, the reference is "
        "read from the rows where it is filled (empty cells elsewhere); without it, from the rows "
        "where the reference columns are filled, at the IMU time.",
    )
    reference_time_units: str | None = text(metavar="UNITS", help="s, ms, us or ns [default: --time-units].")
    reference_quaternion: tuple | None = words(
        metavar="W,X,Y,Z",
        help="Reference attitude: quaternion columns in scalar-first order, rotating sensor-axis vectors "
        "into the reference frame (--reference-frame).",
    )
    reference_euler: tuple | None = words(
        metavar="ROLL,PITCH,HEADING",
        help="Reference attitude: z-y-x Euler angles of the sensor axes in NED, "
        "mat = Rz(heading) Ry(pitch) Rx(roll) (NED only).",
    )
    reference_euler_units: str = text("deg", metavar="UNITS", help="deg or rad.")
    reference_velocity: tuple | None = words(
        metavar="X,Y,Z",
        help="Reference velocity [m/s] in the frame's axis order: north,east,down (ned) or east,north,up (enu).",
    )
    reference_position: tuple | None = words(
        metavar="LAT,LON,H", help="Reference latitude, longitude and height above the WGS-84 ellipsoid [m]."
    )
    reference_position_units: str = text("deg", metavar="UNITS", help="Units of latitude and longitude: deg or rad.")
    reference_frame: str = text(
        "ned",
        metavar="ned|enu",
        help="Navigation frame of the reference quaternion and velocity; enu (East-North-Up, as ROS and "
        "motion capture write it) is converted to NED.",
    )

    def __post_init__(self):
        check_options(self)


@dataclass(frozen=True)
class UlogOptions:
    """``sizefx import ulog``'s own options."""

    site_deg: tuple | None = site(
        "Site: latitude [deg], longitude [deg], height [m] (a log has none; navigation needs one)."
    )

    def __post_init__(self):
        check_options(self)


@dataclass(frozen=True)
class RosbagOptions:
    """``sizefx import rosbag``'s own options: the topics, the frames, the stamps, the site
    (:func:`sizefx.importers.rosbag.load`)."""

    imu: str | None = text(
        flags=("--imu-topic",),
        metavar="TOPIC",
        help="The sensor_msgs/Imu topic [default: the bag's only one; the bag's are listed when it has none or "
        "several].",
    )
    reference: str | None = text(
        flags=("--reference-topic",),
        metavar="TOPIC|tf:PARENT/CHILD",
        help="Reference attitude: a geometry_msgs/PoseStamped (or PoseWithCovarianceStamped) or nav_msgs/Odometry "
        "topic (an Odometry's twist gives the velocity), or the transforms of /tf from frame PARENT to CHILD.",
    )
    body_frame: str | None = text(
        metavar="FRAME",
        help="The frame the reference must describe [default: the IMU messages' frame_id]; name another only "
        "when its axes are the IMU's (a base_link the IMU is aligned with).",
    )
    stamps: str = choice(
        "header",
        ("header", "receive"),
        help="Times from each message's header.stamp, or the time the recorder received it.",
    )
    frame: str = choice(
        "flu",
        ROS_AXES_NAMES,
        help="Axes of the messages: flu (REP 103: body forward-left-up, world east-north-up) or frd (REP 103's "
        "*_ned frames: forward-right-down, north-east-down). Converted to body FRD and NED.",
    )
    site_deg: tuple | None = site()
    navsat: str | None = text(
        flags=("--navsat-topic",),
        metavar="TOPIC",
        help="Take the site from the first fix of this sensor_msgs/NavSatFix topic.",
    )

    def __post_init__(self):
        check_options(self)


@dataclass(frozen=True, kw_only=True)
class TableLogOptions:
    """``sizefx import table-log``'s own options: the IMU record, the table's axes, the log's columns
    and units (:func:`sizefx.importers.table_log.load`)."""

    imu_record: str | Path = path(
        flags=("--imu",),
        metavar="RECORD.h5",
        required=True,
        help="The IMU: a sizefx record made by any importer (e.g. sizefx import csv), on the log's clock.",
    )
    axes: tuple = words(
        MISSING,
        metavar="A1[,A2[,A3]]",
        help="The table's axes, outer to inner, as axes x, y, z of the level table frame (x the zero direction, "
        "z down), a minus where the encoder angle grows turning the other way: z for a single-axis table whose "
        "angle grows clockwise seen from above, -z if anticlockwise; z,x,y for a three-axis one.",
    )
    time: str = text(MISSING, metavar="COLUMN", help="Time column of the log.")
    time_units: str = choice("s", TIME_UNITS, help="Units of the time column.")
    time_offset_s: float = number(
        0.0,
        unit="s",
        low=-1e10,
        high=1e10,
        help="Added to the log's time to put it on the IMU's clock [s]; both loggers must share one clock.",
    )
    angles: tuple = words(MISSING, metavar="COL1[,COL2[,COL3]]", help="Encoder angle columns, one per axis.")
    angle_units: str = choice(
        "deg",
        ("deg", "rad", "counts"),
        help="Units of the angles; counts need --counts-per-rev. Wraps (a jump of over half a turn) are undone.",
    )
    counts_per_rev: float | None = number(unit=None, low=2.0, high=1e15, metavar="N", help="Encoder counts per turn.")
    counter_modulus: float | None = number(
        unit=None,
        low=2.0,
        high=1e20,
        metavar="N",
        help="The count at which the counter rolls over to 0 [default: --counts-per-rev], e.g. 4294967296 for a "
        "32-bit counter.",
    )
    rates: tuple | None = words(metavar="COL1[,COL2[,COL3]]", help="Encoder rate columns, one per axis (optional).")
    rate_units: str | None = choice(
        None, ("deg/s", "rad/s", "counts/s"), help="Units of the rates [default: the angle units per second]."
    )
    table_heading_deg: float = number(
        0.0,
        unit="deg",
        low=-360.0,
        high=360.0,
        help="Heading of the table's zero direction (its x axis), east of north [deg].",
    )
    mount_deg: tuple = numbers(
        (0.0, 0.0, 0.0),
        unit="deg",
        count=3,
        metavar="ROLL,PITCH,YAW",
        help="The IMU's body axes on the inner platform: mat_pb = Rz(yaw) Ry(pitch) Rx(roll) [deg].",
    )
    site_deg: tuple | None = site(
        "Site: latitude [deg], longitude [deg], height [m] [default: the IMU record's; one is needed]."
    )
    delimiter: str = text(",", help="Field separator of the log.")

    def __post_init__(self):
        check_options(self)


#: format -> the class of its own options (the formats ``sizefx import`` reads; the readers are
#: :data:`sizefx.importers.FORMATS`)
IMPORT_OPTIONS = {
    "broad": BroadOptions,
    "psins-imu": NoOptions,
    "psins-mat": NoOptions,
    "csv": CsvOptions,
    "ulog": UlogOptions,
    "rosbag": RosbagOptions,
    "table-log": TableLogOptions,
}

#: Help of --drop-invalid-rows.
DROP_INVALID_ROWS_HELP = (
    "Drop IMU rows holding NaN, inf or values beyond the physical limits (docs/reliability.md) instead of "
    "refusing the source; they become declared gaps, and the report counts them and names the first."
)

ImportOptions = BroadOptions | NoOptions | CsvOptions | UlogOptions | RosbagOptions | TableLogOptions


@dataclass(frozen=True)
class ImportConfig:
    """What ``sizefx import FORMAT SOURCE -o OUTPUT`` is asked to do (see :mod:`sizefx.stage`).

    ``options``: the format's own (:data:`IMPORT_OPTIONS`: column names, units, ``site_deg``,
    ``reference_file``...), or a mapping of them by name; None: the format's defaults. The reader
    (``load(path, **options)`` of the module :data:`sizefx.importers.FORMATS` names) takes them by
    name. ``check_units``: check the magnitudes against physics (:func:`sizefx.sanity.check_units`;
    ``--no-units-check`` turns it off). ``drop_invalid_rows``: drop IMU rows with NaN, inf or values
    beyond the physical limits (they become declared gaps) instead of refusing the source.
    """

    format: str = choice(None, tuple(IMPORT_OPTIONS), argument="FORMAT", help="The source's format.")
    source: str | Path = path(
        argument="SOURCE", kind="path", help="The file to convert (a ROS 2 bag: its folder, or a file)."
    )
    output: str | Path = path(
        required=True, flags=("-o", "--output"), help="Telemetry file to write (HDF5, sizefx/telemetry/1)."
    )
    options: ImportOptions | Mapping | None = one_of("format", IMPORT_OPTIONS)
    force: bool = force()
    check_units: bool = switch(True, flags=("--no-units-check",), sets=False, help=NO_UNITS_CHECK_HELP)
    drop_invalid_rows: bool = switch(help=DROP_INVALID_ROWS_HELP)

    def __post_init__(self):
        object.__setattr__(self, "options", format_options("import", self.format, IMPORT_OPTIONS, self.options))
        check_options(self)
        site_deg = getattr(self.options, "site_deg", None)
        if site_deg is not None:  # before any file is read: a site out of range is the option's fault
            from ..io.schema import site_problem  # the contract's ranges: when a config is made, not for --help

            problem = site_problem(*(float(v) for v in site_deg))
            if problem:
                shown = ",".join(f"{float(v):g}" for v in site_deg)
                raise ConfigError(f"import {self.format}: --site-deg {shown}: {problem}; give a site within the range")

    def reader_options(self) -> dict:
        """The format's own options by name, as its reader's ``load`` takes them."""
        options = self.options
        # made into the format's class in __post_init__ (from None, the defaults, or a mapping by name)
        assert options is not None and not isinstance(options, Mapping)
        return {f.name: getattr(options, f.name) for f in fields(options)}

    def inputs(self) -> dict:
        """The files read, by the option that names them. A SOURCE that is a ROS 2 bag folder is
        its files (``SOURCE metadata.yaml``, ...): each is checked, and none may be an output."""
        options = type(self.options)
        others = {
            option.name: getattr(self.options, name)
            for name, option in declared(options)
            if option.kind in ("file", "folder", "path")
        }
        if self.format in FOLDER_FORMATS and Path(self.source).is_dir():
            from ..ros import bag_files

            return {**{f"SOURCE {f.name}": f for f in bag_files(self.source)}, **others}
        return {"SOURCE": self.source, **others}

    def outputs(self) -> dict:
        return {"-o": self.output}
