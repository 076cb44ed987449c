"""One stage over many records, from Python as from the command line: :func:`run`.

``sizefx.batch.run("navigate", "flights/", "nav", options={"levers": "levers.json"})`` is
``sizefx batch navigate flights/ --levers levers.json --out nav``, and the command is this call: the
records listed (:func:`sizefx.runs.folder.expand_inputs`), compare's other solutions and truths
paired with them by name (:func:`.inputs.pair_inputs`), the folder judged
(:func:`sizefx.runs.folder.check_out_dir`), its manifest read to resume, each record's config made
from the stage's own declarations (:func:`sizefx.options.config_from`) with its outputs named after
it in the folder (:data:`sizefx.configs.batch.BATCH_STAGES`), the files the options name read once
and hashed with every record, and the jobs run (:func:`.runner.run_batch`). ``run("run", ...)`` is a
chain per flight (:mod:`.chains`).
"""

from __future__ import annotations

import os
from dataclasses import MISSING
from pathlib import Path

from ..configs.batch import MAX_WORKERS, MEMORY_MIB_RANGE, BatchStage, batch_options, batch_stage, option_values
from ..errors import ConfigError
from ..options import config_from, declared
from ..runs.folder import check_out_dir, expand_inputs, resolve_path
from . import runner
from .inputs import check_stage_options, output_names, pair_inputs
from .manifest import Manifest, canonical_options
from .outcome import BatchJob, BatchResult

__all__ = ["run"]


def _listed(paths) -> list:
    """One path, or several: a list of them (a file, a folder or a glob each)."""
    if paths is None:
        return []
    if isinstance(paths, (str, os.PathLike)):
        return [paths]
    return list(paths)


def run(
    stage: str,
    inputs,
    out,
    *,
    options=None,
    workers: int | None = None,
    memory_mib: float | None = None,
    scheduler: str | None = None,
    redo: bool = False,
    rehash: bool = False,
    with_plots: bool = False,
    progress=None,
    echo=None,
) -> BatchResult:
    """Run ``stage`` on every record ``inputs`` name, into the folder ``out``: what ``sizefx batch
    STAGE INPUTS --out OUT`` does, with the same outputs and manifest.

    ``stage``: navigate, compensate, calibrate, diagnose, inspect or compare; or ``"run"``, a chain
    per flight (``sizefx batch run``: :func:`.chains.run_chains`). ``inputs``: record files, folders
    of them (``*.h5``) or globs (``runs/**/*.h5``), one or a list. ``options``: the stage's options
    by field name, as its config declares them (``{"levers": "levers.json", "output_rate_hz": 1.0}``),
    or a config to read them from (navigate's ``NavConfig``, or the stage's own config as a template:
    its record and outputs are not read); those left out keep their defaults. The outputs are named
    after each record in ``out`` and are not options. compare's ``b`` and ``reference`` take a file
    for every record, or files, folders or globs paired with each record by name (the command
    line's ``--against`` and ``--reference``). For ``"run"``, ``options`` is the chain as
    :func:`sizefx.chain.run` takes it, less navigate's ``input``: the flights are ``inputs``.

    ``workers``: local worker processes (default: the cores); ``memory_mib``: each one's memory
    bound [MiB]; ``scheduler``: None (or ``"local"``) for local workers, or a Dask scheduler's
    address (``"tcp://HOST:PORT"``) to run on its cluster. ``redo``: run every record again, even
    those the manifest has done with the same input, options and outputs (otherwise skipped: a
    batch resumes where it stopped). ``rehash``: hash every file again instead of trusting its stat.
    ``with_plots``: the figures across the records (``fleet.png``) and each record's plots.
    ``progress(event)`` after each record (a dict: done, total, counts, record, status, rate, time
    left); ``echo(title, report)`` after a chain's calibrate (``"run"``).

    Bad input (no record, a missing option file, a folder of another stage's batch, an option out of
    its range) is refused before anything is written (:class:`~sizefx.errors.ConfigError`); a record
    the stage refuses or that fails is so marked in the result and the manifest, and the others go on.
    """
    if scheduler == "local":
        scheduler = None
    if workers is not None and (
        isinstance(workers, bool) or not isinstance(workers, int) or not 1 <= workers <= MAX_WORKERS
    ):
        raise ConfigError(f"--workers: {workers!r} is not an integer in [1, {MAX_WORKERS}]")
    low, high = MEMORY_MIB_RANGE
    if memory_mib is not None and not (isinstance(memory_mib, (int, float)) and low <= memory_mib <= high):
        raise ConfigError(f"--memory-per-worker-mib: {memory_mib!r} is outside [{low:g}, {high:g}] MiB")
    if stage == "run":
        from .chains import run_chains

        return run_chains(
            options or {},
            inputs,
            out,
            workers=workers,
            memory_mib=memory_mib,
            scheduler=scheduler,
            redo=redo,
            rehash=rehash,
            with_plots=with_plots,
            progress=progress,
            echo=echo,
        )
    spec = batch_stage(stage)
    values = option_values(
        spec.config, options, offered=[*batch_options(stage), *spec.paired], where=f"sizefx batch {stage}"
    )
    values = _resolved_files(spec, values)
    given_pairs = {param: tuple(_listed(values.pop(param, None))) for param in spec.paired}
    for param, (flag, text) in spec.paired.items():
        if not given_pairs[param] and dict(declared(spec.config))[param].default is MISSING:
            raise ConfigError(f"sizefx batch {stage}: give {param!r} ({flag}): {text}")
    inputs = _listed(inputs)
    records = expand_inputs(inputs)
    partners = {
        param: pair_inputs(records, given, spec.paired[param][0]) for param, given in given_pairs.items() if given
    }
    folder = check_out_dir(
        out,
        [*inputs, *(g for given in given_pairs.values() for g in given)],
        [*records, *(p for pairs in partners.values() for p in pairs.values())],
    )
    previous = Manifest(folder, stage)  # each record's entry, looked up as its job is made
    stage_options = canonical_options({**values, **({"plots": True} if with_plots and spec.plots else {})})
    pool, jobs = None, []
    try:
        for job in _jobs(stage, spec, records, partners, values, stage_options, folder, previous, redo, with_plots):
            jobs.append(job)
            # the workers start once the first record's options are judged, while the other configs
            # are built; not for a re-run or a resume, whose records the stat cache may find done
            # without any worker
            if len(jobs) == 1 and scheduler is None and (redo or rehash or not previous.has_entries()):
                pool = runner.start_workers(stage, runner.local_workers(workers, len(records)), memory_mib)
        return runner.run_batch(
            stage,
            jobs,
            folder,
            stage_options,
            workers=workers,
            previous=previous,
            progress=progress,
            scheduler=scheduler,
            plots=with_plots,
            memory_mib=memory_mib,
            pool=pool,
            rehash=rehash,
        )
    finally:  # a refusal before the run: the workers, still starting, are let go
        if pool is not None:
            pool.shutdown(wait=False, cancel_futures=True)


