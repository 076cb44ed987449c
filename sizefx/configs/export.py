"""What ``sizefx export FORMAT RECORD -o OUTPUT`` is asked (:class:`ExportConfig`), each format's own
options (:class:`RosbagExportOptions`); the stage is :mod:`sizefx.exporters`."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields
from pathlib import Path

from ..constants import ROS_AXES_NAMES, ROS_STORAGES
from ..options import check_options, choice, force, one_of, path, text
from . import NoOptions, format_options

__all__ = ["ExportConfig", "RosbagExportOptions", "EXPORT_OPTIONS"]


@dataclass(frozen=True)
class RosbagExportOptions:
    """``sizefx export rosbag``'s own options: the storage, the topic, the frame id, the axes (None:
    the source bag's, when the record came from one)."""

    storage: str = choice("mcap", ROS_STORAGES, help="Storage plug-in of the ROS 2 bag (as ros2 bag record --storage).")
    topic: str | None = text(
        flags=("--imu-topic",),
        metavar="TOPIC",
        help="Topic [default: the source bag's IMU topic, else /imu/data].",
    )
    frame_id: str | None = text(metavar="FRAME", help="header.frame_id [default: the source bag's, else imu_link].")
    axes: str | None = choice(
        None,
        ROS_AXES_NAMES,
        flags=("--frame",),
        help="Axes of the messages: flu (REP 103, forward-left-up) or frd (REP 103's *_ned frames) [default: the "
        "source bag's, else flu].",
    )

    def __post_init__(self):
        check_options(self)


#: format -> the class of its own options (the formats ``sizefx export`` writes)
EXPORT_OPTIONS = {"csv": NoOptions, "rosbag": RosbagExportOptions}


@dataclass(frozen=True)
class ExportConfig:
    """What ``sizefx export FORMAT RECORD -o OUTPUT`` is asked to do (see :mod:`sizefx.stage`).

    ``options``: the format's own (:data:`EXPORT_OPTIONS`; for ``rosbag`` a
    :class:`RosbagExportOptions`), or a mapping of them by name; None: the format's defaults.
    The exporter's ``write(tel, output, **options)`` takes them by name.
    """

    format: str = choice(None, tuple(EXPORT_OPTIONS), argument="FORMAT", help="The format written.")
    record: str | Path = path(argument="RECORD", help="The sizefx/telemetry/1 record to export.")
    output: str | Path = path(
        required=True,
        kind="path",
        flags=("-o", "--output"),
        help="The file to write (csv: one header line), or the ROS 2 bag folder (rosbag: metadata.yaml and "
        "one storage file).",
    )
    options: NoOptions | RosbagExportOptions | Mapping | None = one_of("format", EXPORT_OPTIONS)
    force: bool = force(
        "Replace the -o file if it exists, or the -o folder if it is a ROS 2 bag (never an input; any other "
        "folder is refused)."
    )

    def __post_init__(self):
        object.__setattr__(self, "options", format_options("export", self.format, EXPORT_OPTIONS, self.options))
        check_options(self)

    def writer_options(self) -> dict:
        """The format's own options by name, as its exporter's ``write`` takes them."""
        options = self.options
        # made into the format's class in __post_init__ (from None, the defaults, or a mapping by name)
        assert options is not None and not isinstance(options, Mapping)
        return {f.name: getattr(options, f.name) for f in fields(options)}

    def inputs(self) -> dict:
        return {"RECORD": self.record}

    def outputs(self) -> dict:
        return {"-o": self.output}
