"""Shared fixtures, and the check that the tests run against what users install.

README command 2 installs sizefx without ``-e`` (``pip install ".[test]"``), exactly as a
user gets it, and the tests import that copy: a module left out of the wheel fails here,
not on a user's machine. :func:`_installed_matches_source` refuses to run against the
source tree (``python -m pytest`` puts it first on ``sys.path``) or against an installed
copy older than the source, with the command that fixes it.
"""

from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
REINSTALL = ".venv/bin/pip install --no-deps --force-reinstall . (or README command 2)"


def _installed_matches_source():
    import sizefx

    installed = Path(sizefx.__file__).resolve().parent
    if installed == ROOT / "sizefx":
        pytest.exit(f"the tests imported sizefx from the source tree ({installed}), not the installed package; "
                    "run .venv/bin/pytest rather than python -m pytest (which puts the working folder first "
                    "on sys.path)", returncode=2)
    # source folder -> its installed home (pyproject.toml's [tool.hatch.build.targets.wheel.sources])
    homes = {ROOT / "sizefx": installed, ROOT / "cli": installed.parent / "sizefx_cli",
             ROOT / "data-schemas": installed / "schemas"}
    for src, home in homes.items():
        for f in sorted(src.rglob("*")):
            if f.suffix not in (".py", ".json") or "__pycache__" in f.parts:
                continue
            copy = home / f.relative_to(src)
            if not copy.is_file() or copy.read_bytes() != f.read_bytes():
                pytest.exit(f"the installed sizefx ({installed}) is not the source: {f.relative_to(ROOT)} "
                            f"{'is missing' if not copy.is_file() else 'differs'}; reinstall with {REINSTALL}",
                            returncode=2)


def pytest_configure(config):
    _installed_matches_source()


from support import write_raw  # noqa: E402  (numpy and h5py only: no sizefx before the check)


@pytest.fixture
def raw_file(tmp_path):
    return write_raw(tmp_path / "static.h5")


@pytest.fixture(scope="session")
def turntable_file(tmp_path_factory):
    """The full paper turntable plan with default effects (lever arms + noise), seed 0."""
    from sizefx.simulate import SimulateConfig, run

    path = tmp_path_factory.mktemp("sim") / "turntable.h5"
    run(SimulateConfig("turntable", path, seed=0))
    return path


@pytest.fixture(scope="session")
def short_turntable_plan():
    """One axis (Z), one cycle: a 40 s record for quick checks."""
    from sizefx import scenarios

    return scenarios.TurntablePlan(axes="Z", static_s=5.0, seconds_per_axis=24.0, cycles=1, settle_s=5.0)
