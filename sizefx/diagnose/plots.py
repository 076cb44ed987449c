"""The plots of a diagnosis: residuals before and after (time series, 0.1 s means) and their spectra, PNG.

matplotlib is imported when :func:`plot` is called (the ``plots`` extra), never with the package.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..configs.diagnose import PLOT_FILES
from ..constants import DEG_PER_H, MICRO_G
from ..errors import ConfigError
from ..io.files import atomic_output
from .fit import Diagnosis
from .normal import block_means
from .theta import CHANNELS

__all__ = ["PLOT_FILES", "plot"]


def plot(d: Diagnosis, folder, *, force: bool = False) -> list[str]:
    """Residuals before/after (time series, 0.1 s means) and their spectra (Welch): the files
    :data:`PLOT_FILES` in ``folder`` (created if need be; an existing file replaced only with ``force``).
    ``d`` must keep its series (``diagnose(..., keep_series=True)``)."""
    try:
        import matplotlib
    except ImportError:
        raise ConfigError("plots need matplotlib: pip install 'sizefx[plots]'") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from scipy.signal import welch

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    assert d.t is not None and d.mask is not None, "diagnose(..., keep_series=True) keeps the series"
    assert d.residual_before is not None and d.residual_after is not None, "diagnose(..., keep_series=True)"
    t, m = d.t[d.mask], d.mask
    dt = float(np.median(np.diff(d.t)))
    scale = [1 / DEG_PER_H] * 3 + [1 / MICRO_G] * 3
    units = ["deg/h"] * 3 + ["ug"] * 3
    L = max(1, round(0.1 / dt))
    written = []
    notes = _plot_notes(d)
    fig, axes = plt.subplots(6, 1, figsize=(10, 12 + 0.18 * len(notes)), sharex=True, constrained_layout=True)
    for c, ax in enumerate(axes):
        for res, label, lw in ((d.residual_before, "start model", 0.6), (d.residual_after, "extended model", 0.8)):
            ax.plot(block_means(t, L), block_means(res[m, c], L) * scale[c], lw=lw, label=label)
        for w in d.warnings:  # where the reference is at fault, on every channel
            if w.time_s is not None:
                ax.axvline(w.time_s, color="red", lw=0.8, alpha=0.6)
        ax.set_ylabel(f"{CHANNELS[c]} [{units[c]}]")
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper right", fontsize=8)
    axes[0].set_title(
        "\n".join(
            notes + [f"{Path(d.path).name}: measured minus predicted (0.1 s means); red lines: reference warnings"]
        ),
        fontsize=8,
        loc="left",
    )
    axes[-1].set_xlabel("time [s]")
    written.append(_save(fig, folder / PLOT_FILES[0], force))
    plt.close(fig)
    fig, axes = plt.subplots(2, 3, figsize=(12, 7), constrained_layout=True)
    nper = int(min(m.sum(), 2 ** int(np.log2(max(16, 20.0 / dt)))))
    for c, ax in enumerate(axes.ravel()):
        for res, label in ((d.residual_before, "start model"), (d.residual_after, "extended model")):
            f, pxx = welch(res[m, c] * scale[c], fs=1.0 / dt, nperseg=nper)
            ax.loglog(f[1:], np.sqrt(pxx[1:]), lw=0.8, label=label)
        for u in d.unexplained:  # lines the model leaves, where they are
            if u["channel"] == CHANNELS[c] and u.get("frequency_hz"):
                ax.axvline(u["frequency_hz"], color="red", lw=0.8, ls="--")
        ax.set_title(
            CHANNELS[c]
            + (
                "  (unexplained: "
                + ", ".join(sorted({u["kind"] for u in d.unexplained if u["channel"] == CHANNELS[c]}))
                + ")"
                if any(u["channel"] == CHANNELS[c] for u in d.unexplained)
                else ""
            ),
            fontsize=9,
            color="red" if any(u["channel"] == CHANNELS[c] for u in d.unexplained) else "black",
        )
        ax.set_xlabel("frequency [Hz]")
        ax.set_ylabel(f"[{units[c]}/sqrt(Hz)]")
        ax.grid(alpha=0.3, which="both")
    axes[0, 0].legend(fontsize=8)
    fig.suptitle(f"{Path(d.path).name}: residual amplitude spectral density")
    written.append(_save(fig, folder / PLOT_FILES[1], force))
    plt.close(fig)
    return written


def _plot_notes(d: Diagnosis, most: int = 8) -> list[str]:
    """The warnings and the unexplained structure, first lines of the residual plot (at most ``most``)."""
    notes = [f"WARNING {w.kind}: {w.message}" for w in d.warnings]
    notes += [f"UNEXPLAINED {u['channel']}: {u['sentence']}" for u in d.unexplained]
    if len(notes) > most:
        notes = notes[: most - 1] + [f"... and {len(notes) - most + 1} more (see the report)"]
    return [n if len(n) <= 150 else n[:147] + "..." for n in notes]


def _save(fig, path: Path, force: bool) -> str:
    with atomic_output(path, force=force) as tmp:  # run()'s pre-flight checked each file against the inputs
        fig.savefig(tmp, dpi=100, format="png")
    return str(path)
