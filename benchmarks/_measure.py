"""What the benchmarks share: a command's wall time and peak memory, and the record of a run.

Every benchmark ends with :func:`emit`, which wraps its figures in a record of the run: the
machine (CPU, cores, memory, versions, the 1-minute load average at start and end), the date
(UTC), the exact command line and the checkout's commit. With ``--record`` the record goes to
``benchmarks/results/<script>.json`` (committed: the figures in README.md and docs/ are read
from these files by ``tests/test_figures.py``); ``--json FILE`` writes the same record anywhere.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import shlex
import subprocess
import sys
import time
from importlib import metadata
from pathlib import Path

#: Where ``--record`` writes, one file per script (and label).
RESULTS = Path(__file__).resolve().parent / "results"
ROOT = RESULTS.parents[1]


# A small intermediate Python runs the command and reports its child's peak RSS: measured from a
# large benchmark process, a forked child would count the parent's pages as its own until exec.
# Its first argument is where the command's standard output goes ("" for nowhere).
_PROBE = (
    "import resource, subprocess, sys, time; t0 = time.perf_counter(); "
    "out = open(sys.argv[1], 'w') if sys.argv[1] else subprocess.DEVNULL; "
    "subprocess.run(sys.argv[2:], check=True, stdout=out, stderr=subprocess.PIPE); "
    "print(time.perf_counter() - t0, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)"
)


def run_measured(cmd, env=None, stdout: Path | None = None, cwd: Path | None = None) -> tuple[float, float]:
    """``(wall seconds, peak MiB)`` of ``cmd`` run in a fresh process (in ``cwd``, if given); its output to
    ``stdout`` if given. A command that fails raises :class:`subprocess.CalledProcessError`."""
    done = subprocess.run(
        [sys.executable, "-c", _PROBE, str(stdout or ""), *map(str, cmd)],
        check=True,
        env=env,
        cwd=cwd,
        capture_output=True,
        text=True,
    )
    wall, peak_kib = (float(x) for x in done.stdout.split())
    return wall, peak_kib / 1024.0


def add_output_options(ap: argparse.ArgumentParser) -> None:
    """``--json FILE`` and ``--record [LABEL]``, the same for every benchmark."""
    ap.add_argument("--json", type=Path, help="also write the record of the run (figures, machine, command) here")
    ap.add_argument(
        "--record",
        nargs="?",
        const="",
        metavar="LABEL",
        help="write the record to benchmarks/results/SCRIPT.json (SCRIPT-LABEL.json with a label), "
        "the file the docs' figures are read from",
    )


def results_path(script: str | Path, label: str = "") -> Path:
    """``benchmarks/results/<script>.json``, or ``<script>-<label>.json``."""
    stem = Path(script).stem
    return RESULTS / (f"{stem}-{label}.json" if label else f"{stem}.json")


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _version(dist: str) -> str | None:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return None


def machine(threads: int = 1) -> dict:
    """The machine and its load. ``quiet``: the 1-minute load average was at most 0.5 at the start
    and at most ``threads`` (the benchmark's own busy threads) + 0.5 at the end."""
    start, end = _STARTED["load"], os.getloadavg()[0]
    try:
        usable = len(os.sched_getaffinity(0))
    except AttributeError:
        usable = os.cpu_count()
    return {
        "cpu": _cpu_model(),
        "cores": os.cpu_count(),
        "cores_usable": usable,
        "memory_gib": round(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30, 1),
        "os": platform.platform(),
        "python": platform.python_version(),
        **{name: _version(name) for name in ("numpy", "numba", "scipy", "h5py", "sizefx")},
        "load_average_1min": {"start": round(start, 2), "end": round(end, 2)},
        "threads": threads,
        "quiet": start <= 0.5 and end <= threads + 0.5,
    }


def _git(*args: str) -> str | None:
    try:
        done = subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True, check=True)
    except (OSError, subprocess.CalledProcessError):
        return None
    return done.stdout.strip()


#: What no benchmark runs: a change there leaves the checkout clean for the figures.
_NOT_RUN = ("docs", "*.md", "benchmarks/results", "tests/test_figures.py")


def commit() -> dict:
    """The checkout the figures come from, as the run started; ``dirty``: tracked files that a
    benchmark may run differ from it (the docs, the results and their test aside)."""
    sha = _git("rev-parse", "HEAD")
    if sha is None:
        return {"sha": None, "describe": None, "dirty": None}
    changed = _git(
        "status", "--porcelain", "--untracked-files=no", "--", ".", *(f":(exclude,glob){p}" for p in _NOT_RUN)
    )
    dirty = bool(changed)
    describe = _git("describe", "--always") or sha[:7]
    return {"sha": sha, "describe": describe + ("-dirty" if dirty else ""), "dirty": dirty}


# Taken when the script imports this module, before any work: the machine and the checkout as
# the run found them.
_STARTED = {
    "load": os.getloadavg()[0],
    "clock": time.perf_counter(),
    "date": datetime.datetime.now(datetime.UTC),
    "commit": commit(),
}


def command_line(script: str | Path, argv) -> str:
    """The command as typed from the repository root: ``python benchmarks/SCRIPT ARGS``."""
    argv = sys.argv[1:] if argv is None else [str(a) for a in argv]
    return shlex.join(["python", f"benchmarks/{Path(script).name}", *argv])


def emit(figures: dict, args, script: str | Path, argv=None, threads: int = 1, show: bool = True) -> int:
    """Wrap ``figures`` in the record of this run; print it (``show``), write it to ``args.json``
    and, with ``--record``, to ``benchmarks/results/``. Returns 0, the script's exit code."""
    doc = {
        "script": f"benchmarks/{Path(script).name}",
        "command": command_line(script, argv),
        "date": _STARTED["date"].strftime("%Y-%m-%dT%H:%M:%SZ"),
        "run_s": round(time.perf_counter() - _STARTED["clock"], 1),
        "commit": _STARTED["commit"],
        "machine": machine(threads),
        "figures": figures,
    }
    text = json.dumps(doc, indent=2, default=float)
    if show:
        print(text)
    if getattr(args, "json", None):
        Path(args.json).write_text(text + "\n")
    if getattr(args, "record", None) is not None:
        path = results_path(script, args.record)
        path.parent.mkdir(exist_ok=True)
        path.write_text(text + "\n")
        print(f"recorded: {path.relative_to(ROOT)}", file=sys.stderr)
    return 0
