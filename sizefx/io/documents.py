"""Small text documents a user gives sizefx (effect models in TOML, lever arms and reports in JSON),
read with bounds: a size limit checked before reading, UTF-8 checked, nesting that would exhaust
the parser's recursion refused, each as a one-line :class:`~sizefx.errors.ConfigError` naming the
file. What the document must contain is checked by its reader against its schema afterwards.
"""

from __future__ import annotations

import json
import os
import tomllib
from pathlib import Path

from ..errors import ConfigError

__all__ = ["MAX_DOCUMENT_BYTES", "read_json", "read_toml"]

#: Largest TOML or JSON document read: an effect model or a levers file is a few kB, a diagnosis
#: report with its selection log some 100 kB; anything near this is not one of ours.
MAX_DOCUMENT_BYTES = 16 * 2**20


def _text(path: Path, what: str) -> str:
    try:
        size = os.stat(path).st_size
        if size > MAX_DOCUMENT_BYTES:
            raise ConfigError(f"{path}: {what} of {size / 2**20:.1f} MiB; at most {MAX_DOCUMENT_BYTES // 2**20} MiB "
                              "is read (is it the right file?)")
        with open(path, "rb") as fh:
            raw = fh.read(MAX_DOCUMENT_BYTES + 1)  # a file that grows while read is cut, not followed
    except FileNotFoundError:
        raise ConfigError(f"{path}: {what} does not exist; check the path") from None
    except IsADirectoryError:
        raise ConfigError(f"{path}: is a directory; give a {what}") from None
    except OSError as exc:
        raise ConfigError(f"{path}: {what} cannot be read ({exc.strerror or exc})") from None
    if len(raw) > MAX_DOCUMENT_BYTES:
        raise ConfigError(f"{path}: {what} over {MAX_DOCUMENT_BYTES // 2**20} MiB; is it the right file?")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{path}: {what} is not UTF-8 text (byte {exc.start}); save it as UTF-8") from None


def read_toml(path, what: str = "TOML file") -> dict:
    """The TOML document in ``path`` (``tomllib``), or a one-line ConfigError."""
    path = Path(path)
    text = _text(path, what)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: {what} is not valid TOML ({exc})") from None
    except RecursionError:
        raise ConfigError(f"{path}: {what} nests arrays or tables too deeply to be one of ours") from None


def read_json(path, what: str = "JSON file", **loads_options):
    """The JSON document in ``path`` (``json.loads`` with ``loads_options``), or a one-line ConfigError.
    Exceptions the options raise (a ``parse_float`` that refuses a value) pass through."""
    path = Path(path)
    text = _text(path, what)
    try:
        return json.loads(text, **loads_options)
    except json.JSONDecodeError as exc:
        raise ConfigError(f"{path}: {what} is not valid JSON ({exc})") from None
    except RecursionError:
        raise ConfigError(f"{path}: {what} nests arrays or objects too deeply to be one of ours") from None
