"""What values the contract lets a dataset hold (:mod:`sizefx.io.contract`), in SI after its units:
each sample finite and within the schema's ``sample_limits`` (:func:`invalid_rows`,
:func:`limit_problem`), and the median specific force and angular rate within its ``plausibility``
(:func:`magnitude_problem`). Nothing here raises: each returns what it found (a mask of rows, or
the problem in words), and the reader, an importer or ``sizefx simulate`` says it its own way.
"""

from __future__ import annotations

import numpy as np

from ..schema import POLE_REASON, unit_factor

__all__ = ["invalid_rows", "limit_problem", "magnitude_problem"]


def _bounds(schema: dict, name: str, columns: int):
    """Per column (low, high) of dataset ``name`` from the schema's ``sample_limits`` (one bound for
    all columns, or one per column, symmetric or [low, high]); None without a limit."""
    limit = schema["sample_limits"].get(name)
    if limit is None:
        return None
    per_column = limit if isinstance(limit, list) else [limit] * columns
    return (
        np.array([b[0] if isinstance(b, list) else -b for b in per_column]),
        np.array([b[1] if isinstance(b, list) else b for b in per_column]),
    )


def invalid_rows(schema: dict, name: str, data: np.ndarray) -> np.ndarray:
    """[rows, columns] bool: samples of dataset ``name`` (SI) that are not finite or lie beyond the
    schema's ``sample_limits``."""
    values = data.reshape(data.shape[0], -1)
    bad = ~np.isfinite(values)
    bounds = _bounds(schema, name, values.shape[1])
    if bounds is not None:
        with np.errstate(invalid="ignore"):
            bad |= (values < bounds[0]) | (values > bounds[1])
    return bad


def limit_problem(schema: dict, name: str, data: np.ndarray, first_row: int = 0) -> str | None:
    """What is wrong with the rows ``data`` (SI, finite; rows ``first_row ...``) of dataset ``name``
    against the schema's ``sample_limits``; None when every sample is within them."""
    if data.size == 0 or _bounds(schema, name, 1) is None:
        return None
    values = data.reshape(data.shape[0], -1)
    bad = invalid_rows(schema, name, values)
    if not bad.any():
        return None
    low, high = _bounds(schema, name, values.shape[1])
    row, col = (int(v) for v in np.argwhere(bad)[0])
    if name == "/reference/position" and col == 0 and np.isfinite(values[row, col]):
        # a latitude is said in degrees; up to 90 deg it is a place (near a pole), beyond it a unit or column error
        lat_deg = float(np.degrees(values[row, col]))
        fix = (
            f"{POLE_REASON}: cut the record where it comes that close to the pole"
            if abs(lat_deg) <= 90.0
            else "beyond the poles: check the units attribute and that column 0 is the latitude"
        )
        return (
            f"latitude (column 0) is {lat_deg:.6g} deg at row {row + first_row} ({int(bad.any(axis=1).sum())} rows "
            f"in this read), outside [{np.degrees(low[col]):.6g}, {np.degrees(high[col]):.6g}] deg; {fix}"
        )
    column = f", column {col}" if values.shape[1] > 1 else ""
    return (
        f"holds {values[row, col]:.6g} (SI, after its units) at row {row + first_row}{column}, outside the "
        f"physical limits [{low[col]:g}, {high[col]:g}] ({int(bad.any(axis=1).sum())} rows in this read); check "
        "the units attribute, or remove or interpolate those samples (sizefx import --drop-invalid-rows)"
    )


def magnitude_problem(schema: dict, form: str, period: float, gyro, accel, units: dict) -> tuple[str, str, str] | None:
    """The first median magnitude outside the schema's ``plausibility`` (specific force, then angular
    rate) of IMU rows ``gyro``, ``accel`` (SI; increments divided by the sample ``period`` [s]), as
    ``(dataset, figures, hint)``: what the data read against the plausible range, and the units
    under which the same numbers would be plausible. None when both are plausible.

    The reader's check (:func:`check_magnitudes`); :func:`sizefx.sanity.implausible` applies it to
    a record in memory (``sizefx simulate``). ``units``: dataset -> the units the data were read in.
    """
    gyro_name, accel_name = schema["forms"][form]["datasets"]
    f_est = accel if form == "rates" else accel / period
    w_est = gyro if form == "rates" else gyro / period
    for name, values, key, what in (
        (accel_name, f_est, "median_specific_force_mps2", "specific force"),
        (gyro_name, w_est, "median_angular_rate_rad_s", "angular rate"),
    ):
        lo, hi = schema["plausibility"][key]
        med = float(np.median(np.linalg.norm(values, axis=1)))
        if lo <= med <= hi:
            continue
        quantity = schema["datasets"][name]["quantity"]
        base = unit_factor(quantity, units[name])
        # the units under which the same numbers would be plausible: the data look like those
        fits = [
            u for u, factor in schema["units"][quantity].items() if u != units[name] and lo <= med / base * factor <= hi
        ]
        hint = (
            f"the data look like {fits[0]}: set the units attribute to '{fits[0]}'"
            if len(fits) == 1
            else "the units attribute is probably wrong"
        )
        figures = (
            f"median |{what}| is {med:.4g} in SI after converting from '{units[name]}', outside the "
            f"plausible {lo:g}..{hi:g}"
        )
        return name, figures, hint
    return None
