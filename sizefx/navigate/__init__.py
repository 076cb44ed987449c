"""Strapdown navigation on WGS-84: the ``navigate`` stage.

The package, from the bottom up:

- :mod:`.config`: the constants, each with its reason (the options, :class:`NavConfig`, are declared in
  :mod:`sizefx.configs.navigate`);
- :mod:`.result`: the result (:class:`NavResult`) and the summary lines that present it;
- :mod:`.steps`: the sampling grid, rates to increments, the strapdown kernel call;
- :mod:`.initial`: the initial state, from ``/reference`` or by static alignment;
- :mod:`.reference`: ``/reference`` by time window and the errors against it;
- :mod:`.loop`: the one loop (read chunk, correct, integrate, write) for files and records in memory;
- :mod:`.output`: the error plot (the ``sizefx/navigation/1`` file is :mod:`sizefx.io.navigation`'s);
- here: the stage, :func:`run` of a :class:`NavigateConfig` (declared in :mod:`sizefx.configs.navigate`),
  as ``sizefx navigate`` calls it.
"""

from __future__ import annotations

import importlib
import time
from dataclasses import replace
from pathlib import Path

from ..configs.navigate import NavigateConfig
from ..io.documents import write_json
from ..stage import preflight
from .config import CHUNK_SAMPLES, GAPS_WHY, NavConfig
from .result import NavResult, format_summary

__all__ = [
    "NavConfig",
    "NavResult",
    "NavigateConfig",
    "navigate",
    "navigate_file",
    "navigate_source",
    "run",
    "coarse_alignment",
    "increments_of",
    "format_summary",
    "preload",
    "plot_errors",
    "check_plottable",
    "CHUNK_SAMPLES",
    "GAPS_WHY",
]


#: The names this package gives from its modules that load Numba, imported when first used (PEP 562),
#: so that the options and the config are read without it (``sizefx batch`` decides a re-run from them).
_LAZY = {
    "navigate": ".loop",
    "navigate_file": ".loop",
    "navigate_source": ".loop",
    "coarse_alignment": ".initial",
    "check_plottable": ".output",
    "plot_errors": ".output",
    "increments_of": ".steps",
}


def preload() -> None:
    """Import what :func:`run` imports when it runs (the loop and its kernels, the solution's writer, the
    plot) and set up Numba's target: a batch worker calls it as it starts
    (:func:`sizefx.batch.worker._start_worker`), so that its first record costs what the next ones cost."""
    from ..io import navigation  # noqa: F401
    from ..kernels.jit import load_target
    from . import loop, output  # noqa: F401

    load_target()


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name], __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def run(config: NavigateConfig, *, progress=None) -> NavResult:
    """Navigate ``config.input``; write what was asked; return the result (``report()`` prints it).

    The file is streamed in chunks (:func:`navigate_file`, memory bounded by the chunk);
    ``chunk_samples=0`` reads it whole and navigates in memory (:func:`navigate`): the same
    loop with one chunk, the same figures.
    """
    started = time.perf_counter()
    from ..effects import IDEAL, load_effects
    from ..io.navigation import NavigationWriter, write_navigation
    from .loop import navigate, navigate_file
    from .output import check_plottable, plot_errors

    cfg = config.options
    preflight(inputs=config.inputs(), outputs=config.outputs(), force=config.force)
    if config.model is not None:
        cfg = replace(cfg, model=load_effects(config.model, base=IDEAL))  # a section the file omits is off
    path = config.input
    written = {option: value for option, value in config.outputs().items() if value}  # each, or an error
    # refused before any work when one of them would hold nothing (a record shorter than an output row)
    outputs = tuple(option for option in written if option != "--json")
    if config.chunk_samples == 0:
        from ..io.telemetry import read_telemetry

        res = navigate(read_telemetry(path, allow_gaps=cfg.allow_gaps, segment=cfg.segment), cfg, outputs=outputs)
        published = time.perf_counter()
        if config.plot:
            check_plottable(res)
        if config.output:
            write_navigation(config.output, res, input_file=path, force=config.force)
    else:
        writer = NavigationWriter(config.output, input_file=path, force=config.force) if config.output else None
        try:
            res = navigate_file(
                path, cfg, chunk_samples=config.chunk_samples, progress=progress, writer=writer, outputs=outputs
            )
            published = time.perf_counter()
            if config.plot:  # before the solution is published: a refusal leaves nothing behind
                check_plottable(res)
        except BaseException as exc:
            if writer is not None:
                writer.abort(exc)
            raise
        if writer is not None:
            writer.close(res.config, res.summary)
    if config.json_path:
        write_json(config.json_path, res.to_json(), inputs=[path], force=config.force)
    if config.plot:
        plot_errors(res, config.plot, f"{Path(path).name}: free-inertial position error")
    phases = None
    if res.phases_s is not None:  # the stage's own time around the loop's phases
        ended = time.perf_counter()
        loop = {**res.phases_s, "write": res.phases_s["write"] + ended - published}
        phases = {"open_checks": ended - started - sum(loop.values()), **loop}
    # the loop's solution, with what only the stage knows: the path as given, the files, the whole time
    return replace(res, path=str(path), written=written, phases_s=phases)
