"""What a navigation run returns (:class:`NavResult`) and the lines that present it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from ..constants import SECONDS_PER_HOUR
from .config import JITTER_REPORTED

if TYPE_CHECKING:  # annotations only: the stage's config is read without NumPy (a batch's re-run)
    import numpy as np

__all__ = ["NavResult", "format_summary"]


@dataclass(frozen=True)
class NavResult:
    """A navigation solution: the output rows, what was done, and the errors against ``/reference``.
    Built once, by the loop (:func:`sizefx.navigate.navigate_source`); the stage's (:func:`sizefx.navigate.run`)
    is the loop's with the files it wrote and its own account of the time."""

    time_s: np.ndarray  #: [M] end of each navigation interval
    quat_nb: np.ndarray  #: [M, 4]
    v_n: np.ndarray  #: [M, 3]
    lat_rad: np.ndarray
    lon_rad: np.ndarray
    height_m: np.ndarray
    config: dict
    summary: dict
    #: histories against the reference at errors["time_s"]: horizontal_m, north_m, east_m,
    #: velocity_mps [.., 3], attitude_rad (only where the reference has samples)
    errors: dict | None = None
    path: str | None = None  #: the record navigated
    written: dict | None = None  #: option -> path of each file the stage wrote
    #: where the run's time went [s] (never written to an output): open_checks (the record opened and
    #: checked), initial (the initial state), read (the loop waiting for a chunk's increments: read,
    #: checked and corrected, in a helper thread where one runs), kernels, write (the solution's rows
    #: and its file published), other (the errors against /reference, the loop's bookkeeping); a batch
    #: keeps them per record in its manifest
    phases_s: dict | None = None

    def report(self) -> str:
        """The lines ``sizefx navigate`` prints."""
        lines = [format_summary(self.path, self)]
        names = {"--json": "summary", "-o": "solution", "--plot": "plot"}
        for opt, path in (self.written or {}).items():
            lines.append(f"{names[opt]} -> {path}")
        return "\n".join(lines)

    def to_json(self) -> dict:
        """The summary with the configuration, as ``--json`` writes it."""
        return {**self.summary, "configuration": self.config}


def format_summary(path, res: NavResult) -> str:
    s, c = res.summary, res.config
    lines = [
        f"{path}: {s['samples']} samples, {s['duration_s']:.1f} s ({s['duration_s'] / SECONDS_PER_HOUR:.3f} h), "
        f"{c['subsamples']} sub-samples -> {c['nav_rate_hz']:.6g} Hz navigation, kernel {s['kernel_s']:.2f} s"
    ]
    if c.get("segment"):
        a, b = c["segment_rows"]
        t0, t1 = c["segment_time_s"]
        lines.append(f"  segment {c['segment']} of {c['segment_of']}: rows {a}..{b - 1}, t = {t0:.6f} .. {t1:.6f} s")
    lines.append(f"  initial state from {c['init']}; vertical channel {c['vertical']}")
    if c.get("time_jitter_periods", 0.0) > JITTER_REPORTED:
        lines.append(
            f"  time stamps up to {c['time_jitter_periods']:.2f} periods off the uniform grid of "
            f"{1e3 / c['sample_rate_hz']:.4g} ms (logging jitter): each sample was integrated at its "
            "grid point"
        )
    if c.get("correction"):
        corr = c["correction"]
        lines.append(
            f"  IMU corrected with the effect model {corr['model']} ({corr['mode']}): "
            f"{', '.join(corr['corrected']) or 'nothing enabled'}"
        )
    if "fine_roll_pitch_heading_deg" in c:
        r, p, h = c["fine_roll_pitch_heading_deg"]
        lines.append(
            f"  alignment over {c['align_window_s']:.1f} s: roll {r:.4f} deg, pitch {p:.4f} deg, heading {h:.4f} deg"
        )
    lines.append(
        f"  final position {s['final_latitude_deg']:.7f} deg N, {s['final_longitude_deg']:.7f} deg E, "
        f"{s['final_height_m']:.2f} m"
    )
    if s["final_horizontal_error_m"] is not None:
        lines.append(
            f"  horizontal error: final {s['final_horizontal_error_m']:.4g} m, max "
            f"{s['max_horizontal_error_m']:.4g} m, drift {s['drift_nmi_per_h']:.4g} nmi/h"
        )
    if s["final_velocity_error_mps"] is not None:
        lines.append(f"  final velocity error {s['final_velocity_error_mps']:.4g} m/s")
    if s["final_attitude_error_deg"] is not None:
        lines.append(
            f"  attitude error: final {s['final_attitude_error_deg']:.3g} deg, "
            f"max {s['max_attitude_error_deg']:.3g} deg"
        )
    return "\n".join(lines)
