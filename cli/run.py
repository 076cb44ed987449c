"""``sizefx run --out DIR calibrate T.h5 navigate F.h5 compare``: stages chained in one command, and
``sizefx batch run --out DIR calibrate T.h5 navigate FLIGHTS compare``: the chain per flight.

Each stage of the chain is the single-file command's own (its click options, and its config made
from them by :func:`sizefx.options.config_from`), less the output paths, which the chain names in
DIR: calibrate's lever arms go to navigate, which navigates the flight plain and compensated with
them, and compare sets the two solutions against the flight's reference. Which chains can work is :func:`sizefx.chain.check_chain`'s, decided with
every input checked before any stage runs; the steps run in :func:`sizefx.chain.run`. In a batch,
calibrate runs once and each flight's navigate and compare steps are a batch record
(:func:`sizefx.batch.run_batch`), into ``DIR/NAME/``.
"""

from __future__ import annotations

import importlib
import sys
from pathlib import Path

import click

from sizefx.options import config_from

from .batch import BatchProgress, batch_params
from .options import quiet_option

#: Per chained stage: the single-file command's options a chain does not offer (its outputs, which
#: the chain names in DIR, and the inputs the chain passes from the stage before).
_DROPPED = {
    "calibrate": ("json_path", "plot", "force"),
    "navigate": ("output", "json_path", "plot", "force", "quiet"),
    "compare": ("a", "b", "json_path", "plots_dir", "force"),
}


def _records(record, also, **options):
    """calibrate's records in a chain: RECORD and every --with (a chained command's argument cannot take
    a variable number of values: it would swallow the next stages)."""
    return {"records": (record, *also), **options}


def _link(name: str, batch: bool) -> click.Command:
    """The chain's ``name`` command: the single-file command's parameters; returns them for the chain.
    In a batch, navigate's FILE may also be a folder of flights or a (quoted) glob."""
    single = getattr(importlib.import_module(f"sizefx_cli.{name}"), name)
    params = [p for p in single.params if p.name not in _DROPPED[name]]

    def callback(**options):
        return name, options

    if name == "calibrate":
        params = [
            click.Argument(["record"], type=click.Path(dir_okay=False)),
            click.Option(
                ["--with", "also"],
                multiple=True,
                type=click.Path(dir_okay=False),
                help="Another record fitted jointly (a sway for the delay); repeat for more.",
            ),
            *[p for p in params if p.name != "records"],
        ]

        def callback(**options):
            return name, _records(**options)

    if name == "navigate" and batch:
        params = [
            click.Argument(["input"], type=click.Path(), metavar="FILE") if p.name == "input" else p for p in params
        ]
    where = "see sizefx batch run --help" if batch else "see sizefx run --help"
    return click.Command(
        name,
        params=params,
        callback=callback,
        help=f"{single.help}\n\nIn a chain: outputs go to --out; {where}.",
        short_help=single.get_short_help_str(),
    )


def _checked(steps, out_dir, *, batch: bool):
    """The chain's stages and options, refused in one line before anything runs or is written when it
    cannot work; with the navigate FILE expanded to its flights in a batch."""
    from sizefx.batch.inputs import check_option_files, check_out_dir, expand_inputs
    from sizefx.chain import check_chain, check_truth
    from sizefx.errors import ConfigError

    command = "sizefx batch run" if batch else "sizefx run"
    chain = dict(steps)
    names = [name for name, _ in steps]
    nav = chain.get("navigate", {})
    check_chain(names, navigate_corrects=bool(nav.get("levers") or nav.get("model")), command=command)
    if not out_dir:
        named = nav.get("input") or next(iter(chain.get("calibrate", {}).get("records", ())), None)
        if batch or not named:
            raise ConfigError(f"{command}: give --out DIR, the folder for every stage's outputs")
        out_dir = f"run-{Path(named).stem}"  # the everyday form: sizefx run calibrate T.h5 navigate F.h5 compare
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
    flights = expand_inputs([nav["input"]]) if batch else ([Path(nav["input"])] if nav.get("input") else [])
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
    out = check_out_dir(
        out_dir, [nav["input"]] if batch else [], [*(Path(p).resolve() for p in given.values() if p), *flights]
    )
    return names, chain, nav, flights, out