def _resolved_files(spec: BatchStage, values: dict) -> dict:
    """``values`` with every option that names a file made absolute, as the records' paths are: the
    manifest then says which file each record was run with wherever the batch is run from, and a
    re-run from another folder with the same file judges it unchanged. compare's paired files stay
    as given (folders and globs, matched by name)."""
    options = dict(declared(spec.config))
    out = dict(values)
    for name, value in values.items():
        option = options.get(name)
        if option is None or option.kind not in ("file", "folder", "path") or name in spec.paired or not value:
            continue
        if option.many:
            out[name] = tuple(str(resolve_path(v, option.name)) for v in value)
        else:
            out[name] = str(resolve_path(value, option.name))
    return out


def _jobs(stage, spec: BatchStage, records, partners, options, stage_options, out: Path, previous, redo, plots):
    """The batch's job for each record (:class:`.outcome.BatchJob`), in the records' order, made one
    at a time (the caller starts the workers after the first).

    ``partners``: paired field -> {record: its partner}; ``options``: the stage's options by field
    name, complete; ``previous``: the folder's manifest, whose entry each job carries. Every record's
    config is the stage's own (:func:`sizefx.options.config_from`) with its record, its outputs named
    after it in ``out`` and ``force``. The files its options name (``--levers``, ``--model``,
    ``--nominal``, compare's B and truth) are read once, with the first record's, before any work
    (every record would refuse the same bad one), and hashed with each record, so that a
    re-calibration into the same levers.json runs the records again."""
    accepted = {name for name, _ in declared(spec.config)}
    names = output_names(records)
    for k, record in enumerate(records):
        outputs = {p: str(out / (names[record] + suffix)) for p, suffix in spec.outputs.items()}
        if plots:
            outputs.update({p: str(out / (names[record] + suffix)) for p, suffix in spec.plots.items()})
        paired = {param: str(pairs[record]) for param, pairs in partners.items()}
        given = {
            **options,
            **{p: None for p in spec.plots},
            **outputs,
            "force": True,
            **{param: None for param in spec.paired},
            **paired,
            spec.input_param: (str(record),) if spec.many else str(record),
        }
        config = config_from(spec.config, {key: v for key, v in given.items() if key in accepted})
        option_files = {key: str(v) for key, v in config.inputs().items() if str(key).startswith("-") and v}
        if k == 0:
            check_stage_options(config)  # its options, and its option files by their readers
        yield BatchJob(
            stage,
            str(record),
            names[record],
            config,
            stage_options,
            outputs,
            str(out / f"{names[record]}.{stage}.json") if spec.summary else None,
            previous.entry(str(record)),
            redo,
            {**option_files, **{spec.paired[param][0]: path for param, path in paired.items()}},
        )
