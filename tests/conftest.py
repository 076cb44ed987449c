"""Shared fixtures, and the check that the tests run against this checkout's code.

Two installs are accepted. README command 2 installs sizefx without ``-e`` (``pip install
".[test]"``), exactly as a user gets it: a module left out of the wheel fails here, not on a
user's machine, and the installed copy must equal the source file by file. The developers'
loop is an editable install (``pip install -e ".[test]"``): sizefx, ``sizefx_cli`` and
``sizefx.schemas`` then resolve to ``sizefx/``, ``cli/`` and ``data-schemas/`` of this checkout.
Anything else (the source tree on ``sys.path`` with no install, or another checkout's install)
stops the run with the command that fixes it.
"""

from __future__ import annotations

import importlib
import os
from pathlib import Path

import pytest
from hypothesis import settings

ROOT = Path(__file__).resolve().parents[1]
REINSTALL = '.venv/bin/pip install -e ".[test]" (the development loop) or README command 2'


def _home_of(module: str) -> Path | None:
    try:
        return Path(importlib.import_module(module).__file__).resolve().parent
    except ImportError:
        return None


def _installed_matches_source():
    homes = {ROOT / src: _home_of(module) for src, module in INSTALLED_AS.items()}
    if all(home == src for src, home in homes.items()):
        return  # an editable install of this checkout: every edit is seen at once
    missing = [module for (src, module) in zip(homes, INSTALLED_AS.values()) if homes[src] is None]
    if missing:
        pytest.exit(
            f"{', '.join(missing)} cannot be imported: sizefx is not installed in this environment; "
            f"install it with {REINSTALL}",
            returncode=2,
        )
    if any(home == src for src, home in homes.items()):
        pytest.exit(
            f"the tests imported sizefx partly from the source tree and partly from an install "
            f"({', '.join(str(h) for h in homes.values())}); run .venv/bin/pytest rather than "
            f"python -m pytest from another environment, or install with {REINSTALL}",
            returncode=2,
        )
    for src, home in homes.items():
        for f in sorted(src.rglob("*")):
            if f.suffix not in (".py", ".json") or "__pycache__" in f.parts:
                continue
            copy = home / f.relative_to(src)
            if not copy.is_file() or copy.read_bytes() != f.read_bytes():
                pytest.exit(
                    f"the installed sizefx ({homes[ROOT / 'sizefx']}) is not the source: "
                    f"{f.relative_to(ROOT)} {'is missing' if not copy.is_file() else 'differs'}; "
                    f"reinstall with {REINSTALL}",
                    returncode=2,
                )


# Hypothesis draws new examples on every run by hand (that is how a property finds what nobody
# thought of); CI draws the same ones each time (SIZEFX_HYPOTHESIS_PROFILE=ci, set by .ci/run),
# so that a red CI is the code's doing, never the draw's. benchmarks/fuzz_hostile.py explores.
settings.register_profile("ci", derandomize=True, database=None)
settings.load_profile(os.environ.get("SIZEFX_HYPOTHESIS_PROFILE", "default"))


def pytest_addoption(parser):
    parser.addoption(
        "--full",
        action="store_true",
        help="run both tiers: the fast tier and the long one (the tests marked slow; pytest -m slow runs those alone)",
    )


def pytest_configure(config):
    _installed_matches_source()


def pytest_collection_modifyitems(config, items):
    """The fast tier by default: tests marked ``slow`` are left out unless ``--full`` or a ``-m``
    expression asks for them, or the test is named by its id on the command line."""
    if long_tier_selected(config):
        return
    named = [arg for arg in config.args if "::" in arg]
    keep, slow = [], []
    for item in items:
        if item.get_closest_marker("slow") is None or any(_names(arg, item) for arg in named):
            keep.append(item)
        else:
            slow.append(item)
    if slow:
        config.hook.pytest_deselected(items=slow)
        items[:] = keep
        config._sizefx_slow_left_out = len(slow)


def _names(arg: str, item) -> bool:
    path, _, rest = arg.partition("::")
    return Path(path).resolve() == Path(item.path).resolve() and item.nodeid.split("::", 1)[1].startswith(rest)


def pytest_terminal_summary(terminalreporter, config):
    left_out = getattr(config, "_sizefx_slow_left_out", 0)
    if left_out:
        terminalreporter.write_line(
            f"fast tier: {left_out} tests of the long tier left out; pytest -m slow runs them, pytest --full both tiers"
        )


from support import INSTALLED_AS, long_tier_selected, real_data, write_raw  # noqa: E402  (numpy and h5py only: no sizefx before the check)


@pytest.fixture
def real_data_folder():
    """The real recordings' folder (tests/support.py's real_data: skip, or fail under .ci/run)."""
    return real_data()


@pytest.fixture
def raw_file(tmp_path):
    return write_raw(tmp_path / "static.h5")


@pytest.fixture(scope="session")
def short_turntable_plan():
    """One axis (Z), one cycle: a 40 s record for quick checks."""
    from sizefx import scenarios

    return scenarios.TurntablePlan(axes="Z", static_s=5.0, seconds_per_axis=24.0, cycles=1, settle_s=5.0)
