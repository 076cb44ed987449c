"""Spectral lines in a channel's residual: the last test of :func:`sizefx.diagnose.structure.unexplained`.

The Welch spectrum (Hann window, 50 % overlap, constant detrend, segments
of :data:`WELCH_MIN_SEGMENTS` or more per record, inside runs) of what remains after the
correlations. Each bin's power is compared with the median of its neighbours (at most
:data:`FLOOR_HALF_BINS` on each side, symmetric so that the median of a monotone spectrum,
1/f or 1/f^2, is the spectrum at the bin itself; :data:`GUARD_BINS` on each side left out for
the window's main lobe), corrected for the median's bias. The ratio is an F variable with
Welch's equivalent degrees of freedom ``nu`` (``2 K`` corrected for the overlap, Percival &
Walden 1993, eq. 292b) over those of the floor (``nu`` times the neighbours, times 2/pi for a
median, times 1/2 for the correlation of adjacent bins): nearly the chi-square test of
``nu P / floor``, with the floor's own scatter allowed for. Bonferroni over all tested bins
(bins with fewer than :data:`MIN_FLOOR_BINS` neighbours are not tested: the lowest few
frequencies belong to the trend test). Adjacent significant bins form one line, at the peak,
its frequency interpolated on the log power; a weaker peak within the floor window at less
than :data:`SIDELOBE_FRACTION` of a stronger one is taken for its leakage. ``size`` = the
amplitude ``sqrt(2 sum (P - floor) df)`` over the line's main lobe.

At most :data:`MAX_LINES` lines (the largest) are reported per channel.
"""

from __future__ import annotations

import math

import numpy as np

from .kinds import SIZE_FLOOR

__all__ = [
    "WELCH_MIN_SEGMENTS",
    "WELCH_MAX_NPERSEG",
    "WELCH_MIN_NPERSEG",
    "FLOOR_HALF_BINS",
    "GUARD_BINS",
    "MIN_FLOOR_BINS",
    "SIDELOBE_FRACTION",
    "MAX_LINES",
]

#: Welch: at least this many half-overlapping segments per record (``nu`` about 30 at the least).
WELCH_MIN_SEGMENTS = 16
#: Welch: the longest segment [rows] (0.1 Hz resolution at 1600 Hz; longer adds nothing to the
#: lines of mounts and fixtures, and costs degrees of freedom).
WELCH_MAX_NPERSEG = 16384
#: Welch: the shortest segment [rows]; runs shorter than this are left out of the spectrum.
WELCH_MIN_NPERSEG = 64
#: Neighbours on each side of a bin for its noise floor (a running median).
FLOOR_HALF_BINS = 16
#: Bins on each side of a bin left out of its floor: the Hann window's main lobe is +-2 bins.
GUARD_BINS = 3
#: Fewest neighbours (both sides together) for a bin to be tested.
MIN_FLOOR_BINS = 8
#: A weaker peak within FLOOR_HALF_BINS of a stronger one, under this share of its power, is
#: its leakage (Hann sidelobes: -31 dB at 2.5 bins, falling 18 dB per octave), not a line.
SIDELOBE_FRACTION = 1e-2
#: Lines reported per channel at most (the largest).
MAX_LINES = 5


