"""Not-a-knot cubic spline: 3-channel samples at one set of increasing times onto another.

The spline through knots ``(x_i, Y_i)``, ``i = 0 .. n-1``, is written, as scipy's
``CubicSpline``, by its derivative ``s_i`` at each knot. With ``h_i = x_{i+1} - x_i``
and the chord slopes ``m_i = (Y_{i+1} - Y_i) / h_i``, the continuity of the second
derivative at the inner knots gives the tridiagonal rows (de Boor, *A Practical Guide
to Splines*, ch. IV)

    ``h_i s_{i-1} + 2 (h_{i-1} + h_i) s_i + h_{i-1} s_{i+1} = 3 (h_i m_{i-1} + h_{i-1} m_i)``,

and the not-a-knot ends (a continuous third derivative at ``x_1`` and ``x_{n-2}``) the
first and last rows, written as scipy writes them (``scipy/interpolate/_cubic.py``):

    ``h_1 s_0 + (h_0 + h_1) s_1 = ((h_0 + 2 (h_0 + h_1)) h_1 m_0 + h_0^2 m_1) / (h_0 + h_1)``

and its mirror. Thomas elimination without pivoting is safe here for any increasing
knots: after the first row every multiplier ``u_i = h_{i-1} / p_i`` lies below 1/2 (the
pivots ``p_i`` exceed ``2 h_{i-1} + h_i``), and the last pivot stays positive. Two knots
give the chord, three the parabola (as scipy). On interval ``i`` the spline is
``Y_i + s_i z + c1 z^2 + c0 z^3``, ``z = x - x_i``, with ``t = (s_i + s_{i+1} - 2 m_i) / h_i``,
``c0 = t / h_i`` and ``c1 = (m_i - s_i) / h_i - t`` (scipy's power form, which, unlike
the Hermite basis, stays exact for a straight line extrapolated far); a target lies in
the interval with ``x_i <= target < x_{i+1}``, and beyond the ends the end polynomials
extrapolate (scipy's ``PPoly`` rules).

Two passes: the forward elimination (``u_i`` and the eliminated right-hand sides), then
the back substitution walking down the knots and the (increasing) targets together,
evaluating each target as soon as the two derivatives of its interval are known. The
derivatives are never stored, and each pass reads each row once.

Same results as scipy's ``CubicSpline(x, Y, bc_type="not-a-knot")`` to rounding (a few
1e-16 of the data's scale; tested to 1e-12).

**Increments.** For increments ``y_i`` over ``(x_i, x_{i+1}]`` the spline is that of
their running sum ``Y`` (``Y_0 = 0``, ``Y_{i+1} - Y_i = y_i``). Only differences of Y
are ever formed: ``m_i = y_i / h_i``, and the increment over ``(f_k, f_{k+1}]`` is
``(Y_j - Y_i) + P_j(f_{k+1}) - P_i(f_k)``, with ``P_i = S - Y_i`` on interval i and
``Y_j - Y_i`` the sum of the few increments between the two intervals. Nothing grows
with the record: a 2-hour running sum of velocity increments reaches 7e4 m/s, whose
rounding (1.5e-11 m/s) would be 2e-9 of a 1600 Hz increment, and would differ
between a chunk and the whole record.

**Chunks.** A spline value depends on all the data, but on a sample k rows away only as
``(2 - sqrt(3))^k`` (the Thomas multipliers tend to ``2 - sqrt(3)``, and so do the
entries of the inverse of the tridiagonal matrix away from its diagonal): 1e-37 at 64
rows, far below rounding. So the spline of a chunk read with 64 extra rows on each side
equals, inside, that of the whole record (:data:`sizefx.navigate.config.MARGIN`). A
carried state would not remove the look-ahead (a spline is not causal), and the 64 rows
behind cost 1/8000 of a 2^20-row chunk, so each chunk is solved whole.
"""

from __future__ import annotations

import numpy as np

from .jit import kernel

__all__ = ["resample", "resample_increments", "median_step"]


