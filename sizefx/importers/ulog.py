"""PX4 ULog via ``pyulog``: the ``sensor_combined`` topic.

PX4's body frame is FRD already; ``gyro_rad`` [rad/s] and
``accelerometer_m_s2`` [m/s^2] are sampled at ``timestamp`` [us]; the
accelerometers at ``timestamp + accelerometer_timestamp_relative`` (written
to ``/imu/accel_time``). Logging dropouts stay in the record as gaps, declared
in ``/imu/gaps`` by :func:`sizefx.importers.run_import`: ``sizefx inspect`` lists
the continuous segments between them, and the commands that cannot work across
a gap take ``--segment K``. A log has no surveyed site; ``site_deg`` gives one
(navigation needs it).

pyulog is PX4's own reference parser of the format; it is an optional
dependency (``pip install sizefx[ulog]``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..constants import DEG
from ..errors import SourceError
from ..io.telemetry import Site, Telemetry, find_imu_gaps, nominal_period_s
from . import provenance

#: PX4's RELATIVE_TIMESTAMP_INVALID: the accelerometer stamp is not available
RELATIVE_TIMESTAMP_INVALID = 2147483647
TOPIC = "sensor_combined"


def load(path: Path, *, site_deg=None) -> Telemetry:
    try:
        from pyulog import ULog
    except ImportError:
        raise SourceError(path, "reading ULog needs the pyulog package: pip install 'sizefx[ulog]'") from None
    try:
        log = ULog(str(path), [TOPIC])
    except Exception as exc:  # pyulog raises bare Exceptions on a bad header or stream
        detail = " ".join(str(exc).split())[:100]
        raise SourceError(path, f"is not a readable PX4 ULog ({detail or type(exc).__name__})") from None
    topics = [d for d in log.data_list if d.name == TOPIC]
    if not topics:
        raise SourceError(
            path, f"has no '{TOPIC}' topic; it holds: {', '.join(sorted({d.name for d in log.data_list})) or 'nothing'}"
        )
    data = topics[0].data
    need = ["timestamp"] + [f"gyro_rad[{i}]" for i in range(3)] + [f"accelerometer_m_s2[{i}]" for i in range(3)]
    missing = [k for k in need if k not in data]
    if missing:
        raise SourceError(path, f"topic '{TOPIC}' lacks field '{missing[0]}'")
    t_us = np.asarray(data["timestamp"], dtype=np.int64)
    gyro = np.column_stack([data[f"gyro_rad[{i}]"] for i in range(3)]).astype(float)
    accel = np.column_stack([data[f"accelerometer_m_s2[{i}]"] for i in range(3)]).astype(float)
    accel_time = None
    rel = data.get("accelerometer_timestamp_relative")
    if rel is not None and not np.any(np.asarray(rel) == RELATIVE_TIMESTAMP_INVALID):
        accel_time = (t_us + np.asarray(rel, dtype=np.int64)) * 1e-6
    t = t_us * 1e-6
    if t.size < 2:
        raise SourceError(path, f"topic '{TOPIC}' holds {t.size} sample; at least 2 are needed")
    nominal = nominal_period_s(t)
    gaps = len(find_imu_gaps(t, accel_time))  # the reader's count: one per dropout
    site = None if site_deg is None else Site(site_deg[0] * DEG, site_deg[1] * DEG, float(site_deg[2]))
    return Telemetry(
        time_s=t,
        form="rates",
        gyro_rad_s=gyro,
        accel_mps2=accel,
        accel_time_s=accel_time,
        site=site,
        description=(
            f"PX4 ULog {Path(path).name}, topic {TOPIC}: {t.size} samples at {1 / nominal:g} Hz, "
            f"body FRD, {gaps} logging dropouts (gaps); no reference (the autopilot's estimate is not truth)"
        ),
        source=provenance(path, "ulog", topic=TOPIC, dropouts=gaps, px4_start_timestamp_us=int(t_us[0])),
    )
