"""``sizefx demo``: the main job on built-in data."""

from __future__ import annotations

from pathlib import Path

import click

from sizefx.demo import run_demo


@click.command()
@click.option("--out", "out_dir", default="sizefx-demo", show_default=True, type=click.Path(file_okay=False),
              help="Folder for the demo's files (created; the demo replaces only its own files there).")
@click.option("--seed", default=0, show_default=True, type=int, help="Seed of the simulated noise.")
def demo(out_dir, seed):
    """Run sizefx on built-in data and print what it finds.

    For now: simulate the paper's turntable calibration plan (high-precision
    geometry, navigation-grade noise) and summarise the record. Grows as the
    calibration, compensation and navigation stages land.
    """
    for line in run_demo(Path(out_dir), seed=seed):
        click.echo(line)
