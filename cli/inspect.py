"""``sizefx inspect FILE``."""

from __future__ import annotations

import json

import click

from .options import allow_gaps_option


@click.command()
@click.argument("file", type=click.Path(dir_okay=False))
@allow_gaps_option
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON instead of text.")
def inspect(file, allow_gaps, as_json):
    """Validate FILE against sizefx/telemetry/1 and print what it holds.

    Samples, rate [Hz], duration [s], stored units, gaps, reference and, for
    simulated files, the injected effects. Exit code 0 for a valid file, 2
    (with a one-line reason) otherwise.
    """
    from sizefx.inspect import format_summary, inspect_file

    summary = inspect_file(file, allow_gaps=allow_gaps)
    click.echo(json.dumps(summary, indent=2) if as_json else format_summary(summary))
