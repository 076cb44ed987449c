"""The ``sizefx/navigation/1`` files (``sizefx navigate -o``): written whole or row block by row
block, and read back, each dataset checked against its entry in ``data-schemas/navigation-1.json``.

The contract states each dataset's shape and units (``/time`` [s], ``/position`` [deg, deg, m],
``/velocity`` NED [m/s], ``/quaternion`` q_nb scalar-first, ``/euler`` [deg]); the reader
compares the units with the contract's, converts them to SI with the telemetry contract's units
table (:func:`sizefx.io.schema.unit_factor`), and refuses what breaks it (data in other files,
another shape, a second time axis, non-numbers, NaN, time going backwards, a latitude outside
[-90, 90] deg, a quaternion that is not unit) with a one-line message naming the file, the
dataset and the problem.
"""

from __future__ import annotations

import contextlib
import json
import os
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

from .. import __version__
from ..constants import MAX_WHOLE_READ_ROWS, QUATERNION_NORM_TOLERANCE
from ..errors import TelemetryError
from ..rotation import mat_to_euler, quat_to_mat
from .contract import attr_str, open_hdf5, storage_problem
from .files import atomic_output, check_room
from .schema import load_schema, normalise_units, unit_factor

__all__ = [
    "NAVIGATION_SCHEMA",
    "Solution",
    "read_navigation",
    "read_navigation_datasets",
    "write_navigation",
    "NavigationWriter",
]

NAVIGATION_SCHEMA = "sizefx/navigation/1"

#: The quantity of each dataset of the navigation contract, the key of the units table of
#: ``data-schemas/telemetry-1.json`` that converts it to SI (navigation-1.json states its units
#: but, unlike telemetry-1.json, not its quantities; its conventions are telemetry's).
NAVIGATION_QUANTITIES = {
    "/time": "time",
    "/position": "geodetic",
    "/velocity": "velocity",
    "/quaternion": "dimensionless",
}


@dataclass
class Solution:
    """A navigation solution read from a file: SI units, WGS-84, ``quat_nb`` rotating body into NED."""

    time_s: np.ndarray  #: [M] s, strictly increasing
    lat_rad: np.ndarray  #: [M]
    lon_rad: np.ndarray  #: [M]
    height_m: np.ndarray  #: [M]
    v_n: np.ndarray  #: [M, 3] NED, m/s
    quat_nb: np.ndarray  #: [M, 4] unit, scalar-first


def read_navigation(path) -> Solution:
    """Read and check a ``sizefx/navigation/1`` file."""
    path = Path(path)
    with open_hdf5(path, "it must be a sizefx/navigation/1 file (sizefx navigate -o)") as h5:
        declared = h5.attrs.get("schema")
        declared = None if declared is None else attr_str(declared)
        if declared != NAVIGATION_SCHEMA:
            raise TelemetryError(
                path, "/", f"root attribute schema is {declared!r}; expected {NAVIGATION_SCHEMA!r} (sizefx navigate -o)"
            )
        return read_navigation_datasets(path, h5)


