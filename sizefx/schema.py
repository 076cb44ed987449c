"""Access to the file contracts in ``data-schemas/`` (installed as ``sizefx.schemas``).

The JSON files are the single source of truth for dataset names, shapes,
dtypes and units; :mod:`sizefx.telemetry` and the other readers and writers
take everything from here.
"""

from __future__ import annotations

import functools
import json
from importlib import resources

__all__ = ["load_schema", "TELEMETRY_SCHEMA", "unit_factor"]

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
