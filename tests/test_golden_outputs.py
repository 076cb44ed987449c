"""Every command's outputs, fingerprinted: a change of structure must not change a result.

A chain of small deterministic records (a turntable, a flight, two tumbles, each simulated with a
fixed seed) goes through the commands a user runs: inspect, calibrate, navigate (plain, with the
arms, with a model; rates and increments), compensate, compare, diagnose, export. Each output is
reduced to a fingerprint (for every array: its shape, sum, sum of squares, first and last values;
for a JSON document: its numbers and strings) and compared with ``tests/golden/outputs.json``.

The tolerance is 1e-9 relative (1e-12 absolute): far below anything a change of behaviour moves,
far above the last-bit differences another NumPy or BLAS build may give, so the check holds on a
fresh install and still fails when a refactor changes a result. A deliberate change of results
regenerates the file, from a clean checkout of the new commit, and says so in its commit:

    python tests/test_golden_outputs.py --regenerate

Timings, dates, paths and versions are left out of the fingerprints (:data:`VOLATILE`).
"""

from __future__ import annotations

import csv
import json
import math
import re
import sys
import tempfile
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
GOLDEN = ROOT / "tests" / "golden" / "outputs.json"
RTOL, ATOL = 1e-9, 1e-12
#: Keys whose values depend on the machine, the time or the folder, not on the results.
VOLATILE = {
    "wall_s",
    "kernel_s",
    "read_s",
    "write_s",
    "duration_s_wall",
    "elapsed_s",
    "date",
    "created",
    "path",
    "file",
    "input",
    "output",
    "source",
    "model",
    "json_path",
    "sizefx_version",
    "version",
    "peak_rss_mib",
    "phases_s",
    "threads",
    "runtime_s",
    "fit_s",
    "time_s_spent",
}

#: An absolute path inside a string (at its start or after a space): "ideal + /tmp/x/model.toml";
#: a unit such as "deg/h/g" is no path.
ABSOLUTE_PATH = re.compile(r"(?:^|(?<=\s))/[^\s,;:)\]'\"]+")

EFFECTS_TOML = """\
schema = "sizefx/effects/1"

[lever_arm]
d_y_m = [0.0, 0.0279, 0.0]

[accel_misalignment]
enabled = true

[accel_delay]
enabled = true
tau_s = 0.0005
"""


def _arrays(path: Path) -> dict:
    out = {}
    with h5py.File(path, "r") as f:

        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and obj.dtype.kind in "fiu":
                a = np.asarray(obj[()], dtype=float)
                flat = a.ravel()
                out[name] = [list(a.shape), float(flat.sum()), float((flat**2).sum()), float(flat[0]), float(flat[-1])]

        f.visititems(visit)
        for key, value in f.attrs.items():
            if key.endswith("_json"):
                out[f"@{key}"] = _document(json.loads(value))
    return out


def _document(doc):
    """The numbers and strings of a JSON document, its volatile keys left out."""
    if isinstance(doc, dict):
        # a key that is a file (calibrate's per-record tables) by its name: the folder differs
        return {Path(k).name if "/" in k else k: _document(v) for k, v in sorted(doc.items()) if k not in VOLATILE}
    if isinstance(doc, list):
        return [_document(v) for v in doc]
    if isinstance(doc, str):
        return ABSOLUTE_PATH.sub("<path>", doc)  # a file's folder differs from run to run; units stay
    return doc


def _csv(path: Path) -> dict:
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    values = np.array([[float(x) for x in row] for row in rows[1:]])
    return {"header": rows[0], "values": [list(values.shape), float(values.sum()), float((values**2).sum())]}


