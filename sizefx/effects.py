"""The effects file: what a simulated IMU gets wrong, term by term, as a TOML file gives it.

How each effect changes the readings is :mod:`sizefx.sensor_model` (its table, forward map,
inverse and Jacobian); this module reads and checks the file. The contract, defaults and
units are in ``data-schemas/effects-1.json``; a TOML file gives only what differs from the
defaults::

    [lever_arm]
    preset = "compact"
    r_vehicle_m = [0.10, -0.05, 0.02]

    [accel_delay]
    enabled = true
    tau_s = 0.0005

:func:`load_effects` validates the file against the schema (unknown sections
or keys, wrong shapes and types are errors naming the key) and returns an
:class:`EffectModel` in SI units.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .errors import ConfigError
from .geometry import preset_arms_m
from .io.documents import read_toml
from .io.schema import load_schema
from .sensor_model import SensorParams, unit_axes

__all__ = ["EffectModel", "load_effects", "effects_template", "EFFECTS_SCHEMA", "IDEAL"]

EFFECTS_SCHEMA = "sizefx/effects/1"

#: Overrides that switch every effect off: a point IMU with perfect sensors.
IDEAL = {name: {"enabled": False} for name in load_schema(EFFECTS_SCHEMA)["sections"]}


@dataclass
class EffectModel:
    """Effects resolved to SI. ``raw`` keeps the user-unit values for reports."""

    sections: dict  #: section -> {SI key: SI value} (the schema's si_key names; enabled included)
    raw: dict = field(default_factory=dict)  #: section -> {key: value as given (user units)}
    source: str = "defaults"

    def enabled(self, name: str) -> bool:
        return bool(self.sections[name]["enabled"])

    def get(self, name: str, key: str):
        return self.sections[name][key]

    # Derived quantities used by the simulator -------------------------------------------
    def arms_d_m(self) -> np.ndarray:
        """Rows d_x, d_y, d_z [3, 3] from the triad point (zeros when lever_arm is off)."""
        if not self.enabled("lever_arm"):
            return np.zeros((3, 3))
        s = self.sections["lever_arm"]
        d = preset_arms_m(s["preset"])
        for i, axis in enumerate("xyz"):
            if s[f"d_{axis}_m"] is not None:
                d[i] = s[f"d_{axis}_m"]
        return d

    def offset_m(self) -> np.ndarray:
        """r = r0 + r_plate + r_vehicle [3] (zeros when lever_arm is off)."""
        if not self.enabled("lever_arm"):
            return np.zeros(3)
        s = self.sections["lever_arm"]
        return np.asarray(s["r0_m"]) + np.asarray(s["r_plate_m"]) + np.asarray(s["r_vehicle_m"])

    def arms_total_m(self) -> np.ndarray:
        """Rows r_x, r_y, r_z [3, 3]: reference point to each accelerometer, body axes."""
        return self.arms_d_m() + self.offset_m()

    def accel_axes(self) -> np.ndarray:
        """Rows u_x, u_y, u_z [3, 3]: unit sensitive axes of the accelerometers."""
        return _axes_from_misalignment(self.sections["accel_misalignment"])

    def gyro_axes(self) -> np.ndarray:
        """Rows [3, 3]: unit input axes of the gyros."""
        return _axes_from_misalignment(self.sections["gyro_misalignment"])

    def tilt_rad(self) -> np.ndarray:
        """(phi_N, phi_E, 0) [rad] of the level tilt; zeros when off."""
        s = self.sections["level_tilt"]
        if not s["enabled"]:
            return np.zeros(3)
        return np.array([s["north_rad"], s["east_rad"], 0.0])

    def sensor_params(self) -> SensorParams:
        """The deterministic effects as the sensor model's parameters (SI; a section that is off gives zeros)."""
        return SensorParams.from_effects(self)

    def value_or_zero(self, name: str, key: str, shape=(3,)):
        if not self.enabled(name):
            return np.zeros(shape)
        return np.asarray(self.sections[name][key], dtype=float)

    def truth(self) -> dict:
        """Every effect in SI (JSON-ready), plus the derived arms: for ``/simulation``."""
        out: dict[str, Any] = {}  # a JSON document: sections (dicts) and a note (str)
        for name, keys in self.sections.items():
            out[name] = {k: _jsonable(v) for k, v in keys.items()}
        out["lever_arm"]["d_m"] = self.arms_d_m().tolist()
        out["lever_arm"]["offset_m"] = self.offset_m().tolist()
        out["lever_arm"]["r_m"] = self.arms_total_m().tolist()
        out["accel_misalignment"]["axes"] = self.accel_axes().tolist()
        out["gyro_misalignment"]["axes"] = self.gyro_axes().tolist()
        out["units_note"] = "SI: m, s, rad, m/s^2, rad/s; scale factors dimensionless; noise densities per sqrt(s)"
        return out


