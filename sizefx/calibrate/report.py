"""What ``sizefx calibrate`` shows: the report lines and the paper's Fig. 6."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..constants import ARCSEC, MICRO_G
from ..io.files import atomic_output
from ..levers import Levers
from .joint import BIAS_WINDOW_S
from .per_rotation import detect_rotations
from .records import MIN_SAMPLES, CalibrationError, Record

__all__ = ["report_lines", "compensation_figure"]


def report_lines(
    res, nom: Levers, lev: Levers, records: list[Record], skipped: list[str], per_rotation: dict
) -> list[str]:
    """The lines ``sizefx calibrate`` prints: the joint fit ``res`` (:class:`~.joint.CalibrationResult`)
    against the nominal arms ``nom``, the split ``lev`` into offset and d_i, the per-rotation fits."""
    mm = 1e3
    domain = (
        f"the increment domain ({res.interval_s * 1e3:g} ms intervals, exact mean angular acceleration)"
        if res.interval_s
        else "the rates domain (every sample, the gyros' filtered derivative)"
    )
    # the noise model of each channel (the record whose colour matters most): AR order and how much
    # the colour changes the variance of a long mean (1: as white)
    noisiest = max(
        res.noise, key=lambda rec: max(abs(ch["long_run_variance_ratio"] - 1) for ch in rec["channels"]), default=None
    )
    noise = (
        "; noise model (AR order, long-run variance / variance) "
        + ", ".join(
            f"{a} {ch['ar_order']}, {ch['long_run_variance_ratio']:.2f}" for a, ch in zip("xyz", noisiest["channels"])
        )
        if noisiest
        else ""
    )
    lines = [
        f"joint generalised least squares over {res.samples} samples in {domain}; condition number "
        f"{res.condition:.3g}; residual RMS x, y, z = "
        + ", ".join(f"{v / MICRO_G:.2f}" for v in res.residual_rms)
        + " ug"
        + noise,
        "  arm   r [mm] (from the rotation centre)          sigma [mm]              bound [mm]"
        "              estimate - nominal [mm]",
    ]
    bound = res.bound_arms if res.bound_sigma is not None else np.full((3, 3), np.nan)
    for i, a in enumerate("xyz"):
        lines.append(
            f"  r_{a}  "
            + " ".join(f"{v * mm:8.4f}" for v in res.arms[i])
            + "   "
            + " ".join(f"{v * mm:7.4f}" for v in res.sigma_arms[i])
            + "   "
            + " ".join(f"{v * mm:7.4f}" for v in bound[i])
            + "   "
            + " ".join(f"{v * mm:7.4f}" for v in (res.arms[i] - nom.arms_total[i]))
        )
    lines.append(
        f"  sigma: mean {res.sigma_arms.mean() * mm:.4f} mm, max {res.sigma_arms.max() * mm:.4f} mm; "
        "bound: the Cramer-Rao bound on this motion and measured noise; bound / sigma "
        f"{res.efficiency[:9].min():.3f}..{res.efficiency[:9].max():.3f}"
    )
    segmented = [rec.name for rec in records if " segment " in rec.name]
    if segmented or skipped:
        lines.append(
            f"  records cut at their IMU gaps, each continuous segment fitted on its own: {len(segmented)} "
            "segments used"
            + (f"; left out, shorter than {MIN_SAMPLES} samples: {', '.join(skipped)}" if skipped else "")
        )
    lines.append(
        f"  triad point ({lev.extra['triad_point']}) from the rotation centre [mm]: "
        + " ".join(f"{v * mm:.4f}" for v in lev.offset)
    )
    for i, a in enumerate("xyz"):
        lines.append(f"  d_{a}  " + " ".join(f"{v * mm:8.4f}" for v in lev.arms_triad[i]))
    if res.bound_sigma is not None:
        lines.append(
            f"  accelerometer biases (per {BIAS_WINDOW_S:g} s window): sigma x, y, z = "
            + ", ".join(f"{v / MICRO_G:.3f}" for v in res.bias_windows().mean(axis=0))
            + " ug (bound "
            + ", ".join(f"{v / MICRO_G:.3f}" for v in res.bias_windows(res.bound_sigma).mean(axis=0))
            + "), mean over the windows"
        )
    if res.tilt_rad is not None:
        tb = res.bound_sigma[res.names.index("tilt_north") :][:2] / ARCSEC
        lines.append(
            f"  table tilt: north {res.tilt_rad[0] / ARCSEC:.2f} +- {res.sigma_tilt_rad[0] / ARCSEC:.2f} "
            f"(bound {tb[0]:.2f}) arcsec, east {res.tilt_rad[1] / ARCSEC:.2f} +- "
            f"{res.sigma_tilt_rad[1] / ARCSEC:.2f} (bound {tb[1]:.2f}) arcsec"
        )
    if res.delay_s is not None:
        lines.append(
            f"  accelerometer delay: {res.delay_s * 1e6:.2f} +- {res.sigma_delay_s * 1e6:.2f} "
            f"(bound {res.bound_sigma[-1] * 1e6:.2f}) us"
        )
        if res.left_out_steps:
            lines.append(
                f"  left out of the fit: {res.left_out_s:.2f} s around {res.left_out_steps} step(s) in angular "
                "acceleration, where the delay's lever terms need the angular jerk, which the gyros' "
                "filtered derivative smears"
            )
    for path, rows in per_rotation.items():
        if not rows:  # no block of rotation about one vertical axis (a tumble, a flight): nothing to show
            continue
        lines.append(f"the paper's per-rotation fit ({Path(path).name}; ignores the tilt) [mm]:")
        for row in rows:
            i, j = "xyz".index(row["channel"]), "xyz".index(row["other_component"])
            d_own = (row["r_own"] - nom.arms_total[i][i]) * mm
            d_other = (row["r_other"] - nom.arms_total[i][j]) * mm
            lines.append(
                f"  rotation about {row['axis']}, channel {row['channel']}: "
                f"r_{row['channel']}[{row['channel']}] = {row['r_own'] * mm:8.4f} +- {row['sigma_r_own'] * mm:.4f}, "
                f"r_{row['channel']}[{row['other_component']}] = {row['r_other'] * mm:8.4f} +- "
                f"{row['sigma_r_other'] * mm:.4f}, bias (tau) {row['bias'] / MICRO_G:8.1f} ug; "
                f"minus nominal {d_own:+.4f}, {d_other:+.4f}"
            )
    return lines


def compensation_figure(rec: Record, levers: Levers, png, *, mode: str = "center", title: str = ""):
    """The paper's Fig. 6: horizontal accelerometers before and after compensation, per rotation block.

    Offsets of +-100 ug separate the two horizontal channels, as in the paper. Returns
    the peak-to-peak [ug] of each horizontal channel in each block, before and after.
    """
    from ..kernels.sizeeffect import compensate_rates

    try:
        import matplotlib
    except ImportError:
        raise CalibrationError("plots need matplotlib: pip install 'sizefx[plots]'") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    after = np.empty_like(rec.accel)
    compensate_rates(
        np.ascontiguousarray(rec.accel),
        np.ascontiguousarray(rec.omega),
        np.ascontiguousarray(rec.omegadot),
        np.ascontiguousarray(levers.arms_for(mode)),
        np.ascontiguousarray(levers.axes),
        True,
        True,
        after,
    )
    blocks = detect_rotations(rec)
    dt = float(np.median(np.diff(rec.t)))
    width = max(1, int(round(0.25 / dt)))  # 0.25 s means: the 100 ug sample noise would hide a 60 ug tilt signal

    def smooth(x):
        return np.convolve(x, np.ones(width) / width, mode="valid")

    fig, axes = plt.subplots(len(blocks), 1, figsize=(9, 2.6 * len(blocks)), constrained_layout=True, squeeze=False)
    ug = MICRO_G
    spans = []
    for ax, (a, i0, i1) in zip(axes[:, 0], blocks):
        t = smooth(rec.t[i0:i1] - rec.t[i0])
        horiz = [i for i in range(3) if i != a]
        for off, i in zip((100.0, -100.0), horiz):
            before = smooth(rec.accel[i0:i1, i]) / ug
            compensated = smooth(after[i0:i1, i]) / ug
            ax.plot(t, before + off, lw=0.6, alpha=0.6, label=f"{'xyz'[i]} raw {off:+.0f} ug")
            ax.plot(t, compensated + off, lw=0.9, label=f"{'xyz'[i]} compensated {off:+.0f} ug")
            spans.append(
                {
                    "axis": "xyz"[a],
                    "channel": "xyz"[i],
                    "raw_ptp_ug": float(np.ptp(before)),
                    "compensated_ptp_ug": float(np.ptp(compensated)),
                }
            )
        ax.set_title(f"rotation about {'XYZ'[a]}")
        ax.set_ylabel("specific force, 0.25 s means [ug]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, ncol=2, loc="upper right")
    axes[-1, 0].set_xlabel("time in block [s]")
    if title:
        fig.suptitle(title)
    with atomic_output(png, force=True) as tmp:  # the caller checked the path (and --force)
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return spans
