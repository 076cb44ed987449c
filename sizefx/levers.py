"""The lever-arm file ``sizefx/levers/1`` (JSON): reading, validating, writing.

The JSON Schema in ``data-schemas/levers-1.json`` lists the required keys and
their shapes; :func:`read_levers` checks a file against exactly that list.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import ConfigError
from .io.files import atomic_output
from .geometry import preset_arms_m
from .io.schema import load_schema

__all__ = ["Levers", "read_levers", "write_levers", "levers_from_preset", "LEVERS_SCHEMA"]

LEVERS_SCHEMA = "sizefx/levers/1"


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

        out = {"schema": LEVERS_SCHEMA, "reference_point": self.reference_point}
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


def _check(doc, path):
    schema = load_schema(LEVERS_SCHEMA)
    if not isinstance(doc, dict):
        raise ConfigError(f"{path}: a levers file is a JSON object")
    missing = [k for k in schema["required"] if k not in doc]
    if missing:
        raise ConfigError(f"{path}: key '{missing[0]}' is missing (sizefx/levers/1 requires "
                          f"{', '.join(schema['required'])})")
    if doc["schema"] != LEVERS_SCHEMA:
        raise ConfigError(f"{path}: schema is {doc['schema']!r}, expected {LEVERS_SCHEMA!r}")
    allowed = schema["properties"]["reference_point"]["enum"]
    if doc["reference_point"] not in allowed:
        raise ConfigError(f"{path}: reference_point {doc['reference_point']!r} must be one of {', '.join(allowed)}")
    for key, rule in schema["properties"].items():
        if key not in doc or "$ref" not in rule:
            continue
        nullable = rule["$ref"].endswith("or_null")
        value = doc[key]
        if value is None and nullable:
            continue
        try:
            arr = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise ConfigError(f"{path}: {key} = {value!r} is not a list of 3 numbers (metres)") from None
        if arr.shape != (3,) or not np.all(np.isfinite(arr)):
            raise ConfigError(f"{path}: {key} must be a list of 3 finite numbers (metres), got {value!r}")


def _check_extras(doc, path):
    delay = doc["accel_delay_s"]
    if delay is not None and (isinstance(delay, bool) or not isinstance(delay, (int, float)) or not np.isfinite(delay)):
        raise ConfigError(f"{path}: accel_delay_s = {delay!r} must be a number of seconds or null")
    tilt = doc["tilt_arcsec"]
    if tilt is not None:
        try:
            ok = np.asarray(tilt, dtype=float).shape == (2,)
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise ConfigError(f"{path}: tilt_arcsec = {tilt!r} must be [north, east] in arcsec or null")
    if "axes" in doc:
        try:
            axes = np.asarray(doc["axes"], dtype=float)
        except (TypeError, ValueError):
            axes = np.zeros(0)
        if axes.shape != (3, 3) or not np.all(np.isfinite(axes)) or np.any(np.linalg.norm(axes, axis=1) < 0.5):
            raise ConfigError(f"{path}: axes must be three rows of three numbers, the sensitive axes u_x, u_y, u_z")


def read_levers(path) -> Levers:
    path = Path(path)
    try:
        doc = json.loads(path.read_text("utf-8"))
    except FileNotFoundError:
        raise ConfigError(f"{path}: levers file does not exist") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{path}: not valid JSON ({exc})") from None
    _check(doc, path)
    _check_extras(doc, path)
    rows = lambda prefix: np.array([doc[f"{prefix}_{a}"] for a in "xyz"], dtype=float)  # noqa: E731
    sigma = None if any(doc[f"sigma_{a}"] is None for a in "xyz") else rows("sigma")
    axes = np.asarray(doc.get("axes", np.eye(3)), dtype=float)
    axes = axes / np.linalg.norm(axes, axis=1, keepdims=True)
    known = set(load_schema(LEVERS_SCHEMA)["properties"])
    return Levers(arms_total=rows("r"), offset=np.asarray(doc["offset"], dtype=float), arms_triad=rows("d"),
                  reference_point=doc["reference_point"], sigma=sigma, tilt_arcsec=doc["tilt_arcsec"],
                  accel_delay_s=doc["accel_delay_s"], axes=axes,
                  extra={k: v for k, v in doc.items() if k not in known})


def write_levers(path, levers: Levers, *, inputs=(), force: bool = False):
    with atomic_output(path, inputs=inputs, force=force) as tmp:
        Path(tmp).write_text(json.dumps(levers.to_json(), indent=2) + "\n")


def levers_from_preset(name: str, offset_m=(0.0, 0.0, 0.0)) -> Levers:
    """A geometry preset of the paper as Levers (r_i = offset + d_i)."""
    d = preset_arms_m(name)
    off = np.asarray(offset_m, dtype=float)
    return Levers(arms_total=d + off, offset=off, arms_triad=d, extra={"source": f"preset {name}"})
