"""Options and helpers shared by several commands (rasterio's ``rio/options.py`` pattern)."""

from __future__ import annotations

import sys
import tomllib

import click

from sizefx.errors import ConfigError


def parse_vector(text: str, name: str, n: int = 3) -> tuple[float, ...]:
    """``"1,2,3"`` -> (1.0, 2.0, 3.0), or a one-line error naming the option."""
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise click.BadParameter(f"'{text}' is not {n} comma-separated numbers", param_hint=name) from None
    if len(values) != n:
        raise click.BadParameter(f"'{text}' has {len(values)} values, expected {n}", param_hint=name)
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
            parsed = tomllib.loads(f"v = {value.strip()}")["v"]
        except tomllib.TOMLDecodeError:
            raise ConfigError(f"--set '{item}': '{value}' is not a TOML value (numbers, true/false, "
                              "\"text\", [1, 2, 3])") from None
        out.setdefault(section, {})[name] = parsed
    return out


def force_option(f):
    return click.option("--force", is_flag=True, help="Replace OUTPUT if it exists (never an input).")(f)


def quiet_option(f):
    return click.option("--quiet", "-q", is_flag=True, help="No progress bar.")(f)


def allow_gaps_option(f):
    return click.option("--allow-gaps", is_flag=True,
                        help="Accept IMU time steps longer than 1.5 sample periods that /imu/gaps does not "
                             "declare (they are reported) instead of refusing the file; declared gaps need "
                             "no option.")(f)


#: Help of --no-units-check (import and inspect), in one place.
NO_UNITS_CHECK_HELP = ("Skip the physics check of the units (specific force at rest against gravity, gyros against "
                       "the reference attitude or the tilt the accelerometers see), which refuses data that look like "
                       "deg/s labelled rad/s or g labelled m/s^2. For a record you know is right that the check "
                       "misjudges (an IMU on a centrifuge, in free fall or in orbit); say so when you share the file.")


def no_units_check_option(f):
    return click.option("--no-units-check", is_flag=True, help=NO_UNITS_CHECK_HELP)(f)


def segment_option(f):
    return click.option("--segment", type=click.IntRange(min=1), metavar="K",
                        help="Process only continuous segment K of a record with IMU gaps (1-based, in time "
                             "order, as sizefx inspect lists them).")(f)


class Progress:
    """A one-line progress bar on stderr, only on a terminal and without --quiet."""

    def __init__(self, label: str, quiet: bool):
        self.label = label
        self.on = not quiet and sys.stderr.isatty()
        self._last = -1

    def __call__(self, done: int, total: int):
        if not self.on:
            return
        pct = int(100 * done / max(total, 1))
        if pct != self._last:
            self._last = pct
            bar = "#" * (pct // 4)
            sys.stderr.write(f"\r{self.label} [{bar:<25}] {pct:3d}%")
            if done >= total:
                sys.stderr.write("\n")
            sys.stderr.flush()
