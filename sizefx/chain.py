"""Stages chained in one command: ``sizefx run calibrate T.h5 navigate F.h5 compare --out DIR``.

The everyday workflow is calibrate on the turntable record, navigate the flight without and with
those lever arms, and compare the two solutions against the flight's reference. The command line
(``sizefx_cli.run``) builds each stage's config from its own options and calls its ``run``; this
module holds what does not depend on the command line: which chains can work
(:func:`check_chain`, before any stage runs) and the folder's ``run.json`` (``sizefx/run/1``,
``data-schemas/run-1.json``): per stage its inputs, options, outputs, duration and headline figures.

:func:`run` executes a chain's steps (each the stage's own ``run`` on the config the command line
built), for ``sizefx run`` and, per flight, for ``sizefx batch run`` (where it is a batch stage
like the others: :class:`ChainConfig` in, a result with ``to_json`` and ``report`` out).
"""

from __future__ import annotations

import contextlib
import importlib
import shutil
import time
from dataclasses import dataclass, field
from pathlib import Path

from .errors import ConfigError, SizefxError
from .io.documents import write_json
from .io.schema import as_json, check_document

__all__ = [
    "CHAIN_STAGES",
    "RUN_SCHEMA",
    "RUN_MANIFEST",
    "check_chain",
    "write_run_manifest",
    "ChainStep",
    "ChainConfig",
    "ChainResult",
    "run",
    "check_truth",
    "check_inputs",
    "chain_folder",
]

#: The stages a chain may hold, in the order they can come.
CHAIN_STAGES = ("calibrate", "navigate", "compare")
RUN_SCHEMA = "sizefx/run/1"
RUN_MANIFEST = "run.json"


def check_chain(names: list[str], *, navigate_corrects: bool = False, command: str = "sizefx run") -> None:
    """Refuse, before any stage runs, a chain that cannot work: an unknown or repeated stage, stages
    out of order (calibrate feeds navigate, navigate feeds compare), compare with fewer than two
    solutions to compare (navigate needs a correction, lever arms from calibrate or its own --levers
    or an effect model with --model, to navigate a second time compensated)."""
    if not names:
        raise ConfigError(f"{command}: give the stages to chain, e.g. 'calibrate T.h5 navigate F.h5 compare'")
    for name in names:
        if name not in CHAIN_STAGES:
            raise ConfigError(f"{command}: '{name}' cannot be chained; chain {', '.join(CHAIN_STAGES)}")
        if names.count(name) > 1:
            raise ConfigError(f"{command}: {name} appears {names.count(name)} times; each stage once")
    order = [CHAIN_STAGES.index(n) for n in names]
    if order != sorted(order):
        raise ConfigError(
            f"{command}: '{' '.join(names)}' is out of order; the stages run as "
            f"{' -> '.join(n for n in CHAIN_STAGES if n in names)} (each feeds the next)"
        )
    if "compare" in names:
        if "navigate" not in names:
            raise ConfigError(f"{command}: compare has nothing to compare; put navigate FILE before it")
        if "calibrate" not in names and not navigate_corrects:
            raise ConfigError(
                f"{command}: compare needs two solutions, and navigate makes only one without lever "
                "arms or a model; put calibrate before navigate, or give navigate --levers or --model"
            )


def write_run_manifest(out_dir, steps: list[dict]) -> None:
    """Write ``DIR/run.json`` atomically: the chain's steps so far."""
    doc = as_json({"schema": RUN_SCHEMA, "steps": steps})
    check_document(doc, RUN_SCHEMA)
    write_json(Path(out_dir) / RUN_MANIFEST, doc, force=True)


@dataclass(frozen=True)
class ChainStep:
    """One stage run of a chain: the stage, which run of it (navigate: plain or compensated), its
    config (made from its own options by :func:`sizefx.options.config_from`, as the command line
    makes it) and those options as given (for run.json)."""

    stage: str
    run: str | None
    config: object
    options: dict = field(default_factory=dict)


@dataclass(frozen=True)
class ChainConfig:
    """A chain's steps, in order, and the folder its outputs and run.json go to."""

    steps: tuple
    out_dir: str
    truth: str | None = None  #: the flight compare takes as the truth: checked (:func:`check_truth`) first

    def inputs(self) -> dict:
        """The files the chain reads that no step of it writes (for the stage preflight)."""
        written = {str(v) for step in self.steps for v in step.config.outputs().values() if v}
        return {
            f"{step.stage} {k}": v
            for step in self.steps
            for k, v in step.config.inputs().items()
            if v and str(v) not in written
        }

    def outputs(self) -> dict:
        return {f"{step.stage} {k}": v for step in self.steps for k, v in step.config.outputs().items() if v}


