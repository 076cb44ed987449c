"""The error plot of a navigation run (the solution file is :mod:`sizefx.io.navigation`'s)."""

from __future__ import annotations

from ..errors import TelemetryError
from ..io.files import atomic_output
from .config import MIN_PLOT_ROWS
from .result import NavResult

__all__ = ["plot_errors", "check_plottable"]


def check_plottable(res: NavResult) -> dict:
    """Refuse a result whose error history is too short to draw: the reference position covers fewer
    than :data:`MIN_PLOT_ROWS` of its output rows (the loop refused, before any work, a record without
    ``/reference/position`` or with too few output rows); the error history otherwise."""
    rows = 0 if res.errors is None else len(res.errors.get("horizontal_m", ()))
    if res.errors is None or rows < MIN_PLOT_ROWS:
        raise TelemetryError(
            res.path,
            "/reference/position",
            f"covers {rows} of the solution's output rows; --plot needs at least {MIN_PLOT_ROWS}: leave out "
            "--plot, or give a reference that spans the record",
        )
    return res.errors


def plot_errors(res: NavResult, png, title: str):
    """Horizontal (and north, east) error against the reference versus time, PNG."""
    import matplotlib  # here, not at module level: it costs start-up time

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    errors = check_plottable(res)
    t_min = (errors["time_s"] - res.time_s[0]) / 60.0
    fig, ax = plt.subplots(figsize=(9, 4.5), constrained_layout=True)
    ax.plot(t_min, errors["horizontal_m"], label="horizontal")
    ax.plot(t_min, errors["north_m"], lw=0.8, label="north")
    ax.plot(t_min, errors["east_m"], lw=0.8, label="east")
    ax.set_xlabel("time since start [min]")
    ax.set_ylabel("position error [m]")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend()
    with atomic_output(png, force=True) as tmp:  # the caller checked the path (and --force)
        fig.savefig(tmp, dpi=120, format="png")
    plt.close(fig)
