"""The checks of the ``sizefx/telemetry/1`` contract on an open HDF5 file.

:class:`ContractReader` makes one validation pass: structure, root attributes, each dataset's
shape, dtype and units (converted to SI), time stamps, gaps and their declaration, quaternions
and magnitudes, raising a :class:`~sizefx.errors.TelemetryError` that names the file, the
dataset and the problem, and says how to fix it. Everything about names, shapes, dtypes and
units comes from ``data-schemas/telemetry-1.json`` via :mod:`sizefx.io.schema`.
:func:`open_structure` and :func:`side_groups` are the steps a whole read and a streamed one
(:mod:`sizefx.io.reader`) share.

The package, one concern a module; every name is imported from here:

- :mod:`.validation`: :class:`ContractReader`, the validation pass, and the bounds on its work;
- :mod:`.storage`: the file and its datasets before anything is read (:func:`open_hdf5`,
  :func:`storage_problem`);
- :mod:`.limits`: the values a dataset may hold (:func:`invalid_rows`, :func:`limit_problem`,
  :func:`magnitude_problem`);
- :mod:`.attrs`: HDF5 attributes as plain Python and valid text (``attr_value``, ``attr_str``);
- here: the steps :mod:`sizefx.io.reader` takes with a :class:`ContractReader`
  (:func:`open_structure`, :func:`check_magnitudes`, :func:`side_groups`, :func:`site_from_attrs`).
"""

from __future__ import annotations

import json

import h5py
import numpy as np

from ..provenance import from_attributes
from ..records import Reference, Site

# what the single module sizefx.io.contract held stays importable from here
from .attrs import attr_str, attr_value
from .limits import _bounds, invalid_rows, limit_problem, magnitude_problem  # noqa: F401
from .storage import MAX_CHUNK_BYTES, open_hdf5, storage_problem  # noqa: F401
from .validation import (  # noqa: F401
    MAX_ACCEL_TIME_OFFSET_PERIODS,
    MAX_GAPS,
    MAX_GROUP_DEPTH,
    MAX_OBJECTS,
    ContractReader,
)

__all__ = [
    "ContractReader",
    "open_hdf5",
    "open_structure",
    "check_magnitudes",
    "magnitude_problem",
    "side_groups",
    "site_from_attrs",
    "invalid_rows",
    "limit_problem",
    "storage_problem",
]


def open_structure(path, h5, allow_gaps, check_plausibility):
    """Links, root attributes, groups and the IMU form: ``(reader, root attributes, form)``."""
    r = ContractReader(path, h5, allow_gaps, check_plausibility)
    r.refuse_links_to_other_files()
    attrs = r.root_attributes()
    schema = r.schema
    for gname, gspec in schema["groups"].items():
        if gname in h5 and not isinstance(h5[gname], h5py.Group):
            r.fail(gname, "must be a group")
        if gspec["required"] and gname not in h5:
            r.fail(gname, "group is missing; IMU samples belong in /imu")
    # IMU: exactly one form.
    present = {form: [d for d in spec["datasets"] if d in h5] for form, spec in schema["forms"].items()}
    complete = [form for form, names in present.items() if len(names) == len(schema["forms"][form]["datasets"])]
    if len(complete) == 2:
        r.fail("/imu", "holds both gyro/accel and dtheta/dvel; keep one form")
    if not complete:
        partial = [d for names in present.values() for d in names]
        if partial:
            form = next(f for f, names in present.items() if names)
            missing = [d for d in schema["forms"][form]["datasets"] if d not in h5]
            r.fail(missing[0], f"dataset is missing ({partial[0]} is present; {form} need both)")
        r.fail("/imu", "holds neither gyro+accel (rates) nor dtheta+dvel (increments)")
    return r, attrs, complete[0]


def check_magnitudes(r, form, period, gyro, accel):
    """Refuse (``r.fail``) median magnitudes that betray wrong units: :func:`magnitude_problem`."""
    found = magnitude_problem(r.schema, form, period, gyro, accel, r.units)
    if found is not None:
        name, figures, hint = found
        r.fail(name, f"{figures}; {hint}")


def side_groups(r, h5, reference: bool = True):
    """``/reference`` (read whole; None with ``reference=False``), ``/source`` (a
    :class:`~sizefx.io.provenance.Provenance`) and ``/simulation``."""
    found: Reference | None = None
    if reference and "/reference" in h5:
        ref_t = r.dataset("/reference/time", required=True)
        r.check_time("/reference/time", ref_t)
        quat = r.check_unit_quaternions("/reference/quaternion", r.dataset("/reference/quaternion", required=True))
        pos = r.dataset("/reference/position", required=False)
        vel = r.dataset("/reference/velocity", required=False)
        found = Reference(time_s=ref_t, quat_nb=quat, velocity_n_mps=vel)
        if pos is not None:  # columns within their limits (ContractReader.check_limits)
            found.lat_rad, found.lon_rad, found.height_m = pos[:, 0], pos[:, 1], pos[:, 2]
    source = None
    if "/source" in h5:
        source = from_attributes({attr_str(k): attr_value(v) for k, v in h5["/source"].attrs.items()})
    simulation = None
    if "/simulation" in h5:
        sim_attrs = h5["/simulation"].attrs
        if "truth_json" not in sim_attrs:
            r.fail("/simulation", "attribute truth_json is missing")
        try:
            simulation = json.loads(attr_str(sim_attrs["truth_json"]))
        except json.JSONDecodeError as exc:
            r.fail("/simulation", f"attribute truth_json is not valid JSON ({exc})")
        except (RecursionError, ValueError) as exc:  # nesting past the parser, a 5000-digit integer
            r.fail(
                "/simulation",
                f"attribute truth_json cannot be read ({type(exc).__name__}); it is not one sizefx simulate wrote",
            )
    return found, source, simulation


def site_from_attrs(attrs):
    if "latitude_deg" not in attrs:
        return None
    return Site(np.radians(attrs["latitude_deg"]), np.radians(attrs["longitude_deg"]), attrs["height_m"])
