"""``DIR/manifest.json`` (``sizefx/batch/1``, ``data-schemas/batch-1.json``): what a batch did to each record.

The manifest is the batch's memory: it is rewritten atomically after every record, so a batch
stopped half way (a signal, a crash, a machine switched off) leaves a valid manifest of the
records done, and the next run skips each record whose entry still matches (:func:`reusable`).
"""

from __future__ import annotations

import math
from pathlib import Path

from ..errors import ConfigError
from ..io.documents import read_json, write_json
from ..io.files import sha256_of
from ..io.schema import check_document, validate_input

__all__ = ["BATCH_SCHEMA", "MANIFEST_NAME", "read_manifest", "write_manifest", "reusable", "canonical_options"]

BATCH_SCHEMA = "sizefx/batch/1"
MANIFEST_NAME = "manifest.json"


def canonical_options(options: dict) -> dict:
    """The stage options as the manifest holds and compares them: JSON values (tuples as lists,
    NaN refused earlier by the options' own checks), keys sorted."""

    def plain(v):
        if isinstance(v, (list, tuple)):
            return [plain(x) for x in v]
        if isinstance(v, float) and not math.isfinite(v):
            return str(v)
        return v

    return {k: plain(options[k]) for k in sorted(options)}


def read_manifest(out_dir, stage: str) -> dict | None:
    """The manifest in ``out_dir``, checked against its schema (None when there is none). A manifest of
    another stage is refused: one batch folder holds one stage's outputs."""
    path = Path(out_dir) / MANIFEST_NAME
    if not path.exists():
        return None
    doc = read_json(path, "batch manifest")
    validate_input(doc, BATCH_SCHEMA, path)
    if doc["stage"] != stage:
        raise ConfigError(f"{path}: the folder holds a batch of '{doc['stage']}', not '{stage}'; give another --out")
    return doc


def write_manifest(out_dir, doc: dict) -> None:
    """Write the manifest atomically (a reader sees the old one or the new one, never half)."""
    check_document(doc, BATCH_SCHEMA)
    write_json(Path(out_dir) / MANIFEST_NAME, doc, force=True)


def reusable(entry: dict | None, sha256: str, options: dict, paired: dict | None = None) -> bool:
    """Whether a previous run's ``entry`` for a record stands: it succeeded, on the same input bytes,
    options and paired files (``{option: {"path", "sha256"}}``), and its outputs are still there with
    the sizes and hashes it wrote."""
    if not entry or entry.get("status") != "ok" or entry.get("sha256") != sha256 or entry.get("options") != options:
        return False
    if entry.get("paired", {}) != (paired or {}):
        return False
    for out in entry.get("outputs", {}).values():
        path = Path(out["path"])
        if not path.is_file() or path.stat().st_size != out["bytes"] or sha256_of(path) != out["sha256"]:
            return False
    return True
