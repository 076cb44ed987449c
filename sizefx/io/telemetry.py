"""Read, validate and write ``sizefx/telemetry/1`` HDF5 files: the one place other code imports them from.

Everything about names, shapes, dtypes and units comes from ``data-schemas/telemetry-1.json``
via :mod:`sizefx.io.schema`. The reader converts to SI and refuses bad input with a
:class:`~sizefx.errors.TelemetryError` whose message names the file, the dataset and the
problem, and says how to fix it. The writer writes atomically (see :mod:`sizefx.io.files`) and
in chunks, so a simulator or importer can stream a long record without holding it all.

This module holds no code: it re-exports the public names of the modules that do, one concern
each (none of them imports this one):

- :mod:`sizefx.io.records`: the dataclasses :class:`Telemetry`, :class:`Reference`, :class:`Site`;
- :mod:`sizefx.io.provenance`: :class:`Provenance`, ``/source`` (where a record came from), and its attributes;
- :mod:`sizefx.io.gaps`: :class:`Gap`, :class:`Segment` and the one definition of a gap;
- :mod:`sizefx.io.contract`: the contract's checks on an open file, :func:`open_hdf5`;
- :mod:`sizefx.io.reader`: :func:`read_telemetry`, :class:`TelemetryStream`, :class:`ReferenceStream`;
- :mod:`sizefx.io.writer`: :class:`TelemetryWriter`, :func:`write_telemetry`.
"""

from __future__ import annotations

from .contract import open_hdf5
from .gaps import (
    GAP_MATCH_TOLERANCE,
    NOMINAL_ROWS,
    Gap,
    Segment,
    find_imu_gaps,
    imu_segments,
    nominal_period_s,
    refuse_gaps,
)
from .provenance import Provenance
from .reader import SCAN_ROWS, ReferenceStream, TelemetryStream, read_telemetry
from .records import Reference, Site, Telemetry
from .writer import WRITE_CHUNK_ROWS, TelemetryWriter, write_telemetry

__all__ = [
    "Reference",
    "Site",
    "open_hdf5",
    "TelemetryStream",
    "ReferenceStream",
    "Telemetry",
    "Provenance",
    "read_telemetry",
    "TelemetryWriter",
    "write_telemetry",
    "Gap",
    "Segment",
    "nominal_period_s",
    "find_imu_gaps",
    "imu_segments",
    "refuse_gaps",
    # tuning constants, importable from here as before the split
    "WRITE_CHUNK_ROWS",
    "NOMINAL_ROWS",
    "GAP_MATCH_TOLERANCE",
    "SCAN_ROWS",
]
