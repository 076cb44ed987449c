"""``sizefx paper turntable | sway | flight | all``: the paper's experiments in simulation."""

from __future__ import annotations

from pathlib import Path

import click

from .options import SEED


@click.command()
@click.argument("experiment", type=click.Choice(["turntable", "sway", "flight", "all"]), default="all")
@click.option(
    "--size",
    type=click.Choice(["full", "reduced"]),
    default="full",
    show_default=True,
    help="full: the paper's sizes (1600 Hz, five turntable repeats, the 1.8 h flight); reduced: the "
    "demo's (three turntable repeats and the flight at 400 Hz, the sway at 1600 Hz).",
)
@click.option(
    "--out",
    "out_dir",
    default="sizefx-paper",
    show_default=True,
    type=click.Path(file_okay=False),
    help="Folder for the simulated records, lever-arm files and figures (PNG); created.",
)
@click.option(
    "--json",
    "json_path",
    type=click.Path(dir_okay=False),
    metavar="FILE",
    help="Write every figure to FILE (JSON; an existing FILE is replaced).",
)
@click.option("--seed", default=0, show_default=True, type=SEED, help="Seed of the simulated noise.")
@click.option(
    "--keep-records/--no-keep-records",
    default=True,
    show_default=True,
    help="Keep the simulated HDF5 records in --out (the full flight is 611 MiB).",
)
def paper(experiment, size, out_dir, json_path, seed, keep_records):
    """Reproduce Morozov & Bogdanov (2024) in simulation and print the comparison table.

    \b
    turntable  calibrations of the rotation plan (five; three reduced): arms minus nominal [mm] and
               their spread, beside the paper's table; Fig. 6
    sway       heading sway 10/20/30 deg/s at 1 Hz after 10 min alignment, navigated
               without compensation, with triad and with rotation-centre compensation;
               the closed form r A^2 t^2 / 4 with and without the Schuler loop; Figs. 8, 9
    flight     the 1.8 h helicopter flight: error and drift removed by compensation
               [km, nmi/h], ground-speed error change [m/s]

    docs/paper/ holds the full-size figures, made by:
    sizefx paper all --size full --out docs/paper --json docs/paper/results.json --no-keep-records
    """
    from sizefx.experiments.paper import SIZES, format_results, run_all, to_json
    from sizefx.io.documents import write_json
    from sizefx.stage import preflight

    # --json is replaced when it exists (docs/paper/results.json is regenerated in place), but
    # a folder that does not exist or cannot be written is refused now, not after an hour's run.
    preflight(inputs={}, outputs={"--json": json_path}, force=True)
    which = ("turntable", "sway", "flight") if experiment == "all" else (experiment,)
    res = run_all(Path(out_dir), SIZES[size], which=which, seed=seed, log=click.echo, keep_records=keep_records)
    click.echo(format_results(res))
    if json_path:
        write_json(json_path, to_json(res), force=True)
        click.echo(f"figures -> {json_path}")
    click.echo(f"plots and records -> {out_dir}/")
