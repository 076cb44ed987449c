"""Options and helpers shared by several commands (rasterio's ``rio/options.py`` pattern)."""

from __future__ import annotations

import math
import sys

import click

from sizefx.errors import ConfigError
from sizefx.io.documents import parse_toml


class Span(click.FloatRange):
    """A float option's valid range, finite by construction: NaN and +-inf are refused (click's
    FloatRange lets NaN through, since every comparison with it is false), with the range in the
    message. Every numeric option has one; ``docs/reliability.md`` lists them."""

    def convert(self, value, param, ctx):
        number = super().convert(value, param, ctx)
        if not math.isfinite(number):
            self.fail(f"{value!r} is not a finite number; give a value in {self._describe_range()}", param, ctx)
        return number


def span(low=None, high=None, *, low_open: bool = False, high_open: bool = False) -> Span:
    """A finite float in [low, high] (either end open, or absent)."""
    return Span(low, high, min_open=low_open, max_open=high_open)


#: Seeds are numpy's: non-negative, below 2**63 here.
SEED = click.IntRange(0, 2**63 - 1)


def parse_vector(text: str, name: str, n: int = 3) -> tuple[float, ...]:
    """``"1,2,3"`` -> (1.0, 2.0, 3.0), or a one-line error naming the option."""
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise click.BadParameter(f"'{text}' is not {n} comma-separated numbers", param_hint=name) from None
    if len(values) != n:
        raise click.BadParameter(f"'{text}' has {len(values)} values, expected {n}", param_hint=name)
    if not all(math.isfinite(v) for v in values):
        raise click.BadParameter(f"'{text}' holds a value that is not a finite number", param_hint=name)
    return values


def parse_overrides(items) -> dict:
    """``("accel_delay.tau_s=0.0005", ...)`` -> ``{"accel_delay": {"tau_s": 0.0005}}`` (values in TOML syntax)."""
    out: dict = {}
    for item in items:
        key, sep, value = item.partition("=")
        section, dot, name = key.strip().partition(".")
        if not sep or not dot:
            raise ConfigError(f"--set '{item}': write SECTION.KEY=VALUE, e.g. accel_delay.tau_s=0.0005")
        try:
            parsed = parse_toml(f"v = {value.strip()}", f"--set {key.strip()}")["v"]
        except ConfigError:
            shown = value if len(value) <= 60 else value[:60] + "..."
            raise ConfigError(
                f"--set '{key.strip()}={shown}': not a TOML value (numbers, true/false, "
                '"text", [1, 2, 3]) of reasonable size'
            ) from None
        out.setdefault(section, {})[name] = parsed
    return out


#: --force's help where the command writes one file, given with -o.
FORCE_HELP = "Replace the -o file if it exists (never an input)."


def force_option(f=None, *, text: str = FORCE_HELP):
    """``--force``, whose help names what this command replaces: ``@force_option`` alone, the -o
    file; a command with other outputs names them (``@force_option(text=...)``)."""
    option = click.option("--force", is_flag=True, help=text)
    return option(f) if f is not None else option


def quiet_option(f):
    return click.option("--quiet", "-q", is_flag=True, help="No progress bar.")(f)


def allow_gaps_option(f):
    return click.option(
        "--allow-gaps",
        is_flag=True,
        help="Accept IMU time steps longer than 1.5 sample periods that /imu/gaps does not "
        "declare (they are reported) instead of refusing the file; declared gaps need "
        "no option.",
    )(f)


#: Help of --no-units-check of import and inspect, in one place (simulate's, which writes rather
#: than reads: cli/simulate.py).
NO_UNITS_CHECK_HELP = (
    "Skip the physics check of the units (specific force at rest against gravity, gyros against "
    "the reference attitude or the tilt the accelerometers see), which refuses data that look like "
    "deg/s labelled rad/s or g labelled m/s^2. For a record you know is right that the check "
    "misjudges (an IMU on a centrifuge, in free fall or in orbit); say so when you share the file."
)


def no_units_check_option(f):
    return click.option("--no-units-check", is_flag=True, help=NO_UNITS_CHECK_HELP)(f)


def segment_option(f):
    return click.option(
        "--segment",
        type=click.IntRange(min=1),
        metavar="K",
        help="Process only continuous segment K of a record with IMU gaps (1-based, in time "
        "order, as sizefx inspect lists them).",
    )(f)


class Progress:
    """A progress bar on stderr (``tqdm``), only on a terminal and without ``--quiet``.

    The library calls it as ``progress(done, total)`` after each chunk (``done`` samples of
    ``total``); the bar appears at the first call and is closed when ``done`` reaches ``total``.
    tqdm rather than our own ``\\r`` line: it shows the rate and the time left, redraws at a
    bounded rate (not once per chunk), fits the terminal's width and leaves a clean line when a
    command fails half way. tqdm is imported only when a bar is shown (``--help`` stays light).
    """

    #: Seconds between redraws: a 1600 Hz record streams in chunks of ~0.1 s of work.
    REDRAW_S = 0.2

    def __init__(self, label: str, quiet: bool):
        self.label = label
        self.on = not quiet and sys.stderr.isatty()
        self._bar = None

    def __call__(self, done: int, total: int):
        if not self.on:
            return
        if self._bar is None or self._bar.total != total or done < self._bar.n:
            self.close()
            from tqdm import tqdm

            self._bar = tqdm(
                total=total,
                desc=self.label,
                file=sys.stderr,
                unit=" samples",
                unit_scale=True,
                mininterval=self.REDRAW_S,
                dynamic_ncols=True,
            )
        self._bar.update(done - self._bar.n)
        if done >= total:
            self.close()

    def close(self):
        """End the bar (on its own line) if one is shown."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None
