"""Access to the file contracts in ``data-schemas/`` (installed as ``sizefx.schemas``), and JSON Schema checks.

The JSON files are the single source of truth for dataset names, shapes,
dtypes and units; :mod:`sizefx.io.telemetry` and the other readers and writers
take everything from here.

Two kinds of contract live there. The HDF5 and TOML contracts (``telemetry``, ``navigation``,
``effects``) are our own format, read by our readers. The JSON documents (``levers``,
``diagnosis``, ``comparison``) are JSON Schema (the draft each declares in ``$schema``) and are
validated with ``jsonschema``: :func:`check_document` for what sizefx writes (a failure is a bug),
:func:`validate_input` for what a user gives it (a failure is one line naming the file, the JSON
path and the problem).
"""

from __future__ import annotations

import functools
import json
from importlib import resources

from ..errors import ConfigError

__all__ = [
    "load_schema",
    "TELEMETRY_SCHEMA",
    "POLE_REASON",
    "site_problem",
    "unit_factor",
    "allowed_units",
    "normalise_units",
    "check_document",
    "validate_input",
    "schema_errors",
    "as_json",
]

TELEMETRY_SCHEMA = "sizefx/telemetry/1"
#: Why the telemetry contract's latitudes stop 0.5 deg short of the poles (root attribute
#: ``latitude_deg``, the latitude column of ``/reference/position``), said by every message that
#: refuses one, so that a user at a pole learns it is the place, not the file, that sizefx cannot take.
POLE_REASON = (
    "within 0.5 deg of a pole the north-east-down frame's longitude rate (1/cos latitude) diverges, "
    "so sizefx cannot navigate there"
)


@functools.cache
def load_schema(name: str) -> dict:
    """Load a contract by its name, e.g. ``"sizefx/telemetry/1"`` -> ``telemetry-1.json``."""
    prefix, kind, version = name.split("/")
    if prefix != "sizefx":
        raise ValueError(f"not a sizefx schema name: {name!r}")
    text = resources.files("sizefx.schemas").joinpath(f"{kind}-{version}.json").read_text("utf-8")
    schema = json.loads(text)
    declared = schema.get("schema", schema.get("$id"))  # our HDF5/TOML contracts, or a JSON Schema
    if declared != name:
        raise RuntimeError(f"schema file for {name!r} declares {declared!r}")
    return schema


def normalise_units(units: str) -> str:
    """Canonical spelling of a units string: no spaces."""
    return "".join(str(units).split())


def unit_factor(quantity: str, units: str, schema_name: str = TELEMETRY_SCHEMA):
    """Factor (or per-column factors) that converts ``units`` of ``quantity`` to SI.

    Returns ``None`` when the units are not allowed by the contract.
    """
    table = load_schema(schema_name)["units"][quantity]
    return table.get(normalise_units(units))


def allowed_units(quantity: str, schema_name: str = TELEMETRY_SCHEMA) -> list[str]:
    return list(load_schema(schema_name)["units"][quantity])


def site_problem(latitude_deg: float, longitude_deg: float, height_m: float) -> str | None:
    """What keeps a site (latitude [deg], longitude [deg], height [m]) out of the telemetry contract's
    root attribute ranges, as a clause that names the value and the valid range; None when it is valid.
    One rule for the file's attributes and for every option that sets them (``--site-deg``)."""
    spec = load_schema(TELEMETRY_SCHEMA)["root_attributes"]
    for key, value, unit in (
        ("latitude_deg", latitude_deg, "deg"),
        ("longitude_deg", longitude_deg, "deg"),
        ("height_m", height_m, "m"),
    ):
        rule = spec[key]
        if not rule["min"] <= value <= rule["max"]:
            name = key.rpartition("_")[0]
            why = f" ({POLE_REASON})" if key == "latitude_deg" else ""
            return f"{name} {value:g} {unit} is outside [{rule['min']:g}, {rule['max']:g}] {unit}{why}"
    return None


# --------------------------------------------------------------------------- JSON Schema

#: A value quoted in a message is cut to this many characters (a message is one line).
QUOTED_CHARS = 60


@functools.cache
def _validator(name: str):
    """The ``jsonschema`` validator of contract ``name``, for the draft its ``$schema`` declares.

    Imported here, not at module level: reading telemetry needs the contracts, not jsonschema.
    """
    from jsonschema.validators import validator_for

    schema = load_schema(name)
    if "$schema" not in schema:
        raise ValueError(f"{name} is one of our HDF5/TOML contracts, not a JSON Schema")
    cls = validator_for(schema)
    cls.check_schema(schema)  # a broken schema is our bug: say so before judging any document
    return cls(schema)


