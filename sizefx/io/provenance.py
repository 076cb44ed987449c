"""Where a record came from and what was done to it since: :class:`Provenance`, the ``/source`` group.

The importers build a :class:`Provenance`, :class:`~sizefx.io.records.Telemetry` carries it
(``Telemetry.source``), and the stages that change the samples add what they did
(``compensate --levers``: :attr:`Provenance.compensation`; ``compensate --model``:
:attr:`Provenance.correction`). Only this module knows how it lies in a file:
:func:`to_attributes` gives the ``/source`` attributes the writer stores, :func:`from_attributes`
the record the reader returns. The layout (``data-schemas/telemetry-1.json``, group ``/source``),
one attribute each:

- ``format``, ``file``, ``sha256``, ``importer``, ``credits``: text (``credits`` only when given);
- the importer's own fields (:attr:`Provenance.extra`), each under its name;
- ``imu_source_NAME``: attribute ``NAME`` of :attr:`Provenance.imu` (``import table-log``: where
  the IMU record came from);
- ``correction_json``, ``compensation_json``: :attr:`Provenance.correction` and
  :attr:`Provenance.compensation` as JSON text, in :func:`json.dumps`'s default form.

The group is informational and a file sizefx did not write may hold anything there, so reading
never refuses it: an attribute without its field's type (a ``format`` that is a number, a
``compensation_json`` that is no JSON object in the default form) stays in :attr:`Provenance.extra`
under its own name, and a record read from a file remembers its attributes' order
(:attr:`Provenance.attribute_order`): written back, a ``/source`` holds what it held, as it held it.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np

__all__ = ["Provenance", "AttrValue", "to_attributes", "from_attributes", "IMU_PREFIX"]

#: An attribute's value as a record holds it: text, a number, a flag, or an array as (nested) tuples.
AttrValue = str | int | float | bool | tuple
#: The text fields, each stored under its own name, in this order, before the importer's own fields.
TEXT_FIELDS = ("format", "file", "sha256", "importer", "credits")
#: What the stages did, each a JSON object stored as text: attribute -> field.
JSON_FIELDS = {"correction_json": "correction", "compensation_json": "compensation"}
#: The prefix of the attributes of :attr:`Provenance.imu`.
IMU_PREFIX = "imu_source_"


@dataclass(frozen=True)
class Provenance:
    """Where a record came from (the original file, its checksum, the importer, the credits, the
    importer's own fields) and what sizefx did to its samples since. Read-only: a stage that adds
    to it makes a new one (``dataclasses.replace``)."""

    format: str | None = None  #: the format imported (``sizefx import FORMAT``)
    file: str | None = None  #: the original file's name (its folder left out)
    sha256: str | None = None  #: of the original file's bytes (a ROS 2 bag folder: of its files, in order)
    importer: str | None = None  #: ``sizefx VERSION``
    credits: str | None = None  #: the data's authors and licence, where the format's owners ask for them
    #: the importer's own fields, in order, SI, units and frames in their names (``topic``, ``dropouts``,
    #: ``body_axes``, ``reference_is_approximate``, ...); arrays as tuples
    extra: Mapping[str, AttrValue] = field(default_factory=dict)
    #: ``import table-log``: the provenance of the IMU record the table's attitude was joined to
    imu: Provenance | None = None
    #: ``compensate --model``: what was corrected (:func:`sizefx.correct.correct_imu`), a JSON object
    correction: Mapping[str, Any] | None = None
    #: ``compensate --levers``: what was compensated (:func:`sizefx.compensate.compensate`), a JSON object
    compensation: Mapping[str, Any] | None = None
    #: the attribute names in the order of the file read (empty for a record built in memory): written
    #: back in that order, new ones after, so that a record passed through holds its ``/source`` as it was
    attribute_order: tuple = field(default=(), compare=False, repr=False)

    def __post_init__(self):
        # read-only all the way down: a record shared by two Telemetry copies cannot change under one
        object.__setattr__(self, "extra", MappingProxyType({str(k): _frozen(v) for k, v in self.extra.items()}))
        for name in JSON_FIELDS.values():
            doc = getattr(self, name)
            if doc is not None:
                object.__setattr__(self, name, _frozen(dict(doc)))
        object.__setattr__(self, "attribute_order", tuple(self.attribute_order))

    @property
    def reference_is_approximate(self) -> bool:
        """The importer marked ``/reference``'s attitude approximate (a PSINS log's header attitude, held
        constant): good enough to start a navigation from, no truth to measure errors against."""
        return bool(self.extra.get("reference_is_approximate", False))


def to_attributes(p: Provenance) -> dict:
    """The ``/source`` attributes of ``p``, in the order they are written (module docstring): arrays as
    lists, the JSON objects as text. A field that is set is written in place of an entry of
    :attr:`Provenance.extra` that has its attribute's name (one read from a file where it was not of
    the field's type)."""
    out: dict = {name: getattr(p, name) for name in TEXT_FIELDS if getattr(p, name) is not None}
    for name, value in p.extra.items():
        out.setdefault(name, _thawed(value))
    if p.imu is not None:
        out.update((IMU_PREFIX + name, value) for name, value in to_attributes(p.imu).items())
    for name, attr in JSON_FIELDS.items():
        doc = getattr(p, attr)
        if doc is not None:
            out[name] = json.dumps(_thawed(doc))  # the default form: what sizefx always wrote there
    if p.attribute_order:
        out = {**{name: out[name] for name in p.attribute_order if name in out}, **out}
    return out


def from_attributes(attrs: Mapping[str, Any]) -> Provenance:
    """The :class:`Provenance` that ``/source`` attributes ``attrs`` (name -> plain value, text valid,
    in the file's order) describe; anything else in them goes to :attr:`Provenance.extra` unchanged."""
    text: dict = {}
    docs: dict = {}
    imu: dict = {}
    extra: dict = {}
    for name, value in attrs.items():
        if name in TEXT_FIELDS and isinstance(value, str):
            text[name] = value
        elif name in JSON_FIELDS and (doc := _json_object(value)) is not None:
            docs[JSON_FIELDS[name]] = doc
        elif name.startswith(IMU_PREFIX):
            imu[name[len(IMU_PREFIX) :]] = value
        else:
            extra[name] = value
    return Provenance(
        **text,
        extra=extra,
        imu=from_attributes(imu) if imu else None,
        **docs,
        attribute_order=tuple(attrs),
    )


def _json_object(value) -> dict | None:
    """``value`` as the JSON object it holds when it is one in :func:`json.dumps`'s default form (so that
    writing it back gives the same text); None otherwise (it is then carried as it is)."""
    if not isinstance(value, str):
        return None
    try:
        doc = json.loads(value)
    except (ValueError, RecursionError):  # not JSON, nesting past the parser, a 5000-digit integer
        return None
    if not isinstance(doc, dict):
        return None
    try:
        same = json.dumps(doc) == value
    except (ValueError, RecursionError):
        return None
    return doc if same else None


def _frozen(value):
    """``value`` read-only: arrays and lists as tuples, mappings as read-only mappings, NumPy scalars as
    Python's, all the way down."""
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (list, tuple)):
        return tuple(_frozen(v) for v in value)
    if isinstance(value, Mapping):
        return MappingProxyType({k: _frozen(v) for k, v in value.items()})
    return value


def _thawed(value):
    """A value of :func:`_frozen` as plain lists and dicts (what HDF5 attributes and JSON take)."""
    if isinstance(value, tuple):
        return [_thawed(v) for v in value]
    if isinstance(value, Mapping):
        return {k: _thawed(v) for k, v in value.items()}
    return value
