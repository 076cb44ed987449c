"""The example scripts in ``examples/`` run as a user runs them.

``examples/walkthrough.py`` walks the Python API (docs/api.md) through simulate, calibrate, navigate,
compare, a chain and a batch on short records: run as a script, in a process of its own (its batch
spawns workers, which import the script again: it must not run itself there), it ends cleanly, prints
each step's key result and leaves the outputs the page describes.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: Seconds the walk may take before the test gives up: it takes under ten on two busy cores.
WALK_TIMEOUT_S = 300


def test_the_walkthrough_runs_every_step(tmp_path):
    folder = tmp_path / "walk"
    proc = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "walkthrough.py"), str(folder)],
        capture_output=True,
        text=True,
        timeout=WALK_TIMEOUT_S,
        cwd=tmp_path,
    )
    assert proc.returncode == 0, proc.stderr
    out = proc.stdout
    for line in ("calibrated r_y = ", "compensated: final horizontal error", "A vs B: final horizontal distance"):
        assert line in out, out
    assert out.count("working in") == 1, out  # the workers did not run the walk again
    assert "2 ok, 0 unchanged" in out and "run again: 2 of 2 records unchanged" in out, out
    steps = json.loads((folder / "chain" / "run.json").read_text())["steps"]
    assert [(s["stage"], s.get("run")) for s in steps] == [
        ("calibrate", None),
        ("navigate", "plain"),
        ("navigate", "compensated"),
        ("compare", None),
    ]
    manifest = json.loads((folder / "nav" / "manifest.json").read_text())
    assert [e["name"] for e in manifest["records"]] == ["day1", "day2"]
    assert manifest["options"]["levers"] == str(folder / "levers.json")
    assert not proc.stderr.strip(), proc.stderr  # no progress lines, no warnings
