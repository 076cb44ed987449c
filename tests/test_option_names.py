"""One meaning per option name: every command's parameters walked, the same name the same kind of value.

A user who learnt ``--json FILE`` in one command must not meet ``--json`` as a flag in another, nor
``--plots`` as a folder here and a switch there. The walk covers every command click builds,
``sizefx batch STAGE`` and the stages of ``sizefx run`` and ``sizefx batch run`` included, so a
new command or option is checked without being listed here.
"""

from __future__ import annotations

import re
from collections import defaultdict

import click
import pytest

from sizefx_cli.main import main


def _commands(command: click.Command, path: tuple[str, ...] = ()):
    """(path, command) for every command below ``command`` that takes options (groups too)."""
    yield path, command
    if isinstance(command, click.Group):
        for name, sub in command.commands.items():
            yield from _commands(sub, (*path, name))


def _options():
    """(command path, option name, click.Option) for every visible option name of every command."""
    for path, command in _commands(main):
        for param in command.params:
            if isinstance(param, click.Option) and not param.hidden:
                for name in (*param.opts, *param.secondary_opts):
                    if name.startswith("--"):
                        yield " ".join(path) or "sizefx", name, param


def _kind(param: click.Option) -> str:
    """What an option takes, coarsely: a switch, a path (file, folder or either), a number, a word from
    a list, or text."""
    if param.is_flag:
        return "flag"
    kind = param.type
    if isinstance(kind, click.Path):
        return "folder" if not kind.file_okay else "file" if not kind.dir_okay else "path"
    if isinstance(kind, (click.FloatRange, click.IntRange)) or kind in (click.FLOAT, click.INT):
        return "number"
    if isinstance(kind, click.Choice):
        return "choice"
    return "text"


OPTIONS = list(_options())


def test_the_walk_sees_every_command():
    """The walk reaches the nested commands (batch and chain stages), so the checks below cover them."""
    paths = {path for path, _, _ in OPTIONS}
    for expected in ("inspect", "batch navigate", "run calibrate", "batch run navigate", "import table-log"):
        assert expected in paths
    assert len(OPTIONS) > 300


def test_one_kind_of_value_per_option_name():
    """A name takes the same kind of value everywhere. A batch's paired option (compare's B and
    --reference per record) is a path where the single command's is a file: both are paths."""
    kinds = defaultdict(set)
    for _path, name, param in OPTIONS:
        kind = _kind(param)
        kinds[name].add("path" if kind in ("file", "path") else kind)
    mixed = {name: sorted(k) for name, k in kinds.items() if len(k) > 1}
    assert not mixed, f"one option name, several kinds of value: {mixed}"


@pytest.mark.parametrize(
    "name, kind, metavar",
    [
        ("--json", {"file", "path"}, "FILE"),  # a JSON file written (inspect: '-' for stdout)
        ("--plots", {"folder"}, "DIR"),  # a folder of PNGs
        ("--plot", {"file"}, "FILE"),  # one PNG
        ("--out", {"folder"}, None),  # the folder of a run, a batch or the demo
    ],
)
def test_output_options_mean_one_thing(name, kind, metavar):
    found = [(path, param) for path, n, param in OPTIONS if n == name]
    assert found, name
    for path, param in found:
        assert _kind(param) in kind, f"{path} {name} takes a {_kind(param)}"
        if metavar:
            assert param.metavar == metavar, f"{path} {name} shows {param.metavar}"


#: Unit suffixes of option names and how their help writes the unit.
UNIT_SUFFIXES = {
    "-s": "[s]",
    "-h": "[h]",
    "-hz": "[Hz]",
    "-deg": "[deg]",
    "-dps": "[deg/s]",
    "-dps2": "[deg/s^2]",
    "-mm": "[mm]",
    "-m": "[m]",
    "-mps": "[m/s]",
    "-us": "[us]",
    "-ug": "[ug",  # micro-g, or a noise density in ug/sqrt(Hz)
    "-mib": "[MiB]",
}


#: Float options whose name says their unit in words: seconds, or encoder counts.
NUMBERS_NAMED_IN_WORDS = {"--seconds-per-axis", "--counts-per-rev", "--counter-modulus"}


def test_a_unit_suffix_is_the_unit_of_the_value():
    """``--align-s`` takes seconds and its help says [s]; a number with a unit but no suffix in its
    name would leave the user to guess (the float options without one name their unit in words)."""
    for path, name, param in OPTIONS:
        suffix = next((s for s in sorted(UNIT_SUFFIXES, key=len, reverse=True) if name.endswith(s)), None)
        if suffix is not None:
            assert UNIT_SUFFIXES[suffix] in (param.help or ""), (
                f"{path} {name}: help does not say {UNIT_SUFFIXES[suffix]}"
            )
        elif isinstance(param.type, click.FloatRange):
            assert name in NUMBERS_NAMED_IN_WORDS, f"{path} {name}: a float option without a unit suffix"


def test_force_names_what_it_replaces():
    """Each command's --force says which of its outputs it replaces, by options the command has, and
    that an input is never among them."""
    for path, command in _commands(main):
        force = next((p for p in command.params if p.name == "force"), None)
        if force is None:
            continue
        text = force.help or ""
        assert text.startswith("Replace ") and "never an input" in text, f"{path}: {text}"
        named = set(re.findall(r"(?<![\w-])(--?[a-z][\w-]*)", text))
        flags = {o for p in command.params for o in (*getattr(p, "opts", ()), *getattr(p, "secondary_opts", ()))}
        assert named and named <= flags, f"{path} --force names {sorted(named - flags)}, which it does not have"


def test_help_speaks_of_records_not_of_the_simulation():
    """Commands that take a user's recording describe it as a record; only simulate, plan, demo and
    paper speak of a simulation of their own."""
    own = ("simulate", "plan", "demo", "paper")
    for path, command in _commands(main):
        if path and path[-1] in own or (path and path[0] in own):
            continue
        texts = [command.help or ""] + [getattr(p, "help", None) or "" for p in command.params]
        for text in texts:
            assert not re.search(r"\bthe simulation\b", text), f"{' '.join(path)}: {text}"
