"""Plan files in: a ``sizefx/plan/1`` TOML document (written by ``sizefx plan``), checked.

The document is validated against ``data-schemas/plan-1.json`` (JSON Schema: every value in
range) and against its own table: a plan whose rate or acceleration is above the limits it was
designed for, or which needs an axis vertical that the table cannot reach (or a sway, the
delay's, about an axis it cannot swing about), is refused in one line naming the file. Building
the plan (:class:`sizefx.scenarios.TurntablePlan`, :class:`~sizefx.scenarios.SwayPlan`) is the
caller's (``sizefx simulate turntable --plan``, ``sizefx simulate sway --plan``).
"""

from __future__ import annotations

import math

from ..errors import ConfigError
from .documents import read_toml
from .schema import validate_input

__all__ = ["PLAN_SCHEMA", "read_plan_document"]

PLAN_SCHEMA = "sizefx/plan/1"


def read_plan_document(path) -> dict:
    """The checked document in ``path``; :class:`~sizefx.errors.ConfigError` (one line) otherwise."""
    doc = read_toml(path, "plan file")
    validate_input(doc, PLAN_SCHEMA, path)
    table = doc.get("designed_for", {}).get("table")
    if table is not None:
        _within(doc["turntable"], table, path)
        if "sway" in doc:
            _sway_within(doc["sway"], table, path)
    return doc


def _within(plan: dict, table: dict, path) -> None:
    """Refuse a plan its own table cannot run: a rate or acceleration above the limits, an axis it cannot reach."""
    if plan["peak_rate_dps"] > table["max_rate_dps"]:
        raise ConfigError(
            f"{path}: [turntable] peak_rate_dps = {plan['peak_rate_dps']:g} is above the table's "
            f"max_rate_dps = {table['max_rate_dps']:g}; lower the rate or design the plan again "
            "(sizefx plan)"
        )
    if plan["accel_dps2"] > table["max_accel_dps2"]:
        raise ConfigError(
            f"{path}: [turntable] accel_dps2 = {plan['accel_dps2']:g} is above the table's "
            f"max_accel_dps2 = {table['max_accel_dps2']:g}; lower it or design the plan again "
            "(sizefx plan)"
        )
    missing = sorted(set(plan["axes"]) - set(table["axes"].upper()))
    if missing:
        raise ConfigError(
            f"{path}: [turntable] axes = '{plan['axes']}' needs {', '.join(missing)} vertical, which "
            f"the table (axes = '{table['axes']}') cannot reach"
        )


def _sway_within(sway: dict, table: dict, path) -> None:
    """Refuse a sway its own table cannot run: a rate or acceleration amplitude above the limits, an axis
    it cannot swing about."""
    accel = 2 * math.pi * sway["frequency_hz"] * sway["amplitude_dps"]
    if sway["amplitude_dps"] > table["max_rate_dps"]:
        raise ConfigError(
            f"{path}: [sway] amplitude_dps = {sway['amplitude_dps']:g} is above the table's "
            f"max_rate_dps = {table['max_rate_dps']:g}; lower it or design the plan again (sizefx plan)"
        )
    if accel > table["max_accel_dps2"] * (1 + 1e-9):
        raise ConfigError(
            f"{path}: [sway] needs {accel:.4g} deg/s^2 (2 pi frequency_hz amplitude_dps), above the "
            f"table's max_accel_dps2 = {table['max_accel_dps2']:g}; lower the amplitude or the frequency "
            "or design the plan again (sizefx plan)"
        )
    letter = {"roll": "X", "pitch": "Y"}[sway["axis"]]
    if letter not in table.get("sway_axes", "").upper():
        raise ConfigError(
            f"{path}: [sway] axis = '{sway['axis']}' swings body {letter}, which the table "
            f"(sway_axes = '{table.get('sway_axes', '')}') cannot swing about"
        )
