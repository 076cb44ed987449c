"""Coloured residuals as an autoregressive process: fit, whiten, and the information they leave.

A least squares whose residuals are correlated in time (vibration, a bias wandering inside its
window, the table's own wobble) states standard errors that are too small or too large by the
ratio of the noise's low-frequency power to its average. Modelling the residual as an AR(p)
process,

    e[t] = a_1 e[t-1] + ... + a_p e[t-p] + u[t],    u white with variance s2,

and filtering the design and the data by ``1 - a_1 q^-1 - ... - a_p q^-p`` (prewhitening)
gives the generalised least squares: efficient, and with standard errors that hold on the
coloured noise (the Cochrane-Orcutt / GLSAR recipe of statsmodels' ``GLSAR``). The order is
chosen by an information criterion (BIC, or AIC for a spectral sieve), from 0 (white) to a maximum.

The fit works on pooled autocovariances (:class:`Autocovariance`), so residual series of any
number of records or windows, or of chunks of one long record, add up without being kept.

A bias random walk has its power at frequencies far below any AR order's reach (its spectrum grows
as 1/f^2 down to the record's length). :class:`StateNoise` models the residual as a random walk,
a first-order Gauss-Markov process and white noise, whitened by a Kalman filter
(:func:`sizefx.kernels.kalman.whiten_state`) and fitted by maximum likelihood on the residual
series themselves (:func:`fit_state`); a fit keeps whichever of the two models the Bayesian
information criterion prefers (:func:`sizefx.calibrate.joint.joint_fit`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import solve_toeplitz
from scipy.signal import lfilter

__all__ = [
    "Autocovariance",
    "ARNoise",
    "StateNoise",
    "ChainedNoise",
    "state_log_likelihood",
    "fit_ar",
    "fit_state",
    "whiten_state_slow",
    "WHITE",
    "CRITERIA",
    "VARIOGRAM_LAGS",
]


class Autocovariance:
    """Pooled autocovariance of residual series at lags ``0 .. max_lag`` (series added one by one;
    each contributes its own lag products, none across series)."""

    def __init__(self, max_lag: int):
        self.max_lag = int(max_lag)
        self.sums = np.zeros(self.max_lag + 1)
        self.n = 0

    def add(self, e) -> None:
        e = np.asarray(e, dtype=float)
        m = e.size
        self.n += m
        for lag in range(min(self.max_lag, m - 1) + 1):
            self.sums[lag] += e[lag:] @ e[: m - lag]

    def values(self) -> np.ndarray:
        """The biased estimate (divided by the total count): a positive semi-definite sequence, so
        the Yule-Walker AR is stable."""
        return self.sums / max(self.n, 1)


@dataclass(frozen=True)
class ARNoise:
    """``e[t] = sum_j a[j] e[t-1-j] + u[t]``, ``u`` white with variance ``innovation_var``."""

    a: np.ndarray
    innovation_var: float
    variance: float  #: of e itself (lag-0 autocovariance)

    @property
    def order(self) -> int:
        return int(self.a.size)

    def whiten(self, x: np.ndarray) -> np.ndarray:
        """``u = e - sum_j a[j] e[t-1-j]`` along axis 0; the first ``order`` rows (no past) are dropped."""
        if not self.order:
            return x
        return lfilter(np.r_[1.0, -self.a], [1.0], x, axis=0)[self.order :]

    def variance_ratio(self) -> float:
        """Long-run variance (the spectrum at zero frequency times the sampling rate) over the
        variance: how much a mean of many samples is worse than white noise of the same level
        would make it (> 1 for low-frequency colour)."""
        return self.innovation_var / (1.0 - self.a.sum()) ** 2 / self.variance if self.variance > 0 else 1.0


#: No colour: unit variance white noise (the first pass of a fit, before any residual is known).
WHITE = ARNoise(np.zeros(0), 1.0, 1.0)


#: Order penalties per coefficient: BIC (``log n``) for a parsimonious model to fit with, AIC (2)
#: for a sieve that follows the spectrum (consistent for AR(infinity) noise, Shibata 1980).
CRITERIA = {"bic": lambda n: np.log(n), "aic": lambda n: 2.0}


def fit_ar(
    acov: Autocovariance | np.ndarray, n: int | None = None, *, max_order: int | None = None, criterion: str = "bic"
) -> ARNoise:
    """Yule-Walker AR fit of order 0 .. ``max_order`` (default: every lag held, at most a tenth of
    the count) of least ``n log s2_p + p penalty`` (:data:`CRITERIA`). ``acov``: an
    :class:`Autocovariance`, or its values with the count ``n``."""
    if isinstance(acov, Autocovariance):
        r, n = acov.values(), acov.n
    else:
        if n is None:
            raise TypeError("fit_ar: values of an autocovariance need their count n")
        r = np.asarray(acov, dtype=float)
    penalty = CRITERIA[criterion](max(n, 2))
    top = r.size - 1 if max_order is None else min(int(max_order), r.size - 1)
    top = min(top, max(0, n // 10 - 1))  # ten series values per coefficient at least
    if not (r[0] > 0 and n > 1):
        return ARNoise(np.zeros(0), float(max(r[0], 0.0)), float(max(r[0], 0.0)))
    best = ARNoise(np.zeros(0), float(r[0]), float(r[0]))
    best_score = n * np.log(r[0])
    for p in range(1, top + 1):
        a = solve_toeplitz(r[:p], r[1 : p + 1])
        s2 = float(r[0] - a @ r[1 : p + 1])
        if not s2 > 0:
            break  # the series is (numerically) predictable: nothing more to learn
        score = n * np.log(s2) + p * penalty
        if score < best_score:
            best, best_score = ARNoise(a, s2, float(r[0])), score
    return best


@dataclass(frozen=True)
class StateNoise:
    """``e[t] = b[t] + g[t] + w[t]``: a random walk (increment variance ``q_rw``, starting at 0), a
    first-order Gauss-Markov process (``g[t] = phi g[t-1] + v[t]``, ``var v = s_gm``) and white noise
    of variance ``r``, per row (:mod:`sizefx.kernels.kalman`)."""

    q_rw: float
    phi: float
    s_gm: float
    r: float
    log_likelihood: float = float("nan")  #: of the residual series it was fitted to
    n: int = 0  #: their rows

    #: the whitened rows have unit variance
    innovation_var: float = 1.0
    order: int = 0

    def whiten(self, x: np.ndarray) -> np.ndarray:
        """Each row's innovation over its standard deviation, along axis 0 (no row dropped)."""
        from .kernels.kalman import whiten_state

        x = np.asarray(x, dtype=float)
        flat = x.reshape(x.shape[0], -1)
        out, _ = whiten_state(np.ascontiguousarray(flat), self.q_rw, self.phi, self.s_gm, self.r, 0.0)
        return out.reshape(x.shape)

    def variance(self) -> float:
        """The stationary part's variance per row (the walk has none)."""
        return self.r + (self.s_gm / (1.0 - self.phi**2) if self.phi < 1.0 else 0.0)

    def variance_ratio(self) -> float:
        """The stationary part's long-run variance over its variance (as :meth:`ARNoise.variance_ratio`;
        the walk, whose long-run variance grows without bound, is reported apart)."""
        v = self.s_gm / (1.0 - self.phi**2) if self.phi < 1.0 else 0.0
        total = self.r + v
        return (self.r + v * (1.0 + self.phi) / (1.0 - self.phi)) / total if total > 0 and self.phi < 1.0 else 1.0