@kernel
def _forward(x, y, increments, inv_h, u, d):
    """Forward elimination for knots ``x [n]`` (n >= 4) and values ``y [n, 3]`` (or increments
    ``y [n - 1, 3]``): writes the multipliers ``u [n]`` and the eliminated right-hand sides
    ``d [n, 3]``, so that ``s_{n-1} = d_{n-1}`` and ``s_i = d_i - u_i s_{i+1}``.

    Returns -1, or the first i whose ``h_i`` is not positive and finite (then stops).
    """
    n = x.shape[0]
    h0, h1 = x[1] - x[0], x[2] - x[1]
    if not (0.0 < h0 < np.inf):
        return 0
    if not (0.0 < h1 < np.inf):
        return 1
    ih0, ih1 = 1.0 / h0, 1.0 / h1
    inv_h[0] = ih0
    if increments:
        m0a, m0b, m0c = y[0, 0] * ih0, y[0, 1] * ih0, y[0, 2] * ih0
        m1a, m1b, m1c = y[1, 0] * ih1, y[1, 1] * ih1, y[1, 2] * ih1
    else:
        m0a, m0b, m0c = (y[1, 0] - y[0, 0]) * ih0, (y[1, 1] - y[0, 1]) * ih0, (y[1, 2] - y[0, 2]) * ih0
        m1a, m1b, m1c = (y[2, 0] - y[1, 0]) * ih1, (y[2, 1] - y[1, 1]) * ih1, (y[2, 2] - y[1, 2]) * ih1
    span = h0 + h1
    u[0] = span / h1
    w0, w1 = (h0 + 2.0 * span) * h1, h0 * h0
    d[0, 0] = (w0 * m0a + w1 * m1a) / span / h1
    d[0, 1] = (w0 * m0b + w1 * m1b) / span / h1
    d[0, 2] = (w0 * m0c + w1 * m1c) / span / h1
    # rows 1 .. n-2: (pa, pb, pc) are the chords m_{i-1}, (qa, qb, qc) the chords m_i
    pa, pb, pc = m0a, m0b, m0c
    qa = qb = qc = 0.0
    h_prev = h0
    da, db, dc = d[0, 0], d[0, 1], d[0, 2]
    inv_p = 1.0 / h1  # u_0 = (h_0 + h_1) / p_0 with p_0 = h_1
    hp_prev = span  # the upper entry of row i - 1 (u_{i-1} = hp_prev * inv_p)
    for i in range(1, n - 1):
        h = x[i + 1] - x[i]
        if not (0.0 < h < np.inf):
            return i
        ih = 1.0 / h
        inv_h[i] = ih
        if increments:
            qa, qb, qc = y[i, 0] * ih, y[i, 1] * ih, y[i, 2] * ih
        else:
            qa, qb, qc = (y[i + 1, 0] - y[i, 0]) * ih, (y[i + 1, 1] - y[i, 1]) * ih, (y[i + 1, 2] - y[i, 2]) * ih
        # carry 1/p, not u = h_prev / p: one multiplication less on the loop's critical path
        inv_p = 1.0 / (2.0 * (h_prev + h) - (h * hp_prev) * inv_p)
        u[i] = h_prev * inv_p
        da = (3.0 * (h * pa + h_prev * qa) - h * da) * inv_p
        db = (3.0 * (h * pb + h_prev * qb) - h * db) * inv_p
        dc = (3.0 * (h * pc + h_prev * qc) - h * dc) * inv_p
        d[i, 0], d[i, 1], d[i, 2] = da, db, dc
        hp_prev = h_prev
        if i < n - 2:  # the last row needs m_{n-3} and m_{n-2} as they stand after i = n-2
            pa, pb, pc = qa, qb, qc
            h_prev = h
    ha, hb = h_prev, x[n - 1] - x[n - 2]
    span = ha + hb
    p = ha - span * u[n - 2]
    w0, w1 = hb * hb, (2.0 * span + hb) * ha
    d[n - 1, 0] = ((w0 * pa + w1 * qa) / span - span * da) / p
    d[n - 1, 1] = ((w0 * pb + w1 * qb) / span - span * db) / p
    d[n - 1, 2] = ((w0 * pc + w1 * qc) / span - span * dc) / p
    u[n - 1] = 0.0
    return -1


