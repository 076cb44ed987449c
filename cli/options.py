"""Options and helpers shared by several commands (rasterio's ``rio/options.py`` pattern)."""

from __future__ import annotations

import math
import sys
from dataclasses import MISSING

import click

from sizefx.errors import ConfigError
from sizefx.options import Option, chosen, config_from, declared, parse_list, refusal


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


def quiet_option(f):
    return click.option("--quiet", "-q", is_flag=True, help="No progress bar.")(f)


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


# ------------------------------------------------------ a stage's command, made from its config


def _checked(option: Option, value, ctx):
    """``value`` (in the config's unit) if the declared option accepts it; else the option's own
    refusal (:func:`sizefx.options.refusal`), the words a config made in Python raises."""
    problem = refusal(option, value)
    if problem is not None:
        raise click.UsageError(problem, ctx)
    return value


class DeclaredSpan(Span):
    """A declared number: click parses it and shows its range; the declaration judges it, and the
    field receives it in the config's unit (``--accel-delay-us`` fills seconds)."""

    def __init__(self, option: Option):
        super().__init__(option.low, option.high, min_open=option.low_open, max_open=option.high_open)
        self.option = option

    def convert(self, value, param, ctx):
        number = click.FLOAT.convert(value, param, ctx)
        return _checked(self.option, number if self.option.scale == 1.0 else number * self.option.scale, ctx)


class DeclaredIntRange(click.IntRange):
    """A declared integer: click parses it and shows its range; the declaration judges it."""

    def __init__(self, option: Option):
        super().__init__(option.low, option.high)
        self.option = option

    def convert(self, value, param, ctx):
        return _checked(self.option, click.INT.convert(value, param, ctx), ctx)


class DeclaredChoice(click.Choice):
    """A declared word from a list: click shows the list; the declaration judges it."""

    def __init__(self, option: Option):
        super().__init__(option.choices)
        self.option = option

    def convert(self, value, param, ctx):
        return _checked(self.option, value, ctx)


class DeclaredList(click.ParamType):
    """A declared list (numbers, words), written comma-separated: parsed by the declaration's own
    :func:`~sizefx.options.parse_list` and judged by it, in the same words as from Python."""

    name = "text"

    def __init__(self, option: Option):
        self.option = option

    def convert(self, value, param, ctx):
        if isinstance(value, tuple):  # a value already (a config's, not typed)
            return _checked(self.option, value, ctx)
        try:
            parsed = parse_list(self.option, value)
        except ConfigError as exc:
            raise click.UsageError(str(exc), ctx) from None
        return _checked(self.option, parsed, ctx)


def _list_text(option: Option, value: tuple) -> str:
    """A list's default as the command line writes it: ``10,20,30``."""
    return ",".join(f"{v:.15g}" if option.kind == "numbers" else str(v) for v in value)


def _type(option: Option):
    kind = option.kind
    if kind in ("numbers", "words"):
        return DeclaredList(option)
    if kind == "number":
        return DeclaredSpan(option)
    if kind == "integer":
        return DeclaredIntRange(option)
    if kind == "choice":
        return DeclaredChoice(option)
    if kind == "file":
        return click.Path(dir_okay=False, allow_dash=option.dash)
    if kind == "folder":
        return click.Path(file_okay=False)
    if kind == "path":
        return click.Path()
    return None  # text: click's STRING


def declared_param(name: str, option: Option) -> click.Parameter:
    """The click argument or option of one declared option, named after the config's field."""
    if option.argument is not None:
        metavar = option.argument + ("..." if option.many else "")
        return click.Argument(
            [name], type=_type(option), nargs=-1 if option.many else 1, required=True, metavar=metavar
        )
    if option.kind == "switch":
        if any("/" in flag for flag in option.flags):  # --tilt/--no-tilt: either way, the default shown
            return click.Option([*option.flags, name], default=option.default, show_default=True, help=option.help)
        return click.Option(
            [*option.flags, name], is_flag=True, flag_value=option.sets, default=option.default, help=option.help
        )
    extra = {}
    if option.default is MISSING:
        extra["required"] = True
    elif option.kind in ("numbers", "words") and option.default is not None:
        # as the user writes it (click shows a show_default text in parentheses): "10,20,30"
        extra.update(default=_list_text(option, option.default), show_default=True)
    elif option.default is not None and not option.many:
        # click converts the default as it converts what the user types: in the command line's unit
        extra.update(default=option.default / option.scale if option.scale != 1.0 else option.default)
        extra.update(show_default=True)
    return click.Option(
        [*option.flags, name],
        type=_type(option),
        multiple=option.many,
        metavar=option.metavar,
        help=option.help or None,
        **extra,
    )


def declared_params(config_class: type, fixed: dict | None = None) -> list[click.Parameter]:
    """The command line's parameters of every option ``config_class`` declares, in its order (less
    the fields ``fixed`` gives, :func:`sizefx.options.declared`)."""
    return [declared_param(name, option) for name, option in declared(config_class, fixed)]


def _given(ctx: click.Context, names) -> bool:
    """Whether any of the parameters ``names`` came from the user rather than from its default."""
    from click.core import ParameterSource

    defaults = (ParameterSource.DEFAULT, ParameterSource.DEFAULT_MAP, None)
    return any(ctx.get_parameter_source(name) not in defaults for name in names)


def stage_command(config_class: type, *, fixed: dict | None = None, **attrs):
    """``@click.command()`` for a stage: its arguments and options made from the options
    ``config_class`` declares (:mod:`sizefx.options`), then the command's own (``--quiet``, declared
    below this decorator as usual). The function is called with the config made from them and the
    command's own options by name; ``sizefx batch`` and ``sizefx run`` make their per-record configs
    from the same declarations (the command's ``config_class``).

    ``fixed``: the config's values this command fixes (``{"scenario": "flight"}``: one command per
    scenario or format); a :func:`~sizefx.options.one_of` field shows the chosen class's options and
    is left None (the class's defaults) when the user gives none of them, so that the config can
    tell a plan given on the command line from none (``--plan FILE`` beside a scenario's options)."""
    fixed = dict(fixed or {})

    def decorator(f):
        names = [name for name, _ in declared(config_class, fixed)]
        variants = [[name for name, _ in declared(cls)] for cls in chosen(config_class, fixed).values()]

        def callback(**values):
            mine = {name: values.pop(name) for name in names}
            ctx = click.get_current_context()
            for own in variants:
                if not _given(ctx, own):
                    for name in own:
                        del mine[name]
            config = config_from(config_class, mine, fixed)
            return f(config, **values)

        callback.__name__, callback.__doc__ = f.__name__, f.__doc__
        own = getattr(f, "__click_params__", [])  # click keeps them bottom-up and reverses them
        callback.__click_params__ = [*own, *reversed(declared_params(config_class, fixed))]  # type: ignore[attr-defined]
        command = click.command(**attrs)(callback)
        command.config_class = config_class  # type: ignore[attr-defined]
        command.fixed = fixed  # type: ignore[attr-defined]
        return command

    return decorator


def variant_command(group: click.Group, config_class: type, fixed: dict, name: str):
    """A decorator: the command ``name`` of ``group`` made from ``config_class`` with the values
    ``fixed`` (:func:`stage_command`: one command per scenario or format), registered with the group."""

    def decorator(f):
        command = stage_command(config_class, fixed=fixed, name=name)(f)
        group.add_command(command)
        return command

    return decorator
