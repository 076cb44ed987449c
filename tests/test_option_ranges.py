"""Every numeric option of every command has a finite, documented range: walking the click
tree, a FLOAT or INT option must be a ``Span`` (finite float range) or an ``IntRange``, and NaN and
inf must be refused in one line before any work."""

from __future__ import annotations

import click
import pytest
from click.testing import CliRunner

from sizefx_cli.main import main
from sizefx_cli.options import Span


def _commands(group: click.Group, path=()):
    for name, cmd in sorted(group.commands.items()):
        if isinstance(cmd, click.Group):
            yield from _commands(cmd, path + (name,))
        else:
            yield path + (name,), cmd


NUMERIC = [
    (path, p)
    for path, cmd in _commands(main)
    for p in cmd.params
    if isinstance(p, click.Option) and isinstance(p.type, (click.types.FloatParamType, click.types.IntParamType))
]


def test_there_are_numeric_options_to_check():
    assert len(NUMERIC) >= 25  # the walk found the commands (a broken walk would make the checks below vacuous)


@pytest.mark.parametrize("path,param", NUMERIC, ids=[f"{' '.join(p)} {q.opts[0]}" for p, q in NUMERIC])
def test_each_numeric_option_has_a_range(path, param):
    if isinstance(param.type, click.types.FloatParamType):
        assert isinstance(param.type, Span), f"{' '.join(path)} {param.opts[0]}: a plain float lets NaN and inf in"
        assert param.type.min is not None and param.type.max is not None, "both ends bounded"
    else:
        assert isinstance(param.type, click.IntRange) and param.type.min is not None, "an int option needs a range"
        # --segment is checked against the segments the record has
        assert param.type.max is not None or param.opts[0] == "--segment", "loops and chunks need an upper bound"


@pytest.mark.parametrize(
    "path,param",
    [(p, q) for p, q in NUMERIC if isinstance(q.type, Span)],
    ids=[f"{' '.join(p)} {q.opts[0]}" for p, q in NUMERIC if isinstance(q.type, Span)],
)
@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "1e400"])
def test_non_finite_values_are_one_line(tmp_path, path, param, value):
    cmd = main
    for name in path:
        cmd = cmd.commands[name]
    output = ["-o", str(tmp_path / "x.h5")] if any("-o" in p.opts for p in cmd.params) else []
    result = CliRunner().invoke(main, [*path, param.opts[0], value, *output])
    lines = result.stderr.strip().splitlines()
    assert result.exit_code == 2 and len(lines) == 1 and param.opts[0] in lines[0], result.stderr
    assert list(tmp_path.iterdir()) == []
