"""Stages chained: ``sizefx.chain.run(STAGES, OUT)``, which is ``sizefx run --out OUT calibrate T.h5
navigate F.h5 compare``.

    sizefx.chain.run({"calibrate": {"records": ["T.h5"]}, "navigate": {"input": "F.h5"}, "compare": {}}, "DIR")

The everyday workflow is calibrate on the turntable record, navigate the flight without and with
those lever arms, and compare the two solutions against the flight's reference. :func:`run` takes
the chain as the command line does (each stage's options by its config's field names), refuses
one that cannot work before any stage runs (:func:`check_stages`: which chains can work,
:func:`check_chain`, and every file the chain reads), builds each step's config from the stage's
own declarations (:func:`sizefx.options.config_from`), with the outputs named in DIR, and runs the
steps, writing the folder's ``run.json`` (``sizefx/run/1``, ``data-schemas/run-1.json``) after
each: per stage its inputs, options, outputs, duration and headline figures. The command line
(``sizefx_cli.run``) only parses the chain and prints.

A batch of chains (``sizefx batch run``, :mod:`sizefx.batch.chains`) builds a :class:`ChainConfig`
per flight (:func:`flight_steps`) and runs it with the same :func:`run`, as a batch stage like the
others (:class:`ChainConfig` in, a result with ``to_json`` and ``report`` out).

A batch runs chains, so nothing here imports :mod:`sizefx.batch`: what the two share (a campaign
folder's records, option files, checks and lock; a stage result's headline figures) lives below
both, in :mod:`sizefx.runs`.
"""

from __future__ import annotations

import contextlib
import importlib
import os
import shutil
import time
from dataclasses import dataclass, field
from pathlib import Path

from .configs.batch import CHAIN_CONFIGS, chain_options, option_values
from .errors import ConfigError, SizefxError
from .io.documents import write_json
from .io.schema import as_json, check_document
from .options import config_from
from .runs.figures import headline, table_figures
from .runs.folder import (
    LOCK_NAME,
    RECORD_SUFFIXES,
    check_option_files,
    check_out_dir,
    expand_inputs,
    folder_lock,
    make_out_dir,
)

