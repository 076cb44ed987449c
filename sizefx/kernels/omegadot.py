"""Savitzky-Golay first derivative (angular acceleration from rates), row range by row range.

Inside the record, row ``k`` of the derivative is the centred FIR

    ``d_k = sum_{j=1..m} c_j (x_{k+j} - x_{k-j})``,  window ``W = 2 m + 1``,

with ``c_j`` the antisymmetric half of the least-squares derivative weights (for a
polynomial order of 1 or 2, ``c_j = j / (dt sum_{i=1..m} i^2)``; Savitzky & Golay 1964,
scipy's ``savgol_coeffs``). Within ``m`` rows of a record end the derivative is that of
the polynomial fitted to the first (last) ``W`` rows, at the row's position (scipy's
``savgol_filter(..., mode="interp")``): a fixed ``[m, W]`` weight matrix per end.

A row depends on the rows within ``m`` of it only, always summed in the same order, so
the result for rows ``[j0, j1)`` is the same, bit for bit, however a record is cut into
chunks (``tests/test_stream_kernels.py``). The sum is the direct 41-tap form, not a
running-sum recurrence: no rounding accumulates from row to row and nothing needs
re-anchoring. Run over the flattened ``[rows * channels]`` array, four taps per pass, it
vectorises; ``benchmarks/bench_kernels.py`` measures it against a target of 30 M samples/s (of 3
channels, one core), and against scipy's ``savgol_filter``.
"""

from __future__ import annotations

import numpy as np

from .jit import kernel

__all__ = ["savgol_weights", "savgol_derivative", "BLOCK_ROWS"]

#: Rows per block of the tap sums: the block of input (plus 2 m rows) and of output stays in
#: the L1/L2 cache (2 x 24 KiB at 3 channels) while the taps pass over it.
BLOCK_ROWS = 1024


def savgol_weights(window: int, order: int, dt: float):
    """The derivative weights of a Savitzky-Golay window, divided by ``dt`` [1/s].

    Returns ``(taps [m], head [m, W], tail [m, W])``:

    - ``taps[j - 1]`` multiplies ``x_{k+j} - x_{k-j}`` in the centred derivative at row k;
    - ``head[r]`` maps the first W rows to the derivative at row ``r`` (r < m);
    - ``tail[r]`` maps the last W rows to the derivative at row ``n - m + r``.

    Each is ``D(v) pinv(V)`` with ``V`` the Vandermonde matrix of the window's positions
    ``v = -m .. m`` and ``D(v)`` the derivative of the monomials at position v (least
    squares, as scipy's ``savgol_coeffs`` and ``polyfit``). The monomials are of ``v / m``,
    which keeps ``V`` well conditioned (condition 3 for W = 41, order 2, against 1e3 for
    ``v`` and 1e6 for the positions 0 .. 40) and the weights within a few ulp.
    """
    m = (window - 1) // 2
    v = np.arange(-m, m + 1, dtype=float) / m
    vander = v[:, None] ** np.arange(order + 1)  # [W, order + 1]
    pinv = np.linalg.pinv(vander)  # [order + 1, W]

    def at(pos):
        d = np.zeros((pos.size, order + 1))
        for q in range(1, order + 1):
            d[:, q] = q * (pos / m) ** (q - 1) / m
        return d @ pinv / dt

    centre = at(np.zeros(1))[0]
    taps = 0.5 * (centre[m + 1 :] - centre[m - 1 :: -1])  # exactly antisymmetric
    if order <= 2:  # closed form: c_j = j / (dt sum i^2); the least-squares one agrees to 1e-16
        taps = np.arange(1, m + 1) / (dt * (m * (m + 1) * (2 * m + 1) / 3.0))
    head = at(np.arange(-m, 0, dtype=float))
    tail = at(np.arange(1, m + 1, dtype=float))
    return np.ascontiguousarray(taps), np.ascontiguousarray(head), np.ascontiguousarray(tail)


@kernel
def savgol_derivative(x, row0, n_record, j0, j1, taps, head, tail, out):
    """Savitzky-Golay derivative of record rows ``[j0, j1)`` into ``out [j1 - j0, C]``.

    Parameters
    ----------
    x : float64 [R, C], C-contiguous
        Rows ``[row0, row0 + R)`` of a record of ``n_record`` rows; they must hold rows
        ``[j0 - m, j1 + m]`` clipped to ``[0, n_record)`` (checked by the caller).
    taps, head, tail : from :func:`savgol_weights` (already divided by dt).
    out : float64 [j1 - j0, C], C-contiguous; written, not read.

    Rows below ``m`` use ``head`` on record rows ``0 .. W-1``; rows from ``n_record - m``
    on use ``tail`` on the last W rows; every other row the centred taps.
    """
    m = taps.shape[0]
    w = 2 * m + 1
    n_ch = x.shape[1]
    xf = x.reshape(x.size)
    of = out.reshape(out.size)
    # record ends: the polynomial fitted to the first / last window
    for k in range(j0, j1):
        if k < m:
            for c in range(n_ch):
                acc = 0.0
                for i in range(w):
                    acc += head[k, i] * x[i - row0, c]
                out[k - j0, c] = acc
        elif k >= n_record - m:
            r = k - (n_record - m)
            for c in range(n_ch):
                acc = 0.0
                for i in range(w):
                    acc += tail[r, i] * x[n_record - w + i - row0, c]
                out[k - j0, c] = acc
    # inside: over blocks of the flattened rows, so that the inner loops run over contiguous
    # memory (and vectorise), four taps per pass over the block (fewer loads and stores of the
    # partial sums); each output still sums its taps j = 1 .. m in this one order
    a = max(j0, m)
    b = min(j1, n_record - m)
    for blk in range(a, b, BLOCK_ROWS):
        stop = min(b, blk + BLOCK_ROWS)
        i0 = (blk - row0) * n_ch
        i1 = (stop - row0) * n_ch
        acc = of[(blk - j0) * n_ch : (stop - j0) * n_ch]
        for q in range(i1 - i0):
            acc[q] = 0.0
        j = 1
        while j + 3 <= m:
            c1, c2, c3, c4 = taps[j - 1], taps[j], taps[j + 1], taps[j + 2]
            s1, s2, s3, s4 = j * n_ch, (j + 1) * n_ch, (j + 2) * n_ch, (j + 3) * n_ch
            p1, n1 = xf[i0 + s1 : i1 + s1], xf[i0 - s1 : i1 - s1]
            p2, n2 = xf[i0 + s2 : i1 + s2], xf[i0 - s2 : i1 - s2]
            p3, n3 = xf[i0 + s3 : i1 + s3], xf[i0 - s3 : i1 - s3]
            p4, n4 = xf[i0 + s4 : i1 + s4], xf[i0 - s4 : i1 - s4]
            for q in range(i1 - i0):
                acc[q] = (((acc[q] + c1 * (p1[q] - n1[q])) + c2 * (p2[q] - n2[q])) + c3 * (p3[q] - n3[q])) + c4 * (
                    p4[q] - n4[q]
                )
            j += 4
        while j <= m:
            cj, sj = taps[j - 1], j * n_ch
            pj, nj = xf[i0 + sj : i1 + sj], xf[i0 - sj : i1 - sj]
            for q in range(i1 - i0):
                acc[q] += cj * (pj[q] - nj[q])
            j += 1