@dataclass
class ChainResult:
    """What each step read, wrote and found (run.json's steps), and each stage's printed report."""

    steps: list = field(default_factory=list)
    reports: list = field(default_factory=list)  #: [(title, the stage result's report())]
    out_dir: str = ""

    def to_json(self) -> dict:
        return as_json({"schema": RUN_SCHEMA, "steps": self.steps})

    def report(self) -> str:
        return "\n".join(f"{title}\n{text}" for title, text in self.reports)

    def summary(self) -> str:
        """The chain in one table: a line per step, its stage (and which run), its time and the figures
        a batch's table prints for that stage (navigation errors, each arm component, distances)."""
        from .batch.fleet import table_figures

        lines = []
        for step in self.steps:
            figures = ", ".join(
                f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}"
                for k, v in table_figures(step["stage"], step["headline"]).items()
            )
            name = step["stage"] + (f" ({step['run']})" if step.get("run") else "")
            lines.append(f"  {name}: {step['duration_s']:.1f} s" + (f"; {figures}" if figures else ""))
        return "\n".join(lines)


def run(config: ChainConfig, *, echo=None) -> ChainResult:
    """Run the chain's steps in order into ``config.out_dir`` (made if new), rewriting its run.json after
    each; ``echo(title, report)`` after each step (the command prints the stages as they finish).
    A stage that refuses stops the chain (its error propagates): the steps after it need its outputs."""
    from .batch.fleet import headline  # the batch's figures: a chain's steps and a batch's records alike

    if config.truth is not None:
        check_truth(config.truth)
    check_inputs(config)
    out = Path(config.out_dir)
    out.mkdir(exist_ok=True)
    result = ChainResult(out_dir=str(out))
    for step in config.steps:
        t0 = time.perf_counter()
        stage_result = importlib.import_module(f"sizefx.{step.stage}").run(step.config)
        result.steps.append(
            {
                "stage": step.stage,
                **({"run": step.run} if step.run else {}),
                "inputs": {k: str(v) for k, v in step.config.inputs().items() if v},
                "options": as_json({k: v for k, v in step.options.items() if not isinstance(v, Path)}),
                "outputs": {k: str(v) for k, v in step.config.outputs().items() if v},
                "duration_s": time.perf_counter() - t0,
                "headline": headline(step.stage, as_json(stage_result.to_json())),
            }
        )
        write_run_manifest(out, result.steps)
        title, text = f"== {step.stage}" + (f" ({step.run})" if step.run else ""), stage_result.report()
        result.reports.append((title, text))
        if echo is not None:
            echo(title, text)
    return result


@contextlib.contextmanager
def chain_folder(out_dir):
    """``out_dir``, made if new and locked (:func:`sizefx.batch.folder.folder_lock`) while a chain writes
    there. A chain refused (a step's input or option, however late in the chain) leaves no folder of
    its own making behind: bad input leaves nothing."""
    from .batch.inputs import make_out_dir
    from .batch.runner import LOCK_NAME, folder_lock

    out = Path(out_dir)
    fresh = not out.exists()
    make_out_dir(out)
    try:
        with folder_lock(out):
            yield out
    except SizefxError:
        if fresh:  # refused (a step's input, checked only when the step reads it): the folder was ours alone
            shutil.rmtree(out, ignore_errors=True)
        raise
    except BaseException:
        if fresh and [p.name for p in out.iterdir()] == [LOCK_NAME]:
            (out / LOCK_NAME).unlink()
            out.rmdir()
        raise


def check_inputs(config: ChainConfig) -> None:
    """Every file the chain reads that no step of it writes, checked before the first step writes
    anything: records (``.h5``) as far as their structure (HDF5, root attributes, groups, the IMU
    form: :func:`sizefx.io.contract.open_structure`), lever-arm and model files read in full
    (:func:`sizefx.batch.inputs.check_option_files`). A step's own deeper checks (the samples) still
    come when it reads them; a chain refused then leaves nothing behind (:func:`chain_folder`)."""
    from .batch.inputs import RECORD_SUFFIXES, check_option_files
    from .io.contract import open_hdf5, open_structure

    files = config.inputs()
    for path in files.values():
        if Path(path).suffix.lower() in RECORD_SUFFIXES:
            with open_hdf5(Path(path), "convert it with sizefx import") as h5:
                open_structure(Path(path), h5, allow_gaps=True, check_plausibility=False)
    check_option_files(files)


def check_truth(path) -> None:
    """Refuse a flight that compare cannot judge: without ``/reference/position`` there is no truth
    (checked before any stage runs, so that the flight is not navigated twice for nothing)."""
    from .io.contract import open_hdf5

    with open_hdf5(path, "convert it with sizefx import") as f:
        has = "reference/position" in f
    if not has:
        raise ConfigError(
            f"{path}: compare needs the truth, and the flight has no /reference/position; give compare --reference"
        )
