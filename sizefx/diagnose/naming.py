"""Each effect found, in the report's units and in one plain sentence.

:func:`name_effect` turns a selected candidate (:class:`sizefx.diagnose.selection.Chosen`) and the
estimates into an :class:`Effect`: parameters under the names and units of the
``sizefx/diagnosis/1`` JSON (SI, or the unit in the name: ppm, arcsec, ug_per_g2,
deg_per_h_per_g), their standard errors and nominal values, and the sentence the report prints
(mm, microseconds, arcsec, ppm, ug or deg/h, with sigma and the nominal value).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .selection import Chosen
from .theta import PARAMS

__all__ = ["Effect", "name_effect"]


@dataclass
class Effect:
    """One effect found: values absolute (not differences from the nominal), in SI unless the name
    carries the unit (``ppm``, ``arcsec``, ...)."""

    id: str
    channel: str | None
    params: dict  #: parameter name -> SI value (scalars or lists)
    sigma: dict
    nominal: dict
    explained_fraction: float
    sentence: str
    #: components the record cannot reveal: kept at nominal, or not measured (their estimates, without
    #: an error, in ``params``; :data:`sizefx.diagnose.budget.UNDETERMINED_SHARE`)
    hidden: list = field(default_factory=list)
    #: what the motion cannot tell it from, ruled out by the grade (:class:`sizefx.diagnose.aliases.Alternative`)
    alternative: Any = None


def _fmt(v, s, unit, digits=None):
    """``v +- s unit`` with as many decimals as the standard error's first two significant digits need."""
    if digits is None:
        digits = max(0, min(4, 1 - math.floor(math.log10(abs(s))) if s > 0 else 2))
    return f"{v:.{digits}f} +- {s:.{digits}f} {unit}"


