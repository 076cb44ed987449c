"""Options declared once: what a stage's config accepts, how the command line spells it, and the one
check of every value.

A stage's config (a frozen dataclass, :mod:`sizefx.configs`) declares each option as a field whose
default is made here: :func:`number`, :func:`integer`, :func:`choice`, :func:`switch`, :func:`path`,
:func:`text`, :func:`numbers` and :func:`words` (a comma-separated list), or :func:`group` (another
config whose options are this one's too: navigate's :class:`~sizefx.navigate.NavConfig`) and
:func:`one_of` (the config of whichever class another field names: a simulated scenario's plan, an
import format's own options). The field's metadata holds an :class:`Option`: how the user
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
import numbers as numeric  # the module; `numbers` is the declaration below
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
    "numbers",
    "words",
    "group",
    "one_of",
    "allow_gaps",
    "segment",
    "units_check",
    "force",
    "declared",
    "refusal",
    "check_options",
    "config_from",
    "interval",
    "parse_list",
]

#: A scaled value this close (relative) to a bound is at it: the unit's conversion rounds in the last bits.
SCALED_TOLERANCE = 1e-12
#: The kinds of value an option takes. Paths: a file, a folder, or either (a ROS 2 bag is a folder).
KINDS = ("number", "integer", "choice", "switch", "file", "folder", "path", "text", "numbers", "words")
#: The kinds whose value is a tuple that the command line writes as one comma-separated word.
LISTS = ("numbers", "words")


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
    count: int | None = None  #: a list's number of values (numbers, words); None: any number, at least one

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
    metavar: str | None = None,
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
        metavar=metavar,
    )


def integer(
    default=None, *, help: str, low: int, high: int | None = None, metavar: str | None = None, flags: tuple = ()
) -> Any:
    """An integer in [low, high] (high None: no upper end)."""
    return _declare("integer", default, help=help, low=low, high=high, metavar=metavar, flags=flags)


def choice(
    default, choices: tuple, *, help: str, flags: tuple = (), allow_none: bool = False, argument: str | None = None
) -> Any:
    """One word of ``choices`` (or None when the default is None, or ``allow_none``); ``argument``:
    a required word a command fixes (``sizefx simulate SCENARIO``: each scenario its own command),
    named so in a refusal."""
    if argument is not None:
        default = MISSING
    return _declare(
        "choice", default, help=help, choices=tuple(choices), flags=flags, allow_none=allow_none, argument=argument
    )


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


def text(default=None, *, help: str, flags: tuple = (), metavar: str | None = None, many: bool = False) -> Any:
    """Free text the config interprets itself (a preset name or a file, a list of axes); ``many``:
    a repeatable option that collects a tuple (default empty)."""
    if many and default is None:
        default = ()
    return _declare("text", default, help=help, flags=flags, metavar=metavar, many=many)


def numbers(
    default=None,
    *,
    help: str,
    unit: str | None,
    low: float | None = None,
    high: float | None = None,
    low_open: bool = False,
    high_open: bool = False,
    count: int | None = None,
    metavar: str | None = None,
    flags: tuple = (),
) -> Any:
    """A tuple of finite reals, each in [low, high] (either end open, or absent), ``count`` of them
    (None: one or more); the command line writes them comma-separated (``--offset-mm 10,0,0``)."""
    return _declare(
        "numbers",
        default,
        help=help,
        unit=unit,
        low=low,
        high=high,
        low_open=low_open,
        high_open=high_open,
        count=count,
        metavar=metavar,
        flags=flags,
    )


def words(default=None, *, help: str, count: int | None = None, metavar: str | None = None, flags: tuple = ()) -> Any:
    """A tuple of texts (column names, signed axes), ``count`` of them (None: one or more); the
    command line writes them comma-separated (``--gyro gx,gy,gz``). What each word must be is the
    reader's to judge (it knows the file's columns)."""
    return _declare("words", default, help=help, count=count, metavar=metavar, flags=flags)


def group(config_class: type, *, required: bool = False) -> Any:
    """A field holding another config whose declared options are this config's too (navigate's
    ``options: NavConfig``); the command line shows them in its place. The field defaults to that
    config's defaults unless ``required`` (one with a required option of its own: plan's request)."""
    if required:
        return dataclasses.field(metadata={"group": config_class})
    return dataclasses.field(default_factory=config_class, metadata={"group": config_class})


def one_of(key: str, classes: dict) -> Any:
    """A field holding the config of the class ``classes[config.<key>]``: a simulated scenario's plan
    (``key="scenario"``), an import format's own options. A command made for one value of ``key``
    (:func:`declared`'s ``fixed``) shows that class's options in the field's place. Default None:
    the class's defaults, as the config that holds the field reads it.

    Unlike a :func:`group`'s, the class's options are checked here, by the config that holds them
    (:func:`check_options`): a scenario's plan is plain data that other code also builds, with
    values no command line would give (a sway of zero amplitude, the plan search's candidates)."""
    return dataclasses.field(default=None, metadata={"one_of": (key, dict(classes))})


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


def chosen(config_class: Any, fixed: dict | None) -> dict:
    """``{field name: class}`` of every :func:`one_of` field of ``config_class`` whose key ``fixed``
    gives (a command for one scenario or format)."""
    fixed = fixed or {}
    out = {}
    for f in dataclasses.fields(config_class):
        if "one_of" in f.metadata:
            key, classes = f.metadata["one_of"]
            if fixed.get(key) in classes:
                out[f.name] = classes[fixed[key]]
    return out


def declared(config_class: Any, fixed: dict | None = None) -> tuple[tuple[str, Option], ...]:
    """``(field name, Option)`` of every option a config declares, in field order, a :func:`group`'s
    in its place; the flags filled in (``--`` and the name with dashes where none are given).

    ``fixed``: values a command fixes (``{"scenario": "flight"}``): those fields are no options of
    it, and a :func:`one_of` field whose key it fixes shows the chosen class's options in its place
    (without the key, a :func:`one_of` field shows none)."""
    fixed = fixed or {}
    variants = chosen(config_class, fixed)
    found: list[tuple[str, Option]] = []
    for f in dataclasses.fields(config_class):
        if f.name in fixed:
            continue
        if "group" in f.metadata:
            found += declared(f.metadata["group"])
        elif f.name in variants:
            found += declared(variants[f.name])
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
    if isinstance(value, numeric.Real) and not isinstance(value, bool):
        return f"{float(value) / scale:.15g}"
    return repr(value)


def _is_path(value) -> bool:
    return isinstance(value, (str, os.PathLike))


def _one(option: Option, value) -> str | None:
    """Why one value is wrong for ``option`` (the words after the option's name), or None."""
    kind = {"numbers": "number", "words": "text"}.get(option.kind, option.kind)  # a list's values, each
    if kind in ("number", "integer"):
        if isinstance(value, bool) or not isinstance(value, numeric.Integral if kind == "integer" else numeric.Real):
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
    if (option.many or option.kind in LISTS) and (
        isinstance(value, (str, bytes)) or not isinstance(value, (tuple, list))
    ):
        return f"{option.name}: {_shown(value)} is not a tuple of values"
    if option.kind in LISTS and (len(value) != option.count if option.count is not None else not value):
        wanted = f"give {option.count}" if option.count is not None else "give at least one"
        return f"{option.name}: {len(value)} values; {wanted}" + (f" ({option.metavar})" if option.metavar else "")
    values = value if option.many or option.kind in LISTS else (value,)
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
        if "one_of" in f.metadata and value is not None:
            key, classes = f.metadata["one_of"]
            wanted = classes.get(getattr(config, key))
            if wanted is not None and not isinstance(value, wanted):
                raise ConfigError(f"{f.name}: {value!r} is not a {wanted.__name__} ({key} {getattr(config, key)})")
            check_options(value)
        if "option" in f.metadata:
            problem = refusal(options[f.name], value)
            if problem is not None:
                raise ConfigError(problem)


def config_from(config_class: type, values: dict, fixed: dict | None = None):
    """``config_class`` made from option values by field name, as the command line parses them (a
    :func:`group`'s config made from its own); an option left out keeps its default. ``fixed``: the
    values a command fixes (:func:`declared`); a :func:`one_of` field is made of the chosen class
    when any of its options is given, and keeps its default (None) otherwise."""
    fixed = fixed or {}
    known = {name for name, _ in declared(config_class, fixed)}
    unknown = set(values) - known
    if unknown:
        raise TypeError(f"{config_class.__name__} declares no option {', '.join(sorted(unknown))}")
    variants = chosen(config_class, fixed)
    kwargs = dict(fixed)
    for f in dataclasses.fields(config_class):
        if f.name in fixed:
            continue
        if f.name in variants:
            own = {name for name, _ in declared(variants[f.name])}
            given = {k: v for k, v in values.items() if k in own}
            if given:
                kwargs[f.name] = config_from(variants[f.name], given)
        elif "group" in f.metadata:
            inner = f.metadata["group"]
            own = {name for name, _ in declared(inner)}
            kwargs[f.name] = config_from(inner, {k: v for k, v in values.items() if k in own})
        elif "option" in f.metadata and f.name in values:
            kwargs[f.name] = values[f.name]
    return config_class(**kwargs)


def parse_list(option: Option, text: str) -> tuple:
    """A list option's value as the command line writes it (``"10,0,0"``) -> a tuple (of floats for
    :func:`numbers`, of texts for :func:`words`), for :func:`refusal` to judge; text that is not
    comma-separated numbers refused as :class:`~sizefx.errors.ConfigError`, in the same words."""
    parts = text.split(",")
    if option.kind == "words":
        return tuple(parts)
    try:
        return tuple(float(p) for p in parts)
    except ValueError:
        shown = text if len(text) <= 60 else text[:60] + "..."
        wanted = f"{option.count} comma-separated numbers" if option.count else "a list of numbers (comma-separated)"
        raise ConfigError(f"{option.name}: {shown!r} is not {wanted}") from None
