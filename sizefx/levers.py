"""The lever-arm file ``sizefx/levers/1`` (JSON): reading, validating, writing.

The JSON Schema in ``data-schemas/levers-1.json`` lists the required keys and
their shapes; :func:`read_levers` checks a file against it with ``jsonschema``
(:func:`sizefx.io.schema.validate_input`), and :func:`write_levers` checks what it writes.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import ConfigError
from .geometry import PRESETS, preset_arms_m
from .io.documents import read_json
from .io.files import atomic_output
from .io.schema import check_document, load_schema, validate_input

__all__ = ["Levers", "read_levers", "write_levers", "levers_from_preset", "nominal_levers", "LEVERS_SCHEMA"]

LEVERS_SCHEMA = "sizefx/levers/1"
#: A row of ``axes`` shorter than this is no direction (a typo, a zero row); rows are normalised,
#: so any length near 1 is accepted.
MIN_AXIS_NORM = 0.5


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

    Raises
    ------
    ConfigError
        One line naming the file, the JSON path and the problem (a missing key, a vector
        that is not 3 numbers, an unknown ``reference_point``, an axis that is no direction).
    """
    path = Path(path)
    doc = _parse(path)
    validate_input(doc, LEVERS_SCHEMA, path)
    axes = np.asarray(doc.get("axes", np.eye(3)), dtype=float)
    norms = np.linalg.norm(axes, axis=1)
    if np.any(norms < MIN_AXIS_NORM):
        i = int(np.argmin(norms))
        raise ConfigError(
            f"{path}: $.axes[{i}] has length {norms[i]:.3g}; axes are the sensitive directions "
            "u_x, u_y, u_z, one unit vector per row"
        )

    def rows(prefix):
        return np.array([doc[f"{prefix}_{a}"] for a in "xyz"], dtype=float)

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
        axes=axes / norms[:, None],
        extra={k: v for k, v in doc.items() if k not in known},
    )


def write_levers(path, levers: Levers, *, inputs=(), force: bool = False):
    """Write ``levers`` as ``sizefx/levers/1`` JSON, atomically; the document is checked against its
    contract first (a failure is a bug in :meth:`Levers.to_json`)."""
    doc = levers.to_json()
    check_document(doc, LEVERS_SCHEMA)
    with atomic_output(path, inputs=inputs, force=force) as tmp:
        Path(tmp).write_text(json.dumps(doc, indent=2) + "\n")


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
