"""Benchmark: the test suite's two tiers, as a newcomer and CI run them.

    python benchmarks/bench_tests.py [--tier fast|slow|both] [--workers N] [--json FILE] [--record]

Each tier runs in a fresh ``git clone`` of this checkout's HEAD (so the figures are those of
what is committed, never of uncommitted edits), into which sizefx is installed without ``-e``
(``pip install --no-deps .``) into a new virtual environment that sees this environment's
packages: the package's files, and so its Numba cache, are new, as on a fresh machine (the
README's test command; only the download of the dependencies is left out of the time).

- fast: ``pytest`` (the default tier), one process, as README command 2 runs it. Targets:
  150 s and 1 GiB on 2 quiet cores.
- slow: ``pytest -m slow -n WORKERS`` (the long tier on every core, as .ci/run runs it).

Figures per tier: wall time of the pytest command, the peak resident memory of its largest
process (``ru_maxrss`` of the children, as ``/usr/bin/time -v`` reports it), pytest's closing
line, and the load average before and after it. Printed as JSON, never asserted; ``--record``
writes ``benchmarks/results/bench_tests.json`` (docs/development.md reads it).
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _measure import add_output_options, emit, run_measured

ROOT = Path(__file__).resolve().parents[1]


#: Console scripts a test tier runs: name -> (module, function), as the packages declare them.
CONSOLE_SCRIPTS = {"pytest": ("pytest", "console_main"), "dask": ("dask.__main__", "main")}


def _clone_and_install(work: Path) -> tuple[Path, Path]:
    """A fresh clone of HEAD and a venv (this environment's packages visible) with sizefx installed in it."""
    clone = work / "sizefx"
    subprocess.run(["git", "clone", "--quiet", str(ROOT), str(clone)], check=True)
    shared = ROOT.parent / "shared"
    if shared.is_dir():  # the real recordings at the same relative place as beside the checkout
        os.symlink(shared, work / "shared")
    venv = work / "venv"
    # no pip or setuptools of its own: this environment's (setuptools 77 or newer) build it
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    # this environment's site-packages, seen from the new venv (a venv's --system-site-packages
    # reaches only the base interpreter's): a .pth file names it, after the venv's own
    site = subprocess.run(
        [str(venv / "bin" / "python"), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        check=True,
        capture_output=True,
        text=True,
    ).stdout.strip()
    ours = [p for p in sys.path if p.endswith("site-packages")]
    Path(site, "zz_parent_env.pth").write_text("\n".join(ours) + "\n")
    subprocess.run(
        [sys.executable, "-m", "pip", "--python", str(venv / "bin" / "python"), "install", "-q", "--no-deps"]
        + ["--no-build-isolation", str(clone)],
        check=True,
    )
    # the console scripts the tiers call, for this venv (the packages are this environment's): the
    # README runs .venv/bin/pytest, which keeps the clone's folder off sys.path, and the fleet tests
    # start a Dask scheduler and worker with the dask script beside the interpreter
    for name, (module, function) in CONSOLE_SCRIPTS.items():
        script = venv / "bin" / name
        # (the guard matters: a batch test's spawned worker imports the main script again)
        script.write_text(
            f"#!{venv / 'bin' / 'python'}\nimport sys\nfrom {module} import {function}\n\n"
            f"if __name__ == '__main__':\n    sys.exit({function}())\n"
        )
        script.chmod(0o755)
    return clone, venv


def _run_tier(clone: Path, venv: Path, args: list[str]) -> dict:
    load_before = os.getloadavg()[0]
    log = clone.parent / "pytest.log"
    cmd = [str(venv / "bin" / "pytest"), "-p", "no:cacheprovider", *args]
    try:
        wall_s, peak_mib = run_measured(cmd, stdout=log, cwd=clone)
    except subprocess.CalledProcessError:  # a failing tier is no figure: say what failed
        sys.exit(f"bench_tests: pytest {' '.join(args)} failed:\n{log.read_text()[-3000:]}")
    closing = [line for line in log.read_text().splitlines() if re.search(r"\d+ (passed|failed)", line)]
    return {
        "command": " ".join(["pytest", *args]),
        "wall_s": round(wall_s, 1),
        "peak_mib": round(peak_mib),
        "pytest_summary": closing[-1].strip("= ") if closing else None,
        "load_1min_before": round(load_before, 2),
        "load_1min_after": round(os.getloadavg()[0], 2),
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--tier", choices=("fast", "slow", "both"), default="both")
    ap.add_argument("--workers", default="auto", help="pytest-xdist workers of the long tier (default: auto)")
    add_output_options(ap)
    args = ap.parse_args(argv)
    tiers = {}
    with tempfile.TemporaryDirectory(prefix="sizefx-bench-tests-") as tmp:
        for tier in ("fast", "slow") if args.tier == "both" else (args.tier,):
            work = Path(tmp) / tier
            work.mkdir()
            clone, venv = _clone_and_install(work)  # a new install per tier: each starts with a cold Numba cache
            tier_args = [] if tier == "fast" else ["-m", "slow", "-n", str(args.workers)]
            tiers[tier] = _run_tier(clone, venv, tier_args)
    # the long tier keeps every core busy: the load it leaves is its own
    return emit(tiers, args, __file__, argv, threads=1 if args.tier == "fast" else os.cpu_count() or 1)


if __name__ == "__main__":
    sys.exit(main())
