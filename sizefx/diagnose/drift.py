"""Bias drift: a random walk of each channel's bias, measured beside the model, and the error it
adds to the estimates.

A bias that walks (a gyro's rate random walk, an accelerometer's bias instability) is no white
noise: its power sits below the record's slowest effects, where it can pass for a misalignment
on a turntable, a scale factor or a mount. The long-run sandwich sees only as much of it as a few
blocks' lags hold; here the walk is modelled instead, and each estimate's error grows by as much
as that parameter's regressor resembles a walk.

The walk of channel ``c`` over the record's span ``[t0, t0 + T]`` is Brownian motion of intensity
``q_c`` (variance ``q_c t`` after ``t``), zero at ``t0``: **a bias is its value at the record's first
sample**, the walk what it does after. Its Karhunen-Loeve series (e.g. Van Trees, *Detection,
Estimation and Modulation Theory I*, 3.4) is

    w(t) = sum_k a_k sin((k - 1/2) pi (t - t0) / T),   a_k ~ N(0, q_c 2T / ((k - 1/2) pi)^2),

independent coefficients on a sine basis. :data:`TERMS` terms hold 97.5 % of the walk's variance
(``sum_{k<=8} 1/(k-1/2)^2`` over ``pi^2/2``); the rest is faster than the record's effects and
left to the long-run sandwich (:func:`sizefx.diagnose.algebra.long_run_meat`).

- :func:`intensity`: ``q_c`` of each channel, the maximum-likelihood variance component of the
  basis coefficients fitted beside every parameter the motion shows, 0 where the residual shows
  no walk beyond its white noise;
- :func:`walk_covariance`: what the walk adds to the covariance of the weighted least-squares
  estimates, ``N^-1 H'WZ Q Z'WH N^-1`` (the estimates themselves are those of the model alone),
  on the channels that walk; flicker's share of the errors is the spectrum's model's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .algebra import scaled_pinv

__all__ = [
    "Drift",
    "TERMS",
    "WALK_BINS",
    "SLOPES",
    "basis",
    "prior_variances",
    "intensity",
    "walk_covariance",
    "NO_DRIFT",
]

#: Sine terms of the walk's series: 97.5 % of its variance over the record (the module's docstring).
TERMS = 8
#: The record's periodogram bins (one cycle over the span per bin) that the series holds: its terms
#: lie at ``(k - 1/2) / 2`` bins, all under ``TERMS / 2``. On a channel that walks
#: (:attr:`Drift.walking`), the slow colour under these bins is the walk's part of the errors, and
#: the model of the residual's spectrum leaves it out (:func:`sizefx.diagnose.spectrum.spectral_meat`):
#: each slice of the spectrum is counted once.
WALK_BINS = TERMS / 2
#: The slopes of the slow noise's spectrum tried per channel (:func:`intensity`): a random walk of
#: the bias (``f^-2``) and flicker (``f^-1``, a bias instability).
SLOPES = (2.0, 1.0)


@dataclass(frozen=True)
class Drift:
    """The walk of each channel's bias over a record: intensities, the span they hold on, and the
    model's regressors against the walk's basis."""

    q: np.ndarray  #: [6] intensity per channel [unit^2 / s]: (rad/s)^2/s for gyros, (m/s^2)^2/s for accelerometers
    t0: float  #: start of the span [s]
    span_s: float  #: T [s]
    cross: dict = field(default_factory=dict)  #: channel -> [P, TERMS] H'WZ, for the channels that walk
    #: [6] per channel, the slope of its slow noise's spectrum (:data:`SLOPES`; 2: a walk)
    slope: np.ndarray = field(default_factory=lambda: np.full(6, 2.0))

    @property
    def walking(self) -> np.ndarray:
        """[6] the channels whose bias walks: slow noise measured, with a walk's slope. Flicker is
        measured and reported, but the model of the residual's spectrum carries it in the errors
        (:func:`walk_covariance`)."""
        return (self.q > 0) & (self.slope >= SLOPES[0])


#: No walk anywhere (the fit as under white noise).
NO_DRIFT = Drift(np.zeros(6), 0.0, 0.0)


def basis(t, t0: float, span_s: float) -> np.ndarray:
    """``[m, TERMS]``: ``sin((k - 1/2) pi (t - t0) / T)`` at times ``t`` [s]."""
    k = np.arange(1, TERMS + 1) - 0.5
    return np.sin(np.outer((np.asarray(t, dtype=float) - t0) * (math.pi / max(span_s, 1e-300)), k))


def prior_variances(span_s: float, slope: float = 2.0) -> np.ndarray:
    """``[TERMS]``: the coefficients' variances per unit intensity, ``2T / ((k - 1/2) pi)^2`` [s] for a
    walk; for slow noise of spectrum ``f^-slope``, in proportion to ``(k - 1/2)^-slope`` (a
    coefficient's variance is the spectrum at its frequency), equal to the walk's at ``k = 1``, so that
    the intensity reads as that of the walk with the same slowest term."""
    k = np.arange(1, TERMS + 1) - 0.5
    return 2.0 * span_s / (k * math.pi) ** 2 * (2.0 * k) ** (2.0 - slope)


def _ml_intensity(a, V, lam) -> tuple[float, float]:
    """The ``q >= 0`` maximising the likelihood of ``a ~ N(0, V + q diag(lam))``, and its negative
    log-likelihood (twice, less constants)."""

    def nll(q):
        C = V + q * np.diag(lam)
        sign, logdet = np.linalg.slogdet(C)
        if sign <= 0:
            return np.inf
        return float(logdet + a @ np.linalg.solve(C, a))

    scale = float(np.trace(V) / np.sum(lam))  # the intensity whose walk equals the noise on the basis
    if not scale > 0 or not np.all(np.isfinite(a)):
        return 0.0, math.inf
    grid = scale * np.logspace(-3, 8, 45)
    values = [nll(q) for q in grid]
    best = int(np.argmin(values))
    if nll(0.0) <= values[best]:
        return 0.0, nll(0.0)
    lo, hi = math.log(grid[max(0, best - 1)]), math.log(grid[min(len(grid) - 1, best + 1)])
    for _ in range(40):  # golden section on log q between the grid's neighbours of the best
        m1, m2 = lo + 0.382 * (hi - lo), lo + 0.618 * (hi - lo)
        if nll(math.exp(m1)) < nll(math.exp(m2)):
            hi = m2
        else:
            lo = m1
    q = math.exp(0.5 * (lo + hi))
    return q, nll(q)


def intensity(N, b, NU, UU, bU, channels, t0: float, span_s: float) -> Drift:
    """The walk of each channel's bias from the normal equations summed over blocks: ``N [P, P]``,
    ``b [P]`` of the model and, per channel ``c`` of ``channels``, ``NU[c] [P, K]``, ``UU[c] [K, K]``,
    ``bU[c] [K]`` of the sine basis (weights the inverse variances of white noise).

    Every parameter the motion shows is fitted beside the walk (a bias takes the constant, an effect
    not yet selected its own slow signature: neither passes for a walk), and the basis coefficients
    ``a`` of each channel then carry the white noise (covariance: their block of the joint
    inverse) and the walk (``q`` times :func:`prior_variances`); ``q`` is their maximum-likelihood
    variance component, 0 when the coefficients are no larger than the noise makes them. The slope of
    their spectrum is chosen per channel by the same likelihood among :data:`SLOPES`: a walk's
    coefficients fall as ``(k - 1/2)^-2``, flicker's as ``(k - 1/2)^-1``. Flicker is reported, and
    left to the model of the residual's spectrum in the errors (:func:`walk_covariance`). A slow
    Gauss-Markov process shows as one of the two."""
    q = np.zeros(6)
    if not channels or span_s <= 0:
        return Drift(q, t0, span_s)
    K = TERMS
    shown = np.flatnonzero(np.diag(N) > 0)
    P = shown.size
    A = np.zeros((P + K * len(channels), P + K * len(channels)))
    r = np.zeros(A.shape[0])
    A[:P, :P], r[:P] = N[np.ix_(shown, shown)], b[shown]
    for i, c in enumerate(channels):
        u = slice(P + i * K, P + (i + 1) * K)
        A[:P, u] = NU[c][shown]
        A[u, :P] = NU[c][shown].T
        A[u, u] = UU[c]
        r[u] = bU[c]
    inv = scaled_pinv(A)
    x = inv @ r
    slope = np.full(6, SLOPES[0])
    for i, c in enumerate(channels):
        u = slice(P + i * K, P + (i + 1) * K)
        fits = [(*_ml_intensity(x[u], inv[u, u], prior_variances(span_s, a)), a) for a in SLOPES]
        # no walk (q = 0) has the same likelihood under either slope: the tie keeps SLOPES[0]
        q[c], _, slope[c] = min(fits, key=lambda f: f[1])
    return Drift(q, t0, span_s, {c: NU[c] for c in channels if q[c] > 0}, slope)


def walk_covariance(drift: Drift, free, inv) -> np.ndarray | None:
    """``[f, f]``: what the walk adds to the covariance of the estimates of ``free`` (indices into the
    model's parameters), ``inv`` their ``N^-1``: ``inv (sum_c H_c'WZ Q_c Z'WH_c) inv`` with ``Q_c`` the
    walk's prior on channel ``c``'s coefficients. None where nothing walks.

    A channel whose slow noise is flicker (:attr:`Drift.walking` false) adds nothing: flicker is
    stationary, the model of the residual's spectrum holds it at every frequency
    (:mod:`.spectrum`), and its terms on the series of a walk from the record's first sample are
    neither independent nor of the variances the series gives them. Least squares of a step under
    white noise and flicker, the draws read as flicker: this part with the flicker slope predicted
    1.5 times the step's scatter, on top of the spectrum's model's 0.85 of it
    (``tests/test_diagnose_spectrum.py``)."""
    walking = [c for c in drift.cross if drift.walking[c]]
    if not walking:
        return None
    free = np.asarray(free, dtype=int)
    meat = np.zeros((free.size, free.size))
    for c in walking:
        NU = drift.cross[c]
        A = NU[free] * np.sqrt(drift.q[c] * prior_variances(drift.span_s, drift.slope[c]))[None, :]
        meat += A @ A.T
    return inv @ meat @ inv
