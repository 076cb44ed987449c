"""Access to the file contracts in ``data-schemas/`` (installed as ``sizefx.schemas``).

The JSON files are the single source of truth for dataset names, shapes,
dtypes and units; :mod:`sizefx.io.telemetry` and the other readers and writers
take everything from here.
"""

from __future__ import annotations

import functools
import json
from importlib import resources

__all__ = ["load_schema", "TELEMETRY_SCHEMA", "unit_factor", "check_document"]

TELEMETRY_SCHEMA = "sizefx/telemetry/1"


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


def _problems(value, node: dict, root: dict, where: str, out: list):
    """Required keys, ``const`` and ``enum`` of ``value`` and its nested objects, following
    ``$ref`` (local), ``properties`` and ``items``: the parts of JSON Schema our writers use."""
    while "$ref" in node:
        ref = node["$ref"]
        if not ref.startswith("#/"):
            raise RuntimeError(f"{root.get('$id')}: only local $ref are supported, got {ref!r}")
        node = root
        for part in ref[2:].split("/"):
            node = node[part]
    if "const" in node and value != node["const"]:
        out.append(f"{where or '/'} = {value!r}, not {node['const']!r}")
    if "enum" in node and value not in node["enum"]:
        out.append(f"{where or '/'} = {value!r}, not one of the schema's")
    if isinstance(value, dict):
        out += [f"{where}.{k} missing" for k in node.get("required", []) if k not in value]
        for key, sub in node.get("properties", {}).items():
            if key in value and value[key] is not None:
                _problems(value[key], sub, root, f"{where}.{key}", out)
    elif isinstance(value, list) and "items" in node:
        for i, item in enumerate(value):
            _problems(item, node["items"], root, f"{where}[{i}]", out)


def check_document(doc: dict, name: str):
    """Check a JSON document our code wrote against its contract ``name`` (a JSON Schema in
    ``data-schemas/``); a failure is a bug in the writer, so it raises AssertionError."""
    schema = load_schema(name)
    problems: list = []
    _problems(doc, schema, schema, "", problems)
    if problems:
        raise AssertionError(f"document breaks {name}: {'; '.join(problems)}")
