"""What the benchmarks share: a command's wall time and peak memory, and the JSON they print."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

# A small intermediate Python runs the command and reports its child's peak RSS: measured from a
# large benchmark process, a forked child would count the parent's pages as its own until exec.
_PROBE = (
    "import resource, subprocess, sys, time; t0 = time.perf_counter(); "
    "subprocess.run(sys.argv[1:], check=True, capture_output=True); "
    "print(time.perf_counter() - t0, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)"
)


def run_measured(cmd, env=None) -> tuple[float, float]:
    """``(wall seconds, peak MiB)`` of ``cmd`` run in a fresh process."""
    done = subprocess.run(
        [sys.executable, "-c", _PROBE, *map(str, cmd)], check=True, env=env, capture_output=True, text=True
    )
    wall, peak_kib = (float(x) for x in done.stdout.split())
    return wall, peak_kib / 1024.0


def emit(result: dict, json_path: Path | None) -> int:
    """Print the figures as JSON, and write them to ``json_path`` when given."""
    text = json.dumps(result, indent=2)
    print(text)
    if json_path:
        json_path.write_text(text + "\n")
    return 0
