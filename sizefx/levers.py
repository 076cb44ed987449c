"""The lever-arm file ``sizefx/levers/1`` (JSON): reading, validating, writing.

The JSON Schema in ``data-schemas/levers-1.json`` lists the required keys and
their shapes; :func:`read_levers` checks a file against it with ``jsonschema``
(:func:`sizefx.io.schema.validate_input`), and :func:`write_levers` checks what it writes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import ConfigError
from .geometry import PRESETS, preset_arms_m
from .io.documents import read_json, write_json
from .io.schema import check_document, load_schema, validate_input
from .sensor_model.table import MAX_AXES_CONDITION

__all__ = ["Levers", "read_levers", "write_levers", "levers_from_preset", "nominal_levers", "LEVERS_SCHEMA"]

LEVERS_SCHEMA = "sizefx/levers/1"
#: Largest disagreement [m] accepted between ``r_i`` and ``offset + d_i`` (per component). A file
#: sizefx writes carries 17 significant digits, so the two agree to 1e-14 m even 100 m out; one
#: typed by hand in millimetres to three decimals (micrometres) agrees to 1.5 um (three roundings
#: of 0.5 um). 10 um accepts both and is a third of the best arm sigma a calibration states
#: (0.032 mm, docs/calibrate.md): a larger disagreement makes ``--mode center`` and ``--mode
#: triad`` compensate two different geometries, and one of the two numbers is wrong.
LEVER_CHAIN_TOLERANCE_M = 1e-5
#: Largest departure of an ``axes`` row's length from 1. A unit vector typed with three decimals
#: per component is within sqrt(3) * 0.5e-3 = 0.87e-3 of unit length (such rows are normalised);
#: a row further off is not a rounded direction but a gain folded in, another unit, or a typo.
AXIS_LENGTH_TOLERANCE = 1e-3


@dataclass
class Levers:
    """Arms in metres, body axes. ``arms_total`` rows r_x, r_y, r_z from the reference point."""

    arms_total: np.ndarray  #: [3, 3] r_i
    offset: np.ndarray  #: [3] r, reference point to the triad point
    arms_triad: np.ndarray  #: [3, 3] d_i, triad point to accelerometer i
    reference_point: str = "rotation-center"
    sigma: np.ndarray | None = None  #: [3, 3] standard errors of r_i
    tilt_arcsec: list | None = None
    accel_delay_s: float | None = None
    axes: np.ndarray = field(default_factory=lambda: np.eye(3))  #: rows u_i
    extra: dict = field(default_factory=dict)

    def arms_for(self, mode: str) -> np.ndarray:
        """Arms to compensate with: ``triad`` uses d_i (to the triad point), ``center`` r_i (to the rotation centre)."""
        if mode == "triad":
            return self.arms_triad
        if mode == "center":
            return self.arms_total
        raise ConfigError(f"compensation mode '{mode}': use triad or center")

    def to_json(self) -> dict:
        def vec(a):
            return None if a is None else [float(x) for x in a]

        out: dict[str, object] = {"schema": LEVERS_SCHEMA, "reference_point": self.reference_point}
        for i, axis in enumerate("xyz"):
            out[f"r_{axis}"] = vec(self.arms_total[i])
            out[f"sigma_{axis}"] = None if self.sigma is None else vec(self.sigma[i])
        out["offset"] = vec(self.offset)
        for i, axis in enumerate("xyz"):
            out[f"d_{axis}"] = vec(self.arms_triad[i])
        out["tilt_arcsec"] = None if self.tilt_arcsec is None else [float(x) for x in self.tilt_arcsec]
        out["accel_delay_s"] = None if self.accel_delay_s is None else float(self.accel_delay_s)
        if not np.allclose(self.axes, np.eye(3)):
            out["axes"] = [vec(r) for r in self.axes]
        out.update(self.extra)
        return out


class _NotFinite(ValueError):
    """A number JSON cannot hold (NaN, Infinity, or one that overflows a float), met while parsing."""


def _finite_float(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise _NotFinite(f"the number {text} overflows a float")
    return value


def _finite_int(text: str) -> int:
    try:
        value = int(text)
        float(value)
    except (ValueError, OverflowError):
        raise _NotFinite(f"the number {text[:20]}{'...' if len(text) > 20 else ''} overflows a float") from None
    return value


def _no_constant(name: str):
    raise _NotFinite(f"{name} is not a JSON number")


def _parse(path: Path):
    """The JSON document in ``path``; every number in it finite (Python's json reads NaN and
    Infinity, which JSON does not allow, and 1e999 as inf): a one-line ConfigError otherwise."""
    try:
        return read_json(
            path,
            "levers file (sizefx/levers/1 JSON)",
            parse_float=_finite_float,
            parse_int=_finite_int,
            parse_constant=_no_constant,
        )
    except _NotFinite as exc:
        raise ConfigError(f"{path}: {exc}; write finite numbers (null where the contract allows it)") from None


def read_levers(path) -> Levers:
    """Read a ``sizefx/levers/1`` file, checked against ``data-schemas/levers-1.json`` (``jsonschema``).

    Beyond the schema, the numbers must describe one geometry: ``r_i = offset + d_i`` within
    :data:`LEVER_CHAIN_TOLERANCE_M`, and ``axes`` (when given) three unit rows (within
    :data:`AXIS_LENGTH_TOLERANCE`, then normalised), independent (condition number under the
    sensor model's :data:`~sizefx.sensor_model.table.MAX_AXES_CONDITION`), row i nearest body
    axis +i (channel i of a record is accelerometer i).

    Raises
    ------
    ConfigError
        One line naming the file, the JSON path and the problem (a missing key, a vector
        that is not 3 numbers, an unknown ``reference_point``, arms that disagree with their
        offset, an axis that is no unit direction, axes that are dependent or out of order),
        and how to fix it.
    """
    path = Path(path)
    doc = _parse(path)
    validate_input(doc, LEVERS_SCHEMA, path)
    axes = _checked_axes(path, np.asarray(doc.get("axes", np.eye(3)), dtype=float))

    def rows(prefix):
        return np.array([doc[f"{prefix}_{a}"] for a in "xyz"], dtype=float)

    _check_chain(path, rows("r"), np.asarray(doc["offset"], dtype=float), rows("d"))
    sigma = None if any(doc[f"sigma_{a}"] is None for a in "xyz") else rows("sigma")
    known = set(load_schema(LEVERS_SCHEMA)["properties"])
    return Levers(
        arms_total=rows("r"),
        offset=np.asarray(doc["offset"], dtype=float),
        arms_triad=rows("d"),
        reference_point=doc["reference_point"],
        sigma=sigma,
        tilt_arcsec=doc["tilt_arcsec"],
        accel_delay_s=doc["accel_delay_s"],
        axes=axes,
        extra={k: v for k, v in doc.items() if k not in known},
    )


def _check_chain(path: Path, arms_total: np.ndarray, offset: np.ndarray, arms_triad: np.ndarray):
    """Refuse arms ``r_i`` [3, 3] that are not ``offset + d_i`` within :data:`LEVER_CHAIN_TOLERANCE_M`."""
    miss = arms_total - (offset + arms_triad)
    i, j = np.unravel_index(int(np.argmax(np.abs(miss))), miss.shape)
    if abs(miss[i, j]) > LEVER_CHAIN_TOLERANCE_M:
        a = "xyz"[i]
        raise ConfigError(
            f"{path}: $.r_{a}[{j}] = {arms_total[i, j]:.9g} m disagrees with $.offset[{j}] + $.d_{a}[{j}] = "
            f"{offset[j] + arms_triad[i, j]:.9g} m by {miss[i, j]:.3g} m (tolerance {LEVER_CHAIN_TOLERANCE_M:g} m); "
            f"the contract has r_i = offset + d_i: correct r_{a}, offset or d_{a} so that they agree"
        )


def _checked_axes(path: Path, axes: np.ndarray) -> np.ndarray:
    """``axes`` [3, 3] as unit rows, refused unless each row is a unit vector nearest its own body
    axis and the three are independent (one line naming the row and the fix)."""
    norms = np.linalg.norm(axes, axis=1)
    off = np.abs(norms - 1.0)
    i = int(np.argmax(off))
    if off[i] > AXIS_LENGTH_TOLERANCE:
        raise ConfigError(
            f"{path}: $.axes[{i}] has length {norms[i]:.6g}, not 1 (tolerance {AXIS_LENGTH_TOLERANCE:g}); "
            "axes are the sensitive directions u_x, u_y, u_z, one unit vector per row: write the direction "
            "alone, normalised"
        )
    unit = axes / norms[:, None]
    cond = np.linalg.cond(unit)
    if not cond < MAX_AXES_CONDITION:
        pairs = [(0, 1), (0, 2), (1, 2)]
        angles = [np.degrees(np.arccos(min(1.0, abs(float(unit[a] @ unit[b]))))) for a, b in pairs]
        k = int(np.argmin(angles))
        a, b = pairs[k]
        raise ConfigError(
            f"{path}: $.axes are not three independent directions (condition number {cond:.3g}, limit "
            f"{MAX_AXES_CONDITION:g}; $.axes[{a}] and $.axes[{b}] are {angles[k]:.3g} deg from parallel); "
            "each row is the sensitive axis of its own accelerometer (x, y, z): give three that span space"
        )
    for i, u in enumerate(unit):
        if not u[i] > np.max(np.abs(np.delete(u, i))):
            raise ConfigError(
                f"{path}: $.axes[{i}] = {[round(float(x), 6) for x in u]} is not nearest body axis +{'xyz'[i]}; "
                f"row {i} is the sensitive axis of accelerometer {'xyz'[i]}, which a record's channel {i} reads "
                f"along body axis +{'xyz'[i]}: give the rows in the order x, y, z, each along its own positive axis"
            )
    return unit


def write_levers(path, levers: Levers, *, inputs=(), force: bool = False):
    """Write ``levers`` as ``sizefx/levers/1`` JSON, atomically; the document is checked against its
    contract first (a failure is a bug in :meth:`Levers.to_json`)."""
    doc = levers.to_json()
    check_document(doc, LEVERS_SCHEMA)
    write_json(path, doc, inputs=inputs, force=force)


def levers_from_preset(name: str, offset_m=(0.0, 0.0, 0.0)) -> Levers:
    """A geometry preset of the paper as Levers (r_i = offset + d_i)."""
    d = preset_arms_m(name)
    off = np.asarray(offset_m, dtype=float)
    return Levers(arms_total=d + off, offset=off, arms_triad=d, extra={"source": f"preset {name}"})


def nominal_levers(nominal: str) -> Levers:
    """The nominal geometry: a preset of the paper, or a ``sizefx/levers/1`` file."""
    if nominal in PRESETS:
        return levers_from_preset(nominal)
    return read_levers(nominal)
