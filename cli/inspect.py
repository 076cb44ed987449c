"""``sizefx inspect FILE``."""

from __future__ import annotations

import json

import click

from .options import allow_gaps_option, no_units_check_option


@click.command()
@click.argument("file", type=click.Path(dir_okay=False))
@allow_gaps_option
@no_units_check_option
@click.option(
    "--json",
    "as_json",
    is_flag=True,
    help="A flag, it takes no file: print the summary to stdout as JSON instead of text "
    "(redirect it to keep it: sizefx inspect FILE --json > summary.json).",
)
def inspect(file, allow_gaps, no_units_check, as_json):
    """Validate FILE against sizefx/telemetry/1 and print what it holds.

    Samples, rate [Hz], duration [s], stored units and the physics check of
    them, gaps and the continuous segments between them, reference and, for
    simulated files, the injected effects. Exit code 0 for a valid file, 2
    (with a one-line reason) otherwise: a file whose data look like another
    unit than they declare is not valid.
    """
    from sizefx.inspect import run

    result = run(config_of(file, allow_gaps, no_units_check))
    click.echo(json.dumps(result.to_json(), indent=2) if as_json else result.report())


def config_of(file, allow_gaps, no_units_check):
    """The stage's config from the command's options (also ``sizefx batch inspect``'s, per record)."""
    from sizefx.inspect import InspectConfig

    return InspectConfig(file, allow_gaps=allow_gaps, check_units=not no_units_check)