def name_effect(c: Chosen, theta, theta0, sig, frac, alternative=None, undetermined=()) -> Effect:
    """The effect ``c`` at the estimate ``theta`` (start ``theta0``, standard errors ``sig`` by parameter,
    ``frac`` of the residual it explains): parameters in the JSON's names and units, and the sentence;
    ``alternative``: what the motion cannot tell it from, ruled out by the grade, said after it;
    ``undetermined``: its parameters the record does not measure (their error mostly other
    parameters' priors): their estimates stay in the values, without an error, and they are listed
    with the components not revealed."""
    idx = list(c.cand.idx)
    ps = [PARAMS[j] for j in idx]
    val = [float(theta[j]) for j in idx]
    nom = [float(theta0[j]) for j in idx]
    sg = [float(sig[j]) if j in sig and j not in undetermined else None for j in idx]
    unmeasured = [PARAMS[j].label for j in undetermined]
    axis = c.cand.channel[-1] if c.cand.channel else None
    hidden = [PARAMS[j].label for j in c.hidden]
    eid = c.cand.id

    def user(k):
        return val[k] / ps[k].per_unit, (sg[k] or 0.0) / ps[k].per_unit, nom[k] / ps[k].per_unit

    # JSON values, by effect: a number, a list of three, or a dict by component
    params: dict[str, Any]
    sigma: dict[str, Any]
    nominal: dict[str, Any]

    if eid == "lever_arm":
        params, sigma, nominal = {"r_m": val}, {"r_m": sg}, {"r_m": nom}
        comp = []
        for k, a in enumerate("xyz"):
            if sg[k] is None:
                continue
            v, s, n0 = user(k)
            comp.append(f"{a} = {_fmt(v, s, 'mm')} (nominal {n0:.3f} mm, {v - n0:+.3f} mm)")
        moved = float(np.linalg.norm(np.subtract(val, nom))) * 1e3
        sentence = (
            f"accelerometer {axis} sits {moved:.2f} mm from where the nominal geometry puts it: "
            + "; ".join(comp)
            + " from the reference point of the motion"
        )
        if hidden:
            sentence += f" ({', '.join(hidden)} not revealed by this record: kept at nominal)"
    elif eid in ("accel_delay", "reference_delay"):
        v, s, n0 = user(0)
        params, sigma, nominal = {"tau_s": val[0]}, {"tau_s": sg[0]}, {"tau_s": nom[0]}
        if eid == "accel_delay":
            word = "lag" if v >= 0 else "lead"
            sentence = f"the accelerometers {word} the gyros by {_fmt(abs(v), s, 'microseconds')}"
        else:
            word, sign = ("lags", "-") if v >= 0 else ("leads", "+")
            sentence = (
                f"the reference {word} the IMU by {_fmt(abs(v), s, 'microseconds')} (its rows stamped t "
                f"hold the motion at t {sign} {abs(v):.1f} us)"
            )
        if n0:
            sentence += f" (nominal {n0:.1f} us)"
    elif eid == "level_tilt":
        (vn, sn, nn), (ve, se, ne) = user(0), user(1)
        params = {"north_arcsec": vn, "east_arcsec": ve}
        sigma = {"north_arcsec": sn, "east_arcsec": se}
        nominal = {"north_arcsec": nn, "east_arcsec": ne}
        sentence = (
            f"the table (or the reference) is tilted off the local level: {_fmt(vn, sn, 'arcsec')} about "
            f"north and {_fmt(ve, se, 'arcsec')} about east"
        )
    elif eid == "reference_mount":
        params = {"arcsec": [user(k)[0] for k in range(3)]}
        sigma = {"arcsec": [user(k)[1] if sg[k] is not None else None for k in range(3)]}
        nominal = {"arcsec": [user(k)[2] for k in range(3)]}
        parts = [f"{_fmt(user(k)[0], user(k)[1], 'arcsec')} about {'xyz'[k]}" for k in range(3) if sg[k] is not None]
        sentence = (
            "the IMU sits rotated against the reference's body frame by "
            + ", ".join(parts)
            + " (marker body or fixture alignment)"
        )
        if hidden:
            sentence += f" ({', '.join(hidden)} not revealed by this record: kept at nominal)"
    elif eid in ("accel_bias", "gyro_bias"):
        v, s, n0 = user(0)
        key = "bias_mps2" if eid == "accel_bias" else "bias_rad_s"
        params, sigma, nominal = {key: val[0]}, {key: sg[0]}, {key: nom[0]}
        what = "accelerometer" if eid == "accel_bias" else "gyro"
        sentence = f"{what} {axis} has a bias of {_fmt(v, s, ps[0].unit)}" + (f" (nominal {n0:.3g})" if n0 else "")
    elif eid in ("accel_scale_factor", "gyro_scale_factor"):
        v, s, n0 = user(0)
        params, sigma, nominal = {"ppm": v}, {"ppm": s}, {"ppm": n0}
        what = "accelerometer" if eid.startswith("accel") else "gyro"
        sentence = (
            f"{what} {axis} reads {_fmt(abs(v), s, 'ppm')} {'too much' if v >= 0 else 'too little'} (scale factor)"
        )
    elif eid in ("accel_misalignment", "gyro_misalignment"):
        params = {"arcsec": {ps[k].label: user(k)[0] for k in range(len(ps)) if sg[k] is not None}}
        sigma = {"arcsec": {ps[k].label: user(k)[1] for k in range(len(ps)) if sg[k] is not None}}
        nominal = {"arcsec": {ps[k].label: user(k)[2] for k in range(len(ps))}}
        what = "accelerometer" if eid.startswith("accel") else "gyro"
        parts = [
            f"{_fmt(user(k)[0], user(k)[1], 'arcsec')} towards {ps[k].label[-1]}"
            for k in range(len(ps))
            if sg[k] is not None
        ]
        sentence = f"the {what} {axis} axis is misaligned: " + " and ".join(parts)
    elif eid == "accel_quadratic":
        v, s, n0 = user(0)
        params, sigma, nominal = {"ug_per_g2": v}, {"ug_per_g2": s}, {"ug_per_g2": n0}
        sentence = f"accelerometer {axis} has a quadratic term K2 = {_fmt(v, s, 'ug/g^2')}"
    elif eid == "gyro_g_sensitivity":
        params = {"deg_per_h_per_g": [user(k)[0] for k in range(3)]}
        sigma = {"deg_per_h_per_g": [user(k)[1] if sg[k] is not None else None for k in range(3)]}
        nominal = {"deg_per_h_per_g": [user(k)[2] for k in range(3)]}
        parts = [
            f"{_fmt(user(k)[0], user(k)[1], 'deg/h/g')} per g along {'xyz'[k]}" for k in range(3) if sg[k] is not None
        ]
        sentence = f"gyro {axis} responds to specific force: " + ", ".join(parts)
    else:  # pragma: no cover - every candidate id is handled above
        raise AssertionError(eid)
    if unmeasured:
        sentence += f" ({', '.join(unmeasured)} not measured by this record: see not revealed)"
    if alternative is not None:
        values = ", ".join(f"{k} = {v:+.4g}" for k, v in alternative.parameters.items())
        added = ", ".join(f"{k} +- {v:.3g}" for k, v in alternative.sigma_added.items())
        sentence += (
            f"; the motion cannot tell it from {alternative.key} (canonical correlation {alternative.rho:.4f}), "
            f"but that would need {values} {alternative.unit}: {alternative.reason}; the errors include "
            f"what it could be within that range ({added} {alternative.finding_unit})"
        )
    return Effect(eid, c.cand.channel, params, sigma, nominal, frac, sentence, hidden + unmeasured, alternative)
