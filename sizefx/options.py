"""Options declared once: what a stage's config accepts, how the command line spells it, and the one
check of every value.

A stage's config (a frozen dataclass, :mod:`sizefx.configs`) declares each option as a field whose
default is made here: :func:`number`, :func:`integer`, :func:`choice`, :func:`switch`, :func:`path`,
:func:`text`, or :func:`group` (another config whose options are this one's too: navigate's
:class:`~sizefx.navigate.NavConfig`). The field's metadata holds an :class:`Option`: how the user
writes it (``--align-s``), its unit, valid range or choices, default and help. From it

- the config checks its values (:func:`check_options`, from its ``__post_init__``), every refusal in
  one wording that names the option as the command line does:
  ``--align-s: 0 is outside (0, 86400] s``;
- the command line builds the command's options (``cli/options.py``), whose types call the same
  :func:`refusal`, so a bad value is refused in the same words from Python and from a shell.

Rules across options (``--levers`` beside ``--model``) stay the config's own, in its
``__post_init__`` after :func:`check_options`: one home each. This module imports only the
standard library, so that ``sizefx --help`` reads the declarations without loading numpy.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import numbers
import os
from dataclasses import MISSING, dataclass
from typing import Any

from .errors import ConfigError

__all__ = [
    "Option",
    "number",
    "integer",
    "choice",
    "switch",
    "path",
    "text",
    "group",
    "allow_gaps",
    "segment",
    "units_check",
    "force",
    "declared",
    "refusal",
    "check_options",
    "config_from",
    "option_values",
    "interval",
]

#: A scaled value this close (relative) to a bound is at it: the unit's conversion rounds in the last bits.
SCALED_TOLERANCE = 1e-12
#: The kinds of value an option takes. Paths: a file, a folder, or either (a ROS 2 bag is a folder).
KINDS = ("number", "integer", "choice", "switch", "file", "folder", "path", "text")


@dataclass(frozen=True)
class Option:
    """One option of a stage, as its config declares it (the metadata of the field).

    ``flags`` are the command line's spellings (click's declarations: ``("-o", "--output")``,
    ``("--tilt/--no-tilt",)``); empty: ``--`` and the field's name with dashes. ``argument``: a
    positional argument's name instead (``FILE``). ``scale``: the field's unit per the command
    line's (``--accel-delay-us`` fills a field in seconds: 1e-6); ``low``, ``high`` and the
    messages are in the command line's unit. ``sets``: the value a switch's flag gives the field
    (``--centripetal-only`` sets ``tangential`` False).
    """

    kind: str
    default: Any = MISSING
    help: str = ""
    flags: tuple = ()
    argument: str | None = None
    unit: str | None = None
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    choices: tuple = ()
    scale: float = 1.0
    many: bool = False  #: several values: a repeatable option, or an argument that takes any number
    sets: bool = True
    metavar: str | None = None
    dash: bool = False  #: a path option that also takes '-' (stdout)
    allow_none: bool = False  #: None is a value too, though the default is not (the config says what it means)

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"option kind {self.kind!r}: use one of {', '.join(KINDS)}")

    @property
    def name(self) -> str:
        """The option as the user writes it: ``--align-s``, ``--tilt`` (of ``--tilt/--no-tilt``), ``FILE``."""
        if self.argument is not None:
            return self.argument
        longest = max(self.flags, key=len)
        return longest.partition("/")[0]


def _declare(kind: str, default, **spec) -> Any:
    """A dataclass field holding ``Option(kind, default, **spec)``; no default: a required field."""
    option = Option(kind, default, **spec)
    metadata = {"option": option}
    if default is MISSING:
        return dataclasses.field(metadata=metadata)
    return dataclasses.field(default=default, metadata=metadata)


def number(
    default=None,
    *,
    help: str,
    unit: str | None,
    low: float,
    high: float,
    low_open: bool = False,
    high_open: bool = False,
    scale: float = 1.0,
    flags: tuple = (),
    allow_none: bool = False,
) -> Any:
    """A finite real in [low, high] (either end open) of ``unit`` (None: a pure number); the field
    holds ``scale`` times what the command line takes. Default None: the option may be left out;
    ``allow_none``: None is valid beside another default."""
    return _declare(
        "number",
        default,
        help=help,
        unit=unit,
        low=low,
        high=high,
        low_open=low_open,
        high_open=high_open,
        scale=scale,
        flags=flags,
        allow_none=allow_none,
    )


def integer(
    default=None, *, help: str, low: int, high: int | None = None, metavar: str | None = None, flags: tuple = ()
) -> Any:
    """An integer in [low, high] (high None: no upper end)."""
    return _declare("integer", default, help=help, low=low, high=high, metavar=metavar, flags=flags)


def choice(default, choices: tuple, *, help: str, flags: tuple = (), allow_none: bool = False) -> Any:
    """One word of ``choices`` (or None when the default is None, or ``allow_none``)."""
    return _declare("choice", default, help=help, choices=tuple(choices), flags=flags, allow_none=allow_none)


def switch(default: bool = False, *, help: str, flags: tuple = (), sets: bool | None = None) -> Any:
    """True or False. A flag alone (``--allow-gaps``) sets ``not default``; a pair
    (``("--tilt/--no-tilt",)``) sets either and shows the default."""
    return _declare("switch", default, help=help, flags=flags, sets=not default if sets is None else sets)


def path(
    default=None,
    *,
    help: str = "",
    kind: str = "file",
    flags: tuple = (),
    argument: str | None = None,
    many: bool = False,
    metavar: str | None = None,
    dash: bool = False,
    required: bool = False,
) -> Any:
    """A file (``kind="file"``), a folder or either (``"path"``); ``argument``: a positional one,
    which is required (one or, ``many``, any number); ``many`` options repeat and collect a tuple;
    ``required`` options have no default."""
    if argument is not None or required:
        default = MISSING
    return _declare(kind, default, help=help, flags=flags, argument=argument, many=many, metavar=metavar, dash=dash)


def text(default=None, *, help: str, flags: tuple = (), metavar: str | None = None) -> Any:
    """Free text the config interprets itself (a preset name or a file, a list of axes)."""
    return _declare("text", default, help=help, flags=flags, metavar=metavar)


def group(config_class: type) -> Any:
    """A field holding another config whose declared options are this config's too (navigate's
    ``options: NavConfig``); the command line shows them in its place."""
    return dataclasses.field(default_factory=config_class, metadata={"group": config_class})


# --------------------------------------------------------------- options several stages share


def allow_gaps() -> Any:
    """``--allow-gaps`` (inspect, calibrate, compensate, navigate, diagnose)."""
    return switch(
        help="Accept IMU time steps longer than 1.5 sample periods that /imu/gaps does not "
        "declare (they are reported) instead of refusing the file; declared gaps need "
        "no option."
    )


def segment() -> Any:
    """``--segment K`` (compensate, navigate, diagnose)."""
    return integer(
        None,
        low=1,
        metavar="K",
        help="Process only continuous segment K of a record with IMU gaps (1-based, in time "
        "order, as sizefx inspect lists them).",
    )


#: Help of --no-units-check of the commands that read a record (inspect, import).
NO_UNITS_CHECK_HELP = (
    "Skip the physics check of the units (specific force at rest against gravity, gyros against "
    "the reference attitude or the tilt the accelerometers see), which refuses data that look like "
    "deg/s labelled rad/s or g labelled m/s^2. For a record you know is right that the check "
    "misjudges (an IMU on a centrifuge, in free fall or in orbit); say so when you share the file."
)


def units_check() -> Any:
    """``check_units``, which ``--no-units-check`` turns off (inspect)."""
    return switch(True, flags=("--no-units-check",), sets=False, help=NO_UNITS_CHECK_HELP)


def force(help: str = "Replace the -o file if it exists (never an input).") -> Any:
    """``--force``, whose help names what the stage replaces."""
    return switch(help=help)


# ------------------------------------------------------------------------ reading and checking


def declared(config_class: Any) -> tuple[tuple[str, Option], ...]:
    """``(field name, Option)`` of every option a config declares, in field order, a :func:`group`'s
    in its place; the flags filled in (``--`` and the name with dashes where none are given)."""
    found: list[tuple[str, Option]] = []
    for f in dataclasses.fields(config_class):
        if "group" in f.metadata:
            found += declared(f.metadata["group"])
        elif "option" in f.metadata:
            option = f.metadata["option"]
            if not option.flags and option.argument is None:
                option = dataclasses.replace(option, flags=("--" + f.name.replace("_", "-"),))
            found.append((f.name, option))
    names = [name for name, _ in found]
    if len(set(names)) != len(names):
        raise TypeError(f"{config_class.__name__}: an option is declared twice: {names}")
    return tuple(found)


def _bound(x: float, integer: bool) -> str:
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return str(int(x)) if integer else f"{x:g}"


def interval(option: Option) -> str:
    """The valid range in the command line's unit: ``(0, 86400] s``, ``[1, inf)``."""
    low = -math.inf if option.low is None else option.low
    high = math.inf if option.high is None else option.high
    left = "(" if option.low_open or low == -math.inf else "["
    right = ")" if option.high_open or high == math.inf else "]"
    unit = f" {option.unit}" if option.unit else ""
    integer = option.kind == "integer"
    return f"{left}{_bound(low, integer)}, {_bound(high, integer)}{right}{unit}"