def fingerprints(folder: Path) -> dict:
    """Run the commands in ``folder`` and fingerprint what they write."""
    from click.testing import CliRunner

    from sizefx_cli.main import main

    def sx(*args):
        result = CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)
        assert result.exit_code == 0, (args, result.output)
        return result.output

    f = folder
    (f / "imu.toml").write_text(EFFECTS_TOML)
    common = ["--effects", f / "imu.toml", "-q"]
    sx("simulate", "turntable", "-o", f / "tt.h5", "--rate-hz", 200, "--vertical-axes", "YXZ", "--cycles", 1,
       "--seconds-per-axis", 24, "--static-s", 5, "--seed", 1, *common)  # fmt: skip
    sx("simulate", "flight", "-o", f / "fl.h5", "--rate-hz", 200, "--duration-h", 0.3, "--align-s", 30,
       "--offset-mm", "500,100,-200", "--seed", 2, *common)  # fmt: skip
    sx("simulate", "tumble", "-o", f / "tumble_incr.h5", "--form", "increments", "--rate-hz", 200, "--duration-s", 30,
       "--seed", 4, *common)  # fmt: skip
    sx("simulate", "tumble", "-o", f / "tumble.h5", "--rate-hz", 200, "--reference-rate-hz", 100, "--duration-s", 60,
       "--seed", 3, *common)  # fmt: skip
    sx("inspect", f / "fl.h5", "--json", f / "inspect.json")
    sx("calibrate", f / "tt.h5", "--json", f / "levers.json")
    sx("diagnose", f / "tumble.h5", "--json", f / "diagnosis.json", "--model-out", f / "model.toml")
    for name, extra in {
        "plain": [],
        "levers": ["--levers", f / "levers.json"],
        "levers_center": ["--levers", f / "levers.json", "--mode", "center"],
        "model": ["--model", f / "model.toml"],
    }.items():
        sx("navigate", f / "fl.h5", "-o", f / f"{name}.nav.h5", "--json", f / f"{name}.nav.json", "--quiet", *extra)
    sx("navigate", f / "tumble_incr.h5", "-o", f / "incr_model.nav.h5", "--model", f / "model.toml", "--quiet")
    sx("compensate", f / "fl.h5", "--levers", f / "levers.json", "-o", f / "comp_levers.h5")
    sx("compensate", f / "fl.h5", "--model", f / "model.toml", "-o", f / "comp_model.h5")
    sx("compare", f / "levers.nav.h5", f / "plain.nav.h5", "--reference", f / "fl.h5", "--json", f / "compare.json")
    sx("compensate", f / "tumble.h5", "--levers", f / "levers.json", "-o", f / "tumble_comp.h5")
    sx("export", "csv", f / "tumble_comp.h5", "-o", f / "tumble_comp.csv")

    out: dict = {}
    for path in sorted(f.iterdir()):
        if path.suffix == ".h5":
            out[path.name] = _arrays(path)
        elif path.suffix == ".json":
            out[path.name] = _document(json.loads(path.read_text()))
        elif path.suffix == ".csv":
            out[path.name] = _csv(path)
        elif path.name == "model.toml":
            out[path.name] = [line for line in path.read_text().splitlines() if line and not line.startswith("#")]
    return out


def _differences(golden, now, where: str = "") -> list[str]:
    if isinstance(golden, dict) and isinstance(now, dict):
        found = [f"{where}/{k}: missing" for k in golden if k not in now]
        found += [f"{where}/{k}: new" for k in now if k not in golden]
        for k in golden.keys() & now.keys():
            found += _differences(golden[k], now[k], f"{where}/{k}")
        return found
    if isinstance(golden, list) and isinstance(now, list):
        if len(golden) != len(now):
            return [f"{where}: {len(golden)} items, now {len(now)}"]
        return [d for i, (g, n) in enumerate(zip(golden, now)) for d in _differences(g, n, f"{where}[{i}]")]
    if isinstance(golden, float) or isinstance(now, float):
        if isinstance(golden, (int, float)) and isinstance(now, (int, float)):
            if math.isclose(golden, now, rel_tol=RTOL, abs_tol=ATOL) or (math.isnan(golden) and math.isnan(now)):
                return []
    elif golden == now:
        return []
    return [f"{where}: {golden!r}, now {now!r}"]


def test_every_commands_outputs_are_as_recorded(tmp_path):
    golden = json.loads(GOLDEN.read_text())
    found = _differences(golden, fingerprints(tmp_path))
    assert not found, (
        f"{len(found)} outputs differ from tests/golden/outputs.json (a change meant to keep results must keep "
        f"them; a deliberate one regenerates the file: python tests/test_golden_outputs.py --regenerate):\n"
        + "\n".join(found[:30])
    )


def test_a_changed_result_is_seen():
    """The comparison itself: a relative change of 1e-7 is a difference, one of 1e-12 is not."""
    assert _differences({"a": [1.0, {"b": 2.0}]}, {"a": [1.0, {"b": 2.0 * (1 + 1e-7)}]}) == [
        "/a[1]/b: 2.0, now 2.0000002"
    ]
    assert _differences({"a": [1.0, {"b": 2.0}]}, {"a": [1.0, {"b": 2.0 * (1 + 1e-12)}]}) == []
    assert _differences({"a": "x"}, {"a": "y", "c": 1}) == ["/c: new", "/a: 'x', now 'y'"]


if __name__ == "__main__":
    if sys.argv[1:] != ["--regenerate"]:
        sys.exit("usage: python tests/test_golden_outputs.py --regenerate  (from a clean checkout)")
    with tempfile.TemporaryDirectory() as tmp:
        doc = fingerprints(Path(tmp))
    GOLDEN.parent.mkdir(exist_ok=True)
    GOLDEN.write_text(json.dumps(doc, indent=1, sort_keys=True) + "\n")
    print(f"wrote {GOLDEN.relative_to(ROOT)}: {len(doc)} outputs")