def _dataset(path: Path, h5: h5py.File, name: str, rows: dict) -> np.ndarray:
    """One dataset of a navigation file, checked against its contract entry; float64, SI units.

    ``rows`` binds the contract's row symbol (``"M"``) to the first dataset's length, so that
    every later dataset must share the time axis.
    """
    spec = load_schema(NAVIGATION_SCHEMA)["datasets"][name]
    if name not in h5:
        raise TelemetryError(path, name, "dataset is missing; sizefx navigate -o writes it")
    link = h5.get(name, getlink=True)
    if isinstance(link, h5py.ExternalLink):
        raise TelemetryError(
            path,
            name,
            f"is an HDF5 external link to {link.filename}:{link.path}; navigation files must be self-contained",
        )
    dset = h5[name]
    if not isinstance(dset, h5py.Dataset):
        raise TelemetryError(path, name, f"is a {type(dset).__name__}, expected a dataset")
    if dset.is_virtual or dset.external:
        raise TelemetryError(path, name, "keeps its data in other files; store the data in this file")
    shape = spec["shape"]
    if dset.ndim != len(shape) or any(isinstance(w, int) and w != g for w, g in zip(shape, dset.shape)):
        raise TelemetryError(path, name, f"has shape {dset.shape}; expected [{', '.join(map(str, shape))}]")
    bound = rows.setdefault(shape[0], dset.shape[0])
    if dset.shape[0] != bound:
        raise TelemetryError(
            path, name, f"has {dset.shape[0]} rows but /time has {bound}; all datasets share the time axis"
        )
    if dset.dtype.kind not in "fiu":
        raise TelemetryError(path, name, f"has dtype {dset.dtype}; expected numbers (float64)")
    problem = storage_problem(dset)
    if problem is None and dset.shape[0] > MAX_WHOLE_READ_ROWS:
        problem = f"holds {dset.shape[0]} rows; a solution is read whole, at most {MAX_WHOLE_READ_ROWS} rows"
    if problem:
        raise TelemetryError(path, name, problem)
    # The navigation contract allows its own units only (an absent attribute means them); the
    # telemetry contract's units table converts them to SI.
    units = dset.attrs.get("units")
    if units is not None and normalise_units(attr_str(units)) != normalise_units(spec["units"]):
        raise TelemetryError(path, name, f"has units '{attr_str(units)}'; {NAVIGATION_SCHEMA} stores '{spec['units']}'")
    factor = unit_factor(NAVIGATION_QUANTITIES[name], spec["units"])
    try:
        data = np.asarray(dset[()], dtype=np.float64)
    except OSError as exc:
        raise TelemetryError(path, name, f"cannot be read ({exc}); the file is truncated or corrupt") from None
    bad = ~np.isfinite(data)
    if bad.any():
        first = int(np.argwhere(bad)[0][0])
        raise TelemetryError(path, name, f"holds {int(bad.sum())} NaN/Inf values, the first at row {first}")
    return data * np.asarray(factor, dtype=float)


def read_navigation_datasets(path: Path, h5: h5py.File) -> Solution:
    rows: dict = {}
    t = _dataset(path, h5, "/time", rows)
    if t.shape[0] < 2:
        raise TelemetryError(path, "/time", f"holds {t.shape[0]} sample; a track needs at least 2")
    step = np.diff(t)
    if np.any(step <= 0.0):
        k = int(np.flatnonzero(step <= 0.0)[0]) + 1
        raise TelemetryError(path, "/time", f"is not strictly increasing at row {k} ({t[k - 1]:.6f} s -> {t[k]:.6f} s)")
    pos = _dataset(path, h5, "/position", rows)  # latitude [rad], longitude [rad], height [m]
    outside = np.abs(pos[:, 0]) > 0.5 * np.pi
    if outside.any():
        k = int(np.flatnonzero(outside)[0])
        raise TelemetryError(
            path,
            "/position",
            f"latitude {np.degrees(pos[k, 0]):g} deg at row {k} is outside "
            "[-90, 90]; columns are latitude [deg], longitude [deg], height [m]",
        )
    vel = _dataset(path, h5, "/velocity", rows)
    quat = _dataset(path, h5, "/quaternion", rows)
    norm = np.linalg.norm(quat, axis=1)
    k = int(np.argmax(np.abs(norm - 1.0)))
    if abs(norm[k] - 1.0) > QUATERNION_NORM_TOLERANCE:
        raise TelemetryError(
            path, "/quaternion", f"row {k} has norm {norm[k]:.9g}; q_nb must be unit (scalar-first [w, x, y, z])"
        )
    return Solution(t, pos[:, 0], pos[:, 1], pos[:, 2], vel, quat / norm[:, None])


