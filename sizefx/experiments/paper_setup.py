"""What the paper's experiments start from: the paper's figures as printed (:data:`PAPER`), the unit it
calibrated (its drawing plus its measured deviations), and the sizes the experiments run at
(:class:`Size`, :data:`SIZES`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..geometry import preset_arms_m

__all__ = ["PAPER", "SIZES", "Size"]

#: The paper's figures, as printed.
PAPER: dict[str, dict[str, Any]] = {
    "turntable": {
        "diff_mean_mm": 0.5,
        "diff_max_mm": 1.6,
        "sigma_mean_mm": 0.04,
        "sigma_max_mm": 0.12,
        # Delta r_x, Delta r_y, Delta r_z [m], rows: the paper's estimate minus nominal
        "delta_m": [[0.0007, 0.0000, -0.0009], [-0.0016, 0.0000, -0.0011], [-0.0005, 0.0000, -0.0008]],
        "sigma_m": [[0.000118, 0.000011, 0.000059], [0.000014, 0.000025, 0.000035], [0.000047, 0.000047, 0.000011]],
    },  # sigma(r_z) prints a 4th value, 0.000071: left out
    "sway": {"divergence_km": 3.0},
    "flight": {"gain_km": 1.1, "gain_nmi_per_h": 0.3, "ground_speed_change_mps": 0.828, "duration_h": 1.8},
}


@dataclass(frozen=True)
class Size:
    """How big each experiment is run."""

    name: str
    turntable_repeats: int
    turntable_rate_hz: float
    sway_rate_hz: float
    sway_static_s: float
    sway_segment_s: float
    flight_rate_hz: float
    flight_duration_h: float


#: ``full``: the paper's sizes (docs/ figures). ``reduced``: the demo's. It keeps every duration
#: (the Schuler loop needs them) and the sway's 1600 Hz, and runs the turntable (three repeats) and
#: the flight at 400 Hz: the arm sigma is set by the noise density, not the rate (the spread over
#: three repeats is rougher), and at 400 Hz the flight's 32 Hz rotor harmonic has 12 samples a
#: period, which moves the flight's gain by about 10 %.
#: ``smoke``: for the test suite only (``tests/test_cli.py``): every step of the demo runs and
#: prints in seconds, at sizes too small for its figures to mean anything.
SIZES = {
    "full": Size("full", 5, 1600.0, 1600.0, 600.0, 600.0, 1600.0, 1.8),
    "reduced": Size("reduced", 3, 400.0, 1600.0, 600.0, 600.0, 400.0, 1.8),
    "smoke": Size("smoke", 1, 200.0, 200.0, 60.0, 60.0, 100.0, 0.45),
}


def _true_arms_d():
    """The paper's unit: the high-precision drawing plus its measured deviations."""
    return preset_arms_m("high-precision") + np.asarray(PAPER["turntable"]["delta_m"])
