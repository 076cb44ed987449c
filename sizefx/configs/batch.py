"""What a stage is asked when it runs as a batch's record or as a chain's step: which of its
config's options the batch or the chain offers, and which it names itself (the record, the
outputs, ``force``).

A batch names every record's outputs after it in its folder (:data:`BATCH_STAGES`: the suffix of
each output, the plots written with ``with_plots``), pairs compare's other solutions and truths
with each record by name, and offers the rest of the stage's options unchanged; a chain names
every stage's outputs in its folder and passes each stage's outputs to the next
(:data:`CHAIN_NAMED`). The command line builds ``sizefx batch STAGE`` and ``sizefx run``'s stages
from these tables, and :mod:`sizefx.batch` and :mod:`sizefx.chain` the configs (from options a
Python caller gives by name or as a config: :func:`option_values`): one table, so that an option
can never mean something else in a batch. Like the other configs, this module imports
only the standard library and :mod:`sizefx.options` (``sizefx --help`` reads it).
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import MISSING, dataclass, field

from ..errors import ConfigError
from ..options import declared
from .calibrate import CalibrateConfig
from .compare import CompareConfig
from .compensate import CompensateConfig
from .diagnose import DiagnoseConfig
from .inspect import InspectConfig
from .navigate import NavigateConfig

__all__ = [
    "MAX_WORKERS",
    "MEMORY_MIB_RANGE",
    "BatchStage",
    "BATCH_STAGES",
    "CHAIN_CONFIGS",
    "CHAIN_NAMED",
    "batch_stage",
    "batch_options",
    "chain_options",
    "option_values",
]


#: The local worker processes a batch may ask for (``--workers``, ``workers``).
MAX_WORKERS = 1024
#: A local worker's memory bound [MiB] (``--memory-per-worker-mib``, ``memory_mib``): from what a
#: worker with NumPy, Numba and h5py loaded and a record in hand needs at the least, to a TiB.
MEMORY_MIB_RANGE = (256.0, 2.0**40)


@dataclass(frozen=True)
class BatchStage:
    """How a stage runs as a batch: its config, and the options of it the batch sets itself."""

    config: type  #: the stage's config class (``NavigateConfig``, ...)
    input_param: str  #: the record's field in the config
    outputs: dict = field(default_factory=dict)  #: output field -> file suffix, written for every record
    plots: dict = field(default_factory=dict)  #: output field -> suffix, written with plots
    summary: bool = False  #: the batch writes the result's JSON (the stage has no JSON output of its own)
    dropped: tuple = ()  #: other options a batch does not offer
    many: bool = False  #: the record's field takes several records (calibrate: one per batch record)
    #: fields that a batch pairs with each record instead of taking one value: field -> (the command
    #: line's option, its help); given files, folders or globs (:func:`sizefx.batch.inputs.pair_inputs`)
    paired: dict = field(default_factory=dict)

    def named(self) -> set:
        """The fields the batch sets itself: the record, the outputs and plots, force, the dropped."""
        return {self.input_param, "force", *self.outputs, *self.plots, *self.dropped}


#: The stages a batch runs, and what it names itself in each.
BATCH_STAGES = {
    "navigate": BatchStage(
        NavigateConfig, "input", {"output": ".nav.h5", "json_path": ".navigate.json"}, {"plot": ".navigate.png"}
    ),
    "compensate": BatchStage(CompensateConfig, "input", {"output": ".compensated.h5"}, summary=True),
    "calibrate": BatchStage(
        CalibrateConfig, "records", {"json_path": ".levers.json"}, {"plot": ".calibrate.png"}, many=True
    ),
    "diagnose": BatchStage(
        DiagnoseConfig,
        "input",
        {"json_path": ".diagnosis.json", "model_out": ".model.toml"},
        {"plots": ".diagnose-plots"},
    ),
    "inspect": BatchStage(InspectConfig, "file", summary=True, dropped=("json_path",)),
    "compare": BatchStage(
        CompareConfig,
        "a",
        {"json_path": ".comparison.json"},
        {"plots_dir": ".compare-plots"},
        paired={
            "b": (
                "--against",
                "B for each record A: the solutions to compare with (a file for every record, or "
                "folders or globs, paired by name: flight07.nav.h5 with flight07.nav.h5 or flight07.h5).",
            ),
            "reference": (
                "--reference",
                "The truth for each record (a file for every record, or folders or globs of "
                "records or solutions, paired by name as --against).",
            ),
        },
    ),
}

#: The stages a chain holds, and their configs.
CHAIN_CONFIGS = {"calibrate": CalibrateConfig, "navigate": NavigateConfig, "compare": CompareConfig}
#: Per chained stage: the options of its config the chain sets itself (its outputs, which the chain
#: names in its folder, and the inputs the chain passes from the stage before).
CHAIN_NAMED = {
    "calibrate": ("json_path", "plot", "force"),
    "navigate": ("output", "json_path", "plot", "force"),
    "compare": ("a", "b", "json_path", "plots_dir", "force"),
}


def batch_stage(stage: str) -> BatchStage:
    """The batch of ``stage``, or a one-line refusal naming the stages a batch runs."""
    if stage not in BATCH_STAGES:
        raise ConfigError(f"batch {stage!r}: no such stage; a batch runs {', '.join(BATCH_STAGES)} or run (a chain)")
    return BATCH_STAGES[stage]


def batch_options(stage: str) -> tuple:
    """The field names of the options a batch of ``stage`` offers, as its config declares them, in
    their order (the paired ones not among them)."""
    spec = batch_stage(stage)
    skip = spec.named() | set(spec.paired)
    return tuple(name for name, _ in declared(spec.config) if name not in skip)


def chain_options(stage: str) -> tuple:
    """The field names of the options ``stage`` takes in a chain, in its config's order (the record
    that the chain reads included: navigate's ``input``, calibrate's ``records``)."""
    return tuple(name for name, _ in declared(CHAIN_CONFIGS[stage]) if name not in CHAIN_NAMED[stage])


def _plain(value):
    """A value as the command line gives it: a path as text, a list as a tuple."""
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    if isinstance(value, (list, tuple)):
        return tuple(_plain(v) for v in value)
    return value


def _declared_values(config) -> dict:
    """Every declared option of the config ``config`` by field name, a :func:`group`'s in its place."""
    values = {}
    for f in dataclasses.fields(config):
        if "group" in f.metadata:
            values.update(_declared_values(getattr(config, f.name)))
        elif "option" in f.metadata:
            values[f.name] = getattr(config, f.name)
    return values