@dataclass(frozen=True)
class ChainedNoise:
    """A :class:`StateNoise` followed by an :class:`ARNoise` fitted to what it leaves: the state model
    takes the walk and the Gauss-Markov part, the AR model any colour left (vibration, the table's
    wobble) and the scale of the innovations (order 0 and variance 1 when the state model is right)."""

    state: StateNoise
    ar: ARNoise

    @property
    def innovation_var(self) -> float:
        return self.ar.innovation_var

    @property
    def order(self) -> int:
        return self.ar.order

    def whiten(self, x: np.ndarray) -> np.ndarray:
        return self.ar.whiten(self.state.whiten(x))

    def variance_ratio(self) -> float:
        return self.state.variance_ratio() * self.ar.variance_ratio()


def whiten_state_slow(x, q_rw, phi, s_gm, r, p0_rw):
    """The textbook Kalman filter with 2x2 matrices: the twin of
    :func:`sizefx.kernels.kalman.whiten_state` (same outputs, for the tests)."""
    x = np.asarray(x, dtype=float)
    F = np.diag([1.0, phi])
    Q = np.diag([q_rw, s_gm])
    H = np.array([1.0, 1.0])
    P = np.diag([p0_rw, s_gm / (1.0 - phi**2) if phi < 1.0 else 0.0])
    state = np.zeros((2, x.shape[1]))
    out = np.empty_like(x)
    log_s = 0.0
    for t in range(x.shape[0]):
        if t > 0:
            state = F @ state
            P = F @ P @ F.T + Q
        S = H @ P @ H + r
        K = P @ H / S
        v = x[t] - H @ state
        out[t] = v / np.sqrt(S)
        state = state + np.outer(K, v)
        P = P - np.outer(K, H @ P)
        log_s += np.log(S)
    return out, log_s


