"""The joint fit's noise: the residuals' model, the rows whitened by it, and the bound.

- :func:`_noise_model`: each record's and channel's residuals as a random walk, a first-order
  Gauss-Markov process and white noise (:func:`sizefx.noise_model.fit_state`), then an AR process
  of what that leaves (order by BIC up to :data:`AR_MAX_ORDER`);
- :func:`_normal_equations`: the normal equations of the rows whitened by those models
  (generalised least squares: the inverse is the covariance);
- :func:`cramer_rao_fisher`: the Fisher information on the same rows with the noise's spectrum
  measured by an AR sieve (:data:`BOUND_AR_ORDER`), whose inverse is the Cramer-Rao bound;
- :func:`_noise_summary`: what the fit took the noise to be, for the report and the JSON.
"""

from __future__ import annotations

import numpy as np

from ..noise_model import ARNoise, Autocovariance, ChainedNoise, StateNoise, fit_ar, fit_state, state_log_likelihood
from .design import _columns

__all__ = ["AR_MAX_ORDER", "BOUND_AR_ORDER", "NOISE_FLOOR_MPS2", "STATE_LR_THRESHOLD", "cramer_rao_fisher"]

#: Smallest residual level [m/s^2 per row] the noise model takes as measured: 0.01 ug, far below
#: any accelerometer. A simulated record without noise leaves residuals of rounding size, whose
#: fitted "noise" would weight its channels 1e10 times over the others.
NOISE_FLOOR_MPS2 = 1e-7
#: Highest AR order of the interval rows' noise model: 8 intervals (160 ms) of memory covers
#: table vibration and the bias's wander inside its window; BIC usually picks fewer.
AR_MAX_ORDER = 8


def _residual_autocovariance(segments, x, max_lag, n_records, n_bias, with_tilt, with_delay):
    """Autocovariances [record][channel] of the rows' residuals at ``x``, pooled over each record's windows."""
    acov = [[Autocovariance(max_lag) for _ in range(3)] for _ in range(n_records)]
    for k, window, Hs, ys in segments:
        for i in range(3):
            acov[k][i].add(ys[i] - Hs[i] @ x[_columns(i, window, n_bias, with_tilt, with_delay)])
    return acov


def _residual_series(segments, x, n_records, n_bias, with_tilt, with_delay):
    """The rows' residuals at ``x`` [record][channel]: one series per segment (a bias window's run)."""
    out: list = [[[] for _ in range(3)] for _ in range(n_records)]
    for k, window, Hs, ys in segments:
        for i in range(3):
            out[k][i].append(ys[i] - Hs[i] @ x[_columns(i, window, n_bias, with_tilt, with_delay)])
    return out


#: The state model's walk and Gauss-Markov part are kept when they raise the likelihood of the
#: residuals over white noise by this much (twice the log-likelihood ratio): the 1 % point of a
#: chi-square with two degrees of freedom (the two variances; their correlation time comes with
#: them). Kept always, a walk found in white noise by chance made the errors of a short white-noise
#: plan up to 21 % wider than the plan predicts (tests/test_plan.py).
STATE_LR_THRESHOLD = 9.21


def _noise_model(series) -> ChainedNoise:
    """The residuals' noise model: a random walk, a first-order Gauss-Markov process and white noise
    (:func:`sizefx.noise_model.fit_state`), then an AR process (order by BIC up to
    :data:`AR_MAX_ORDER`) of what that model leaves, which also sets the innovations' scale.

    Every accelerometer has a bias random walk, and its power lies below any AR order's reach: an AR
    model alone prewhitened it as white noise, and its drift within a bias window passed into the
    arms with standard errors that did not know it (on validate_calibrate's development range, z RMS
    up to 1.54 and an efficiency of 0.64 against the bound for the true noise); so did choosing
    between the two models by BIC, which took the walk for white noise where it was small against
    the white noise per row and still large against the arms."""
    state = fit_state(series)
    floor = NOISE_FLOOR_MPS2**2
    if not state.r >= floor:  # residuals of rounding size (a simulation without noise)
        return ChainedNoise(StateNoise(0.0, 0.0, 0.0, floor), ARNoise(np.zeros(0), 1.0, 1.0))
    white = StateNoise(0.0, 0.0, 0.0, state.variance())
    ll_white = state_log_likelihood(series, white)
    if 2.0 * (state.log_likelihood - ll_white) < STATE_LR_THRESHOLD:
        state = white  # no walk nor Gauss-Markov part beyond chance
    acov = Autocovariance(AR_MAX_ORDER)
    for e in series:
        if e.size:
            acov.add(state.whiten(e))
    return ChainedNoise(state, _floored(fit_ar(acov)))