def as_json(value):
    """``value`` as the JSON file will hold it: NumPy scalars and arrays as Python numbers and lists,
    tuples as lists (JSON Schema's ``integer`` and ``array`` know only those)."""
    if isinstance(value, dict):
        return {k: as_json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [as_json(v) for v in value]
    if hasattr(value, "tolist") and hasattr(value, "dtype"):  # NumPy scalar or array, without importing NumPy
        return as_json(value.tolist())
    return value


def _quote(value) -> str:
    text = json.dumps(value) if not isinstance(value, float) or value == value else "NaN"
    return text if len(text) <= QUOTED_CHARS else text[: QUOTED_CHARS - 3] + "..."


def _describe(node: dict, root: dict) -> str | None:
    """What a schema node asks for, in words (``"a list of 3 numbers or null"``); None if not simple."""
    while "$ref" in node and node["$ref"].startswith("#/"):
        target = root
        for part in node["$ref"][2:].split("/"):
            target = target[part]
        node = {**target, **{k: v for k, v in node.items() if k != "$ref"}}
    if "const" in node:
        return _quote(node["const"])
    if "enum" in node:
        return "one of " + ", ".join(_quote(v) for v in node["enum"])
    types = node.get("type")
    if types is None:
        return None
    words = {
        "number": "a number",
        "integer": "an integer",
        "string": "a string",
        "boolean": "true or false",
        "object": "an object",
        "null": "null",
    }
    out = []
    for t in [types] if isinstance(types, str) else types:
        if t == "array":
            lo, hi = node.get("minItems"), node.get("maxItems")
            count = f"{lo} " if lo is not None and lo == hi else ""
            item = _describe(node.get("items", {}), root) if isinstance(node.get("items"), dict) else None
            noun = {"a number": "numbers", "an integer": "integers", "a string": "strings"}.get(item or "", "items")
            if noun == "items" and item and item.startswith("a list of "):
                noun = "lists of " + item[len("a list of ") :]
            out.append(f"a list of {count}{noun}")
        else:
            out.append(words.get(t, t))
    return " or ".join(out)


def _problems(error, root: dict) -> list[str]:
    """One ``jsonschema`` error as clauses a user can act on, each starting with its JSON path:
    ``$.r_y must be a list of 3 numbers, got [0.0, 0.02]``, ``$.r_z: key 'r_z' is missing``
    (a ``required`` error of an object missing several keys: one clause per key)."""
    where = error.json_path
    if error.validator == "required":
        instance = error.instance if isinstance(error.instance, dict) else {}
        return [f"{where}.{key}: key '{key}' is missing" for key in error.validator_value if key not in instance]
    wanted = _describe(error.schema, root) if isinstance(error.schema, dict) else None
    if wanted and error.validator in ("type", "minItems", "maxItems", "const", "enum"):
        return [f"{where} must be {wanted}, got {_quote(error.instance)}"]
    message = error.message if len(error.message) <= 2 * QUOTED_CHARS else error.message[: 2 * QUOTED_CHARS] + "..."
    return [f"{where}: {message}"]


def schema_errors(doc, name: str) -> list[str]:
    """Every way ``doc`` breaks the JSON Schema ``name``, one clause each (:func:`_problems`), in document order."""
    errors = sorted(_validator(name).iter_errors(as_json(doc)), key=lambda e: [str(p) for p in e.absolute_path])
    root = load_schema(name)
    out: list[str] = []
    for error in errors:
        out += [clause for clause in _problems(error, root) if clause not in out]
    return out


def check_document(doc: dict, name: str):
    """Check a JSON document our code wrote against its contract ``name`` (a JSON Schema in
    ``data-schemas/``); a failure is a bug in the writer, so it raises AssertionError listing
    every problem."""
    problems = schema_errors(doc, name)
    if problems:
        raise AssertionError(f"document breaks {name}: " + "; ".join(problems))


def validate_input(doc, name: str, path) -> None:
    """Check a JSON document a user gave (``path``) against the JSON Schema ``name``.

    Raises :class:`~sizefx.errors.ConfigError` with one line: the file, the JSON path of the
    problem (``jsonschema``'s most relevant one, :func:`jsonschema.exceptions.best_match`), what
    is wrong, and where the contract is written.
    """
    from jsonschema.exceptions import best_match

    best = best_match(_validator(name).iter_errors(as_json(doc)))
    if best is None:
        return
    _, kind, version = name.split("/")
    raise ConfigError(
        f"{path}: {_problems(best, load_schema(name))[0]} (the {name} contract: data-schemas/{kind}-{version}.json)"
    )
