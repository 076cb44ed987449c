"""``sizefx diagnose MEASURED.h5``."""

from __future__ import annotations

import click

from .options import allow_gaps_option, force_option, segment_option, span


@click.command()
@click.argument("measured", type=click.Path(dir_okay=False))
@click.option(
    "--nominal",
    default=None,
    help="Geometry the prediction starts from: high-precision (default), compact, none, or a "
    "sizefx/levers/1 file; lever arms from the reference point of the motion.",
)
@click.option(
    "--model",
    type=click.Path(dir_okay=False),
    help="Start from this effect model instead (sizefx/effects/1 TOML, e.g. a previous diagnosis); "
    "sections it omits are off.",
)
@click.option(
    "--json",
    "json_path",
    type=click.Path(dir_okay=False),
    metavar="FILE",
    help="Write the report to FILE (JSON, sizefx/diagnosis/2).",
)
@click.option(
    "--plots",
    type=click.Path(file_okay=False),
    metavar="DIR",
    help="Write residual time series and spectra, before and after, into the folder DIR (created if "
    "missing): residuals.png, spectra.png; existing ones are replaced only with --force.",
)
@click.option(
    "--model-out",
    type=click.Path(dir_okay=False),
    metavar="FILE",
    help="Where to write the extended model (TOML, sizefx/effects/1) [default: MEASURED with .model.toml].",
)
@click.option(
    "--bandwidth-hz",
    type=span(0.01, 1e5),
    help="Fit the residual low-passed at this frequency [Hz] (zero-phase, applied to the regressors "
    "alike). Without it, the band is measured: where the reference's own differentiated noise "
    "(motion capture) overtakes the IMU's, or the full band for a table's or simulation's "
    "reference; the report says which.",
)
@click.option(
    "--grade",
    type=click.Choice(["auto", "navigation", "tactical", "industrial"]),
    default="auto",
    show_default=True,
    help="Sensor grade whose plausible ranges an estimate must lie in to be a finding (auto: inferred "
    "from the noise, and reported).",
)
@click.option("--from-s", type=span(-1e10, 1e10), help="Diagnose the record from this time on [s] (IMU clock).")
@click.option(
    "--to-s",
    type=span(-1e10, 1e10),
    help="Diagnose the record up to this time [s] (IMU clock). The file is read whole first: at most 12 "
    "million IMU rows (2 h at 1600 Hz; a longer file is refused), and memory grows with its length "
    "(docs/diagnose.md, Memory against length).",
)
@click.option(
    "--navigation/--no-navigation",
    default=True,
    show_default=True,
    help="On records of 10 minutes or more with reference position, also navigate with the start "
    "and the extended model and report the horizontal error.",
)
@click.option(
    "--validate-on",
    "validate_on",
    multiple=True,
    type=click.Path(dir_okay=False),
    metavar="RECORD",
    help="Another record of the same IMU (repeat for more) to measure the extended model on: its "
    "residual RMS per channel with the start and the extended model, and its navigation error "
    "when it is long enough to navigate. The record diagnosed is cross-validated in any case.",
)
@segment_option
@allow_gaps_option
@force_option(
    text="Replace the --json report, the extended model (--model-out or its default) and the PNGs in --plots "
    "if they exist (never an input)."
)
def diagnose(
    measured,
    nominal,
    model,
    json_path,
    plots,
    model_out,
    bandwidth_hz,
    grade,
    from_s,
    to_s,
    navigation,
    validate_on,
    segment,
    allow_gaps,
    force,
):
    """What the sensor model gets wrong about a recording: named, fixed, the gain measured.

    For a real recording (imported, with its reference system in /reference)
    or a simulated one alike. Checks the record's /reference against the IMU
    first (glitches are dropped, the motion split at jumps, every finding a
    warning), predicts the IMU from it under the start model, selects the physical effects the
    residual supports (lever arms, accelerometer and reference delays, table
    tilt, reference mount, biases, scale factors, misalignments, quadratic
    term, g-sensitivity) with robust tests and honest errors, rejects what is
    implausible for the sensor grade or cannot be told apart on this motion,
    names what the model still cannot explain, writes the extended model and
    reports the residual RMS per channel before and after, in sample and on
    blocked folds held out in time (and on --validate-on records).
    """
    from sizefx.diagnose import run

    click.echo(
        run(
            config_of(
                measured,
                nominal,
                model,
                json_path,
                plots,
                model_out,
                bandwidth_hz,
                grade,
                from_s,
                to_s,
                navigation,
                segment,
                allow_gaps,
                force,
                validate_on,
            )
        ).report()
    )


def config_of(
    measured,
    nominal,
    model,
    json_path,
    plots,
    model_out,
    bandwidth_hz,
    grade,
    from_s,
    to_s,
    navigation,
    segment,
    allow_gaps,
    force,
    validate_on=(),
):
    """The stage's config from the command's options (also ``sizefx batch diagnose``'s, per record)."""
    from sizefx.diagnose import DiagnoseConfig

    return DiagnoseConfig(
        measured,
        nominal=nominal,
        model=model,
        json_path=json_path,
        plots=plots,
        model_out=model_out,
        bandwidth_hz=bandwidth_hz,
        grade=grade,
        from_s=from_s,
        to_s=to_s,
        segment=segment,
        allow_gaps=allow_gaps,
        navigation=navigation,
        validate_on=tuple(validate_on or ()),
        force=force,
    )