def write_navigation(path, res, *, input_file, force: bool = False):
    """Write ``sizefx/navigation/1`` atomically, decimated to ``output_rate_hz``."""
    rate = res.config.get("output_rate_hz")
    stride = 1
    if rate and not res.config.get("streamed"):  # a streamed result holds the output rows already
        stride = max(1, int(round(res.config["nav_rate_hz"] / rate)))
    sel = slice(stride - 1, None, stride)
    roll, pitch, heading = mat_to_euler(quat_to_mat(res.quat_nb[sel]))
    with atomic_output(path, inputs=[input_file], force=force) as tmp, h5py.File(tmp, "w") as h5:
        h5.attrs["schema"] = NAVIGATION_SCHEMA
        h5.attrs["input_file"] = attr_str(input_file)  # a file name may not be UTF-8
        h5.attrs["configuration_json"] = json.dumps(res.config, default=float)
        h5.attrs["summary_json"] = json.dumps(res.summary, default=float)
        h5.attrs["sizefx_version"] = __version__
        h5.create_dataset("time", data=res.time_s[sel]).attrs["units"] = "s"
        h5.create_dataset(
            "position",
            data=np.column_stack([np.degrees(res.lat_rad[sel]), np.degrees(res.lon_rad[sel]), res.height_m[sel]]),
        ).attrs["units"] = "deg,deg,m"
        h5.create_dataset("velocity", data=res.v_n[sel]).attrs["units"] = "m/s"
        h5.create_dataset("quaternion", data=res.quat_nb[sel]).attrs["units"] = "1"
        h5.create_dataset(
            "euler", data=np.column_stack([np.degrees(roll), np.degrees(pitch), np.degrees(heading) % 360.0])
        ).attrs["units"] = "deg"


class NavigationWriter:
    """``sizefx/navigation/1`` written row block by row block, atomically (a streamed run's output).

    The rows go to resizable datasets of a temporary file; :meth:`close` adds the
    configuration and summary and renames it into place, :meth:`abort` removes it.
    """

    def __init__(self, path, *, input_file, force: bool = False):
        self.path = Path(path)
        self._ctx = atomic_output(path, inputs=[input_file], force=force)
        tmp = self._tmp = self._ctx.__enter__()
        try:
            self.h5 = h5py.File(tmp, "w")
            self.h5.attrs["schema"] = NAVIGATION_SCHEMA
            self.h5.attrs["input_file"] = attr_str(input_file)  # a file name may not be UTF-8
            self.h5.attrs["sizefx_version"] = __version__
            self._sets = {}
            for name, width, units in (
                ("time", None, "s"),
                ("position", 3, "deg,deg,m"),
                ("velocity", 3, "m/s"),
                ("quaternion", 4, "1"),
                ("euler", 3, "deg"),
            ):
                shape, maxshape = ((0,), (None,)) if width is None else ((0, width), (None, width))
                chunks = (1 << 14,) if width is None else (1 << 14, width)
                dset = self.h5.create_dataset(name, shape=shape, maxshape=maxshape, chunks=chunks, dtype="f8")
                dset.attrs["units"] = units
                self._sets[name] = dset
        except BaseException as exc:
            self._ctx.__exit__(type(exc), exc, exc.__traceback__)
            raise
        self.rows = 0

    def append(self, time_s, lat_rad, lon_rad, height_m, v_n, quat_nb):
        if len(time_s) == 0:
            return
        roll, pitch, heading = mat_to_euler(quat_to_mat(quat_nb))
        block = {
            "time": time_s,
            "position": np.column_stack([np.degrees(lat_rad), np.degrees(lon_rad), height_m]),
            "velocity": v_n,
            "quaternion": quat_nb,
            "euler": np.column_stack([np.degrees(roll), np.degrees(pitch), np.degrees(heading) % 360.0]),
        }
        n0, n1 = self.rows, self.rows + len(time_s)
        # room for the block (and 1 MiB of metadata at close) before HDF5 writes a byte of it: a write
        # HDF5 sees fail leaves the file in a state it may crash closing
        check_room(
            self.path, sum(np.asarray(d).nbytes for d in block.values()) + (1 << 20), already=os.path.getsize(self._tmp)
        )
        for name, data in block.items():
            dset = self._sets[name]
            dset.resize(n1, axis=0)
            dset[n0:n1] = data
        self.rows = n1

    def close(self, config: dict, summary: dict):
        self.h5.attrs["configuration_json"] = json.dumps(config, default=float)
        self.h5.attrs["summary_json"] = json.dumps(summary, default=float)
        self.h5.close()
        self._ctx.__exit__(None, None, None)

    def abort(self, exc: BaseException):
        self.h5.close()
        with contextlib.suppress(type(exc)):
            self._ctx.__exit__(type(exc), exc, exc.__traceback__)
