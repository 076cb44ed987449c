"""Stages chained in one command: ``sizefx run calibrate T.h5 navigate F.h5 compare --out DIR`` (issue 18).

The everyday workflow is calibrate on the turntable record, navigate the flight without and with
those lever arms, and compare the two solutions against the flight's reference. The command line
(``sizefx_cli.run``) builds each stage's config from its own options and calls its ``run``; this
module holds what does not depend on the command line: which chains can work
(:func:`check_chain`, before any stage runs) and the folder's ``run.json`` (``sizefx/run/1``,
``data-schemas/run-1.json``): per stage its inputs, options, outputs, duration and headline figures.
"""

from __future__ import annotations

from pathlib import Path

from .errors import ConfigError
from .io.documents import write_json
from .io.schema import as_json, check_document

__all__ = ["CHAIN_STAGES", "RUN_SCHEMA", "RUN_MANIFEST", "check_chain", "write_run_manifest"]

#: The stages a chain may hold, in the order they can come.
CHAIN_STAGES = ("calibrate", "navigate", "compare")
RUN_SCHEMA = "sizefx/run/1"
RUN_MANIFEST = "run.json"


def check_chain(names: list[str], *, navigate_has_levers: bool = False) -> None:
    """Refuse, before any stage runs, a chain that cannot work: an unknown or repeated stage, stages
    out of order (calibrate feeds navigate, navigate feeds compare), compare with fewer than two
    solutions to compare (navigate needs lever arms, from calibrate or its own --levers, to navigate
    a second time compensated)."""
    if not names:
        raise ConfigError("sizefx run: give the stages to chain, e.g. 'calibrate T.h5 navigate F.h5 compare'")
    for name in names:
        if name not in CHAIN_STAGES:
            raise ConfigError(f"sizefx run: '{name}' cannot be chained; chain {', '.join(CHAIN_STAGES)}")
        if names.count(name) > 1:
            raise ConfigError(f"sizefx run: {name} appears {names.count(name)} times; each stage once")
    order = [CHAIN_STAGES.index(n) for n in names]
    if order != sorted(order):
        raise ConfigError(f"sizefx run: '{' '.join(names)}' is out of order; the stages run as "
                          f"{' -> '.join(n for n in CHAIN_STAGES if n in names)} (each feeds the next)")
    if "compare" in names:
        if "navigate" not in names:
            raise ConfigError("sizefx run: compare has nothing to compare; put navigate FILE before it")
        if "calibrate" not in names and not navigate_has_levers:
            raise ConfigError("sizefx run: compare needs two solutions, and navigate makes only one without lever "
                              "arms; put calibrate before navigate, or give navigate --levers")


def write_run_manifest(out_dir, steps: list[dict]) -> None:
    """Write ``DIR/run.json`` atomically: the chain's steps so far."""
    doc = as_json({"schema": RUN_SCHEMA, "steps": steps})
    check_document(doc, RUN_SCHEMA)
    write_json(Path(out_dir) / RUN_MANIFEST, doc, force=True)
