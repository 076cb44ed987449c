"""``sizefx demo``: the main job on built-in data."""

from __future__ import annotations

from pathlib import Path

import click

from .options import SEED


@click.command()
@click.option(
    "--out",
    "out_dir",
    default="sizefx-demo",
    show_default=True,
    type=click.Path(file_okay=False),
    help="Folder for the demo's files (created; the demo replaces only its own files there).",
)
@click.option("--seed", default=0, show_default=True, type=SEED, help="Seed of the simulated noise.")
def demo(out_dir, seed):
    """Run sizefx on built-in data and print what it finds.

    The paper's three experiments at reduced size (turntable calibration,
    heading sway, helicopter flight) with the comparison table, then a
    two-minute tumble with a lever-arm error and an accelerometer delay hidden
    in it, which sizefx diagnose finds. Plots go to --out. The first run also
    compiles the Numba kernels; README.md gives the measured run time and
    memory after that. Full size: sizefx paper all.
    """
    from sizefx.experiments.demo import run_demo

    for line in run_demo(Path(out_dir), seed=seed):
        click.echo(line)
