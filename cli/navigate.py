"""``sizefx navigate FILE``."""

from __future__ import annotations

import click

from sizefx.constants import MAX_WHOLE_READ_ROWS

from .options import Progress, allow_gaps_option, force_option, quiet_option, segment_option, span


def _every_or_rate(ctx, param, value):
    """0 (every navigation interval) or a rate of at least 0.001 Hz (a row every 17 minutes)."""
    if 0.0 < value < 1e-3:
        raise click.BadParameter(f"{value:g} Hz is below 0.001 Hz; give 0 for every interval, or 0.001 to 100000 Hz")
    return value


@click.command()
@click.argument("file", type=click.Path(dir_okay=False))
@click.option("-o", "--output", type=click.Path(dir_okay=False), help="Write the solution (HDF5, sizefx/navigation/1).")
@click.option(
    "--json", "json_path", type=click.Path(dir_okay=False), metavar="FILE", help="Write the summary to FILE (JSON)."
)
@click.option(
    "--plot",
    type=click.Path(dir_okay=False),
    metavar="FILE",
    help="Write the position error versus time to FILE (one PNG).",
)
@click.option(
    "--subsamples",
    default=4,
    show_default=True,
    type=click.IntRange(1, 4),
    help="IMU samples per navigation interval (coning/sculling sub-samples); 4 at 1600 Hz -> 400 Hz.",
)
@click.option(
    "--init",
    type=click.Choice(["auto", "reference", "align"]),
    default="auto",
    show_default=True,
    help="Initial attitude from /reference, or by static alignment over --align-s "
    "(auto: the reference when it covers the start and is not approximate).",
)
@click.option(
    "--align-s",
    default=300.0,
    show_default=True,
    type=span(0.0, 86400.0, low_open=True),
    help="Alignment window from the start of the record [s]; the vehicle must be at rest.",
)
@click.option(
    "--vertical",
    type=click.Choice(["auto", "held", "reference", "free"]),
    default="auto",
    show_default=True,
    help="Vertical channel: held at the known height, replaced by the reference "
    "height, or free (auto: held at rest, reference when moving).",
)
@click.option(
    "--output-rate-hz",
    default=10.0,
    show_default=True,
    type=span(0.0, 1e5),
    callback=_every_or_rate,
    help="Rate of the written solution [Hz] (0: every navigation interval).",
)
@click.option(
    "--levers",
    type=click.Path(dir_okay=False),
    help="Compensate the size effect first with these lever arms (sizefx/levers/1).",
)
@click.option(
    "--model",
    type=click.Path(dir_okay=False),
    help="Correct the IMU first with this effect model (sizefx/effects/1 TOML, e.g. from sizefx "
    "diagnose): delay, biases, scale factors, misalignments, quadratic term, g-sensitivity, "
    "lever arms. Sections the file omits are off. Not with --levers.",
)
@click.option(
    "--mode",
    type=click.Choice(["triad", "center"]),
    default="triad",
    show_default=True,
    help="With --levers or --model: bring the accelerometers to the triad point or to the rotation centre.",
)
@click.option(
    "--chunk-samples",
    default=1 << 20,
    show_default=True,
    type=click.IntRange(0, MAX_WHOLE_READ_ROWS),
    help="IMU rows read and processed at a time (memory is bounded by the chunk, results are identical); "
    "0 reads the whole record into memory.",
)
@segment_option
@allow_gaps_option
@force_option(text="Replace the -o, --json and --plot files if they exist (never an input).")
@quiet_option
def navigate(
    file,
    output,
    json_path,
    plot,
    subsamples,
    init,
    align_s,
    vertical,
    output_rate_hz,
    levers,
    model,
    mode,
    chunk_samples,
    segment,
    allow_gaps,
    force,
    quiet,
):
    """Whole-record strapdown navigation on WGS-84 (Numba).

    Prints the errors against /reference when the file has one: final and
    maximum horizontal error [m], drift [nmi/h], final velocity error [m/s],
    attitude error [deg]. A record with IMU gaps is navigated one continuous
    segment at a time (--segment K): the integration cannot bridge a gap.
    """
    from sizefx.navigate import run

    config = config_of(
        file,
        output,
        json_path,
        plot,
        subsamples,
        init,
        align_s,
        vertical,
        output_rate_hz,
        levers,
        model,
        mode,
        chunk_samples,
        segment,
        allow_gaps,
        force,
    )
    click.echo(run(config, progress=Progress("navigate", quiet)).report())


def config_of(
    file,
    output,
    json_path,
    plot,
    subsamples,
    init,
    align_s,
    vertical,
    output_rate_hz,
    levers,
    model,
    mode,
    chunk_samples,
    segment,
    allow_gaps,
    force,
):
    """The stage's config from the command's options (also ``sizefx batch navigate``'s, per record)."""
    from sizefx.navigate import NavConfig, NavigateConfig

    options = NavConfig(
        subsamples=subsamples,
        vertical=vertical,
        init=init,
        align_s=align_s,
        output_rate_hz=output_rate_hz or None,
        allow_gaps=allow_gaps,
        segment=segment,
        levers=levers,
        mode=mode,
    )
    return NavigateConfig(
        input=file,
        options=options,
        model=model,
        output=output,
        json_path=json_path,
        plot=plot,
        force=force,
        chunk_samples=chunk_samples,
    )