@kernel
def _solve(x, y, increments, inv_h, u, d):
    """:func:`_forward`, and for two knots the chord, for three the parabola (scipy's special
    cases), written as ``u = 0``, ``d = s``."""
    n = x.shape[0]
    if n >= 4:
        return _forward(x, y, increments, inv_h, u, d)
    for i in range(n - 1):
        if not (0.0 < x[i + 1] - x[i] < np.inf):
            return i
        inv_h[i] = 1.0 / (x[i + 1] - x[i])
    for c in range(3):
        m0 = (y[0, c] if increments else y[1, c] - y[0, c]) / (x[1] - x[0])
        if n == 2:
            d[0, c] = d[1, c] = m0
            continue
        m1 = (y[1, c] if increments else y[2, c] - y[1, c]) / (x[2] - x[1])
        mid = ((x[2] - x[1]) * m0 + (x[1] - x[0]) * m1) / (x[2] - x[0])
        d[0, c], d[1, c], d[2, c] = 2.0 * m0 - mid, mid, 2.0 * m1 - mid
    for i in range(n):
        u[i] = 0.0
    return -1


@kernel
def resample(x, y, t, inv_h, u, d, out):
    """``out[k] = S(t_k)``, S the not-a-knot spline through ``(x_i, y_i)``.

    Parameters
    ----------
    x : float64 [n], strictly increasing finite knots, n >= 2.
    y : float64 [n, 3], C-contiguous, the values at the knots.
    t : float64 [K], finite, non-decreasing targets.
    inv_h [n - 1], u [n], d [n, 3] : float64 scratch.
    out : float64 [K, 3], written.

    Returns
    -------
    (int, int)
        The first interval where ``x`` fails to increase, and a target that is not finite
        or earlier than the one before it, each -1 if none; on either, ``out`` is left
        incomplete.
    """
    n = x.shape[0]
    bad = _solve(x, y, False, inv_h, u, d)
    if bad >= 0:
        return bad, -1
    k = t.shape[0] - 1
    t_next = np.inf
    sa, sb, sc = d[n - 1, 0], d[n - 1, 1], d[n - 1, 2]  # s_{i+1}
    for i in range(n - 2, -1, -1):
        ui = u[i]
        ra, rb, rc = d[i, 0] - ui * sa, d[i, 1] - ui * sb, d[i, 2] - ui * sc  # s_i
        xi = x[i]
        if k >= 0 and (t[k] >= xi or i == 0):
            ih = inv_h[i]
            ma, mb, mc = (y[i + 1, 0] - y[i, 0]) * ih, (y[i + 1, 1] - y[i, 1]) * ih, (y[i + 1, 2] - y[i, 2]) * ih
            ta, tb, tc = (ra + sa - 2.0 * ma) * ih, (rb + sb - 2.0 * mb) * ih, (rc + sc - 2.0 * mc) * ih
            a0, b0, c0 = ta * ih, tb * ih, tc * ih
            a1, b1, c1 = (ma - ra) * ih - ta, (mb - rb) * ih - tb, (mc - rc) * ih - tc
            while k >= 0 and (t[k] >= xi or i == 0):
                tk = t[k]
                if not abs(tk) < np.inf:
                    return -1, k
                if not tk <= t_next:  # walking down: the row above goes back in time
                    return -1, k + 1
                z = tk - xi
                out[k, 0] = y[i, 0] + ((a0 * z + a1) * z + ra) * z
                out[k, 1] = y[i, 1] + ((b0 * z + b1) * z + rb) * z
                out[k, 2] = y[i, 2] + ((c0 * z + c1) * z + rc) * z
                t_next = tk
                k -= 1
        sa, sb, sc = ra, rb, rc
    return -1, -1


