"""Whitening by a Kalman filter: rows whose noise is a bias random walk, a Gauss-Markov process and
white noise (:class:`sizefx.noise_model.StateNoise`).

The noise of each row is ``b[t] + g[t] + w[t]``: ``b`` a random walk (increments of variance
``q_rw``; it starts at 0 when a bias parameter of the fit carries its level), ``g`` a first-order
Gauss-Markov process (``g[t] = phi g[t-1] + v[t]``, ``v`` of variance ``s_gm``, started from its
stationary variance) and ``w`` white of variance ``r``. The filter's gains do not depend on the
data, so one pass whitens the data and every column of the design alike: each row is replaced by
its innovation over the innovation's standard deviation, ``v[t] / sqrt(S[t])``. Least squares on
the whitened rows is the generalised least squares under that noise (and the sum of ``log S[t]``
and of the squared whitened rows its Gaussian likelihood).

The NumPy twin, :func:`sizefx.noise_model.whiten_state_slow`, runs the textbook filter with 2x2
matrices (``tests/test_noise_model.py`` holds the two together).
"""

from __future__ import annotations

import math

import numpy as np

from .jit import kernel

__all__ = ["whiten_state"]


@kernel
def whiten_state(x, q_rw, phi, s_gm, r, p0_rw):
    """``(x whitened [n, m], sum of log S [t])`` for the columns of ``x`` [n, m] under the noise above;
    ``p0_rw``: the walk's variance at the first row (0 when a bias parameter carries its level,
    large for a level left free: the diffuse start of a likelihood)."""
    n, m = x.shape
    out = np.empty((n, m))
    b = np.zeros(m)
    g = np.zeros(m)
    p00 = p0_rw
    p01 = 0.0
    p11 = s_gm / (1.0 - phi * phi) if phi < 1.0 else 0.0
    log_s = 0.0
    for t in range(n):
        if t > 0:  # predict: b stays, g decays; their variances grow by q_rw and s_gm
            p00 += q_rw
            p01 *= phi
            p11 = phi * phi * p11 + s_gm
            for j in range(m):
                g[j] *= phi
        s = p00 + 2.0 * p01 + p11 + r
        k0 = (p00 + p01) / s
        k1 = (p01 + p11) / s
        root = math.sqrt(s)
        for j in range(m):
            v = x[t, j] - b[j] - g[j]
            out[t, j] = v / root
            b[j] += k0 * v
            g[j] += k1 * v
        h0 = p00 + p01
        h1 = p01 + p11
        p00 -= k0 * h0
        p01 -= k0 * h1
        p11 -= k1 * h1
        log_s += math.log(s)
    return out, log_s
