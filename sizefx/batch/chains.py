"""A chain per flight (``sizefx batch run``): calibrate once into the folder, then each flight
navigated plain and compensated and compared, as a batch record of the stage ``run`` into
``DIR/NAME/`` (each its own :class:`sizefx.chain.ChainConfig`, run by :func:`sizefx.chain.run` in
a worker), listed in the folder's manifest with the lever arms' hash, so that a re-run skips the
flights whose inputs, options and arms are unchanged."""

from __future__ import annotations

from .. import chain as chain_stage
from ..runs.folder import folder_lock, make_out_dir
from . import runner
from .folder import check_batch_writes
from .inputs import output_names
from .manifest import Manifest, canonical_options
from .outcome import BatchJob, BatchResult

__all__ = ["run_chains"]


def run_chains(
    stages,
    flights,
    out,
    *,
    workers: int | None = None,
    memory_mib: float | None = None,
    scheduler: str | None = None,
    redo: bool = False,
    rehash: bool = False,
    with_plots: bool = False,
    progress=None,
    echo=None,
) -> BatchResult:
    """The chain ``stages`` (as :func:`sizefx.chain.run` takes it, less navigate's ``input``) on every
    flight ``flights`` name (files, folders or globs) into ``out``: :func:`sizefx.batch.run` with the
    stage ``"run"``, whose arguments these are. A chain that cannot work, and a scheduler that cannot
    be reached, are refused before calibrate runs or anything is written."""
    chain = chain_stage.check_stages(stages, out, flights=[] if flights is None else flights)
    previous = Manifest(chain.out, "run")  # each flight's entry, looked up as its job is made
    client = runner.dask_client(scheduler) if scheduler is not None else None
    try:
        return _run(chain, previous, client, workers, memory_mib, redo, rehash, with_plots, progress, echo)
    finally:
        if client is not None:
            client.close()


def _run(chain, previous, client, workers, memory_mib, redo, rehash, plots, progress, echo) -> BatchResult:
    """calibrate once into the folder (if in the chain), then the chain per flight as a batch."""
    out = chain.out
    levers = str(out / "levers.json") if "calibrate" in chain.stages else chain.navigate.get("levers")
    # the flights' options (each stage's, flattened: the manifest compares them as JSON)
    options = canonical_options(
        {
            f"{stage}.{k}": v
            for stage, opts in chain.stages.items()
            if stage != "calibrate"
            for k, v in opts.items()
            if not (stage == "navigate" and k == "input")
        }
    )
    flight_names = output_names(chain.flights)
    jobs = []
    for flight in chain.flights:
        folder = out / flight_names[flight]
        config = chain_stage.ChainConfig(
            tuple(chain_stage.flight_steps(chain, flight, levers, folder, plots)),
            str(folder),
            truth=str(flight) if "compare" in chain.stages and not chain.stages["compare"].get("reference") else None,
        )
        # the files the chain reads besides the flight (the lever arms, a --model, compare's
        # --reference) are hashed with it: a new calibration reruns the flights
        jobs.append(
            BatchJob(
                "run",
                str(flight),
                flight_names[flight],
                config,
                options,
                {"folder": str(folder)},
                previous=previous.entry(str(flight)),
                redo=redo,
                paired={k: str(v) for k, v in config.inputs().items() if str(v) != str(flight)},
            )
        )
    # calibrate's files are the chain's own: no flight's folder may take their names, and nothing is
    # written (calibrate neither) before every path is checked
    own = (
        {
            "levers.json": "calibrate's lever arms",
            "calibrate.png": "calibrate's plot",
            chain_stage.RUN_MANIFEST: "calibrate's run.json",
        }
        if "calibrate" in chain.stages
        else {}
    )
    check_batch_writes(out, jobs, own)
    make_out_dir(out)
    with folder_lock(out):
        if "calibrate" in chain.stages:
            step, _ = chain_stage.calibrate_step(chain, out, plots)
            chain_stage.run(chain_stage.ChainConfig((step,), str(out)), echo=echo)
        return runner.run_batch(
            "run",
            jobs,
            out,
            options,
            workers=workers,
            previous=previous,
            progress=progress,
            client=client,
            plots=plots,
            memory_mib=memory_mib,
            locked=True,
            own=own,
            rehash=rehash,
        )
