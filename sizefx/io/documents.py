"""Small text documents a user gives sizefx (effect models in TOML, lever arms and reports in JSON),
read with bounds (and JSON documents written: :func:`write_json`, and :func:`write_json_streamed` for
one too long to hold): a size limit checked before reading, UTF-8 checked, nesting that would exhaust
the parser's recursion refused, each as a one-line :class:`~sizefx.errors.ConfigError` naming the
file. What the document must contain is checked by its reader against its schema afterwards.
"""

from __future__ import annotations

import json
import os
import stat
import tomllib
from pathlib import Path

from ..errors import ConfigError
from .files import atomic_output

__all__ = [
    "MAX_DOCUMENT_BYTES",
    "MAX_TOML_BYTES",
    "parse_toml",
    "read_json",
    "read_toml",
    "write_json",
    "write_json_streamed",
]

#: Largest JSON document read: a levers file is a few kB, a diagnosis report with its selection log
#: some 100 kB; anything near this is not one of ours.
MAX_DOCUMENT_BYTES = 16 * 2**20
#: Largest TOML document and longest TOML line: an effect model is about 2 kB in lines under 200
#: characters. The standard library's parser is quadratic in a dotted key's parts (16 000 parts
#: took 0.7 s, 100 000 about 27 s), so a long line is refused before parsing.
MAX_TOML_BYTES = 2**20
MAX_TOML_LINE_CHARS = 10_000


def _text(path: Path, what: str, limit: int = MAX_DOCUMENT_BYTES) -> str:
    try:
        info = os.stat(path)
        if stat.S_ISDIR(info.st_mode):
            raise IsADirectoryError
        if not stat.S_ISREG(info.st_mode):  # a FIFO would block the read until a writer came; /dev/zero never ends
            raise ConfigError(f"{path}: {what} is not a regular file (a pipe or a device); give a file")
        size = info.st_size
        if size > limit:
            raise ConfigError(
                f"{path}: {what} of {size / 2**20:.2f} MiB; at most {limit / 2**20:g} MiB is read (is "
                "it the right file?)"
            )
        with open(path, "rb") as fh:
            raw = fh.read(limit + 1)  # a file that grows while read (a FIFO, /dev/zero) is cut, not followed
    except FileNotFoundError:
        raise ConfigError(f"{path}: {what} does not exist; check the path") from None
    except IsADirectoryError:
        raise ConfigError(f"{path}: is a directory; give a {what}") from None
    except OSError as exc:
        raise ConfigError(f"{path}: {what} cannot be read ({exc.strerror or exc})") from None
    if len(raw) > limit:
        raise ConfigError(f"{path}: {what} over {limit / 2**20:g} MiB; is it the right file?")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{path}: {what} is not UTF-8 text (byte {exc.start}); save it as UTF-8") from None


def read_toml(path, what: str = "TOML file") -> dict:
    """The TOML document in ``path`` (``tomllib``), or a one-line ConfigError."""
    path = Path(path)
    text = _text(path, what, MAX_TOML_BYTES)
    return parse_toml(text, f"{path}: {what}")


def parse_toml(text: str, where: str) -> dict:
    """TOML ``text`` (a file's, or a ``--set`` value's) parsed with the bounds of :func:`read_toml`;
    ``where`` starts each error."""
    for number, line in enumerate(text.splitlines(), 1):
        if len(line) > MAX_TOML_LINE_CHARS:
            raise ConfigError(
                f"{where}: line {number} has {len(line)} characters; at most {MAX_TOML_LINE_CHARS} "
                "(is it the right file?)"
            )
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{where} is not valid TOML ({exc})") from None
    except RecursionError:
        raise ConfigError(f"{where} nests arrays or tables too deeply to be one of ours") from None
    except ValueError as exc:  # an integer of more digits than Python converts (4300)
        raise ConfigError(f"{where} holds a value Python cannot convert ({exc})") from None


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
    except ValueError as exc:
        if type(exc) is not ValueError:  # an option's own refusal (a parse_float that raises a subclass)
            raise
        # an integer of more digits than Python converts (4300)
        raise ConfigError(f"{path}: {what} holds a value Python cannot convert ({exc})") from None


def _json_text(doc, *, allow_nan: bool = True) -> str:
    """``doc`` as the text of a JSON document sizefx writes: indented, NumPy scalars as floats, no final
    newline."""
    return json.dumps(doc, indent=2, default=float, allow_nan=allow_nan)


def write_json(path, doc, *, inputs=(), force: bool = False, allow_nan: bool = True) -> Path:
    """Write ``doc`` as indented UTF-8 JSON, ending in a newline, to ``path`` atomically
    (never over an input; an existing file only with ``force``); NumPy scalars as floats.
    ``allow_nan=False``: a NaN or infinity is a ValueError instead of the ``NaN`` strict JSON readers refuse."""
    with atomic_output(path, inputs=inputs, force=force) as tmp:
        Path(tmp).write_text(_json_text(doc, allow_nan=allow_nan) + "\n", encoding="utf-8")
    return Path(path)


def write_json_streamed(path, doc: dict, key: str, items, *, force: bool = False, interrupted: bool = False) -> Path:
    """Write ``doc`` as :func:`write_json` does, but with its last entry ``key`` (an empty list in
    ``doc``) filled from ``items``, each the JSON text of one element, one element a line, as they
    come: a document too large to hold whole (a batch's manifest of any length). Atomically;
    ``interrupted``: published also when a signal stops the writing (:func:`~sizefx.io.files.atomic_output`)."""
    head = _json_text(doc)
    empty = f'"{key}": []\n}}'
    if not head.endswith(empty):
        raise ValueError(f"write_json_streamed: {key!r} must be the document's last entry, an empty list")
    with atomic_output(path, force=force, interrupted=interrupted) as tmp, open(tmp, "w", encoding="utf-8") as f:
        f.write(head[: -len("[]\n}")] + "[")
        for k, text in enumerate(items):
            f.write(("," if k else "") + "\n    " + text)
        f.write("\n  ]\n}\n")
    return Path(path)
