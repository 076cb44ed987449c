"""The constants that decide how a record is navigated, each with its reason.

The run's options (:class:`NavConfig`) and the default chunk (:data:`CHUNK_SAMPLES`) are declared
with the stage's config in :mod:`sizefx.configs.navigate`, and given here too.
"""

from __future__ import annotations

from ..configs.navigate import CHUNK_SAMPLES, NavConfig
from ..kernels.modes import VERTICAL_FREE, VERTICAL_HELD, VERTICAL_REFERENCE

__all__ = [
    "NavConfig",
    "VERTICAL_MODES",
    "GAPS_WHY",
    "GRID_TOLERANCE",
    "JITTER_REPORTED",
    "STATIONARY_SPAN_M",
    "CHUNK_SAMPLES",
    "MARGIN",
    "MIN_ROWS",
    "MIN_PLOT_ROWS",
]

VERTICAL_MODES = {"free": VERTICAL_FREE, "held": VERTICAL_HELD, "reference": VERTICAL_REFERENCE}
#: A reference whose position spans less than this [m] is a stationary site: vertical channel held.
STATIONARY_SPAN_M = 1.0
#: Navigation integrates on the uniform grid ``t_first + k dt``; every stamp must lie within this many
#: periods of its grid point. Then each sample is unambiguously the k-th, and treating it as on the grid
#: misplaces it by at most this fraction of a period. Logged stamps jitter: PX4's sensor_combined has
#: steps of 3.94 to 4.84 ms around 4.02 ms and leaves its grid by up to 0.40 periods; a rate change or a
#: lost sample leaves it by more, and grows.
GRID_TOLERANCE = 0.5
#: Time stamps further than this from the uniform grid [periods] are reported in the summary: the
#: samples are integrated at their grid points, and a user should know by how much they were moved.
JITTER_REPORTED = 0.05
#: Why navigation refuses a record with IMU gaps (:func:`sizefx.io.telemetry.refuse_gaps`).
GAPS_WHY = "integrates every sample and cannot bridge a gap (--allow-gaps does not help here)"

#: Extra rows read on each side of a chunk, so that every filter sees the neighbours it sees in a
#: whole-record run: the four-point increment stencil, the edge rates of the increment-domain
#: compensation, the Savitzky-Golay window (20 rows) of a rates-domain model correction, and the
#: not-a-knot sync spline, whose dependence on a sample k rows away decays as (2 - sqrt(3))^k
#: (1e-37 at 64 rows).
MARGIN = 64
#: Fewest rows read for any chunk: the rates-domain compensation of a model needs 164.
MIN_ROWS = 512
#: Fewest output rows (``--output-rate-hz``) the error plot (``--plot``) is drawn from: a curve joins two
#: points, and a single one draws an empty figure.
MIN_PLOT_ROWS = 2
