"""The effects diagnose tests, and their regressors: the columns of d(prediction)/d(theta).

Every effect of :data:`CANDIDATES` is a group of parameters of the model vector (an identifier,
the channel it acts on, its indices). Its regressors are the partial derivatives of the
prediction, analytic (:func:`jacobian_columns`, the sensor model's
:func:`sizefx.sensor_model.jacobian`); :func:`numeric_jacobian`, the slow twin, is what the
tests compare them with. :data:`PRIORITY` says which explanation is the ordinary one
when a record cannot tell two apart.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, fields, is_dataclass, replace

import numpy as np

from .. import sensor_model as sm
from .theta import A_BIAS, A_K2, A_MIS, A_SF, G_BIAS, G_G, G_MIS, G_SF, LEVER, MOUNT, NP, PARAMS, TAU_A, TAU_R, TILT

__all__ = ["CANDIDATES", "PRIORITY", "Candidate", "columns_between", "jacobian_columns", "numeric_jacobian"]


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
        c.append(Candidate("accel_misalignment", f"accel_{a}", tuple(A_MIS[2 * i : 2 * i + 2])))
        c.append(Candidate("accel_quadratic", f"accel_{a}", (A_K2[i],)))
        c.append(Candidate("lever_arm", f"accel_{a}", tuple(LEVER[3 * i : 3 * i + 3])))
    c.append(Candidate("accel_delay", None, (TAU_A,)))
    c.append(Candidate("reference_delay", None, (TAU_R,)))
    c.append(Candidate("level_tilt", None, tuple(TILT)))
    c.append(Candidate("reference_mount", None, tuple(MOUNT)))
    for i, a in enumerate("xyz"):
        c.append(Candidate("gyro_bias", f"gyro_{a}", (G_BIAS[i],)))
        c.append(Candidate("gyro_scale_factor", f"gyro_{a}", (G_SF[i],)))
        c.append(Candidate("gyro_misalignment", f"gyro_{a}", tuple(G_MIS[2 * i : 2 * i + 2])))
        c.append(Candidate("gyro_g_sensitivity", f"gyro_{a}", tuple(G_G[3 * i : 3 * i + 3])))
    return tuple(c)


CANDIDATES = _candidates()
#: Which explanation is the ordinary one when the data cannot tell two apart (see
#: :func:`sizefx.diagnose.selection.select`): biases and the geometry first, then clocks, the
#: table, the reference's mount, and the sensor-error terms. The mount before both misalignments:
#: a rigid rotation of both triads against the reference is, to first order, the common
#: antisymmetric part of the gyro and the accelerometer misalignments, and its ordinary cause is
#: the marker body or the fixture, not two sensor triads turned alike.
PRIORITY = (
    "accel_bias",
    "gyro_bias",
    "lever_arm",
    "accel_delay",
    "reference_delay",
    "level_tilt",
    "reference_mount",
    "accel_scale_factor",
    "gyro_scale_factor",
    "accel_misalignment",
    "gyro_misalignment",
    "accel_quadratic",
    "gyro_g_sensitivity",
)


#: Every deterministic effect of the sensor model but the reference delay (whose columns
#: :func:`jacobian_columns` asks for separately).
_ALL_BUT_REFERENCE_DELAY = tuple(e.name for e in sm.EFFECTS if e.deterministic and e.name != "reference_delay")


def jacobian_columns(theta: np.ndarray, terms: dict, t: np.ndarray) -> dict:
    """``{param: (channels, [n, len(channels)])}``: the nonzero columns of d(prediction)/d(theta).

    ``terms``: what :func:`sizefx.diagnose.predictor.predict_readings` returned with its
    readings at ``theta``; ``t`` [n] the sample times (s) for the time derivatives the tilt
    and delay columns need (``numpy.gradient``: relative error (2 pi f dt)^2 / 6 for motion at
    f, 1e-3 at 10 Hz sampled at 286 Hz).

    The columns are :func:`sizefx.sensor_model.jacobian`'s on the motion the prediction used
    (exact for the biases, scale factors, misalignments, K2, arms and G; the tilt through
    ``f_b`` and ``omega_in``; the delays by the chain rule). Gauss-Newton only needs the
    directions right: the residual itself is always evaluated exactly. Two things are left out:
    the gyro parameters also move the accelerometer prediction a little, through the corrected
    gyro rates in the lever terms (relative size 1e-4 of 1e-4); and increments records are
    differentiated as point values (the ``dt^2/24`` interval-mean term). The reference delay
    moves the reference's ``f_b`` but not the measured gyros the lever terms come from, so its
    accelerometer columns are the specific force's rate alone (no ``omegaddot``).
    """
    p = sm.SensorParams.from_vector(theta)
    at_g, at_a = terms["at_gyro"], terms["at_accel"]

    def rate(x):
        return np.gradient(x, t, axis=0)

    at_g = replace(at_g, omegadot_ib_b=rate(at_g.omega_ib_b), fdot_b=rate(at_g.f_b))
    at_a = replace(at_a, fdot_b=rate(at_a.f_b), omegaddot_ib_b=rate(at_a.omegadot_ib_b))
    # the accelerometers' lever terms come from the measured gyros, which the mount does not turn
    cols = dict(sm.jacobian(p, at_g, at_a, effects=_ALL_BUT_REFERENCE_DELAY, measured_lever_rates=True))
    cols.update(sm.jacobian(p, at_g, replace(at_a, omegaddot_ib_b=None), effects=["reference_delay"]))
    return cols


def columns_between(theta: np.ndarray, terms, t: np.ndarray):
    """``(lo, hi) -> jacobian_columns`` for the samples ``lo:hi`` only, as
    :func:`sizefx.diagnose.normal.normal_equations` asks for them chunk by chunk. ``terms``: the
    whole record's (:meth:`sizefx.diagnose.predictor.Predictor.terms`), or a function ``(a, b) ->``
    the terms of the samples ``a:b`` (:meth:`~sizefx.diagnose.predictor.Predictor.terms_span`: then
    nothing is held for the whole record). One sample more on each side feeds the time
    derivatives, so the columns equal the whole record's exactly."""
    n = t.size

    def piece(x, a, b):
        return x[a:b] if isinstance(x, np.ndarray) and x.ndim and x.shape[0] == n else x

    def sliced(a, b):
        return {
            k: (
                replace(v, **{f.name: piece(getattr(v, f.name), a, b) for f in fields(v)})
                if is_dataclass(v) and not isinstance(v, type) and k != "params"
                else v
            )
            for k, v in terms.items()
        }

    terms_of = terms if callable(terms) else sliced

    def cols(lo, hi):
        a, b = max(0, lo - 1), min(n, hi + 1)
        full = jacobian_columns(theta, terms_of(a, b), t[a:b])
        return {j: (ch, x[lo - a : lo - a + hi - lo]) for j, (ch, x) in full.items()}

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
