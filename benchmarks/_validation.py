"""What the validation protocols share (``validate_diagnose.py``, ``validate_calibrate.py``).

- The two seed ranges: :func:`seeds` of the development range (0, 1, ...), which changes are
  tried on, or of the validation range (from :data:`VALIDATION_FIRST_SEED`), only reported.
- :func:`run_jobs`: one call per seed, in spawned worker processes of one thread each.
- :func:`plot_pit`: the simulation-based-calibration histograms (Talts et al. 2018) of z-scores.
"""

from __future__ import annotations

import multiprocessing
import os
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

#: The first seed of the validation range; the development range is 0 .. VALIDATION_FIRST_SEED - 1.
VALIDATION_FIRST_SEED = 1_000_000
RANGES = ("dev", "validation")


def seeds(which: str, count: int) -> list[int]:
    """The first ``count`` seeds of the range ``which`` (:data:`RANGES`)."""
    first = 0 if which == "dev" else VALIDATION_FIRST_SEED
    return list(range(first, first + count))


def run_jobs(func, jobs: list, workers: int) -> list:
    """``[func(job) for job in jobs]``, in ``workers`` processes when more than one. The workers are
    spawned with one BLAS and Numba thread each (they read these before they import numpy):
    ``workers`` sets the parallelism, the libraries must not add theirs."""
    if workers <= 1:
        return [func(job) for job in jobs]
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
        os.environ[var] = "1"
    with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")) as pool:
        return list(pool.map(func, jobs))


def plot_pit(z_by_name: dict, path: Path, title: str, cols: int = 4) -> None:
    """Per name, the histogram of ``Phi(z)`` (the probability integral transform of each truth under
    its stated normal error, uniform when the errors are right), with the band a uniform histogram of
    that many values stays inside 99 % of the time (per bin)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from scipy.stats import binom, norm

    names = list(z_by_name)
    rows = max(1, -(-len(names) // cols))
    fig, axes = plt.subplots(rows, cols, figsize=(12, 2.6 * rows))
    axes = np.atleast_1d(axes).ravel()
    bins = 10
    for ax, name in zip(axes, names):
        z = np.asarray(z_by_name[name], dtype=float)
        ax.hist(norm.cdf(z), bins=bins, range=(0, 1), color="tab:blue", alpha=0.8)
        lo, hi = binom.ppf([0.005, 0.995], z.size, 1 / bins)
        ax.axhspan(lo, hi, color="grey", alpha=0.25, lw=0)
        ax.set_title(f"{name} ({z.size})", fontsize=9)
        ax.set_xlim(0, 1)
    for ax in axes[len(names) :]:
        ax.axis("off")
    fig.suptitle(f"{title}: PIT of the truth under each stated error (uniform when the errors are right)")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90)
    plt.close(fig)