def _shown(value, scale: float = 1.0) -> str:
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        return f"{float(value) / scale:.15g}"
    return repr(value)


def _is_path(value) -> bool:
    return isinstance(value, (str, os.PathLike))


def _one(option: Option, value) -> str | None:
    """Why one value is wrong for ``option`` (the words after the option's name), or None."""
    kind = option.kind
    if kind in ("number", "integer"):
        if isinstance(value, bool) or not isinstance(value, numbers.Integral if kind == "integer" else numbers.Real):
            return f"{_shown(value)} is not {'an integer' if kind == 'integer' else 'a number'}"
        shown, value = _shown(value, option.scale), float(value)
        if not math.isfinite(value):
            return f"{shown} is not a finite number; give a value in {interval(option)}"
        v = value / option.scale  # judged in the command line's unit, as the user wrote it

        def at(bound: float) -> bool:  # 10e-6 s is 10 us, though 10e-6 / 1e-6 is not 10 exactly
            return v == bound or (option.scale != 1.0 and math.isclose(v, bound, rel_tol=SCALED_TOLERANCE))

        low, high = option.low, option.high
        if low is not None and ((v < low and not at(low)) or (option.low_open and at(low))):
            return f"{shown} is outside {interval(option)}"
        if high is not None and ((v > high and not at(high)) or (option.high_open and at(high))):
            return f"{shown} is outside {interval(option)}"
        return None
    if kind == "choice":
        return None if value in option.choices else f"{_shown(value)} is not one of {', '.join(option.choices)}"
    if kind == "switch":
        return None if value in (True, False) else f"{_shown(value)} is not true or false"
    if kind == "text":
        return None if isinstance(value, str) else f"{_shown(value)} is not text"
    return None if _is_path(value) else f"{_shown(value)} is not a path"


