"""``sizefx batch STAGE [STAGE OPTIONS] INPUTS... --out DIR``: one stage over many records.

Each batch command is made from the single-file command itself: the same click options (less the
record argument and the output paths, which the batch names in DIR: the table
:data:`sizefx.configs.batch.BATCH_STAGES`), so an option can never mean something else in a batch.
The command parses them and calls :func:`sizefx.batch.run`, which builds every record's config
from the same declarations, runs the batch and keeps the manifest; it prints the progress and the
result.
"""

from __future__ import annotations

import importlib
import json
import sys

import click

from sizefx.configs.batch import BATCH_STAGES, MAX_WORKERS, MEMORY_MIB_RANGE, batch_options

from .options import quiet_option, span


class BatchProgress:
    """The batch's progress on stderr: a bar (records done, rate, time left) on a terminal, a plain line
    per record otherwise, a JSON object per record with ``--json-progress`` (for schedulers)."""

    def __init__(self, stage: str, json_lines: bool, quiet: bool):
        self.stage, self.json_lines, self.quiet = stage, json_lines, quiet
        self.bar = None

    def __call__(self, event: dict):
        if self.json_lines:
            click.echo(json.dumps({"stage": self.stage, **event}), err=True)
            return
        if self.quiet:
            return
        if sys.stderr.isatty():
            if self.bar is None:
                from tqdm import tqdm

                self.bar = tqdm(
                    total=event["total"],
                    desc=f"batch {self.stage}",
                    unit=" records",
                    file=sys.stderr,
                    dynamic_ncols=True,
                )
            self.bar.set_postfix(
                ok=event["ok"],
                refused=event["refused"],
                failed=event["failed"],
                unchanged=event["skipped"],
                refresh=False,
            )
            self.bar.update(1)
            if event["done"] >= event["total"]:
                self.bar.close()
            return
        left = "" if event["eta_s"] is None else f", {event['eta_s']:.0f} s left"
        click.echo(
            f"batch {self.stage}: {event['done']}/{event['total']} {event['record']} {event['status']}; "
            f"{event['ok']} ok, {event['skipped']} unchanged, {event['refused']} refused, {event['failed']} "
            f"failed; {event['records_per_s']:.3g} records/s{left}",
            err=True,
        )


def batch_params(record_plots: bool, chain: bool = False) -> list:
    """The options every batch command has (``sizefx batch STAGE`` and ``sizefx batch run``). A chain
    checks --out itself (click would ask for it before a chained stage's --help)."""
    return [
        click.Option(
            ["--out", "out_dir"],
            required=not chain,
            type=click.Path(file_okay=False),
            help="Folder for every record's outputs and manifest.json (made if new; not inside an "
            "input folder)." + (" Required." if chain else ""),
        ),
        click.Option(
            ["--workers"],
            type=click.IntRange(1, MAX_WORKERS),
            help="Worker processes [default: the cores]; each loads the kernels once.",
        ),
        click.Option(
            ["--memory-per-worker-mib", "memory_mib"],
            type=span(*MEMORY_MIB_RANGE),
            help="Each local worker's memory bound [MiB]: a record that needs more fails alone "
            "(MemoryError) [default: 80 % of the machine's memory over the workers].",
        ),
        click.Option(
            ["--redo"],
            is_flag=True,
            help="Run every record again, even those whose input, options and outputs match the manifest.",
        ),
        click.Option(
            ["--rehash"],
            is_flag=True,
            help="Hash every input and output again instead of trusting a file whose size, times and "
            "inode are those it had when hashed (a file system whose clock cannot be trusted).",
        ),
        click.Option(
            ["--scheduler"],
            metavar="tcp://HOST:PORT",
            help="Run on this Dask scheduler's cluster instead of local workers (the 'distributed' "
            "package: pip install 'sizefx[dask]'); the workers must see the records' paths.",
        ),
        click.Option(
            ["--json-progress"], is_flag=True, help="Progress as one JSON object per record on stderr (for schedulers)."
        ),
        click.Option(
            ["--with-plots", "plots"],
            is_flag=True,
            help="Also write fleet.png into --out, the headline figures across the records"
            + (
                ", and each record's plots beside its other outputs (named after the record, where the "
                "single command's --plot FILE or --plots DIR would go)."
                if record_plots
                else "."
            ),
        ),
    ]


def _make(name: str) -> click.Command:
    spec = BATCH_STAGES[name]
    single = getattr(importlib.import_module(f"sizefx_cli.{name}"), name)
    offered = set(batch_options(name))
    stage_params = [p for p in single.params if p.name in offered]
    paired_params = [
        click.Option(
            [flag, f"paired_{param}"],
            multiple=True,
            type=click.Path(),
            help=text,
            required=param == "b",
            metavar="PATH",
        )
        for param, (flag, text) in spec.paired.items()
    ]
    params = [
        click.Argument(["inputs"], nargs=-1, required=True, type=click.Path()),
        *stage_params,
        *paired_params,
        *batch_params(bool(spec.plots)),
    ]

    def callback(
        inputs, out_dir, workers, memory_mib, redo, rehash, scheduler, json_progress, quiet, plots=False, **options
    ):
        from sizefx.batch import run

        options.update({param: options.pop(f"paired_{param}") for param in spec.paired})
        result = run(
            name,
            inputs,
            out_dir,
            options=options,
            workers=workers,
            memory_mib=memory_mib,
            scheduler=scheduler,
            redo=redo,
            rehash=rehash,
            with_plots=plots,
            progress=BatchProgress(name, json_progress, quiet),
        )
        click.echo(result.report())
        if not result.all_ok:
            sys.exit(1)

    help_text = (
        f"sizefx {name} over many records, in parallel, into one folder.\n\n"
        f"INPUTS: record files, folders of them (*.h5) or globs. Each record goes through the "
        f"same stage code as 'sizefx {name}' with the options below (see sizefx {name} --help); its "
        f"outputs are named after it in --out, with manifest.json (sizefx/batch/1): per record the input's "
        f"SHA-256, the options, the outputs, the status (ok, refused with its reason, failed), duration, "
        f"peak memory and headline figures. A re-run skips records whose input, options and outputs "
        f"match (--redo to force), deciding from each file's stat where it is the one the file had when "
        f"hashed (--rehash to hash them all again). Exit code 0 when every record succeeded, 1 otherwise, 2 for bad input."
    )
    return quiet_option(
        click.Command(
            name, params=params, callback=callback, help=help_text, short_help=f"sizefx {name} over many records."
        )
    )


@click.group()
def batch():
    """One stage over many records: all cores, one folder, a manifest, resumable."""


for _name in BATCH_STAGES:
    batch.add_command(_make(_name))