@kernel
def resample_increments(x, y, f, inv_h, u, d, out):
    """``out[k] = S(f_{k+1}) - S(f_k)``, S the not-a-knot spline of the running sum of the
    increments ``y [n - 1, 3]`` over the intervals between the knots ``x [n]``.

    ``f [K + 1]``: finite, non-decreasing target edges; ``out [K, 3]``; scratch ``inv_h [n - 1]``,
    ``u [n]``, ``d [n, 3]``. Returns as :func:`resample`. See the module docstring for how the running
    sum is avoided.
    """
    n = x.shape[0]
    bad = _solve(x, y, True, inv_h, u, d)
    if bad >= 0:
        return bad, -1
    k = f.shape[0] - 1
    f_next = np.inf
    sa, sb, sc = d[n - 1, 0], d[n - 1, 1], d[n - 1, 2]
    ya = yb = yc = 0.0  # Y at the interval of the edge above, less Y at the current interval
    na = nb = nc = 0.0  # P of the edge above in its interval
    for i in range(n - 2, -1, -1):
        if i < n - 2:  # down across knot i + 1: Y_{i+1} - Y_i
            ya += y[i, 0]
            yb += y[i, 1]
            yc += y[i, 2]
        ui = u[i]
        ra, rb, rc = d[i, 0] - ui * sa, d[i, 1] - ui * sb, d[i, 2] - ui * sc
        xi = x[i]
        if k >= 0 and (f[k] >= xi or i == 0):
            ih = inv_h[i]
            ma, mb, mc = y[i, 0] * ih, y[i, 1] * ih, y[i, 2] * ih
            ta, tb, tc = (ra + sa - 2.0 * ma) * ih, (rb + sb - 2.0 * mb) * ih, (rc + sc - 2.0 * mc) * ih
            a0, b0, c0 = ta * ih, tb * ih, tc * ih
            a1, b1, c1 = (ma - ra) * ih - ta, (mb - rb) * ih - tb, (mc - rc) * ih - tc
            while k >= 0 and (f[k] >= xi or i == 0):
                fk = f[k]
                if not abs(fk) < np.inf:
                    return -1, k
                if not fk <= f_next:  # walking down: the row above goes back in time
                    return -1, k + 1
                z = fk - xi
                pa = ((a0 * z + a1) * z + ra) * z
                pb = ((b0 * z + b1) * z + rb) * z
                pc = ((c0 * z + c1) * z + rc) * z
                if k < f.shape[0] - 1:
                    out[k, 0] = ya + (na - pa)
                    out[k, 1] = yb + (nb - pb)
                    out[k, 2] = yc + (nc - pc)
                na, nb, nc = pa, pb, pc
                ya = yb = yc = 0.0
                f_next = fk
                k -= 1
        sa, sb, sc = ra, rb, rc
    return -1, -1


#: Steps sampled to bracket the median in :func:`median_step` (in MEDIAN_BLOCKS runs), and
#: the half-width of the bracket in sample ranks: four standard deviations of the sample
#: median's rank (``sqrt(S) / 2 = 64``) for independent steps, so that the bracket rarely
#: misses the median (then the full selection runs; the result is the same either way).
MEDIAN_SAMPLE = 16384
MEDIAN_BRACKET = 256
MEDIAN_BLOCKS = 16


@kernel
def _select(d, k):
    """The k-th smallest of ``d`` (0-based), by Hoare's selection in place (``d`` is reordered;
    afterwards ``d[:k]`` holds no element above it). A small loop instead of ``np.partition``,
    whose Numba implementation takes several times longer to compile than this module."""
    lo, hi = 0, d.shape[0] - 1
    while lo < hi:
        mid = (lo + hi) // 2  # median of three as the pivot: sorted or constant runs stay linear
        a, b, c = d[lo], d[mid], d[hi]
        pivot = b if (a <= b <= c or c <= b <= a) else (a if (b <= a <= c or c <= a <= b) else c)
        i, j = lo, hi
        while i <= j:
            while d[i] < pivot:
                i += 1
            while d[j] > pivot:
                j -= 1
            if i <= j:
                d[i], d[j] = d[j], d[i]
                i += 1
                j -= 1
        if k <= j:
            hi = j
        elif k >= i:
            lo = i
        else:
            return d[k]
    return d[k]


