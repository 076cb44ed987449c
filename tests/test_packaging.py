"""The wheel holds every module and every schema, and the plain install has what the demo needs.

A hand-written package list once left ``sizefx.kernels`` out of the wheel and
the README's first command failed on a fresh machine, while an editable install hid the
hole. Here the wheel is built from the checkout, as ``pip install .`` builds it, and
compared with the source tree file by file.
"""

from __future__ import annotations

import ast
import json
import re
import shutil
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest
from support import INSTALLED_AS

ROOT = Path(__file__).resolve().parents[1]


#: what a build reads: the sources, and what pyproject.toml and setup.py name
BUILD_INPUTS = ("sizefx", "cli", "data-schemas", "pyproject.toml", "setup.py", "README.md", "LICENSE")


def _copy_of_the_sources(dest: Path) -> Path:
    for name in BUILD_INPUTS:
        if (ROOT / name).is_dir():
            shutil.copytree(ROOT / name, dest / name, ignore=shutil.ignore_patterns("__pycache__"))
        else:
            shutil.copy2(ROOT / name, dest / name)
    return dest


def _build(hook: str, src: Path, out: Path) -> Path:
    """Call the build backend's ``hook`` (build_wheel, build_editable) in ``src``; the file it wrote."""
    proc = subprocess.run(
        [sys.executable, "-c", f"from setuptools.build_meta import {hook}; print({hook}({str(out)!r}))"],
        cwd=src,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    return out / proc.stdout.strip().splitlines()[-1]


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> zipfile.ZipFile:
    """The wheel ``pip install .`` would build, built from a copy of the sources.

    A copy, so that the build's ``build/`` and ``*.egg-info`` never land in the checkout (a stale
    ``build/lib`` would also hide a file that the build no longer picks up), and so that parallel
    runs of the suite never share a build folder. setuptools is one of the test extras: the build
    runs in this process's environment, with no download, exactly what pip's build step calls.
    """
    src = _copy_of_the_sources(tmp_path_factory.mktemp("source"))
    built = _build("build_wheel", src, tmp_path_factory.mktemp("wheel"))
    with zipfile.ZipFile(built) as zf:
        yield zf


def _expected() -> dict[str, Path]:
    """Installed path -> source file for every module and schema of the checkout."""
    want = {}
    for src, package in INSTALLED_AS.items():
        home = package.replace(".", "/")
        for f in (ROOT / src).rglob("*"):
            if f.is_file() and f.suffix in (".py", ".json") and "__pycache__" not in f.parts:
                want[f"{home}/{f.relative_to(ROOT / src).as_posix()}"] = f
    return want


def test_every_module_and_schema_is_in_the_wheel(wheel):
    names = set(wheel.namelist())
    want = _expected()
    # the ones that went missing before, and each kind of file, by name: the walk above found them
    for must in (
        "sizefx/kernels/strapdown.py",
        "sizefx/importers/table.py",
        "sizefx_cli/main.py",
        "sizefx/schemas/telemetry-1.json",
        "sizefx/schemas/__init__.py",
    ):
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
    or be optional: pyulog (the ULog importer), rosbags (the ROS bag importer and exporter) or
    distributed (``sizefx batch --scheduler``), each of which says how to install it.
    """
    meta = wheel.read("sizefx-0.1.0.dist-info/METADATA").decode()
    # distribution names as module names: tomli-w installs tomli_w
    base = {
        re.split(r"[<>=!~ ;\[]", line.split(":", 1)[1].strip())[0].lower().replace("-", "_")
        for line in meta.splitlines()
        if line.startswith("Requires-Dist:") and "extra ==" not in line
    }
    assert {"numpy", "numba", "scipy", "h5py", "click", "matplotlib"} <= base, base
    stdlib = set(sys.stdlib_module_names)
    ours = {"sizefx", "sizefx_cli"}
    optional = {"pyulog", "rosbags", "distributed"}
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


def _packages_in_the_tree() -> set[str]:
    """Every package of the checkout by its installed name: each folder with an ``__init__.py``."""
    found = set()
    for src, home in INSTALLED_AS.items():
        for init in (ROOT / src).rglob("__init__.py"):
            if "__pycache__" not in init.parts:
                rel = init.parent.relative_to(ROOT / src).parts
                found.add(".".join((home, *rel)))
    return found


def test_setup_py_discovers_every_package():
    """The fast twin of the wheel tests above: the package list setup.py hands to setuptools is
    every package folder of the tree, found, not written by hand, and the two renamed folders
    are mapped where pyproject.toml says."""
    tree = ast.parse((ROOT / "setup.py").read_text())
    by_hand = [
        n.value
        for n in ast.walk(tree)
        if isinstance(n, ast.Constant)
        and isinstance(n.value, str)
        and n.value.startswith("sizefx.")
        and n.value not in ("sizefx.*", "sizefx.schemas")
    ]
    assert not by_hand, f"a package written by hand in setup.py: {by_hand}"
    from setuptools import find_packages

    discovered = {*find_packages(where=str(ROOT), include=["sizefx", "sizefx.*"]), "sizefx_cli", "sizefx.schemas"}
    assert discovered == _packages_in_the_tree()
    cfg = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert cfg["build-system"]["build-backend"] == "setuptools.build_meta"
    renamed = {package: src for src, package in INSTALLED_AS.items() if package != src}
    assert cfg["tool"]["setuptools"]["package-dir"] == renamed


#: run in a fresh interpreter: the editable wheel's import finder first on sys.meta_path (ahead of
#: whatever sizefx this environment has installed), then where each of the three packages comes from
_WHERE_FROM = """
import importlib.util, json, sys
spec = importlib.util.spec_from_file_location("finder", sys.argv[1])
finder = importlib.util.module_from_spec(spec)
spec.loader.exec_module(finder)
finder.install()
sys.meta_path.insert(0, sys.meta_path.pop())
import sizefx, sizefx_cli, sizefx.schemas, sizefx.constants
print(json.dumps([sizefx.__file__, sizefx_cli.__file__, sizefx.schemas.__file__,
                  getattr(sizefx.constants, "EDITED", None)]))
"""


def test_editable_install_maps_the_three_folders_and_sees_an_edit(tmp_path):
    """``pip install -e .`` (the developers' loop): the editable wheel setuptools builds maps
    ``sizefx``, ``sizefx_cli`` and ``sizefx.schemas`` onto ``sizefx/``, ``cli/`` and ``data-schemas/``
    of the checkout, and an edited module is seen by the next process without reinstalling."""
    src = _copy_of_the_sources(tmp_path / "source")
    built = _build("build_editable", src, tmp_path)
    with zipfile.ZipFile(built) as zf:
        finders = [n for n in zf.namelist() if n.startswith("__editable__") and n.endswith("_finder.py")]
        assert len(finders) == 1, zf.namelist()
        zf.extract(finders[0], tmp_path / "site")
    finder = tmp_path / "site" / finders[0]

    def where_from():
        proc = subprocess.run(
            [sys.executable, "-c", _WHERE_FROM, str(finder)], capture_output=True, text=True, timeout=120
        )
        assert proc.returncode == 0, proc.stderr
        return json.loads(proc.stdout)

    sizefx_init, cli_init, schemas_init, edited = where_from()
    assert Path(sizefx_init) == src / "sizefx" / "__init__.py"
    assert Path(cli_init) == src / "cli" / "__init__.py"
    assert Path(schemas_init) == src / "data-schemas" / "__init__.py"
    assert edited is None
    with (src / "sizefx" / "constants.py").open("a") as f:
        f.write("\nEDITED = 1\n")
    assert where_from()[3] == 1
