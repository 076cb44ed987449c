"""``sizefx run --out DIR calibrate T.h5 navigate F.h5 compare``: stages chained in one command, and
``sizefx batch run --out DIR calibrate T.h5 navigate FLIGHTS compare``: the chain per flight.

Each stage of the chain is the single-file command's own (its click options), less the output
paths, which the chain names in DIR (:data:`sizefx.configs.batch.CHAIN_NAMED`). The commands parse
the chain and call :func:`sizefx.chain.run` (which refuses a chain that cannot work before any
stage runs, builds each stage's config from the same declarations and runs them) or, per flight,
:func:`sizefx.batch.run` with the stage ``run``; they print what those return.
"""

from __future__ import annotations

import importlib
import sys

import click

from sizefx.configs.batch import CHAIN_CONFIGS, chain_options

from .batch import BatchProgress, batch_params
from .options import quiet_option


def _records(record, also, **options):
    """calibrate's records in a chain: RECORD and every --with (a chained command's argument cannot take
    a variable number of values: it would swallow the next stages)."""
    return {"records": (record, *also), **options}


def _link(name: str, batch: bool) -> click.Command:
    """The chain's ``name`` command: the single-file command's parameters; returns them for the chain.
    In a batch, navigate's FILE may also be a folder of flights or a (quoted) glob."""
    single = getattr(importlib.import_module(f"sizefx_cli.{name}"), name)
    offered = set(chain_options(name))
    params = [p for p in single.params if p.name in offered]

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
    from sizefx import chain

    result = chain.run(steps, out_dir, with_plots=plots, echo=lambda title, text: click.echo(f"{title}\n{text}"))
    names = " -> ".join(name for name, _ in steps)
    click.echo(f"run: {names}; every output and run.json in {result.out_dir}\n{result.summary()}")


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
    from sizefx.batch import run

    # navigate's FILE is the flights (a file, a folder or a glob): the batch's inputs
    flights = [options["input"] for name, options in steps if name == "navigate"][-1:]
    stages = [
        (name, {k: v for k, v in options.items() if not (name == "navigate" and k == "input")})
        for name, options in steps
    ]
    result = run(
        "run",
        flights,
        out_dir,
        options=stages,
        workers=workers,
        memory_mib=memory_mib,
        scheduler=scheduler,
        redo=redo,
        rehash=rehash,
        with_plots=plots,
        progress=BatchProgress("run", json_progress, quiet),
        echo=None if quiet else (lambda title, text: click.echo(f"{title}\n{text}")),
    )
    click.echo(result.report())
    if not result.all_ok:
        sys.exit(1)


for _name in CHAIN_CONFIGS:
    run.add_command(_link(_name, batch=False))
    batch_run.add_command(_link(_name, batch=True))
batch_run = quiet_option(batch_run)
