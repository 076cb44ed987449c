"""``sizefx run --out DIR calibrate T.h5 navigate F.h5 compare``: stages chained in one command.

Each stage of the chain is the single-file command's own (its click options and its ``config_of``),
less the output paths, which the chain names in DIR: calibrate's lever arms go to navigate, which
navigates the flight plain and compensated with them, and compare sets the two solutions against
the flight's reference. Which chains can work is :func:`sizefx.chain.check_chain`'s, decided with
every input checked before any stage runs.
"""

from __future__ import annotations

import importlib
import time
from pathlib import Path

import click

#: Per chained stage: the single-file command's options a chain does not offer (its outputs, which
#: the chain names in DIR, and the inputs the chain passes from the stage before).
_DROPPED = {"calibrate": ("json_path", "plot", "force"),
            "navigate": ("output", "json_path", "plot", "force", "quiet"),
            "compare": ("a", "b", "json_path", "plots_dir", "force")}


def _records(record, also, **options):
    """calibrate's records in a chain: RECORD and every --with (a chained command's argument cannot take
    a variable number of values: it would swallow the next stages)."""
    return {"records": (record, *also), **options}


def _link(name: str) -> click.Command:
    """The chain's ``name`` command: the single-file command's parameters; returns them for the chain."""
    single = getattr(importlib.import_module(f"sizefx_cli.{name}"), name)
    params = [p for p in single.params if p.name not in _DROPPED[name]]
    callback = lambda **options: (name, options)  # noqa: E731
    if name == "calibrate":
        params = [click.Argument(["record"], type=click.Path(dir_okay=False)),
                  click.Option(["--with", "also"], multiple=True, type=click.Path(dir_okay=False),
                               help="Another record fitted jointly (a sway for the delay); repeat for more."),
                  *[p for p in params if p.name != "records"]]
        callback = lambda **options: (name, _records(**options))  # noqa: E731
    return click.Command(name, params=params, callback=callback,
                         help=f"{single.help}\n\nIn a chain: outputs go to --out; see sizefx run --help.",
                         short_help=single.get_short_help_str())


@click.group(chain=True)
@click.option("--out", "out_dir", type=click.Path(file_okay=False),
              help="Folder for every stage's outputs and run.json (made if new). Required.")
@click.option("--plots", is_flag=True, help="Also write each stage's plots into --out.")
def run(out_dir, plots):
    """Chain calibrate, navigate and compare in one command.

    \b
    sizefx run --out results calibrate turntable.h5 navigate flight.h5 compare
    sizefx run --out r calibrate --with sway.h5 --delay t.h5 navigate f.h5

    In a chain a stage's options come before its file (click's rule for
    chained commands: what follows the file belongs to the next stage).

    calibrate's lever arms (levers.json) go to navigate, which navigates the
    flight twice, plain and compensated (or, without calibrate, with its own
    --levers); compare sets the compensated solution against the plain one and
    both against the flight's /reference (or compare --reference). Every stage
    option keeps its meaning (see each stage's --help). A chain that cannot
    work is refused before any stage runs; run.json (sizefx/run/1) lists what
    each stage read, wrote and found.
    """


for _name in _DROPPED:
    run.add_command(_link(_name))


def _has_reference(path) -> bool:
    import h5py

    with h5py.File(path, "r") as f:
        return "reference/position" in f


@run.result_callback()
def _execute(steps, out_dir, plots):
    from sizefx.batch.inputs import check_out_dir
    from sizefx.batch.fleet import headline
    from sizefx.chain import check_chain, write_run_manifest
    from sizefx.errors import ConfigError
    from sizefx.io.schema import as_json
    from sizefx.stage import preflight

    if not out_dir:
        raise ConfigError("sizefx run: give --out DIR, the folder for every stage's outputs")
    chain = dict(steps)
    names = [name for name, _ in steps]
    nav = chain.get("navigate", {})
    check_chain(names, navigate_has_levers=bool(nav.get("levers")))
    if "calibrate" in chain and nav.get("levers"):
        raise ConfigError("sizefx run: navigate --levers and calibrate in one chain: the chain passes calibrate's "
                          "lever arms to navigate; leave out one of the two")
    if nav.get("model") and ("calibrate" in chain or nav.get("levers")):
        raise ConfigError("sizefx run: navigate --model cannot be combined with lever arms (from calibrate or "
                          "--levers); navigate the model on its own")
    # every file the chain reads, before any stage runs
    given = {**{f"calibrate RECORDS ({k + 1})": r for k, r in enumerate(chain.get("calibrate", {}).get("records", ()))},
             "navigate FILE": nav.get("file"), "navigate --levers": nav.get("levers"),
             "navigate --model": nav.get("model"), "compare --reference": chain.get("compare", {}).get("reference")}
    preflight(inputs=given, outputs={})
    if "compare" in chain and not chain["compare"].get("reference") and not _has_reference(nav["file"]):
        raise ConfigError(f"{nav['file']}: compare needs the truth, and the flight has no /reference/position; "
                          "give compare --reference")
    out = check_out_dir(out_dir, [], [Path(p).resolve() for p in given.values() if p])
    out.mkdir(exist_ok=True)
    record: list[dict] = []

    def stage(name, run_label, config, options):
        module = importlib.import_module(f"sizefx.{name}")
        t0 = time.perf_counter()
        result = module.run(config)
        record.append({"stage": name, **({"run": run_label} if run_label else {}),
                       "inputs": {k: str(v) for k, v in config.inputs().items() if v},
                       "options": as_json({k: v for k, v in options.items() if not isinstance(v, Path)}),
                       "outputs": {k: str(v) for k, v in config.outputs().items() if v},
                       "duration_s": time.perf_counter() - t0, "headline": headline(name, as_json(result.to_json()))})
        write_run_manifest(out, record)
        title = f"== {name}" + (f" ({run_label})" if run_label else "")
        click.echo(f"{title}\n{result.report()}")

    levers = nav.get("levers")
    if "calibrate" in chain:
        from sizefx_cli.calibrate import config_of

        levers = str(out / "levers.json")
        options = chain["calibrate"]
        stage("calibrate", None, config_of(**{**options, "json_path": levers, "force": True,
                                              "plot": str(out / "calibrate.png") if plots else None}), options)
    solutions = {}
    if nav:
        from sizefx_cli.navigate import config_of

        for label, with_levers in (("plain", None), ("compensated", levers)):
            if label == "compensated" and not with_levers:
                continue
            solutions[label] = str(out / f"{label}.nav.h5")
            stage("navigate", label, config_of(**{**nav, "levers": with_levers, "output": solutions[label],
                                                  "json_path": str(out / f"{label}.navigate.json"), "force": True,
                                                  "plot": str(out / f"{label}.navigate.png") if plots else None}),
                  {**nav, "levers": with_levers})
    if "compare" in chain:
        from sizefx_cli.compare import config_of

        options = chain["compare"]
        stage("compare", None, config_of(a=solutions["compensated"], b=solutions["plain"],
                                         reference=options.get("reference") or nav["file"],
                                         json_path=str(out / "comparison.json"),
                                         plots_dir=str(out / "compare-plots") if plots else None, force=True), options)
    click.echo(f"run: {' -> '.join(names)}; every output and run.json in {out}")
