"""Checks of every sample in one pass: a read scaled to SI in place with the first sample that is
not finite and the first beyond the physical limits (:func:`scale_and_check`); the time stamp
farthest from the uniform grid (:func:`worst_grid_offset`).

The telemetry contract (:meth:`sizefx.io.contract.validation.ContractReader.rows`) checks each read this way.
Done with NumPy it took eight passes and three temporaries over each chunk (``isfinite``, ``any``,
the scaling, ``isfinite`` again, two comparisons, their ``or``, ``any``): 44 % of ``sizefx navigate``'s
time on the 1.8 h flight, and memory traffic that two records in parallel share. The
NumPy twin is :func:`sizefx.io.contract.limits.invalid_rows` (``tests/test_contract_kernel.py``). The grid
check took seven NumPy passes; its twin is :func:`sizefx.navigate.steps.grid_offsets_periods`.
"""

from __future__ import annotations

import numpy as np

from .jit import kernel

#: Rows :func:`scale_and_check` judges at a time without branching; a block that holds a bad sample
#: is scanned again sample by sample from its first row (1024 rows of 3 columns: 24 KiB, still in
#: the cache for that second look).
CHECK_BLOCK_ROWS = 1024


@kernel
def scale_and_check(values, factor, low, high):
    """``values [N, C]`` in the file's units -> SI in place (times ``factor [C]``); returns
    ``(first_not_finite, first_beyond)``, flat row-major indices into ``values`` (-1: none).

    ``first_not_finite``: the first sample not finite as read (NaN/Inf in the file; left unscaled).
    ``first_beyond``: the first finite sample whose SI value is not finite (an overflow of the scaling)
    or lies outside ``[low[c], high[c]]`` (``-inf``/``inf`` where a column has no limit).

    A record already in SI (every factor 1, the common case) is judged block by block, each in one
    branch-free pass that the compiler vectorises, and only a block that is not clean is scanned
    sample by sample (:func:`_scan`, from its first row, which finds the first indices). Other
    records take :func:`_scan` from the start, which scales as it goes. On 1 M rows of 3 columns in
    SI: 5.8 ms instead of 9.3 ms for the scan alone; in ``sizefx navigate`` of the 1.8 h flight the
    checks took 0.18 s instead of 0.28 s (cProfile, one thread).
    """
    n, c = values.shape
    unit = True
    for j in range(c):
        if factor[j] != 1.0:
            unit = False
    if not unit:
        return _scan(values, factor, low, high, 0)
    for b0 in range(0, n, CHECK_BLOCK_ROWS):
        if not _block_is_clean(values, low, high, b0, min(n, b0 + CHECK_BLOCK_ROWS)):
            return _scan(values, factor, low, high, b0)
    return -1, -1


@kernel
def _block_is_clean(values, low, high, b0, b1):
    """Whether rows ``b0:b1`` (in SI) hold only finite samples within the limits. ``y - y != 0`` is
    true exactly for NaN and +-Inf."""
    c = values.shape[1]
    bad = False
    for i in range(b0, b1):
        for j in range(c):
            y = values[i, j]
            bad |= (y - y != 0.0) | (y < low[j]) | (y > high[j])
    return not bad


@kernel
def _scan(values, factor, low, high, r0):
    """:func:`scale_and_check` sample by sample from row ``r0`` on (the rows before it are clean)."""
    n, c = values.shape
    first_not_finite = -1
    first_beyond = -1
    for i in range(r0, n):
        for j in range(c):
            x = values[i, j]
            if not np.isfinite(x):
                if first_not_finite < 0:
                    first_not_finite = i * c + j
                continue
            y = x * factor[j]
            values[i, j] = y
            if first_beyond < 0 and (not np.isfinite(y) or y < low[j] or y > high[j]):
                first_beyond = i * c + j
    return first_not_finite, first_beyond


@kernel
def worst_grid_offset(time_s, t_first, dt, first_row):
    """``(row, offset)``: the stamp of ``time_s`` farthest from its point of the uniform grid
    ``t_first + (first_row + k) dt`` and how far [periods, signed] (the first of equals), with the
    formula of :func:`sizefx.navigate.steps.grid_offsets_periods`, so the same numbers."""
    worst = 0
    worst_offset = 0.0
    for k in range(time_s.shape[0]):
        offset = (time_s[k] - (t_first + float(first_row + k) * dt)) / dt
        if abs(offset) > abs(worst_offset) or k == 0:
            worst = k
            worst_offset = offset
    return worst, worst_offset
