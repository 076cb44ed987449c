"""What each stage is asked: its config, a frozen dataclass that declares every option once
(:mod:`sizefx.options`), one module per stage.

Each stage re-exports its config (``from sizefx.navigate import NavigateConfig``); the configs live
here, apart from the stages' code, because the command line builds every command from them and
``sizefx --help`` must not load numpy: these modules import only the standard library and
:mod:`sizefx.options`. A config checks its options when it is made (``__post_init__``): first each
declared option on its own (:func:`sizefx.options.check_options`), then its rules across options.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from ..errors import ConfigError
from ..options import config_from, declared

__all__ = ["refuse_levers_and_model", "NoOptions", "format_options"]


def refuse_levers_and_model(levers, model) -> None:
    """The one refusal of a levers file beside an effect model (navigate, compensate and the
    chains alike): a model has its own arms."""
    if levers and model is not None and model != "":
        raise ConfigError(
            "--levers and --model both given: the effect model has its own lever arms ([lever_arm]); give one of them"
        )


@dataclass(frozen=True)
class NoOptions:
    """The options of a format that takes none of its own (``sizefx import psins-imu``, ``export csv``)."""


def format_options(command: str, fmt: str, classes: dict, given):
    """A format's own options as the config holds them: an instance of ``classes[fmt]`` (the
    :func:`~sizefx.options.one_of` field's), made from a mapping of them by name (a Python caller's
    ``options={"stamps": "receive"}``), or its defaults for None; anything else is left for
    :func:`~sizefx.options.check_options` to refuse. An unknown format is left alone: its
    declaration refuses it."""
    chosen = classes.get(fmt)
    if chosen is None or not (given is None or isinstance(given, Mapping)):
        return given
    names = [name for name, _ in declared(chosen)]
    unknown = sorted(set(given or {}) - set(names))
    if unknown:
        raise ConfigError(f"{command} {fmt}: no option {', '.join(unknown)}; its options: {', '.join(names) or 'none'}")
    return config_from(chosen, dict(given or {}))
