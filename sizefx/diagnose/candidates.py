"""The effects diagnose tests, and their regressors: the columns of d(prediction)/d(theta).

Every effect of :data:`CANDIDATES` is a group of parameters of the model vector (an identifier,
the channel it acts on, its indices). Its regressors are the partial derivatives of the
prediction, analytic (:func:`jacobian_columns`); :func:`numeric_jacobian`, the slow twin, is
what the tests compare them with. :data:`PRIORITY` says which explanation is the ordinary one
when a record cannot tell two apart.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .predictor import tilted_to_body
from .theta import (A_BIAS, A_K2, A_MIS, A_SF, G_BIAS, G_G, G_MIS, G_SF, LEVER, NP, OFFDIAG, PARAMS, TAU_A, TAU_R,
                    TILT, offdiag_row)

__all__ = ["CANDIDATES", "PRIORITY", "Candidate", "jacobian_columns", "numeric_jacobian"]


@dataclass(frozen=True)
class Candidate:
    """One effect to test: an identifier, the channel it acts on (or None) and its parameters."""

    id: str
    channel: str | None
    idx: tuple

    @property
    def key(self) -> str:
        return self.id if self.channel is None else f"{self.id}:{self.channel}"


def _candidates():
    c = []
    for i, a in enumerate("xyz"):
        c.append(Candidate("accel_bias", f"accel_{a}", (A_BIAS[i],)))
        c.append(Candidate("accel_scale_factor", f"accel_{a}", (A_SF[i],)))
        c.append(Candidate("accel_misalignment", f"accel_{a}", tuple(A_MIS[2 * i:2 * i + 2])))
        c.append(Candidate("accel_quadratic", f"accel_{a}", (A_K2[i],)))
        c.append(Candidate("lever_arm", f"accel_{a}", tuple(LEVER[3 * i:3 * i + 3])))
    c.append(Candidate("accel_delay", None, (TAU_A,)))
    c.append(Candidate("reference_delay", None, (TAU_R,)))
    c.append(Candidate("level_tilt", None, tuple(TILT)))
    for i, a in enumerate("xyz"):
        c.append(Candidate("gyro_bias", f"gyro_{a}", (G_BIAS[i],)))
        c.append(Candidate("gyro_scale_factor", f"gyro_{a}", (G_SF[i],)))
        c.append(Candidate("gyro_misalignment", f"gyro_{a}", tuple(G_MIS[2 * i:2 * i + 2])))
        c.append(Candidate("gyro_g_sensitivity", f"gyro_{a}", tuple(G_G[3 * i:3 * i + 3])))
    return tuple(c)


CANDIDATES = _candidates()
#: Which explanation is the ordinary one when the data cannot tell two apart (see
#: :func:`sizefx.diagnose.selection.select`): biases and the geometry first, then clocks, the
#: table, and the sensor-error terms.
PRIORITY = ("accel_bias", "gyro_bias", "lever_arm", "accel_delay", "reference_delay", "level_tilt",
            "accel_scale_factor", "gyro_scale_factor", "accel_misalignment", "gyro_misalignment",
            "accel_quadratic", "gyro_g_sensitivity")


def jacobian_columns(theta: np.ndarray, terms: dict, t: np.ndarray) -> dict:
    """``{param: (channels, [n, len(channels)])}``: the nonzero columns of d(prediction)/d(theta).

    ``terms``: what :func:`sizefx.diagnose.predictor.predict_readings` returned with its
    readings at ``theta``; ``t`` [n] the sample times (s) for the delays' time derivatives.

    Analytic: exact for the biases, scale factors, misalignments, K2, arms and G; the tilt
    to first order in the tilt (1e-4 relative at 20 arcsec); the delays as time derivatives
    of the predicted series (``numpy.gradient``: relative error (2 pi f dt)^2 / 6 for motion
    at f, 1e-3 at 10 Hz sampled at 286 Hz). Gauss-Newton only needs the directions right:
    the residual itself is always evaluated exactly. The gyro parameters also move the
    accelerometer prediction a little, through the corrected gyro rates in the lever terms
    (relative size 1e-4 of 1e-4); these columns leave that out. Increments records are
    differentiated as point values (the ``dt^2/24`` interval-mean term is left out too).
    """
    th, p = theta, terms
    cols = {}
    n = t.size
    one = np.ones((n, 1))
    w_ib, f_g, u_g = p["w_ib"], p["f_g"], p["u_g"]
    for i in range(3):
        cols[G_BIAS[i]] = (np.array([i]), one)
        cols[G_SF[i]] = (np.array([i]), (w_ib @ u_g[i])[:, None])
        v_norm = np.linalg.norm(np.eye(3)[i] + offdiag_row(th[G_MIS], i))
        for k, (ii, jj) in enumerate(OFFDIAG):
            if ii == i:  # d u_i / d m_ij = (e_j - u_i u_ij) / |v_i|
                col = (1.0 + th[G_SF[i]]) * (w_ib[:, jj] - (w_ib @ u_g[i]) * u_g[i, jj]) / v_norm
                cols[G_MIS[k]] = (np.array([i]), col[:, None])
        for jj in range(3):
            cols[G_G[3 * i + jj]] = (np.array([i]), f_g[:, jj:jj + 1].copy())
    a, u_a, w, wd, w2 = p["a"], p["u_a"], p["w"], p["wd"], p["w2"]
    for i in range(3):
        ch = np.array([3 + i])
        gain = 1.0 + th[A_SF[i]] + 2.0 * th[A_K2[i]] * a[:, i]
        cols[A_BIAS[i]] = (ch, one)
        cols[A_SF[i]] = (ch, a[:, i:i + 1].copy())
        cols[A_K2[i]] = (ch, (a[:, i] ** 2)[:, None])
        v_norm = np.linalg.norm(np.eye(3)[i] + offdiag_row(th[A_MIS], i))
        f_i = p["f_i"][i]
        for k, (ii, jj) in enumerate(OFFDIAG):
            if ii == i:
                col = gain * (f_i[:, jj] - a[:, i] * u_a[i, jj]) / v_norm
                cols[A_MIS[k]] = (ch, col[:, None])
        # d a_i / d r_i = u x wd + (u . w) w - |w|^2 u
        grad = np.cross(u_a[i], wd) + (w @ u_a[i])[:, None] * w - w2[:, None] * u_a[i]
        for c in range(3):
            cols[LEVER[3 * i + c]] = (ch, (gain * grad[:, c])[:, None])
    gain = 1.0 + th[A_SF] + 2.0 * th[A_K2] * a  # [n, 3] d(output)/d(input) of each accelerometer
    f_u = np.column_stack([p["f_a"] @ u_a[i] for i in range(3)])  # the reference's part of a_i
    m_g, g_sens = p["m_g"], p["g_sens"]
    cols[TAU_R] = (np.arange(6), np.hstack([np.gradient(w_ib @ m_g.T + f_g @ g_sens.T, t, axis=0),
                                             gain * np.gradient(f_u, t, axis=0)]))
    cols[TAU_A] = (np.arange(3, 6), -gain * np.gradient(a, t, axis=0))
    kg, ka, r_tilt = p["kg"], p["ka"], p["r_tilt"]
    for k in range(2):  # R(phi)^T v ~ v + v x phi: d/dphi_k = v x e_k
        e = np.eye(3)[k]
        gyro = (tilted_to_body(kg, np.cross(kg["w_in"], e), r_tilt) @ m_g.T
                + tilted_to_body(kg, np.cross(kg["f_n"], e), r_tilt) @ g_sens.T)
        df = tilted_to_body(ka, np.cross(ka["f_n"], e), r_tilt)
        cols[TILT[k]] = (np.arange(6), np.hstack([gyro, gain * (df @ u_a.T)]))
    return cols


def numeric_jacobian(predict: Callable[[np.ndarray], np.ndarray], theta: np.ndarray, mask: np.ndarray) -> dict:
    """The slow twin of :func:`jacobian_columns`: central differences of ``predict`` (theta -> [n, 6])
    with each parameter's :attr:`Param.step`; a column's channels are those it moves on ``mask``."""
    def column(j):
        up, dn = theta.copy(), theta.copy()
        up[j] += PARAMS[j].step
        dn[j] -= PARAMS[j].step
        d = (predict(up) - predict(dn)) / (2.0 * PARAMS[j].step)
        ch = np.flatnonzero(np.any(d[mask] != 0.0, axis=0))
        return ch, d[:, ch]

    return {j: column(j) for j in range(NP)}