def _floored(model: ARNoise) -> ARNoise:
    """The noise model, or white noise at :data:`NOISE_FLOOR_MPS2` when the residuals are below it."""
    floor = NOISE_FLOOR_MPS2**2
    return model if model.innovation_var >= floor else ARNoise(np.zeros(0), floor, floor)


def _normal_equations(segments, noise, p, n_bias, with_tilt, with_delay):
    """``N = sum H~' H~ / s2``, ``b = sum H~' y~ / s2`` with ``~`` the rows whitened by each record's
    and channel's noise model (:class:`~sizefx.noise_model.ARNoise`, innovation variance s2)."""
    N = np.zeros((p, p))
    b = np.zeros(p)
    for k, window, Hs, ys in segments:
        for i in range(3):
            model = noise[k][i]
            H, y = model.whiten(Hs[i]), model.whiten(ys[i])
            cols = _columns(i, window, n_bias, with_tilt, with_delay)
            N[np.ix_(cols, cols)] += H.T @ H / model.innovation_var
            b[cols] += H.T @ y / model.innovation_var
    return N, b


#: The bound's noise model: an AR process of up to this order (64 intervals, 1.3 s at 20 ms),
#: chosen by AIC: a sieve for the residuals' spectrum, which follows colour that the fit's own
#: model (:data:`AR_MAX_ORDER`, BIC) leaves out. (A fixed order would not do: on white noise its
#: 64 spurious coefficients move the spectrum at the motion's frequencies by ~10 %.)
BOUND_AR_ORDER = 64


def cramer_rao_fisher(segments, x, p, n_bias, with_tilt, with_delay, n_records) -> np.ndarray:
    """The Fisher information [p, p] of the parameters on these rows (:func:`_rows`), the noise of
    each record's channel Gaussian with the spectrum measured on the residuals at ``x`` (an AR
    sieve, :data:`BOUND_AR_ORDER`). Its inverse is the Cramer-Rao bound of any unbiased estimator
    from these rows; on white noise it is ``H'H / s2``. The rows are interval means: what the
    averaging itself gives up is not in it (on the paper's plan the rates domain's standard errors,
    from every sample, are within 1 % of the increment domain's; benchmarks/accuracy_calibrate.py)."""
    acov = _residual_autocovariance(segments, x, BOUND_AR_ORDER, n_records, n_bias, with_tilt, with_delay)
    noise = [[_floored(fit_ar(a, criterion="aic")) for a in per_record] for per_record in acov]
    return _normal_equations(segments, noise, p, n_bias, with_tilt, with_delay)[0]


def _noise_summary(model) -> dict:
    """What the fit took the noise of one record's channel to be (at the rows' rate), for the report
    and the JSON: the state model's walk, Gauss-Markov part and white noise (per row, SI), the AR
    model of what they leave (its order and coefficients), and how much the colour changes the
    variance of a long mean (1: as white; the walk, which grows without bound, apart)."""
    out = {"ar_order": model.order, "ar_coefficients": [], "long_run_variance_ratio": float(model.variance_ratio())}
    if isinstance(model, ChainedNoise):
        state = model.state
        out.update(
            ar_coefficients=model.ar.a.tolist(),
            random_walk_var_per_row=state.q_rw,
            markov_phi=state.phi,
            markov_var=state.s_gm / (1.0 - state.phi**2) if state.phi < 1.0 else 0.0,
            white_var=state.r,
        )
    elif isinstance(model, ARNoise):
        out["ar_coefficients"] = model.a.tolist()
    return out
