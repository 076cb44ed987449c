"""What each stage is asked: its config, a frozen dataclass that declares every option once
(:mod:`sizefx.options`), one module per stage.

Each stage re-exports its config (``from sizefx.navigate import NavigateConfig``); the configs live
here, apart from the stages' code, because the command line builds every command from them and
``sizefx --help`` must not load numpy: these modules import only the standard library and
:mod:`sizefx.options`. A config checks its options when it is made (``__post_init__``): first each
declared option on its own (:func:`sizefx.options.check_options`), then its rules across options.
"""

from __future__ import annotations

from ..errors import ConfigError

__all__ = ["refuse_levers_and_model"]


def refuse_levers_and_model(levers, model) -> None:
    """The one refusal of a levers file beside an effect model (navigate, compensate and the
    chains alike): a model has its own arms."""
    if levers and model is not None and model != "":
        raise ConfigError(
            "--levers and --model both given: the effect model has its own lever arms ([lever_arm]); give one of them"
        )