__all__ = [
    "CHAIN_STAGES",
    "RUN_SCHEMA",
    "RUN_MANIFEST",
    "check_chain",
    "check_stages",
    "CheckedChain",
    "calibrate_step",
    "flight_steps",
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


def _stages(stages, *, command: str, batch: bool) -> list:
    """The chain as ``[(stage, options), ...]`` in the order given, each stage's options complete by
    field name (:func:`sizefx.configs.batch.option_values`: what the command line gives, defaults
    included). ``stages``: a mapping ``{stage: options}`` or a sequence of ``(stage, options)``
    pairs (the command line's, which may repeat a stage for :func:`check_chain` to refuse). In a
    batch navigate's ``input`` is not an option: the flights are the batch's inputs."""
    pairs = list(stages.items()) if hasattr(stages, "items") else list(stages)
    out: list[tuple[str, dict]] = []
    for pair in pairs:
        if not (isinstance(pair, (tuple, list)) and len(pair) == 2):
            raise ConfigError(f"{command}: give the chain as {{stage: options}} or (stage, options) pairs")
        name, given = pair
        if name not in CHAIN_CONFIGS:  # refused by check_chain, with the stages that can be chained
            out.append((name, {}))
            continue
        offered = [o for o in chain_options(name) if not (batch and name == "navigate" and o == "input")]
        options = option_values(CHAIN_CONFIGS[name], given, offered=offered, where=f"{command}: {name}")
        required = {"calibrate": ("records", "the records to fit"), "navigate": ("input", "the flight")}.get(name)
        if required and required[0] in offered and required[0] not in options:
            raise ConfigError(f"{command}: {name} needs {required[0]!r}, {required[1]}")
        out.append((name, options))
    return out


@dataclass(frozen=True)
class CheckedChain:
    """A chain that can work (:func:`check_stages`): its stages in order, each one's options, the
    folder, and the flights (a batch's every flight; a single chain's one, or none)."""

    names: list  #: the stages, in the order given
    stages: dict  #: stage -> its options by field name (navigate's in a batch with its ``input`` as given)
    out: Path  #: the folder, resolved
    flights: list  #: a batch's every flight, resolved; a single chain's navigate input as given, or none

    @property
    def navigate(self) -> dict:
        return self.stages.get("navigate", {})


def check_stages(stages, out=None, *, flights=None) -> CheckedChain:
    """The chain ``stages`` (as :func:`run` takes it) refused in one line before anything runs or
    is written when it cannot work: the stages (:func:`check_chain`), a stage's options, lever arms
    both from calibrate and from navigate's ``levers``, a model beside lever arms, every file the
    chain reads (the lever arms and a model read by their readers: :func:`sizefx.runs.folder.check_option_files`),
    a flight without the truth compare needs, the folder ``out`` (default ``run-NAME``, NAME the
    flight's file name, or calibrate's record's). ``flights``: a batch of chains, one per flight
    (files, folders or globs, expanded here); None: one chain, on navigate's ``input``."""
    batch = flights is not None
    command = "sizefx batch run" if batch else "sizefx run"
    pairs = _stages(stages, command=command, batch=batch)
    chain = dict(pairs)
    names = [name for name, _ in pairs]
    nav = chain.get("navigate", {})
    check_chain(names, navigate_corrects=bool(nav.get("levers") or nav.get("model")), command=command)
    if out is None or not str(out):
        named = nav.get("input") or next(iter(chain.get("calibrate", {}).get("records", ())), None)
        if batch or not named:
            raise ConfigError(f"{command}: give --out DIR, the folder for every stage's outputs")
        out = f"run-{Path(named).stem}"  # the everyday form: sizefx run calibrate T.h5 navigate F.h5 compare
    if "calibrate" in chain and nav.get("levers"):
        raise ConfigError(
            f"{command}: navigate --levers and calibrate in one chain: the chain passes calibrate's "
            "lever arms to navigate; leave out one of the two"
        )
    if nav.get("model") and ("calibrate" in chain or nav.get("levers")):
        raise ConfigError(
            f"{command}: navigate --model cannot be combined with lever arms (from calibrate or "
            "--levers); navigate the model on its own"
        )
    if batch and "navigate" not in chain:
        raise ConfigError("sizefx batch run: the chain runs per flight: put navigate FLIGHTS in it")
    if batch:
        given_flights = [flights] if isinstance(flights, (str, os.PathLike)) else list(flights)
        found = expand_inputs(given_flights)
        # run.json records what navigate was given, as the command line's FILE: the flights' pattern
        shown = [str(f) for f in given_flights]
        chain["navigate"] = {"input": shown[0] if len(shown) == 1 else shown, **nav}
    else:
        found = [Path(nav["input"])] if nav.get("input") else []
    # every file the chain reads, before any stage runs
    given = {
        **{f"calibrate RECORDS ({k + 1})": r for k, r in enumerate(chain.get("calibrate", {}).get("records", ()))},
        **({} if batch else {"navigate FILE": nav.get("input")}),
        "navigate --levers": nav.get("levers"),
        "navigate --model": nav.get("model"),
        "compare --reference": chain.get("compare", {}).get("reference"),
        "calibrate --nominal": _nominal_file(chain.get("calibrate", {}).get("nominal")),
    }
    check_option_files(given)  # the lever arms and the model read by their readers, too
    if "compare" in chain and not chain["compare"].get("reference") and not batch:
        check_truth(nav["input"])  # in a batch each flight is checked in its own record
    folder = check_out_dir(
        out, given_flights if batch else [], [*(Path(p).resolve() for p in given.values() if p), *found]
    )
    return CheckedChain(names, chain, folder, found)


def _nominal_file(nominal):
    """calibrate --nominal when it names a file (not one of the presets)."""
    from .geometry import PRESETS

    return nominal if nominal and nominal not in PRESETS else None


def calibrate_step(chain: CheckedChain, out, plots: bool) -> tuple:
    """calibrate's step of ``chain`` into ``out``, and the lever arms' file it writes (levers.json)."""
    options = chain.stages["calibrate"]
    levers = str(Path(out) / "levers.json")
    plot = str(Path(out) / "calibrate.png") if plots else None
    given = {**options, "json_path": levers, "force": True, "plot": plot}
    return ChainStep("calibrate", None, config_from(CHAIN_CONFIGS["calibrate"], given), options), levers


def flight_steps(chain: CheckedChain, flight, levers, out, plots: bool) -> list:
    """navigate ``flight`` plain (and compensated, with the lever arms ``levers`` or navigate's
    model), then compare, into ``out``: the steps of ``chain`` after calibrate."""
    out = Path(out)
    nav = chain.navigate
    steps, solutions = [], {}
    if nav:
        runs = [("plain", {"levers": None, "model": None})]
        if levers or nav.get("model"):  # the correction: calibrate's or --levers' arms, or a --model
            runs.append(("compensated", {"levers": levers, "model": nav.get("model")}))
        for label, correction in runs:
            solutions[label] = str(out / f"{label}.nav.h5")
            given = {
                **nav,
                "input": str(flight),
                **correction,
                "output": solutions[label],
                "json_path": str(out / f"{label}.navigate.json"),
                "force": True,
                "plot": str(out / f"{label}.navigate.png") if plots else None,
            }
            steps.append(
                ChainStep("navigate", label, config_from(CHAIN_CONFIGS["navigate"], given), {**nav, **correction})
            )
    if "compare" in chain.stages:
        options = chain.stages["compare"]
        given = {
            **options,
            "a": solutions["compensated"],
            "b": solutions["plain"],
            "reference": options.get("reference") or str(flight),
            "json_path": str(out / "comparison.json"),
            "plots_dir": str(out / "compare-plots") if plots else None,
            "force": True,
        }
        steps.append(ChainStep("compare", None, config_from(CHAIN_CONFIGS["compare"], given), options))
    return steps


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
        lines = []
        for step in self.steps:
            figures = ", ".join(
                f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}"
                for k, v in table_figures(step["stage"], step["headline"]).items()
            )
            name = step["stage"] + (f" ({step['run']})" if step.get("run") else "")
            lines.append(f"  {name}: {step['duration_s']:.1f} s" + (f"; {figures}" if figures else ""))
        return "\n".join(lines)