def option_values(config_class: type, given, *, offered, where: str) -> dict:
    """The options a caller in Python gives a stage of ``config_class`` that runs as a batch's record
    or a chain's step, complete as the command line gives them: every option named in ``offered``
    (field names), those ``given`` first in their order, the others at their declared default (an
    option without one left out). Paths come back as text and sequences as tuples, so that the
    manifest and run.json hold what the command would write.

    ``given``: None, a mapping by field name, or a config whose declared options are read (a
    :func:`group`'s, such as navigate's ``NavConfig``, or the stage's own config as a template: the
    options ``offered`` leaves out, its record and outputs, are not read from it). A name the config
    does not declare, or one that ``offered`` leaves out (the batch or the chain names it), is
    refused in one line (:class:`~sizefx.errors.ConfigError`) that begins with ``where``."""
    offered = tuple(offered)
    declared_here = {name: option for name, option in declared(config_class)}
    if given is None:
        values = {}
    elif dataclasses.is_dataclass(given) and not isinstance(given, type):
        values = {k: v for k, v in _declared_values(given).items() if k in offered}
    elif hasattr(given, "keys"):
        values = dict(given)
        for name in values:
            if name not in declared_here:
                raise ConfigError(
                    f"{where}: {config_class.__name__} has no option {name!r}; give some of {', '.join(offered)}"
                )
            if name not in offered:
                raise ConfigError(
                    f"{where}: {name!r} is not an option here: the batch or the chain sets it (the record, "
                    "the outputs, force); leave it out"
                )
    else:
        raise ConfigError(f"{where}: give the options as a dict by name or a config, not {type(given).__name__}")
    out = {name: _plain(value) for name, value in values.items()}
    for name in offered:
        if name not in out and declared_here[name].default is not MISSING:
            out[name] = declared_here[name].default
    return out
