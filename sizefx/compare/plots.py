"""Figures of ``sizefx compare``: one PNG per question, axes labelled with units.

Kept apart from the numerics (:mod:`sizefx.compare.metrics`); :func:`sizefx.compare.run` calls
:func:`write_plots` with its :class:`~sizefx.compare.Comparison` and
:class:`~sizefx.compare.Track` objects. matplotlib is imported only inside
:func:`pyplot`, when figures are asked for.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .. import earth
from ..configs.compare import PLOT_NAMES
from ..errors import ConfigError
from ..io.files import atomic_output

__all__ = ["PLOT_NAMES", "plot_names", "pyplot", "write_plots"]


def pyplot():
    """matplotlib.pyplot on the Agg back end, or a ConfigError saying how to install it."""
    try:
        import matplotlib
    except ImportError:
        raise ConfigError("plots need matplotlib: pip install 'sizefx[plots]'") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_names(comparisons) -> list[str]:
    """The figures a run writes: attitude.png only when some comparison has attitude."""
    names = list(PLOT_NAMES[:3])
    if any(c.attitude_rad is not None for c in comparisons):
        names.append(PLOT_NAMES[3])
    return names


def _save(fig, png: Path, plt):
    with atomic_output(png, force=True) as tmp:  # the caller checked the path (and --force)
        fig.savefig(tmp, dpi=120, format="png")
    plt.close(fig)


def _rows(plt, n: int, title: str):
    fig, axes = plt.subplots(n, 1, figsize=(9, 2.2 + 2.4 * n), sharex=True, squeeze=False, constrained_layout=True)
    fig.suptitle(title)
    return fig, axes[:, 0]


def write_plots(comparisons, tracks: dict, out_dir) -> list[Path]:
    """One PNG per question in ``out_dir`` (paths already checked by the caller); return the paths.

    ``trajectories.png``: latitude against longitude of every track, with the axes'
    aspect ``R_M / (R_T cos(lat))`` at the mean latitude, so that a metre north and a
    metre east are the same length on the page. ``horizontal_error.png``,
    ``velocity.png``, ``attitude.png``: one row per comparison against time in
    minutes since the first compared stamp.
    """
    plt = pyplot()
    out_dir = Path(out_dir)
    written = []
    t0 = min(float(c.time_s[0]) for c in comparisons)

    def minutes(c):
        return (c.time_s - t0) / 60.0

    xlabel = f"time since t = {t0:.3f} s [min]"

    fig, ax = plt.subplots(figsize=(7.5, 7.5), constrained_layout=True)
    lat_all = np.concatenate([tr.lat_rad for tr in tracks.values()])
    lat_mid = 0.5 * (lat_all.min() + lat_all.max())
    r_mer, r_tr = earth.radii_m(lat_mid)
    for key, tr in tracks.items():
        lon_deg = np.degrees(np.unwrap(tr.lon_rad))
        ax.plot(lon_deg, np.degrees(tr.lat_rad), lw=1.4 if key == "REF" else 1.0, label=f"{key}: {Path(tr.name).name}")
        ax.plot(lon_deg[0], np.degrees(tr.lat_rad[0]), "o", ms=4, color=ax.lines[-1].get_color())
    ax.set_aspect(float(r_mer / (r_tr * np.cos(lat_mid))), adjustable="datalim")
    ax.ticklabel_format(useOffset=False)
    ax.set_xlabel("longitude [deg]")
    ax.set_ylabel("latitude [deg]")
    ax.set_title("trajectories (equal metric scale; dot: start)")
    ax.grid(alpha=0.3)
    ax.legend()
    _save(fig, out_dir / "trajectories.png", plt)
    written.append(out_dir / "trajectories.png")

    fig, axes = _rows(plt, len(comparisons), "horizontal distance and its along/cross-track parts")
    for ax, c in zip(axes, comparisons):
        x = minutes(c)
        one, two = c.pair
        ax.plot(x, c.horizontal_m, label="horizontal")
        ax.plot(x, c.along_track_m, lw=0.9, label=f"along track ({one} ahead +)")
        ax.plot(x, c.cross_track_m, lw=0.9, label=f"cross track ({one} right of {two}'s track +)")
        ax.set_ylabel("distance [m]")
        ax.set_title(f"{c.label}: {Path(c.a).name} minus {Path(c.b).name}", fontsize=10)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    axes[-1].set_xlabel(xlabel)
    _save(fig, out_dir / "horizontal_error.png", plt)
    written.append(out_dir / "horizontal_error.png")

    fig, axes = _rows(plt, len(comparisons), "velocity differences")
    for ax, c in zip(axes, comparisons):
        x = minutes(c)
        ax.plot(x, c.velocity_n_mps[:, 0], lw=0.9, label="north")
        ax.plot(x, c.velocity_n_mps[:, 1], lw=0.9, label="east")
        ax.plot(x, c.ground_speed_mps, lw=1.2, label="ground speed")
        ax.set_ylabel("velocity difference [m/s]")
        derived = [name for name, key in zip(c.pair, ("a", "b")) if c.velocity_derived[key]]
        extra = f" (velocity of {', '.join(derived)} from positions)" if derived else ""
        ax.set_title(f"{c.label}: {Path(c.a).name} minus {Path(c.b).name}{extra}", fontsize=10)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    axes[-1].set_xlabel(xlabel)
    _save(fig, out_dir / "velocity.png", plt)
    written.append(out_dir / "velocity.png")

    with_att = [c for c in comparisons if c.attitude_rad is not None]
    if with_att:
        fig, axes = _rows(plt, len(with_att), "attitude differences")
        for ax, c in zip(axes, with_att):
            x = minutes(c)
            deg = np.degrees(c.attitude_rad)
            for i, name in enumerate(("roll", "pitch", "heading", "rotation angle")):
                ax.plot(x, deg[:, i], lw=1.2 if i == 3 else 0.9, ls="--" if i == 3 else "-", label=name)
            ax.set_ylabel("attitude difference [deg]")
            ax.set_title(f"{c.label}: {Path(c.a).name} minus {Path(c.b).name}", fontsize=10)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8)
        axes[-1].set_xlabel(xlabel)
        _save(fig, out_dir / "attitude.png", plt)
        written.append(out_dir / "attitude.png")
    return written
