"""sizefx from Python: simulate, calibrate, navigate, compare, a chain and a batch.

A walk through the Python API (docs/api.md), one section per step: every stage is a config, a
``run`` and a result, as ``sizefx STAGE`` is on the command line, and the command line's chains and
batches are ``sizefx.chain.run`` and ``sizefx.batch.run``.

    python examples/walkthrough.py [FOLDER]

FOLDER (default: a new temporary folder, removed at the end) receives the records and every result.
The records are short (a turntable run of two minutes and two flights of ten at 200 Hz), so that the
whole walk takes seconds. The hidden effect is the one sizefx is about: accelerometer y sits 3.0 mm
further out than the drawing says. ``tests/test_examples.py`` runs this file.

The steps are in :func:`main`, which the script calls under ``if __name__ == "__main__":``: a batch's
workers are spawned processes, which import the script again, and must not run it again. In a
notebook, paste the body of :func:`main` into cells as it is (a notebook needs no such guard).
"""

from __future__ import annotations

import shutil
import sys
import tempfile
from pathlib import Path

import sizefx.batch
import sizefx.chain
from sizefx.calibrate import CalibrateConfig
from sizefx.calibrate import run as calibrate
from sizefx.compare import CompareConfig
from sizefx.compare import run as compare
from sizefx.navigate import NavConfig, NavigateConfig
from sizefx.navigate import run as navigate
from sizefx.scenarios import FlightPlan, TurntablePlan
from sizefx.simulate import SimulateConfig
from sizefx.simulate import run as simulate

#: The records' IMU rate [Hz]: low, so that the walk runs in seconds.
RATE_HZ = 200.0
#: The hidden effect, as ``sizefx simulate --set lever_arm.d_y_m=[0,0.0279,0]`` gives it:
#: accelerometer y 27.9 mm from the centre, where the drawing says 24.9 mm.
ARM_Y = {"lever_arm": {"d_y_m": [0.0, 0.0279, 0.0]}}
#: One cycle about each axis, short dwells: a turntable run of two minutes.
TURNTABLE = TurntablePlan(static_s=10.0, seconds_per_axis=20.0, cycles=1)
#: Ten minutes, one of them aligning, without S-turns: about the shortest flight the plan allows.
FLIGHT = FlightPlan(duration_s=600.0, align_s=60.0, weave_deg=0.0)


def main(folder: Path) -> None:
    # -- 1. Simulate: a turntable run for the calibration and two flights, the same IMU in each.
    # A simulated record holds the truth (/simulation) and a reference system's solution
    # (/reference), so every figure below can be judged.
    turntable = folder / "turntable.h5"
    flights = folder / "flights"
    flights.mkdir(exist_ok=True)
    made = simulate(SimulateConfig("turntable", turntable, plan=TURNTABLE, rate_hz=RATE_HZ, overrides=ARM_Y))
    print(made.report())
    for seed, day in enumerate(("day1", "day2"), start=1):
        flight_config = SimulateConfig(
            "flight", flights / f"{day}.h5", plan=FLIGHT, rate_hz=RATE_HZ, seed=seed, overrides=ARM_Y
        )
        print(simulate(flight_config).report())
    flight = flights / "day1.h5"

    # -- 2. Calibrate the lever arms from the turntable's rotations.
    # The config holds what `sizefx calibrate` is given; the result what it found (report(): the
    # lines the command prints; to_json(): the document it writes).
    levers = folder / "levers.json"
    cal = calibrate(CalibrateConfig((str(turntable),), json_path=str(levers)))
    r_y_mm, sigma_mm = cal.levers.arms_total[1] * 1e3, cal.levers.sigma[1] * 1e3  # row r_y, body axes
    print(f"calibrated r_y = {r_y_mm.round(3)} mm, sigma {sigma_mm.round(3)} mm (the truth: 0, 27.9, 0)")

    # -- 3. Navigate the flight, plain and with the calibrated arms.
    # NavConfig holds the navigation's options (the command line's --output-rate-hz, --levers, ...).
    plain_nav, compensated_nav = folder / "plain.nav.h5", folder / "compensated.nav.h5"
    plain = navigate(NavigateConfig(str(flight), options=NavConfig(output_rate_hz=1.0), output=str(plain_nav)))
    with_arms = NavConfig(output_rate_hz=1.0, levers=str(levers))
    compensated = navigate(NavigateConfig(str(flight), options=with_arms, output=str(compensated_nav)))
    for label, solution in (("plain", plain), ("compensated", compensated)):
        print(f"{label}: final horizontal error {solution.summary['final_horizontal_error_m']:.2f} m")

    # -- 4. Compare the two solutions with each other and with the flight's reference.
    comparison = compare(CompareConfig(str(compensated_nav), str(plain_nav), reference=str(flight)))
    for c in comparison.comparisons:  # A vs REF, B vs REF, A vs B
        print(f"{c.label}: final horizontal distance {c.horizontal_m[-1]:.2f} m")

    # -- 5. Steps 2 to 4 in one call: a chain, `sizefx run --out chain calibrate T.h5 navigate F.h5 compare`.
    # Each stage's options by its config's field names; the outputs are named in the folder, and
    # run.json lists what each step read, wrote and found.
    stages = {
        "calibrate": {"records": [str(turntable)]},
        "navigate": {"input": str(flight), "output_rate_hz": 1.0},
        "compare": {},
    }
    chain = sizefx.chain.run(stages, folder / "chain")
    print(chain.summary())

    # -- 6. A batch: every flight of the campaign navigated with the arms, in worker processes.
    # `sizefx batch navigate flights --levers levers.json --output-rate-hz 1 --out nav`: the outputs
    # are named after each record, and the folder's manifest lets a second run skip what is done.
    options = {"levers": str(levers), "output_rate_hz": 1.0}
    batch = sizefx.batch.run("navigate", flights, folder / "nav", options=options, workers=1)
    print(batch.report())
    again = sizefx.batch.run("navigate", flights, folder / "nav", options=options, workers=1)
    print(f"run again: {again.counts()['skipped']} of {len(again.outcomes)} records unchanged, none run again")


if __name__ == "__main__":
    given = Path(sys.argv[1]) if len(sys.argv) > 1 else None
    where = given or Path(tempfile.mkdtemp(prefix="sizefx-walkthrough-"))
    where.mkdir(parents=True, exist_ok=True)
    print(f"working in {where}")
    try:
        main(where)
    finally:
        if given is None:  # a temporary folder of our own
            shutil.rmtree(where, ignore_errors=True)