def _state_log_likelihood(series, q_rw, phi, s_gm, r) -> tuple[float, int]:
    """Gaussian log-likelihood of the residual ``series`` under the noise, each series' level free
    (the walk's start diffuse, its first row left out: the diffuse likelihood), and the rows counted."""
    from .kernels.kalman import whiten_state

    ll, n = 0.0, 0
    for e in series:
        diffuse = 1e6 * (float(e @ e) / e.size + r)
        out, log_s = whiten_state(np.ascontiguousarray(e[:, None]), q_rw, phi, s_gm, r, diffuse)
        s0 = diffuse + (s_gm / (1.0 - phi**2) if phi < 1.0 else 0.0) + r
        ll -= 0.5 * (log_s - np.log(s0) + float(out[1:, 0] @ out[1:, 0]) + (e.size - 1) * np.log(2.0 * np.pi))
        n += e.size - 1
    return ll, n


#: Lags of the variogram :func:`fit_state` matches, log-spaced from one row to a fifth of the
#: longest series: a random walk shows at the long lags, the Gauss-Markov part at its correlation
#: time, white noise at one row.
VARIOGRAM_LAGS = 25


def _variogram(series, lags) -> np.ndarray:
    """Half the mean squared difference of the series' values ``k`` rows apart, per lag ``k``,
    pooled over the series (none across them)."""
    out = np.zeros(lags.size)
    for i, k in enumerate(lags):
        num, den = 0.0, 0
        for e in series:
            if e.size > k:
                d = e[k:] - e[:-k]
                num += float(d @ d)
                den += d.size
        out[i] = 0.5 * num / den if den else np.nan
    return out


def fit_state(series) -> StateNoise:
    """:class:`StateNoise` of the residual ``series`` (a list of 1-D arrays, each its own stretch: a
    record's bias window), by matching their variogram: for a walk, a Gauss-Markov process and white
    noise, half the mean squared difference ``k`` rows apart is ``r + v (1 - phi^k) + q k / 2``
    (``v`` the Gauss-Markov part's variance), fitted in relative terms over :data:`VARIOGRAM_LAGS`
    log-spaced lags by bounded least squares from a few starting correlations (a method of moments:
    consistent, and cheap on any length); then the walk's variance, which the variogram sees worst,
    by the Gaussian likelihood with the other parts held (a bounded search over its logarithm)."""
    from scipy.optimize import least_squares

    series = [np.asarray(e, dtype=float) for e in series if np.asarray(e).size > 2]
    longest = max((e.size for e in series), default=0)
    var = float(np.mean(np.concatenate(series) ** 2)) if series else 0.0
    if not var > 0 or longest < 10:
        return StateNoise(0.0, 0.0, 0.0, max(var, 0.0), 0.0, 0)
    lags = np.unique(np.round(np.logspace(0.0, np.log10(max(2.0, longest / 5.0)), VARIOGRAM_LAGS)).astype(int))
    gamma = _variogram(series, lags)
    ok = np.isfinite(gamma) & (gamma > 0)
    lags, gamma = lags[ok], gamma[ok]

    def model(p):
        r, v, phi, q = p
        return r + v * (1.0 - phi**lags) + 0.5 * q * lags

    best = None
    for phi0 in (0.3, 0.8, 0.95, 0.99):
        start = np.array([0.5 * gamma[0], 0.5 * gamma[0], phi0, max(0.0, 2.0 * (gamma[-1] - gamma[0]) / lags[-1])])
        fit = least_squares(
            lambda p: model(p) / gamma - 1.0,
            start,
            bounds=([0.0, 0.0, 0.0, 0.0], [np.inf, np.inf, 0.9999, np.inf]),
        )
        if best is None or fit.cost < best.cost:
            best = fit
    assert best is not None  # four starts were tried
    r, v, phi, q = (float(a) for a in best.x)
    r = max(r, 1e-6 * var)  # some white noise always: the filter divides by it
    s_gm = v * (1.0 - phi**2)
    # the walk's variance is the one the variogram sees worst (its signature lies at lags beyond a
    # fifth of a window, under the white noise's sampling error): its likelihood decides it, the
    # other parts held where the variogram put them
    from scipy.optimize import minimize_scalar

    walk = minimize_scalar(
        lambda lq: -_state_log_likelihood(series, r * 10.0**lq, phi, s_gm, r)[0],
        bounds=(-14.0, -2.0),
        method="bounded",
        options={"xatol": 0.05},
    )
    q_ml = r * 10.0**walk.x
    ll, n = _state_log_likelihood(series, q_ml, phi, s_gm, r)
    ll0, _ = _state_log_likelihood(series, q, phi, s_gm, r)
    if ll0 > ll:
        q_ml, ll = q, ll0
    return StateNoise(float(q_ml), phi, s_gm, r, float(ll), n)


def state_log_likelihood(series, model: StateNoise) -> float:
    """The Gaussian log-likelihood of the residual ``series`` under ``model`` (each series' level free)."""
    series = [np.asarray(e, dtype=float) for e in series if np.asarray(e).size > 2]
    return _state_log_likelihood(series, model.q_rw, model.phi, model.s_gm, model.r)[0]
