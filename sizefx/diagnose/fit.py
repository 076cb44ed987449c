"""The loop: predict, select, update, re-weight, until the selection no longer changes.

:func:`diagnose` runs it on one record:

1. **Predict** the IMU from the reference under the start model (:mod:`.predictor`);
   the **residual** is measured minus predicted on the six channels.
2. **Select** (:func:`sizefx.diagnose.selection.select`) on the weighted normal equations of
   the candidates' Jacobian columns (:func:`sizefx.diagnose.candidates.jacobian_columns`),
   linearised at the current estimate.
3. **Iterate.** The model is updated with the selected estimates, the prediction and
   regressors are recomputed there (Gauss-Newton), the channel weights are re-estimated from
   the new residual (``1 / (sigma_c^2 kappa_c)``, ``kappa_c`` the largest variance inflation of
   block means from 0.5 s to a twentieth of the record: coloured residuals, such as a bias
   random walk, count as fewer samples), and the selection is repeated until it no longer
   changes (at most :data:`MAX_PASSES` passes).
4. **Measure**: the residual RMS per channel before and after, and each effect's share of the
   residual it explains (:class:`Diagnosis`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from ..io.telemetry import Telemetry
from .candidates import jacobian_columns
from .naming import name_effect
from .predictor import Predictor
from .selection import Rows, block_means, normal_equations, select, sigmas, solve
from .theta import CHANNELS, PARAMS

__all__ = ["Diagnosis", "diagnose", "KAPPA_BLOCK_S", "MAX_PASSES"]

#: Shortest block for the variance inflation kappa of a channel's residual [s]; longer ones, by
#: factors of 4, up to a twentieth of the record.
KAPPA_BLOCK_S = 0.5
#: Gauss-Newton passes at most; selection and estimates settle in two or three.
MAX_PASSES = 6


@dataclass
class Diagnosis:
    """What :func:`diagnose` found in one record (SI), and what :func:`sizefx.diagnose.run` adds:
    the path of the extended model and the navigation gain."""

    path: str
    effects: list
    unrevealed: list  #: [{"id", "channel", "parameters", "reason"}]
    rms_before: dict  #: channel -> SI RMS
    rms_after: dict
    theta_nominal: np.ndarray
    theta: np.ndarray
    sigma_theta: dict
    samples: int
    block: int
    weights_sigma: np.ndarray  #: per-channel noise sigma used in the weights (SI)
    kappa: np.ndarray
    passes: int
    log: list
    wall_s: float
    residual_before: np.ndarray | None = None  #: [n, 6]
    residual_after: np.ndarray | None = None
    t: np.ndarray | None = None
    mask: np.ndarray | None = None
    model_path: str | None = None
    navigation: dict | None = None
    bandwidth_hz: float | None = None
    white_sigma: dict | None = None  #: per channel: the residual's sample-to-sample (first-difference) noise
    rms_full_before: dict | None = None  #: full-band RMS (differs from rms_* when bandwidth_hz is set)
    rms_full_after: dict | None = None


def _noise(rows_of: Rows, res):
    """Per channel: the residual's sigma and kappa, the variance inflation of its 0.5 s block means.

    Computed on the rows the fit uses. kappa is 1 for white noise and grows with colour
    (drift, unmodelled slow terms, a low-pass): the weights ``1 / (sigma^2 kappa)`` then
    count a coloured channel as fewer independent samples.
    """
    r = rows_of(res)[rows_of.keep]
    r = r - r.mean(axis=0)
    sigma = np.maximum(r.std(axis=0), 1e-300)
    kappa = np.ones(6)
    B = max(2, round(KAPPA_BLOCK_S / rows_of.dt))
    while r.shape[0] // B >= 20:  # 0.5 s, 2 s, 8 s, ...: a random walk shows only in the long blocks
        blocks = block_means(r, B)
        kappa = np.maximum(kappa, blocks.var(axis=0) * B / sigma**2)
        B *= 4
    return sigma, kappa


def _rms(rows_of: Rows, res):
    return np.sqrt(np.mean(rows_of(res)[rows_of.keep] ** 2, axis=0))


def _power(rows_of: Rows, r, weights, chans):
    return float(np.sum(weights[chans] * _rms(rows_of, r)[chans] ** 2))


def diagnose(tel: Telemetry, theta_nominal: np.ndarray, *, bandwidth_hz: float | None = None,
             keep_series: bool = True, progress=None) -> Diagnosis:
    """Run the loop of the module docstring on one record; ``theta_nominal`` [NP] is the start model.

    ``bandwidth_hz`` fits the residual low-passed at that frequency (see :class:`Rows`):
    for references whose differentiated noise swamps the high band (motion capture).
    ``keep_series`` keeps the residuals and times for the plots. ``progress(done, total)``,
    when given, is called after each Gauss-Newton pass (total :data:`MAX_PASSES`; the last
    call says done when the selection settles earlier).
    """
    started = time.perf_counter()
    pred = Predictor(tel)
    rows_of = Rows(pred.t, pred.mask, pred.dt, bandwidth_hz)
    theta0 = np.asarray(theta_nominal, dtype=float).copy()
    residual_before = pred.measured - pred.predict(theta0)
    theta = theta0.copy()
    first = rows_of(residual_before)[rows_of.keep]  # white-noise sigma from first differences to start
    sigma_c = np.maximum(np.sqrt(np.mean(np.diff(first, axis=0) ** 2, axis=0) / 2.0), 1e-300)
    kappa = np.ones(6)
    history = []
    log = []
    residual = residual_before
    for passes in range(1, MAX_PASSES + 1):
        cols = jacobian_columns(theta, pred.terms(theta), pred.t)
        weights = 1.0 / (sigma_c**2 * kappa)
        nrm = normal_equations(rows_of, residual, cols, weights)
        penalty = math.log(max(nrm.rows, 2))
        offset = theta0 - theta  # a parameter not selected stays at its nominal value
        chosen, unrevealed, steps = select(nrm, offset, penalty)
        log.append(f"pass {passes}: " + ("; ".join(steps) if steps else "nothing selected"))
        free = np.array(sorted({j for c in chosen for j in c.active}), dtype=int)
        N, b, yy = nrm.total()
        x, _, cov = solve(N, b, yy, free, offset)
        new = theta0.copy()
        new[free] = theta[free] + x
        sig = dict(zip(free.tolist(), np.sqrt(np.abs(np.diag(cov)))))
        step = max((abs(new[j] - theta[j]) / sig[j] for j in free.tolist()), default=0.0)
        key = tuple(sorted(c.cand.key for c in chosen))
        theta = new
        residual = pred.measured - pred.predict(theta)
        sigma_c, kappa = _noise(rows_of, residual)
        history.append(key)
        if progress is not None:
            progress(passes, MAX_PASSES)
        if passes >= 2 and history[-1] == history[-2] and step < 1e-3:
            break
    if progress is not None and passes < MAX_PASSES:
        progress(MAX_PASSES, MAX_PASSES)
    # Final standard errors with the final weights; the regressors are the last pass's (theta has
    # moved by less than 1e-3 sigma since, when the loop converged).
    weights = 1.0 / (sigma_c**2 * kappa)
    nrm = normal_equations(rows_of, residual, cols, weights)
    N, b, yy = nrm.total()
    sig = sigmas(N, b, yy, free, theta0 - theta) if free.size else {}
    mask = pred.mask
    rms_b, rms_a = _rms(rows_of, residual_before), _rms(rows_of, residual)
    effects = []
    for c in chosen:
        # share of the weighted residual power of the channels it acts on that this effect removes,
        # the others staying in the model
        without = theta.copy()
        without[list(c.active)] = theta0[list(c.active)]
        r_wo = pred.measured - pred.predict(without)
        # its channels: where its contribution, in units of each channel's noise, is at least a
        # tenth of its largest (the tilt acts on the gyros too, through Earth rate, but 1e5 times less)
        size = _rms(rows_of, r_wo - residual) / sigma_c
        chans = np.flatnonzero(size >= 0.1 * size.max()) if size.max() > 0 else np.arange(6)
        p0 = _power(rows_of, residual_before, weights, chans)
        frac = max(0.0, (_power(rows_of, r_wo, weights, chans) - _power(rows_of, residual, weights, chans)) / p0) \
            if p0 > 0 else 0.0
        effects.append(name_effect(c, theta, theta0, sig, frac))
    effects.sort(key=lambda e: -e.explained_fraction)
    unrev = [{"id": cand.id, "channel": cand.channel, "parameters": [PARAMS[j].label for j in hidden],
              "reason": reason} for cand, hidden, reason in unrevealed.values()]
    return Diagnosis(
        path=str(tel.path), effects=effects, unrevealed=unrev,
        rms_before=dict(zip(CHANNELS, rms_b.tolist())), rms_after=dict(zip(CHANNELS, rms_a.tolist())),
        theta_nominal=theta0, theta=theta, sigma_theta=sig, samples=int(mask.sum()), block=rows_of.L,
        bandwidth_hz=bandwidth_hz,
        white_sigma=dict(zip(CHANNELS, (np.sqrt(np.mean(np.diff(rows_of(residual)[rows_of.keep], axis=0) ** 2, axis=0)
                                                / 2.0)).tolist())),
        rms_full_before=dict(zip(CHANNELS, np.sqrt(np.mean(residual_before[mask] ** 2, axis=0)).tolist())),
        rms_full_after=dict(zip(CHANNELS, np.sqrt(np.mean(residual[mask] ** 2, axis=0)).tolist())),
        weights_sigma=sigma_c, kappa=kappa, passes=passes, log=log, wall_s=time.perf_counter() - started,
        residual_before=residual_before if keep_series else None, residual_after=residual if keep_series else None,
        t=pred.t if keep_series else None, mask=mask if keep_series else None)

