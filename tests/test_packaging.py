"""The wheel holds every module and every schema, and the plain install has what the demo needs.

Issue 13: a hand-written package list once left ``sizefx.kernels`` out of the wheel and
the README's first command failed on a fresh machine, while an editable install hid the
hole. Here the wheel is built from the checkout, as ``pip install .`` builds it, and
compared with the source tree file by file.
"""

from __future__ import annotations

import ast
import re
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> zipfile.ZipFile:
    out = tmp_path_factory.mktemp("wheel")
    # hatchling is the build backend (pyproject.toml) and one of the test extras: build in
    # this process's environment, with no download, exactly what pip's build step calls.
    proc = subprocess.run([sys.executable, "-c", f"from hatchling.build import build_wheel; "
                                                 f"print(build_wheel({str(out)!r}))"],
                          cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    name = proc.stdout.strip().splitlines()[-1]
    with zipfile.ZipFile(out / name) as zf:
        yield zf


def _expected() -> dict[str, Path]:
    """Installed path -> source file for every module and schema of the checkout."""
    homes = {"sizefx": "sizefx", "cli": "sizefx_cli", "data-schemas": "sizefx/schemas"}
    want = {}
    for src, home in homes.items():
        for f in (ROOT / src).rglob("*"):
            if f.is_file() and f.suffix in (".py", ".json") and "__pycache__" not in f.parts:
                want[f"{home}/{f.relative_to(ROOT / src).as_posix()}"] = f
    return want


def test_every_module_and_schema_is_in_the_wheel(wheel):
    names = set(wheel.namelist())
    want = _expected()
    # the ones that went missing before, and each kind of file, by name: the walk above found them
    for must in ("sizefx/kernels/strapdown.py", "sizefx/importers/table.py", "sizefx_cli/main.py",
                 "sizefx/schemas/telemetry-1.json", "sizefx/schemas/__init__.py"):
        assert must in want, must
    missing = sorted(set(want) - names)
    assert not missing, f"left out of the wheel: {missing}"
    for installed, source in want.items():
        assert wheel.read(installed) == source.read_bytes(), installed


def test_the_wheel_carries_no_caches_or_stray_files(wheel):
    stray = [n for n in wheel.namelist() if "__pycache__" in n or n.endswith((".pyc", ".nbi", ".nbc", ".h5"))]
    assert not stray, stray
    tops = {n.split("/")[0] for n in wheel.namelist()}
    assert tops == {"sizefx", "sizefx_cli", "sizefx-0.1.0.dist-info"}, tops


def test_plain_install_has_every_library_the_package_imports(wheel):
    """matplotlib (plots) and the rest are base dependencies: the demo draws on a plain install.

    Every top-level import of a third-party module in the package must be a base dependency,
    or be optional: pyulog (the ULog importer) or distributed (``sizefx batch --scheduler``), each of
    which says how to install it.
    """
    meta = wheel.read("sizefx-0.1.0.dist-info/METADATA").decode()
    # distribution names as module names: tomli-w installs tomli_w
    base = {re.split(r"[<>=!~ ;\[]", line.split(":", 1)[1].strip())[0].lower().replace("-", "_")
            for line in meta.splitlines() if line.startswith("Requires-Dist:") and "extra ==" not in line}
    assert {"numpy", "numba", "scipy", "h5py", "click", "matplotlib"} <= base, base
    stdlib = set(sys.stdlib_module_names)
    ours = {"sizefx", "sizefx_cli"}
    optional = {"pyulog", "distributed"}
    imported = set()
    for name in wheel.namelist():
        if name.endswith(".py"):
            for node in ast.walk(ast.parse(wheel.read(name))):
                if isinstance(node, ast.Import):
                    imported |= {a.name.split(".")[0] for a in node.names}
                elif isinstance(node, ast.ImportFrom) and node.level == 0:
                    imported.add(node.module.split(".")[0])
    third = imported - stdlib - ours - optional - {"__future__"}
    assert third <= base, f"imported but not a base dependency: {sorted(third - base)}"


def test_pyproject_lists_no_packages_by_hand():
    cfg = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert "setuptools" not in cfg.get("tool", {}), "packages are discovered by hatchling, not listed"
    assert cfg["tool"]["hatch"]["build"]["targets"]["wheel"]["only-include"] == ["sizefx", "cli", "data-schemas"]
