"""HDF5 attributes as the contract reads them (:mod:`sizefx.io.contract`): plain Python values
(str, float, int, list) whose every text is valid, whatever bytes the file holds. The writer and the
other readers of HDF5 files take their attributes through these too.
"""

from __future__ import annotations

import numpy as np

__all__ = ["attr_value", "attr_str"]


def attr_value(value):
    """An HDF5 attribute as plain Python (str, float, int, list), every text in it valid (:func:`attr_str`)."""
    if isinstance(value, (bytes, str)):
        return attr_str(value)
    if isinstance(value, np.ndarray):
        return attr_value(value[()]) if value.shape == () else [attr_value(v) for v in value.tolist()]
    if isinstance(value, list):  # the rows of a multi-dimensional array's tolist()
        return [attr_value(v) for v in value]
    if isinstance(value, np.generic):
        return attr_value(value.item())
    return value


def attr_str(value) -> str:
    """An HDF5 text attribute as valid text, whatever bytes the file holds.

    HDF5 does not check that a string attribute declared UTF-8 is UTF-8, and h5py hands the bytes that
    are not over as lone surrogates (``surrogateescape``), which no output can take: h5py refuses to write
    them into a new file, and stdout and JSON readers choke on them. Those bytes become backslash escapes
    (``b"caf\\xe9"`` -> ``"caf\\\\xe9"``), not an error: the text attributes sizefx only carries or prints
    (``description``, the ``/source`` provenance) are informational, and a record is not refused for a
    comment in Latin-1; they stay readable and travel into every output. The ones sizefx interprets
    (``schema``, ``units``, ``/simulation`` ``truth_json``) keep their escapes too and are then refused by
    their own checks, which quote the value."""
    if isinstance(value, np.ndarray) and value.shape == ():
        value = value[()]
    if isinstance(value, bytes):
        return value.decode("utf-8", "backslashreplace")
    text = str(value)
    try:
        raw = text.encode("utf-8", "surrogateescape")  # the bytes h5py could not decode, back as bytes
    except UnicodeEncodeError:  # a surrogate that is no escaped byte: keep it visible as \udXXX
        return text.encode("utf-8", "backslashreplace").decode("utf-8")
    return raw.decode("utf-8", "backslashreplace")