def refusal(option: Option, value) -> str | None:
    """Why ``value`` (in the field's unit) is not valid for ``option``, in the one wording every
    refusal uses (``--align-s: 0 is outside (0, 86400] s``); None when it is valid. None is valid
    where the default is None (the option left out)."""
    if value is None:
        return None if option.default is None or option.allow_none else f"{option.name}: give a value (None is not one)"
    if option.many and (isinstance(value, (str, bytes)) or not isinstance(value, (tuple, list))):
        return f"{option.name}: {_shown(value)} is not a tuple of values"
    values = value if option.many else (value,)
    problem = next((p for p in map(functools.partial(_one, option), values) if p is not None), None)
    return None if problem is None else f"{option.name}: {problem}"


def check_options(config) -> None:
    """Every declared option of ``config`` checked (:func:`refusal`); the first bad one refused as
    :class:`~sizefx.errors.ConfigError`. A config calls it first thing in its ``__post_init__`` (a
    :func:`group`'s config has checked its own when it was made)."""
    options = dict(declared(type(config)))
    for f in dataclasses.fields(config):
        value = getattr(config, f.name)
        if "group" in f.metadata and not isinstance(value, f.metadata["group"]):
            raise ConfigError(f"{f.name}: {value!r} is not a {f.metadata['group'].__name__}")
        if "option" in f.metadata:
            problem = refusal(options[f.name], value)
            if problem is not None:
                raise ConfigError(problem)