def _nominal_file(nominal):
    """calibrate --nominal when it names a file (not one of the presets)."""
    from sizefx.geometry import PRESETS

    return nominal if nominal and nominal not in PRESETS else None


def _calibrate_step(chain, out: Path, plots: bool):
    from sizefx.chain import ChainStep
    from sizefx.configs.calibrate import CalibrateConfig

    options = chain["calibrate"]
    levers = str(out / "levers.json")
    given = {**options, "json_path": levers, "force": True, "plot": str(out / "calibrate.png") if plots else None}
    return ChainStep("calibrate", None, config_from(CalibrateConfig, given), options), levers


def _flight_steps(chain, nav, flight, levers, out: Path, plots: bool) -> list:
    """navigate the flight plain (and compensated, with lever arms), then compare, into ``out``."""
    from sizefx.chain import ChainStep

    steps, solutions = [], {}
    if nav:
        from sizefx.configs.navigate import NavigateConfig

        runs = [("plain", {"levers": None, "model": None})]
        if levers or nav.get("model"):  # the correction: calibrate's or --levers' arms, or a --model
            runs.append(("compensated", {"levers": levers, "model": nav.get("model")}))
        for label, correction in runs:
            solutions[label] = str(out / f"{label}.nav.h5")
            steps.append(
                ChainStep(
                    "navigate",
                    label,
                    config_from(
                        NavigateConfig,
                        {
                            **nav,
                            "input": str(flight),
                            **correction,
                            "output": solutions[label],
                            "json_path": str(out / f"{label}.navigate.json"),
                            "force": True,
                            "plot": str(out / f"{label}.navigate.png") if plots else None,
                        },
                    ),
                    {**nav, **correction},
                )
            )
    if "compare" in chain:
        from sizefx.configs.compare import CompareConfig

        options = chain["compare"]
        given = {
            **options,
            "a": solutions["compensated"],
            "b": solutions["plain"],
            "reference": options.get("reference") or str(flight),
            "json_path": str(out / "comparison.json"),
            "plots_dir": str(out / "compare-plots") if plots else None,
            "force": True,
        }
        steps.append(ChainStep("compare", None, config_from(CompareConfig, given), options))
    return steps


@click.group(chain=True)
@click.option(
    "--out",
    "out_dir",
    type=click.Path(file_okay=False),
    help="Folder for every stage's outputs and run.json (made if new) [default: run-NAME in the "
    "current folder, NAME the flight's file name, or calibrate's record's].",
)
@click.option(
    "--with-plots",
    "plots",
    is_flag=True,
    help="Also write each stage's plots into --out (calibrate.png, plain.navigate.png, "
    "compensated.navigate.png, compare-plots/).",
)
def run(out_dir, plots):
    """Chain calibrate, navigate and compare in one command.

    \b
    sizefx run --out results calibrate turntable.h5 navigate flight.h5 compare
    sizefx run --out r calibrate --with sway.h5 --delay t.h5 navigate f.h5

    In a chain a stage's options come before its file (click's rule for
    chained commands: what follows the file belongs to the next stage).

    calibrate's lever arms (levers.json) go to navigate, which navigates the
    flight twice, plain and compensated (or, without calibrate, with its own
    --levers or --model); compare sets the compensated solution against the plain one and
    both against the flight's /reference (or compare --reference). Every stage
    option keeps its meaning (see each stage's --help). A chain that cannot
    work is refused before any stage runs; run.json (sizefx/run/1) lists what
    each stage read, wrote and found. For many flights: sizefx batch run.
    """


@run.result_callback()
def _execute(steps, out_dir, plots):
    from sizefx import chain as chain_stage

    names, chain, nav, flights, out = _checked(steps, out_dir, batch=False)
    with chain_stage.chain_folder(out):
        chain_steps, levers = [], nav.get("levers")
        if "calibrate" in chain:
            step, levers = _calibrate_step(chain, out, plots)
            chain_steps.append(step)
        chain_steps += _flight_steps(chain, nav, nav.get("input"), levers, out, plots)
        result = chain_stage.run(
            chain_stage.ChainConfig(tuple(chain_steps), str(out)),
            echo=lambda title, text: click.echo(f"{title}\n{text}"),
        )
    click.echo(f"run: {' -> '.join(names)}; every output and run.json in {out}\n{result.summary()}")


