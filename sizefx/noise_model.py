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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import solve_toeplitz
from scipy.signal import lfilter

__all__ = ["Autocovariance", "ARNoise", "fit_ar", "WHITE", "CRITERIA"]


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