@kernel
def _largest(d):
    best = d[0]
    for i in range(1, d.shape[0]):
        best = max(best, d[i])
    return best


@kernel
def _median_of(d):
    """``np.median(d)``: the middle element, or the mean of the two middle ones (as numpy,
    ``(a + b) / 2``). ``d`` is reordered."""
    m = d.shape[0]
    r2 = m // 2
    upper = _select(d, r2)
    if m % 2 == 1:
        return upper
    return (_largest(d[:r2]) + upper) / 2.0


@kernel
def median_step(t):
    """``np.median(np.diff(t))`` for ``t [n]`` (n >= 2), exactly, without sorting all the steps.

    A sample of the steps gives a bracket ``[lo, hi]`` that holds the median's ranks
    (checked by counting); only the steps inside it (about 3 %) are selected from. A NaN
    step gives NaN, as numpy.
    """
    m = t.shape[0] - 1
    if m <= 4 * MEDIAN_SAMPLE:
        d = np.empty(m)
        nans = 0
        for i in range(m):
            d[i] = t[i + 1] - t[i]
            nans += d[i] != d[i]
        return np.nan if nans else _median_of(d)
    # the sample: MEDIAN_BLOCKS runs of consecutive steps spread over the record (a strided
    # sample would miss the cache at every step)
    run = MEDIAN_SAMPLE // MEDIAN_BLOCKS
    stride = (m - run) // (MEDIAN_BLOCKS - 1)
    sample = np.empty(MEDIAN_SAMPLE)
    for b in range(MEDIAN_BLOCKS):
        for j in range(run):
            i = b * stride + j
            sample[b * run + j] = t[i + 1] - t[i]
    hi = _select(sample, MEDIAN_SAMPLE // 2 + MEDIAN_BRACKET)
    lo = _select(sample[: MEDIAN_SAMPLE // 2 + MEDIAN_BRACKET], MEDIAN_SAMPLE // 2 - MEDIAN_BRACKET)
    # One pass: count the steps below the bracket and keep those inside. A step falls either
    # side of the bracket's middle at random, so that count adds a comparison instead of
    # branching on it; the one branch (inside or not: one comparison) is taken for few steps.
    # Inside means |step - mid| <= half, a contiguous run of floats around mid (rounding is
    # monotonic), so the steps outside and below mid are below every step inside.
    mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    d = np.empty(m)  # only the pages of the steps kept are touched
    lower = inside = inside_lower = nans = 0
    if half == 0.0:  # e.g. a grid: count the steps equal to lo, keep none
        for i in range(m):
            step = t[i + 1] - t[i]
            lower += step < mid
            inside += step == mid
            nans += step != step
        inside_lower = 0
    else:
        for i in range(m):
            step = t[i + 1] - t[i]
            lower += step < mid
            nans += step != step
            if abs(step - mid) <= half:
                d[inside] = step
                inside += 1
                inside_lower += step < mid
    if nans:
        return np.nan  # as np.median
    below = lower - inside_lower
    r1, r2 = (m - 1) // 2, m // 2  # the ranks of the middle steps (equal for odd m)
    if below <= r1 and r2 < below + inside:
        if half == 0.0:
            return mid  # both middle steps equal it, and (x + x) / 2 == x
        b = _select(d[:inside], r2 - below)
        if r1 == r2:
            return b
        return (_largest(d[: r2 - below]) + b) / 2.0  # r2 - below >= 1: the other middle step is inside too
    for i in range(m):  # the bracket missed: select from all the steps
        d[i] = t[i + 1] - t[i]
    return _median_of(d[:m])
