"""TOML out: a document (nested dicts of numbers, strings, booleans and lists) to text or a file.

``tomli-w`` writes it: the standard library reads TOML (``tomllib``) but does not write it, and a
hand-made writer gets quoting, escapes and float spelling wrong in the corners (a string with a
quote, ``inf``, a nested table). Written files are atomic (:func:`sizefx.io.files.atomic_output`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import tomli_w

from .files import atomic_output

__all__ = ["dumps_toml", "write_toml"]


def _plain(value):
    """NumPy scalars and arrays as the Python numbers and lists TOML knows; None is dropped by the caller."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items() if v is not None}
    if isinstance(value, (list, tuple, np.ndarray)):
        return (
            [_plain(v) for v in np.asarray(value, dtype=object).tolist()]
            if isinstance(value, np.ndarray)
            else [_plain(v) for v in value]
        )
    if isinstance(value, np.generic):
        return value.item()
    return value


def dumps_toml(doc: dict, *, header: str = "") -> str:
    """``doc`` as TOML text; ``header`` (lines without ``#``) goes first as comments."""
    comment = "".join(f"# {line}\n" if line else "#\n" for line in header.splitlines())
    return comment + ("\n" if comment else "") + tomli_w.dumps(_plain(doc))


def write_toml(path, doc: dict, *, header: str = "", inputs=(), force: bool = False) -> Path:
    """Write ``doc`` to ``path`` atomically (never over an input; an existing file only with ``force``)."""
    with atomic_output(path, inputs=inputs, force=force) as tmp:
        Path(tmp).write_text(dumps_toml(doc, header=header), encoding="utf-8")
    return Path(path)
