"""``sizefx inspect FILE``."""

from __future__ import annotations

import json

import click

from .options import allow_gaps_option, force_option, no_units_check_option


@click.command()
@click.argument("file", type=click.Path(dir_okay=False))
@allow_gaps_option
@no_units_check_option
@click.option(
    "--json",
    "json_path",
    type=click.Path(dir_okay=False, allow_dash=True),
    metavar="FILE",
    help="Write the summary to FILE (JSON); '-' prints it to stdout instead of the text.",
)
@force_option(text="Replace the --json file if it exists (never an input).")
def inspect(file, allow_gaps, no_units_check, json_path, force):
    """Validate FILE against sizefx/telemetry/1 and print what it holds.

    Samples, rate [Hz], duration [s], stored units and the physics check of
    them, gaps and the continuous segments between them, reference and, for
    simulated files, the injected effects. Exit code 0 for a valid file, 2
    (with a one-line reason) otherwise: a file whose data look like another
    unit than they declare is not valid.
    """
    from sizefx.inspect import run

    result = run(config_of(file, allow_gaps, no_units_check, json_path, force))
    if json_path == "-":
        click.echo(json.dumps(result.to_json(), indent=2))
        return
    click.echo(result.report())
    if json_path:
        click.echo(f"summary -> {json_path}")


def config_of(file, allow_gaps, no_units_check, json_path=None, force=False):
    """The stage's config from the command's options (also ``sizefx batch inspect``'s, per record)."""
    from sizefx.inspect import InspectConfig

    return InspectConfig(file, allow_gaps=allow_gaps, check_units=not no_units_check, json_path=json_path, force=force)
