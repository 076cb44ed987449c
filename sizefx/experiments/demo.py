"""The demo behind ``sizefx demo``: the paper's three experiments and a diagnosis, on built-in data.

Everything is simulated here, at the reduced size (:data:`sizefx.experiments.paper.SIZES`): the
turntable calibration (three repeats at 400 Hz), the heading sway (40 min at 1600 Hz,
three navigations), the 1.8 h helicopter flight at 400 Hz, then ``diagnose`` on a two-minute tumble
record with a hidden lever-arm error and accelerometer delay. It prints the comparison
table with the paper's figures and writes every plot into the folder it names.
"""

from __future__ import annotations

import time
from pathlib import Path

from .. import diagnose, scenarios
from ..simulate import SimulateConfig, run
from .paper import SIZES, format_results, run_all

__all__ = ["run_demo"]

#: The hidden effects of the diagnosis record: accelerometer y 2.5 mm further out and 1.0 mm
#: higher than the drawing, and the accelerometers 0.5 ms late.
DIAGNOSIS_HIDDEN = {"lever_arm": {"d_y_m": [0.0, 0.0274, -0.001]}, "accel_delay": {"enabled": True, "tau_s": 0.0005}}


def run_demo(out_dir: Path, *, seed: int = 0, size: str = "reduced"):
    """Yield the demo's report line by line (the caller prints).

    ``size`` names one of :data:`sizefx.experiments.paper.SIZES` for the paper's experiments; ``sizefx demo``
    runs ``reduced``, the test suite ``smoke``.
    """
    started = time.perf_counter()
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    lines: list[str] = []
    res = run_all(out_dir, SIZES[size], seed=seed, log=lines.append)
    yield from lines
    yield format_results(res)
    # The heart of sizefx: hide effects in a record and find them.
    path = out_dir / "tumble.h5"
    # The demo owns its folder: it replaces its own files from an earlier run.
    run(
        SimulateConfig(
            "tumble",
            path,
            plan=scenarios.TumblePlan(duration_s=120.0),
            rate_hz=400.0,
            seed=seed,
            overrides=DIAGNOSIS_HIDDEN,
            force=True,
        )
    )
    found = diagnose.run(
        diagnose.DiagnoseConfig(
            path,
            json_path=out_dir / "diagnosis.json",
            plots=out_dir / "diagnosis",
            model_out=out_dir / "tumble.model.toml",
            force=True,
        )
    )
    yield "diagnose: accelerometer y placed 2.5 mm out and 1.0 mm up from the drawing, accelerometers 0.5 ms late:"
    yield diagnose.format_report(found.diagnosis, found.start, found.checks)  # the demo lists the plots itself, below
    figures = sorted(p.name for p in out_dir.glob("*.png")) + [
        f"diagnosis/{p.name}" for p in sorted((out_dir / "diagnosis").glob("*.png"))
    ]
    yield f"plots in {out_dir}/: {', '.join(figures)}"
    yield f"demo finished in {time.perf_counter() - started:.0f} s"