def run(stages, out=None, *, with_plots: bool = False, echo=None) -> ChainResult:
    """Run a chain of stages: what ``sizefx run --out OUT [--with-plots] calibrate ... navigate ...
    compare`` does.

    ``stages``: the stages in order, each with its options by field name as its config declares them
    (``sizefx run``'s options, less the outputs the chain names), as a mapping
    ``{"calibrate": {"records": ["T.h5"]}, "navigate": {"input": "F.h5"}, "compare": {}}`` or as
    ``(stage, options)`` pairs; options left out keep their defaults. calibrate's lever arms go to
    navigate, which navigates the flight plain and compensated (with them, or with its own ``levers``
    or ``model``); compare sets the two solutions against the flight's reference (or its
    ``reference``). A chain that cannot work is refused before any stage runs (:func:`check_stages`).

    ``out``: the folder for every output and run.json (default ``run-NAME`` in the current folder,
    NAME the flight's file name or calibrate's record's), made if new and locked while the chain
    writes; a chain refused leaves no folder of its own making behind (:func:`chain_folder`).
    ``with_plots``: each stage's plots too. ``echo(title, report)`` after each step (the command
    prints the stages as they finish). A stage that refuses stops the chain (its error propagates):
    the steps after it need its outputs.

    ``stages`` may also be a :class:`ChainConfig` already built, a batch's flight: its steps run as
    they are into its folder (made if new, not locked: the batch holds its own folder's lock)."""
    if isinstance(stages, ChainConfig):
        return _run_steps(stages, echo)
    chain = check_stages(stages, out)
    with chain_folder(chain.out):
        steps, levers = [], chain.navigate.get("levers")
        if "calibrate" in chain.stages:
            step, levers = calibrate_step(chain, chain.out, with_plots)
            steps.append(step)
        steps += flight_steps(chain, chain.navigate.get("input"), levers, chain.out, with_plots)
        return _run_steps(ChainConfig(tuple(steps), str(chain.out)), echo)


def _run_steps(config: ChainConfig, echo) -> ChainResult:
    """The chain's steps in order into ``config.out_dir`` (made if new), its run.json rewritten after each."""
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
    """``out_dir``, made if new and locked (:func:`sizefx.runs.folder.folder_lock`) while a chain writes
    there. A chain refused (a step's input or option, however late in the chain) leaves no folder of
    its own making behind: bad input leaves nothing."""
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
    (:func:`sizefx.runs.folder.check_option_files`). A step's own deeper checks (the samples) still
    come when it reads them; a chain refused then leaves nothing behind (:func:`chain_folder`)."""
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