@click.group("run", chain=True, params=batch_params(record_plots=True, chain=True))
def batch_run(**_):
    """A chain per flight: calibrate once, then navigate and compare every flight, in parallel.

    \b
    sizefx batch run --out campaign calibrate turntable.h5 navigate flights/ compare
    sizefx batch run --out c navigate --levers levers.json 'flights/*.h5' compare

    navigate's FILE is a flight, a folder of flights (*.h5) or a quoted glob.
    calibrate (if given) runs first, into DIR (levers.json, run.json); each
    flight is then a batch record: navigated plain and compensated with those
    arms and compared against its own /reference (or compare --reference), into
    DIR/NAME/ with its run.json; DIR/manifest.json (sizefx/batch/1, stage
    'run') lists the flights as sizefx batch does, with the lever arms' hash,
    so that a re-run skips the flights whose inputs, options and arms are
    unchanged. Stage options as in sizefx run (before the stage's file).
    Exit code 0 when every flight succeeded, 1 otherwise, 2 for bad input.
    """


@batch_run.result_callback()
def _execute_batch(steps, out_dir, workers, memory_mib, redo, rehash, scheduler, json_progress, plots, quiet):
    from sizefx.batch.manifest import Manifest
    from sizefx.batch.runner import dask_client

    names, chain, nav, flights, out = _checked(steps, out_dir, batch=True)
    previous = Manifest(out, "run")  # each flight's entry, looked up as its job is made
    client = (
        dask_client(scheduler) if scheduler is not None else None
    )  # refused before calibrate runs or anything is written
    try:
        result = _batch_chain(
            chain, nav, flights, out, previous, client, workers, memory_mib, redo, rehash, json_progress, plots, quiet
        )
    finally:
        if client is not None:
            client.close()
    click.echo(result.report())
    if not result.all_ok:
        sys.exit(1)


def _batch_chain(
    chain, nav, flights, out, previous, client, workers, memory_mib, redo, rehash, json_progress, plots, quiet
):
    """calibrate once into ``out`` (if in the chain), then the chain per flight as a batch."""
    from sizefx import chain as chain_stage
    from sizefx.batch import BatchJob, output_names, run_batch
    from sizefx.batch.inputs import make_out_dir
    from sizefx.batch.manifest import canonical_options
    from sizefx.batch.runner import check_batch_writes, folder_lock
    from sizefx.chain import RUN_MANIFEST

    levers = str(out / "levers.json") if "calibrate" in chain else nav.get("levers")
    # the flights' options (each stage's, flattened: the manifest compares them as JSON)
    options = canonical_options(
        {
            f"{stage}.{k}": v
            for stage, opts in chain.items()
            if stage != "calibrate"
            for k, v in opts.items()
            if not (stage == "navigate" and k == "input")
        }
    )
    flight_names = output_names(flights)
    jobs = []
    for flight in flights:
        folder = out / flight_names[flight]
        config = chain_stage.ChainConfig(
            tuple(_flight_steps(chain, nav, flight, levers, folder, plots)),
            str(folder),
            truth=str(flight) if "compare" in chain and not chain["compare"].get("reference") else None,
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
            RUN_MANIFEST: "calibrate's run.json",
        }
        if "calibrate" in chain
        else {}
    )
    check_batch_writes(out, jobs, own)
    make_out_dir(out)
    with folder_lock(out):
        if "calibrate" in chain:
            step, _ = _calibrate_step(chain, out, plots)
            chain_stage.run(
                chain_stage.ChainConfig((step,), str(out)),
                echo=None if quiet else (lambda title, text: click.echo(f"{title}\n{text}")),
            )
        return run_batch(
            "run",
            jobs,
            out,
            options,
            workers=workers,
            previous=previous,
            progress=BatchProgress("run", len(jobs), json_progress, quiet),
            client=client,
            plots=plots,
            memory_mib=memory_mib,
            locked=True,
            own=own,
            rehash=rehash,
        )


for _name in _DROPPED:
    run.add_command(_link(_name, batch=False))
    batch_run.add_command(_link(_name, batch=True))
batch_run = quiet_option(batch_run)
