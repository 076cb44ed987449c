"""``sizefx batch STAGE [STAGE OPTIONS] INPUTS... --out DIR``: one stage over many records.

Each batch command is made from the single-file command itself: the same click options (less the
record argument and the output paths, which the batch names in DIR), turned into the stage's
config by the same declarations (:func:`sizefx.options.config_from` of the command's
``config_class``), so an option can never mean something else in a batch. The work and the manifest are :mod:`sizefx.batch`'s.
"""

from __future__ import annotations

import importlib
import json
import sys
from dataclasses import dataclass, field

import click

from sizefx.options import config_from, declared

from .options import quiet_option, span


@dataclass(frozen=True)
class _Stage:
    """How a stage's command becomes a batch command."""

    input_param: str  #: the record argument of the single-file command
    outputs: dict = field(default_factory=dict)  #: output option -> file suffix, written for every record
    plots: dict = field(default_factory=dict)  #: output option -> suffix, written with --with-plots
    summary: bool = False  #: the batch writes the result's JSON (the stage has no JSON output of its own)
    dropped: tuple = ()  #: other options a batch does not offer
    many: bool = False  #: the record argument takes several records (calibrate: one per batch record)
    #: arguments or options of the single-file command that a batch pairs with each record instead:
    #: parameter -> (the batch's option, its help); given files, folders or globs (:func:`pair_inputs`)
    paired: dict = field(default_factory=dict)


STAGES = {
    "navigate": _Stage(
        "input", {"output": ".nav.h5", "json_path": ".navigate.json"}, {"plot": ".navigate.png"}, dropped=("quiet",)
    ),
    "compensate": _Stage("input", {"output": ".compensated.h5"}, summary=True),
    "calibrate": _Stage("records", {"json_path": ".levers.json"}, {"plot": ".calibrate.png"}, many=True),
    "diagnose": _Stage(
        "input", {"json_path": ".diagnosis.json", "model_out": ".model.toml"}, {"plots": ".diagnose-plots"}
    ),
    "inspect": _Stage("file", summary=True, dropped=("json_path",)),
    "compare": _Stage(
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


class BatchProgress:
    """The batch's progress on stderr: a bar (records done, rate, time left) on a terminal, a plain line
    per record otherwise, a JSON object per record with ``--json-progress`` (for schedulers)."""

    def __init__(self, stage: str, total: int, json_lines: bool, quiet: bool):
        self.stage, self.total, self.json_lines, self.quiet = stage, total, json_lines, quiet
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
                    total=self.total, desc=f"batch {self.stage}", unit=" records", file=sys.stderr, dynamic_ncols=True
                )
            self.bar.set_postfix(
                ok=event["ok"],
                refused=event["refused"],
                failed=event["failed"],
                unchanged=event["skipped"],
                refresh=False,
            )
            self.bar.update(1)
            if event["done"] >= self.total:
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
            type=click.IntRange(1, 1024),
            help="Worker processes [default: the cores]; each loads the kernels once.",
        ),
        click.Option(
            ["--memory-per-worker-mib", "memory_mib"],
            type=span(256.0, 2.0**40),
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


def _make(name: str, spec: _Stage) -> click.Command:
    single = getattr(importlib.import_module(f"sizefx_cli.{name}"), name)
    skip = {spec.input_param, "force", *spec.outputs, *spec.plots, *spec.dropped, *spec.paired}
    stage_params = [p for p in single.params if p.name not in skip]
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
        from sizefx.batch import BatchJob, expand_inputs, output_names, run_batch
        from sizefx.batch.inputs import check_out_dir, check_stage_options, pair_inputs
        from sizefx.batch.manifest import Manifest, canonical_options
        from sizefx.batch.runner import local_workers, start_workers

        accepted = {name for name, _ in declared(single.config_class)}
        records = expand_inputs(inputs)
        given_pairs = {param: options.pop(f"paired_{param}") for param in spec.paired}
        partners = {
            param: pair_inputs(records, given, spec.paired[param][0]) for param, given in given_pairs.items() if given
        }
        out = check_out_dir(
            out_dir,
            [*inputs, *(g for given in given_pairs.values() for g in given)],
            [*records, *(p for pairs in partners.values() for p in pairs.values())],
        )
        previous = Manifest(out, name)  # each record's entry, looked up as its job is made
        pool = None
        try:
            names = output_names(records)
            stage_options = canonical_options({**options, **({"plots": True} if plots and spec.plots else {})})
            jobs = []
            for record in records:
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
                config = config_from(single.config_class, {k: v for k, v in given.items() if k in accepted})
                # the files the options name (--levers, --model, --nominal, --against, --reference): refused
                # once, before any work, and hashed with each record, so that a re-calibration into the
                # same levers.json reruns the records
                option_files = {k: str(v) for k, v in config.inputs().items() if str(k).startswith("-") and v}
                if not jobs:  # every record would refuse the same bad option: refused once, before any work
                    check_stage_options(config)  # its options, and its option files by their readers
                    # the workers start while the other configs are built; not for a re-run or a
                    # resume, whose records the stat cache may find done without any worker
                    if scheduler is None and (redo or rehash or not previous.has_entries()):
                        pool = start_workers(name, local_workers(workers, len(records)), memory_mib)
                jobs.append(
                    BatchJob(
                        name,
                        str(record),
                        names[record],
                        config,
                        stage_options,
                        outputs,
                        str(out / f"{names[record]}.{name}.json") if spec.summary else None,
                        previous.entry(str(record)),
                        redo,
                        {**option_files, **{spec.paired[param][0]: path for param, path in paired.items()}},
                    )
                )
            progress = BatchProgress(name, len(jobs), json_progress, quiet)
            result = run_batch(
                name,
                jobs,
                out,
                stage_options,
                workers=workers,
                previous=previous,
                progress=progress,
                scheduler=scheduler,
                plots=plots,
                memory_mib=memory_mib,
                pool=pool,
                rehash=rehash,
            )
        finally:  # a refusal before the run: the workers, still starting, are let go
            if pool is not None:
                pool.shutdown(wait=False, cancel_futures=True)
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


for _name, _spec in STAGES.items():
    batch.add_command(_make(_name, _spec))
