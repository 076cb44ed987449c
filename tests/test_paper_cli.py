"""``sizefx paper``: a --json that cannot be written is refused before the experiments run.

The experiments themselves run in ``tests/test_cli.py::test_demo_smoke`` (the demo calls the
same ``run_all``); the closed forms are checked in ``tests/test_paper.py``.
"""

from __future__ import annotations

from click.testing import CliRunner

from sizefx_cli.main import main


def test_unwritable_json_is_refused_before_any_work(tmp_path):
    out = tmp_path / "paper"
    bad = tmp_path / "no" / "results.json"
    result = CliRunner().invoke(main, ["paper", "turntable", "--out", str(out), "--json", str(bad)])
    assert result.exit_code == 2, result.output
    assert result.stderr.strip() == f"sizefx: error: {bad}: directory {bad.parent} does not exist; create it first"
    assert result.stdout == "" and not out.exists()  # no experiment started, no folder made
