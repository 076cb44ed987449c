"""The closed form behind the paper's sway experiment: a horizontal channel's position error
for a step in its accelerometer error, with and without the Schuler loop.

Used by :func:`sizefx.experiments.paper.sway_experiment` (the error expected in each
segment) and by its Fig. 9 (:mod:`sizefx.experiments.paper_report`); ``tests/test_paper.py``
pins the t^2 law, the Schuler bound and superposition.
"""

from __future__ import annotations

import numpy as np

__all__ = ["schuler_response"]


def schuler_response(t, steps, omega_s):
    """Position error of one horizontal channel for a piecewise-constant accelerometer error.

    ``steps``: [(t_k, delta_b_k)]: the error changes by ``delta_b_k`` at ``t_k``. Returns the
    pure double integral (the paper's t^2 law) and the Schuler-loop response
    ``sum delta_b_k / omega_s^2 (1 - cos(omega_s (t - t_k)))``.
    """
    t = np.asarray(t, dtype=float)
    t2 = np.zeros_like(t)
    sch = np.zeros_like(t)
    for tk, db in steps:
        dt = np.clip(t - tk, 0.0, None)
        t2 += db * dt**2 / 2.0
        sch += db / omega_s**2 * (1.0 - np.cos(omega_s * dt))
    return t2, sch
