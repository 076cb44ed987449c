"""Writing ``sizefx/telemetry/1`` files: atomically (:mod:`sizefx.io.files`) and in chunks, so a simulator
or an importer can stream a long record without holding it all (:class:`TelemetryWriter`), or a whole
:class:`~sizefx.io.records.Telemetry` in one call (:func:`write_telemetry`).
"""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np

from .contract import attr_str, attr_value
from .files import atomic_output
from .provenance import Provenance, to_attributes
from .records import Site, Telemetry
from .schema import TELEMETRY_SCHEMA, load_schema

__all__ = ["TelemetryWriter", "write_telemetry", "WRITE_CHUNK_ROWS"]

#: HDF5 chunk length (rows) of written datasets: 2^16 rows of 3 float64 is
#: 1.5 MiB, large enough for fast sequential reads and small enough to stream.
WRITE_CHUNK_ROWS = 1 << 16


class TelemetryWriter:
    """Stream a ``sizefx/telemetry/1`` file to disk, atomically.

    The sizes are declared up front; rows are written in any number of calls
    of :meth:`write_imu` and :meth:`write_reference` (in order). The file
    appears under its final name only when the ``with`` block ends without an
    exception and every declared row has been written.

    Data are stored in SI units (the first units of each quantity in the
    schema) as float64 unless ``dtype`` says otherwise.
    """

    def __init__(
        self,
        path,
        *,
        n_samples: int,
        form: str,
        n_reference: int = 0,
        reference_position: bool = False,
        reference_velocity: bool = False,
        accel_time: bool = False,
        site: Site | None = None,
        description: str = "",
        simulation: dict | None = None,
        source: Provenance | None = None,
        inputs=(),
        force: bool = False,
        dtype=np.float64,
        gaps=None,
    ):
        self.schema = load_schema(TELEMETRY_SCHEMA)
        self.source = source
        if form not in self.schema["forms"]:
            raise ValueError(f"form must be one of {list(self.schema['forms'])}, got {form!r}")
        self.path = Path(path)
        self.n_samples = n_samples
        self.form = form
        self.n_reference = n_reference
        self.site = site
        self.description = description
        self.simulation = simulation
        self.inputs = inputs
        self.force = force
        self.dtype = np.dtype(dtype)
        #: declared IMU gaps, [G, 2] s (time before the gap, length), written whole at creation
        self.gaps = None if gaps is None or len(gaps) == 0 else np.asarray(gaps, dtype=np.float64).reshape(-1, 2)
        self._plan = {"/imu/time": n_samples}
        for name in self.schema["forms"][form]["datasets"]:
            self._plan[name] = n_samples
        if accel_time:
            self._plan["/imu/accel_time"] = n_samples
        if n_reference:
            self._plan["/reference/time"] = n_reference
            self._plan["/reference/quaternion"] = n_reference
            if reference_position:
                self._plan["/reference/position"] = n_reference
            if reference_velocity:
                self._plan["/reference/velocity"] = n_reference
        self._written = dict.fromkeys(self._plan, 0)

    def __enter__(self):
        self._ctx = atomic_output(self.path, inputs=self.inputs, force=self.force, expected_bytes=self.expected_bytes())
        tmp = self._ctx.__enter__()
        try:
            self.h5 = h5py.File(tmp, "w")
            self._create()
        except BaseException as exc:
            self._ctx.__exit__(type(exc), exc, exc.__traceback__)
            raise
        return self

    def expected_bytes(self) -> int:
        """The file's size as planned: every declared row, plus 1 MiB for metadata and attributes."""
        total = 0
        for name, rows in self._plan.items():
            spec = self.schema["datasets"][name]
            width = int(np.prod([s for s in spec["shape"] if not isinstance(s, str)] or [1]))
            size = 8 if spec["quantity"] == "time" else self.dtype.itemsize
            total += rows * width * size
        return total + (1 << 20)

    def _create(self):
        h5 = self.h5
        h5.attrs["schema"] = TELEMETRY_SCHEMA
        if self.site is not None:
            h5.attrs["latitude_deg"] = float(np.degrees(self.site.lat_rad))
            h5.attrs["longitude_deg"] = float(np.degrees(self.site.lon_rad))
            h5.attrs["height_m"] = float(self.site.height_m)
        # text that came from a file or a file name may hold bytes that are not UTF-8 (h5py's lone
        # surrogates), which h5py cannot write: carried as backslash escapes (attr_str says why)
        if self.description:
            h5.attrs["description"] = attr_str(self.description)
        for name, rows in self._plan.items():
            spec = self.schema["datasets"][name]
            shape = tuple(rows if isinstance(s, str) else s for s in spec["shape"])
            chunks = (min(rows, WRITE_CHUNK_ROWS),) + shape[1:] if rows else None
            dtype = np.float64 if spec["quantity"] == "time" else self.dtype  # time keeps full precision
            dset = h5.create_dataset(name, shape=shape, dtype=dtype, chunks=chunks)
            units = spec.get("default_units") or next(iter(self.schema["units"][spec["quantity"]]))
            if spec["quantity"] != "dimensionless":
                dset.attrs["units"] = units
        if self.gaps is not None:
            spec = self.schema["datasets"]["/imu/gaps"]
            dset = h5.create_dataset("/imu/gaps", data=self.gaps, dtype=np.float64)
            dset.attrs["units"] = next(iter(self.schema["units"][spec["quantity"]]))
        if self.source is not None:
            g = h5.create_group("source")
            for key, value in to_attributes(self.source).items():
                g.attrs[attr_str(key)] = attr_value(value)
        if self.simulation is not None:
            g = h5.create_group("simulation")
            g.attrs["truth_json"] = json.dumps(self.simulation, sort_keys=True)
            g.attrs["scenario"] = str(self.simulation.get("scenario", "custom"))
            g.attrs["seed"] = int(self.simulation.get("seed", 0))

    def _put(self, name: str, values):
        values = np.asarray(values, dtype=float)
        start = self._written[name]
        stop = start + values.shape[0]
        if stop > self._plan[name]:
            raise ValueError(f"{name}: writing rows {start}:{stop} beyond the declared {self._plan[name]}")
        self.h5[name][start:stop] = values
        self._written[name] = stop

    def write_imu(self, time_s, gyro_like, accel_like, accel_time_s=None):
        """Append IMU rows: rates (rad/s, m/s^2) or increments (rad, m/s) as declared."""
        gname, aname = self.schema["forms"][self.form]["datasets"]
        self._put("/imu/time", time_s)
        self._put(gname, gyro_like)
        self._put(aname, accel_like)
        if accel_time_s is not None:
            self._put("/imu/accel_time", accel_time_s)

    def write_reference(self, time_s, quat_nb, lat_rad=None, lon_rad=None, height_m=None, velocity_n_mps=None):
        """Append reference rows (positions in radians and metres; stored as deg, deg, m)."""
        self._put("/reference/time", time_s)
        self._put("/reference/quaternion", quat_nb)
        if "/reference/position" in self._plan:
            self._put("/reference/position", np.column_stack([np.degrees(lat_rad), np.degrees(lon_rad), height_m]))
        if "/reference/velocity" in self._plan:
            self._put("/reference/velocity", velocity_n_mps)

    def __exit__(self, exc_type, exc, tb):
        """Close the file; publish it only if the block succeeded and every declared row was written."""
        try:
            self.h5.close()
        except BaseException as close_exc:  # the temporary file is unusable: discard it, report the first error
            self._ctx.__exit__(type(close_exc), close_exc, close_exc.__traceback__)
            if exc is not None:
                raise exc from close_exc
            raise
        if exc_type is None:
            short = {k: (self._written[k], n) for k, n in self._plan.items() if self._written[k] != n}
            if short:
                err = RuntimeError(f"{self.path}: incomplete write {short}")
                self._ctx.__exit__(RuntimeError, err, None)
                raise err
        return self._ctx.__exit__(exc_type, exc, tb)


def write_telemetry(path, tel: Telemetry, *, inputs=(), force: bool = False, dtype=np.float64) -> Path:
    """Write a whole :class:`Telemetry` in one call (atomically)."""
    ref = tel.reference
    writer = TelemetryWriter(
        path,
        n_samples=tel.n_samples,
        form=tel.form,
        n_reference=0 if ref is None else ref.time_s.shape[0],
        reference_position=bool(ref is not None and ref.has_position),
        reference_velocity=bool(ref is not None and ref.velocity_n_mps is not None),
        accel_time=tel.accel_time_s is not None,
        site=tel.site,
        description=tel.description,
        simulation=tel.simulation,
        source=tel.source,
        inputs=inputs,
        force=force,
        dtype=dtype,
        gaps=[(g.time_s, g.duration_s) for g in tel.gaps if g.declared and g.dataset == "/imu/time"],
    )
    with writer as w:
        g, a = tel.imu_arrays()
        w.write_imu(tel.time_s, g, a, tel.accel_time_s)
        if ref is not None:
            w.write_reference(ref.time_s, ref.quat_nb, ref.lat_rad, ref.lon_rad, ref.height_m, ref.velocity_n_mps)
    return Path(path)