def config_from(config_class: type, values: dict):
    """``config_class`` made from option values by field name, as the command line parses them (a
    :func:`group`'s config made from its own); an option left out keeps its default."""
    known = {name for name, _ in declared(config_class)}
    unknown = set(values) - known
    if unknown:
        raise TypeError(f"{config_class.__name__} declares no option {', '.join(sorted(unknown))}")
    kwargs = {}
    for f in dataclasses.fields(config_class):
        if "group" in f.metadata:
            inner = f.metadata["group"]
            own = {name for name, _ in declared(inner)}
            kwargs[f.name] = config_from(inner, {k: v for k, v in values.items() if k in own})
        elif "option" in f.metadata and f.name in values:
            kwargs[f.name] = values[f.name]
    return config_class(**kwargs)


def _plain(value):
    """A value as the command line gives it: a path as text, a list as a tuple."""
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    if isinstance(value, (list, tuple)):
        return tuple(_plain(v) for v in value)
    return value


def _declared_values(config) -> dict:
    """Every declared option of the config ``config`` by field name, a :func:`group`'s in its place."""
    values = {}
    for f in dataclasses.fields(config):
        if "group" in f.metadata:
            values.update(_declared_values(getattr(config, f.name)))
        elif "option" in f.metadata:
            values[f.name] = getattr(config, f.name)
    return values


def option_values(config_class: type, given, *, offered, where: str) -> dict:
    """The options a caller in Python gives a stage of ``config_class`` that runs as a batch's record
    or a chain's step, complete as the command line gives them: every option named in ``offered``
    (field names), those ``given`` first in their order, the others at their declared default (an
    option without one left out). Paths come back as text and sequences as tuples, so that the
    manifest and run.json hold what the command would write.

    ``given``: None, a mapping by field name, or a config whose declared options are read (a
    :func:`group`'s, such as navigate's ``NavConfig``, or the stage's own config as a template: the
    options ``offered`` leaves out, its record and outputs, are not read from it). A name the config
    does not declare, or one that ``offered`` leaves out (the batch or the chain names it), is
    refused in one line (:class:`~sizefx.errors.ConfigError`) that begins with ``where``."""
    offered = tuple(offered)
    declared_here = {name: option for name, option in declared(config_class)}
    if given is None:
        values = {}
    elif dataclasses.is_dataclass(given) and not isinstance(given, type):
        values = {k: v for k, v in _declared_values(given).items() if k in offered}
    elif hasattr(given, "keys"):
        values = dict(given)
        for name in values:
            if name not in declared_here:
                raise ConfigError(
                    f"{where}: {config_class.__name__} has no option {name!r}; give some of {', '.join(offered)}"
                )
            if name not in offered:
                raise ConfigError(
                    f"{where}: {name!r} is not an option here: the batch or the chain sets it (the record, "
                    "the outputs, force); leave it out"
                )
    else:
        raise ConfigError(f"{where}: give the options as a dict by name or a config, not {type(given).__name__}")
    out = {name: _plain(value) for name, value in values.items()}
    for name in offered:
        if name not in out and declared_here[name].default is not MISSING:
            out[name] = declared_here[name].default
    return out
