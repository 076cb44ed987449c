"""Exporters: a record's IMU for other tools (``sizefx export``).

``csv``
    The rows the CSV importer reads back (``sizefx import csv``): ``time_s`` and the gyro and
    accelerometer columns in SI, body FRD (:mod:`sizefx.exporters.table`).
``rosbag``
    A ROS 2 bag of ``sensor_msgs/Imu``, in the source bag's frame convention (REP 103 FLU unless
    the record came from ``*_ned`` frames), its topic and frame id, and its stamps (the record's
    times after the first ROS stamp, which the import kept): a record imported from a bag,
    compensated by ``sizefx compensate``, goes back to any ROS estimator as the corrected stream
    (:mod:`sizefx.exporters.rosbag`).

The stage (:class:`ExportConfig` -> :func:`run` -> :class:`ExportResult`, see :mod:`sizefx.stage`)
(its options declared in :mod:`sizefx.configs.export`) reads the record through the validating reader (whole: at most
:data:`~sizefx.constants.MAX_WHOLE_READ_ROWS` rows; gaps, declared or not, go out as they are)
and writes the output atomically, never over an input. Each exporter module exposes
``write(tel, output, *, force, inputs, **options) -> ExportDetails``.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass, fields
from pathlib import Path

from ..configs.export import ExportConfig
from ..errors import TelemetryError
from ..io.telemetry import Provenance, read_telemetry

__all__ = ["FORMATS", "ExportConfig", "ExportDetails", "ExportResult", "run", "refuse_separate_accel_stamps"]

#: format name -> the module of this package that writes it (the formats of
#: :data:`sizefx.configs.export.EXPORT_OPTIONS`, which declares each one's own options)
FORMATS = {"csv": "table", "rosbag": "rosbag"}


@dataclass
class ExportDetails:
    """What an exporter module reports of what it wrote."""

    lines: list  #: what it wrote, in words (columns and units, topic, axes, stamps)
    reimport: str | None = None  #: the command that imports the output back


@dataclass
class ExportResult:
    """What an export wrote."""

    path: str  #: the file or folder written
    format: str
    samples: int
    form: str  #: rates | increments
    rate_hz: float
    duration_s: float
    #: what was applied before, from ``/source``: "size effect compensated (sizefx compensate)", or ""
    corrected: str
    imu_gaps: int  #: gaps in the IMU stamps, carried as they are
    reference_rows: int  #: /reference rows, not exported
    lines: list  #: the exporter's own lines
    reimport: str | None

    def to_json(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)}

    def report(self) -> str:
        """The lines ``sizefx export`` prints."""
        head = (
            f"wrote {self.path}: {self.samples} {self.form} samples at {self.rate_hz:.6g} Hz, {self.duration_s:.2f} s"
            + (f", {self.corrected}" if self.corrected else ", as recorded")
        )
        lines = [head, *(f"  {line}" for line in self.lines)]
        if self.imu_gaps:
            lines.append(f"  {self.imu_gaps} gaps in the IMU stamps, carried as they are (an import declares them)")
        if self.reference_rows:
            lines.append(f"  not exported: /reference ({self.reference_rows} rows); the IMU stream only")
        if self.reimport:
            lines.append(f"import it back: {self.reimport}")
        return "\n".join(lines)


def _corrected(source: Provenance | None) -> str:
    if source is None:
        return ""
    if source.correction is not None:
        return "corrected by an effect model (sizefx compensate --model)"
    if source.compensation is not None:
        return "size effect compensated (sizefx compensate)"
    return ""


def refuse_separate_accel_stamps(tel, what: str) -> None:
    """A record whose accelerometers have their own stamps (``/imu/accel_time``) cannot be one row
    (one message) per instant: one line that says how to bring them onto the gyro stamps."""
    if tel.accel_time_s is not None:
        raise TelemetryError(
            tel.path,
            "/imu/accel_time",
            f"the accelerometers are stamped apart from the gyros, and {what} has one stamp per sample: "
            "sizefx compensate brings them onto the gyro stamps (with levers of zero arms for nothing else); "
            "export its output",
        )


def run(config: ExportConfig, *, progress=None) -> ExportResult:
    """Export ``config.record`` to ``config.output``; return what was written.

    Pre-flight first (:func:`sizefx.stage.preflight`; an output that is a folder, a ROS 2 bag, by
    :func:`sizefx.io.files.check_output_folder_replace`). ``progress`` is accepted for the shape every
    stage shares and not called: a record exports in seconds.
    """
    from ..stage import preflight

    module = importlib.import_module(f"{__name__}.{FORMATS[config.format]}")
    folder = getattr(module, "OUTPUT_IS_FOLDER", False)
    preflight(inputs=config.inputs(), outputs={} if folder else config.outputs(), force=config.force)
    if folder:
        module.check_output(config.output, inputs=[config.record], force=config.force)
    tel = read_telemetry(config.record, allow_gaps=True)
    details = module.write(
        tel, Path(config.output), force=config.force, inputs=[config.record], **config.writer_options()
    )
    imu_gaps = [g for g in tel.gaps if g.dataset.startswith("/imu")]
    return ExportResult(
        path=str(config.output),
        format=config.format,
        samples=tel.n_samples,
        form=tel.form,
        rate_hz=tel.sample_rate_hz,
        duration_s=tel.duration_s,
        corrected=_corrected(tel.source),
        imu_gaps=len(imu_gaps),
        reference_rows=0 if tel.reference is None else int(tel.reference.time_s.shape[0]),
        lines=list(details.lines),
        reimport=details.reimport,
    )
