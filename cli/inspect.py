"""``sizefx inspect FILE``: its options are :class:`~sizefx.configs.inspect.InspectConfig`'s."""

from __future__ import annotations

import json

import click

from sizefx.configs.inspect import InspectConfig

from .options import stage_command


@stage_command(InspectConfig)
def inspect(config):
    """Validate FILE against sizefx/telemetry/1 and print what it holds.

    Samples, rate [Hz], duration [s], stored units and the physics check of
    them, gaps and the continuous segments between them, reference and, for
    simulated files, the injected effects. Exit code 0 for a valid file, 2
    (with a one-line reason) otherwise: a file whose data look like another
    unit than they declare is not valid.
    """
    from sizefx.inspect import run

    result = run(config)
    if config.json_path == "-":
        click.echo(json.dumps(result.to_json(), indent=2))
        return
    click.echo(result.report())
    if config.json_path:
        click.echo(f"summary -> {config.json_path}")