def _axes_from_misalignment(section) -> np.ndarray:
    return unit_axes(np.asarray(section["angles_rad"], dtype=float) if section["enabled"] else np.zeros((3, 3)))


def _jsonable(v):
    if isinstance(v, np.ndarray):
        return v.tolist()
    return v


def _convert(section: str, key: str, rule: dict, value, units: dict, where: str):
    kind = rule["type"]
    label = f"{where}: [{section}] {key}"
    if kind == "bool":
        if not isinstance(value, bool):
            raise ConfigError(f"{label} = {value!r} must be true or false")
        return value
    if kind == "string":
        if not isinstance(value, str) or ("choices" in rule and value not in rule["choices"]):
            choices = ", ".join(rule.get("choices", []))
            raise ConfigError(f"{label} = {value!r} must be one of {choices}")
        return value
    if value is None:
        return None
    factor = units[rule["unit"]]
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ConfigError(f"{label} = {value!r} is not numeric") from None
    want = {"number": (), "vector": (3,), "matrix": (3, 3)}[kind]
    if arr.shape != want:
        raise ConfigError(
            f"{label} has shape {list(arr.shape)}; expected "
            f"{ {'number': 'a number', 'vector': 'a list of 3 numbers', 'matrix': 'a 3x3 list of lists'}[kind] }"
        )
    if not np.all(np.isfinite(arr)):
        raise ConfigError(f"{label} holds NaN or Inf")
    low, high = rule.get("range", (-np.inf, np.inf))
    outside = (arr < low) | (arr > high)
    if np.any(outside):
        raise ConfigError(
            f"{label} = {arr[outside].ravel()[0]:g} is outside its range [{low:g}, {high:g}] "
            f"{rule['unit']}; check the value and its unit"
        )
    si = arr * factor
    return float(si) if kind == "number" else si


def load_effects(path=None, overrides: dict | None = None, base: dict | None = None) -> EffectModel:
    """Defaults from the schema, then ``base``, the TOML file at ``path``, then ``overrides``.

    ``base`` and ``overrides`` have the TOML file's layout (``{"section": {"key": value}}``);
    ``base=IDEAL`` starts from a point IMU with perfect sensors.
    """
    schema = load_schema(EFFECTS_SCHEMA)
    units = schema["units"]
    raw = {name: {k: rule["default"] for k, rule in sec["keys"].items()} for name, sec in schema["sections"].items()}
    layers = [("base", base)] if base else []
    source = "defaults" if not base else "ideal"
    if path is not None:
        path = Path(path)
        layers.append((str(path), read_toml(path, "effects file (sizefx/effects/1 TOML)")))
        source = f"{source} + {path}"
    if overrides:
        layers.append(("overrides", overrides))
        source = f"{source} + overrides"
    for where, doc in layers:
        for name, body in doc.items():
            if name == "schema":
                if body != EFFECTS_SCHEMA:
                    raise ConfigError(f"{where}: schema = {body!r}; expected {EFFECTS_SCHEMA!r}")
                continue
            if name not in schema["sections"]:
                raise ConfigError(f"{where}: unknown section [{name}]; known: {', '.join(schema['sections'])}")
            if not isinstance(body, dict):
                raise ConfigError(f"{where}: [{name}] must be a table")
            for key, value in body.items():
                if key not in schema["sections"][name]["keys"]:
                    known = ", ".join(schema["sections"][name]["keys"])
                    raise ConfigError(f"{where}: [{name}] has unknown key '{key}'; known: {known}")
                raw[name][key] = value
    sections = {}
    for name, sec in schema["sections"].items():
        sections[name] = {
            rule.get("si_key", k): _convert(name, k, rule, raw[name][k], units, source)
            for k, rule in sec["keys"].items()
        }
    return EffectModel(sections=sections, raw=raw, source=source)


def effects_template() -> str:
    """A complete, commented TOML file with every default (``sizefx simulate --print-effects``)."""
    schema = load_schema(EFFECTS_SCHEMA)
    lines = [f"# {schema['title']}", f"# {schema['description']}", f'schema = "{EFFECTS_SCHEMA}"', ""]

    def fmt(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return f'"{v}"'
        if isinstance(v, list):
            return "[" + ", ".join(fmt(x) for x in v) + "]"
        if isinstance(v, float) and (abs(v) < 1e-3 and v != 0.0):
            return f"{v:.6e}"
        return repr(v)

    for name, sec in schema["sections"].items():
        lines.append(f"# {sec['description']}")
        lines.append(f"[{name}]")
        for key, rule in sec["keys"].items():
            note = f"  # {rule['description']}" if "description" in rule else ""
            if rule["default"] is None:
                lines.append(f"# {key} = [0.0, 0.0, 0.0]{note or '  # unset: taken from the preset'}")
            else:
                lines.append(f"{key} = {fmt(rule['default'])}{note}")
        lines.append("")
    return "\n".join(lines)