def _lines(y, runs, dt, sigma, level, max_hz=None):
    """Spectral lines of one channel's residual over its local floor (see the module docstring)."""
    from scipy.stats import f as fisher

    if dt <= 0.0:
        return []
    n_kept = sum(b - a for a, b in runs)
    longest = max((b - a for a, b in runs), default=0)
    nper = 2 ** int(math.floor(math.log2(max(2.0, 2.0 * n_kept / (WELCH_MIN_SEGMENTS + 1)))))
    nper = min(nper, WELCH_MAX_NPERSEG, 2 ** int(math.floor(math.log2(max(longest, 1)))))
    if nper < WELCH_MIN_NPERSEG:
        return []
    step = nper // 2
    starts, per_run = [], []
    for a, b in runs:
        s = list(range(a, b - nper + 1, step))
        starts += s
        if s:
            per_run.append(len(s))
    window = np.hanning(nper + 1)[:-1]  # periodic Hann: exact 50 % overlap-add
    fs = 1.0 / dt
    seg = np.lib.stride_tricks.sliding_window_view(y, nper)[np.array(starts)]
    seg = seg - seg.mean(axis=1, keepdims=True)
    power = np.mean(np.abs(np.fft.rfft(seg * window, axis=1)) ** 2, axis=0) / (fs * np.sum(window**2))
    power[1:-1] *= 2.0  # one-sided
    df = fs / nper
    # Welch's equivalent degrees of freedom: K segments, neighbours correlated by rho1^2
    rho1 = float(np.sum(window[:-step] * window[step:]) / np.sum(window**2))
    k_total = sum(per_run)
    var = sum(k**2 * (1.0 + 2.0 * (1.0 - 1.0 / k) * rho1**2) / k for k in per_run) / k_total**2
    nu = 2.0 / var
    median_bias = (1.0 - 2.0 / (9.0 * nu)) ** 3  # median of chi2(nu) / nu (Wilson-Hilferty)
    n_bins = power.size
    floor, n_nb = _floor(power)
    floor /= median_bias
    tested = np.isfinite(floor) & (floor > 0.0)
    if max_hz is not None:
        tested &= np.arange(n_bins) * df <= max_hz
    n_tests = int(tested.sum())
    if n_tests == 0:
        return []
    ratio = np.where(tested, power / np.where(tested, floor, 1.0), 0.0)
    nu_floor = nu * n_nb * (2.0 / math.pi) * 0.5
    p = np.ones(n_bins)
    p[tested] = fisher.sf(ratio[tested], nu, nu_floor[tested])
    p_adj = np.minimum(1.0, p * n_tests)
    sig = np.flatnonzero(p_adj <= level)
    if sig.size == 0:
        return []
    groups = np.split(sig, np.flatnonzero(np.diff(sig) > GUARD_BINS) + 1)
    peaks = sorted((int(g[np.argmax(power[g])]) for g in groups), key=lambda k: -power[k])
    lines: list[int] = []
    for k in peaks:
        if any(abs(k - q) <= FLOOR_HALF_BINS and power[k] < SIDELOBE_FRACTION * power[q] for q in lines):
            continue  # leakage of a stronger line
        lines.append(k)
    found = []
    for k in lines:
        lo, hi = max(1, k - GUARD_BINS + 1), min(n_bins - 1, k + GUARD_BINS)
        amplitude = math.sqrt(2.0 * max(0.0, float(np.sum(power[lo:hi] - floor[k]))) * df)
        if amplitude / math.sqrt(2.0) < SIZE_FLOOR * sigma:
            continue
        found.append(
            {
                "kind": "spectral_line",
                "frequency_hz": _peak_hz(power, k, df),
                "regressor": None,
                "size": amplitude,
                "statistic": float(ratio[k]),
                "p_value": float(p_adj[k]),
            }
        )
    return sorted(found, key=lambda f: -f["size"])[:MAX_LINES]


def _floor(power):
    """Per bin: the median of its neighbours (symmetric, guard bins left out, never the DC or Nyquist
    bin) and their number; NaN where fewer than MIN_FLOOR_BINS neighbours exist."""
    n_bins = power.size
    floor = np.full(n_bins, np.nan)
    n_nb = np.zeros(n_bins, dtype=int)
    for h in range(GUARD_BINS + (MIN_FLOOR_BINS + 1) // 2, FLOOR_HALF_BINS + 1):
        # bins whose half-width is h: the two edges for h < FLOOR_HALF_BINS, the interior for h = FLOOR_HALF_BINS
        k = np.arange(1, n_bins - 1)
        k = k[np.minimum(np.minimum(k - 1, n_bins - 2 - k), FLOOR_HALF_BINS) == h]
        if k.size == 0:
            continue
        offsets = np.concatenate((np.arange(-h, -GUARD_BINS), np.arange(GUARD_BINS + 1, h + 1)))
        floor[k] = np.median(power[k[:, None] + offsets[None, :]], axis=1)
        n_nb[k] = offsets.size
    return floor, n_nb


def _peak_hz(power, k, df):
    """The peak's frequency, by a parabola through the log power of bins k-1, k, k+1."""
    if 1 <= k < power.size - 1 and np.all(power[k - 1 : k + 2] > 0.0):
        a, b, c = np.log(power[k - 1 : k + 2])
        den = a - 2.0 * b + c
        shift = 0.5 * (a - c) / den if den < 0.0 else 0.0
        return float((k + max(-0.5, min(0.5, shift))) * df)
    return float(k * df)
