"""The verdict of the units checks (:mod:`sizefx.sanity`): :class:`Check` on one dataset,
:class:`UnitsReport` on a record, and the unit-hypothesis test the three checks share,
:func:`looks_like`: which unit data that disagree with physics look like (the contract's units, then
:data:`UNITS_OUTSIDE_CONTRACT`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..constants import STANDARD_GRAVITY_MPS2
from ..io.schema import TELEMETRY_SCHEMA, load_schema, unit_factor

__all__ = ["Check", "UnitsReport", "looks_like", "UNITS_OUTSIDE_CONTRACT", "FORM_QUANTITIES"]

#: Units a mistake may leave data in that the contract does not accept (named in messages only):
#: velocity increments integrated from accelerometers that read g.
UNITS_OUTSIDE_CONTRACT = {"velocity": {"g*s": STANDARD_GRAVITY_MPS2}}

FORM_QUANTITIES = {"rates": ("angular_rate", "acceleration"), "increments": ("angle", "velocity")}


@dataclass
class Check:
    """The verdict on one dataset's units."""

    what: str  #: "accel" or "gyro"
    dataset: str  #: the telemetry dataset (/imu/gyro, /imu/dvel, ...)
    declared: str  #: the units the data were read in
    verdict: str  #: "ok", "wrong" (refused), "odd" (disagrees but matches no unit; reported) or "unchecked"
    detail: str  #: the figures, or why no check could be made (no path, no dataset name)
    method: str | None = None  #: "rest", "motion", "reference" or "tilt"
    ratio: float | None = None  #: what the data read (in SI, after the declared units) / what physics says
    count: int = 0  #: windows, intervals or tilt changes behind the ratio
    looks_like: str | None = None  #: the unit the data look like, when not the declared one

    def as_dict(self) -> dict:
        return {
            k: getattr(self, k)
            for k in ("what", "dataset", "declared", "verdict", "method", "ratio", "count", "looks_like", "detail")
        }


@dataclass
class UnitsReport:
    accel: Check
    gyro: Check

    @property
    def wrong(self) -> list[Check]:
        return [c for c in (self.accel, self.gyro) if c.verdict == "wrong"]

    def lines(self) -> list[str]:
        return [c.detail for c in (self.accel, self.gyro)]

    def as_dict(self) -> dict:
        return {"accel": self.accel.as_dict(), "gyro": self.gyro.as_dict()}


def looks_like(quantity: str, declared: str, ratio: float, band: float) -> str | None:
    """The unit the data are in, if not ``declared``: data read as ``declared`` came out ``ratio``
    times the physical value, so they are in the unit whose SI factor is ``factor(declared) / ratio``
    (within ``band``). Units from the contract, then :data:`UNITS_OUTSIDE_CONTRACT`; None if none fits.
    """
    base = unit_factor(quantity, declared)
    if base is None or not ratio > 0 or isinstance(base, list):
        return None
    table = {**load_schema(TELEMETRY_SCHEMA)["units"][quantity], **UNITS_OUTSIDE_CONTRACT.get(quantity, {})}
    best, best_err = None, math.log(band)
    for unit, factor in table.items():
        if isinstance(factor, list) or unit == declared:
            continue
        err = abs(math.log(factor * ratio / base))
        if err <= best_err:
            best, best_err = unit, err
    return best
