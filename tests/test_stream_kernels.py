"""The sync and angular-acceleration kernels: against their NumPy twins
(tests/naive.py) and against the scipy calls they replace, whole and chunk by chunk."""

from __future__ import annotations

from dataclasses import replace

import naive
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.interpolate import CubicSpline
from scipy.signal import savgol_coeffs, savgol_filter

from sizefx.io.telemetry import Telemetry
from sizefx.kernels.sync import MEDIAN_SAMPLE, median_step
from sizefx.navigate.config import MARGIN  # the rows the navigation loop reads on each side of a chunk
from sizefx.omegadot import SAVGOL_WINDOW, savgol, savgol_rows
from sizefx.sync import resample_increments, resample_onto, sync_accelerometers

H = 1 / 1600

#: Spline against scipy and the twin, as a part of the largest |value| (of the running sum for
#: increments, which is what scipy splines and rounds). The three solve the same well-conditioned
#: system (diagonally dominant after its first row) by different eliminations: Thomas, LAPACK's
#: banded LU, a dense LU of the 4(n-1) polynomial coefficients; they differ by a few 1e-16.
SPLINE_REL = 1e-12
#: Targets extrapolated d periods beyond the knots grow like d^3: compared as a part of the
#: largest |result| instead.
#: Savitzky-Golay derivative against scipy and the twin, as a part of ``sum |c_j| max |x|`` (the
#: size of the terms summed, which sets any summation's rounding). scipy's taps come from a
#: least-squares solve on an unscaled Vandermonde matrix and are 4e-14 off ``j / (dt sum i^2)``.
SAVGOL_REL = 1e-12
#: A chunk's spline (with MARGIN rows each side) against the whole record's: the dependence on
#: rows 64 away is (2 - sqrt(3))^64 = 1e-37, so only rounding could differ (observed: nothing).
CHUNK_REL = 1e-15


def _jittered(n, rng, jitter=0.2, offset=0.0):
    return (np.arange(n) + rng.uniform(-jitter, jitter, n)) * H + offset


def _close(a, b, rel, scale=None):
    scale = np.abs(b).max() if scale is None else scale
    np.testing.assert_allclose(a, b, rtol=0, atol=rel * max(scale, 1e-300))


# --------------------------------------------------------------------------- spline (sync)


@pytest.mark.parametrize("n", [4, 5, 7, 120])
def test_spline_matches_its_twin_and_scipy_on_jittered_stamps(n):
    rng = np.random.default_rng(n)
    x = _jittered(n, rng)
    y = rng.standard_normal((n, 3))
    t_grid = np.arange(n) * H
    targets = {
        "later": t_grid + 0.3e-3,
        "earlier": t_grid - 0.3e-3,
        "inside": np.sort(rng.uniform(x[0], x[-1], 3 * n)),
        "knots": x.copy(),
    }
    for t in targets.values():
        ours = resample_onto(y, x, t)
        _close(ours, naive.spline_not_a_knot(x, y, t), SPLINE_REL, np.abs(y).max())
        _close(ours, CubicSpline(x, y, bc_type="not-a-knot")(t), SPLINE_REL, np.abs(y).max())
    far = np.linspace(x[0] - 3 * H, x[-1] + 3 * H, 5 * n)  # extrapolated at both ends
    _close(resample_onto(y, x, far), CubicSpline(x, y)(far), SPLINE_REL)


@pytest.mark.parametrize("n", [2, 3])
def test_two_stamps_give_the_chord_and_three_the_parabola(n):
    rng = np.random.default_rng(2)
    x = _jittered(n, rng)
    y = rng.standard_normal((n, 3))
    t = np.linspace(x[0] - H, x[-1] + H, 9)
    ours = resample_onto(y, x, t)
    _close(ours, CubicSpline(x, y)(t), SPLINE_REL)
    _close(ours, naive.spline_not_a_knot(x, y, t), SPLINE_REL)


def test_a_jittered_50_hz_tone_is_resampled_as_scipy_does():
    rng = np.random.default_rng(50)
    t_gyro = np.arange(8000) * H
    t_accel = _jittered(8000, rng, jitter=0.05, offset=0.3e-3)
    w = 2 * np.pi * 50.0
    accel = np.column_stack([np.sin(w * t_accel), np.cos(w * t_accel), 9.81 + np.sin(w * t_accel + 1.0)])
    ours = resample_onto(accel, t_accel, t_gyro)
    _close(ours, CubicSpline(t_accel, accel)(t_gyro), SPLINE_REL, 9.81)
    # and it is a good resampling: the tone on the gyro stamps to 1e-4 rad
    assert np.abs(ours[100:-100, 0] - np.sin(w * t_gyro[100:-100])).max() < 1e-4


def test_values_of_other_shapes_go_three_channels_at_a_time():
    rng = np.random.default_rng(4)
    x = _jittered(50, rng)
    t = np.arange(50) * H
    for y in (rng.standard_normal(50), rng.standard_normal((50, 5)), rng.standard_normal((50, 2, 3))):
        ours = resample_onto(y, x, t)
        assert ours.shape == (50,) + y.shape[1:]
        _close(ours, CubicSpline(x, y)(t), SPLINE_REL, np.abs(y).max())


@pytest.mark.parametrize("n", [4, 9, 150])
def test_increments_match_their_twin_and_the_scipy_formulation(n):
    rng = np.random.default_rng(10 + n)
    incr = rng.standard_normal((n, 3)) * 1e-3 + [0.0, 0.0, 9.81 * H]  # gravity: the running sum grows
    t_to = (np.arange(n) + 1) * H
    for t_from in (t_to + 0.2e-3, _jittered(n, rng, offset=H), t_to - 0.45e-3):
        ours = resample_increments(incr, t_from, t_to)
        cum_scale = np.abs(np.cumsum(incr, axis=0)).max()
        _close(ours, naive.resample_increments(incr, t_from, t_to), SPLINE_REL, cum_scale)

        def edges(t):
            return np.r_[t[0] - np.median(np.diff(t)), t]

        cum = np.vstack([np.zeros(3), np.cumsum(incr, axis=0)])
        scipy_way = np.diff(CubicSpline(edges(t_from), cum, bc_type="not-a-knot")(edges(t_to)), axis=0)
        _close(ours, scipy_way, SPLINE_REL, cum_scale)
    # coarser targets (several source intervals per target) and a common clock (an exact copy)
    coarse = t_to[::3]
    _close(
        resample_increments(incr, t_to, coarse),
        naive.resample_increments(incr, t_to, coarse),
        SPLINE_REL,
        np.abs(np.cumsum(incr, axis=0)).max(),
    )
    _close(resample_increments(incr, t_to, t_to), incr, SPLINE_REL, np.abs(np.cumsum(incr, axis=0)).max())


@settings(max_examples=25, deadline=None)
@given(n=st.integers(2, 60), seed=st.integers(0, 2**32 - 1), shift=st.floats(-0.9, 0.9))
def test_spline_against_scipy_for_any_short_record(n, seed, shift):
    rng = np.random.default_rng(seed)
    x = _jittered(n, rng, jitter=0.45)
    y = rng.standard_normal((n, 3)) * 10.0 ** rng.uniform(-3, 3)
    t = np.arange(n) * H + shift * H
    _close(resample_onto(y, x, t), CubicSpline(x, y)(t), SPLINE_REL, np.abs(y).max())


def _whole_and_chunked(fn, n, bounds):
    """``fn(lo, hi)`` on the whole record, and on chunks ``[j0, j1)`` read with MARGIN rows each
    side (as sizefx.navigate.loop does), kept inside."""
    whole = fn(0, n)
    parts = []
    for j0, j1 in bounds:
        lo, hi = max(0, j0 - MARGIN), min(n, j1 + MARGIN)
        parts.append(fn(lo, hi)[j0 - lo : j1 - lo])
    return whole, np.concatenate(parts)


@pytest.mark.parametrize("form", ["rates", "increments"])
def test_a_record_synced_chunk_by_chunk_equals_the_whole(form):
    rng = np.random.default_rng(7)
    n = 3000
    t = (np.arange(n) + 1) * H
    ta = _jittered(n, rng, jitter=0.1, offset=H + 0.25e-3)
    y = rng.standard_normal((n, 3)) + [0.0, 0.0, 9.81]
    if form == "increments":
        y = y * H

    def sync(lo, hi):
        f = resample_onto if form == "rates" else resample_increments
        return f(y[lo:hi], ta[lo:hi], t[lo:hi])

    bounds = [(0, 700), (700, 701), (701, 2000), (2000, n)]
    whole, chunked = _whole_and_chunked(sync, n, bounds)
    # Increments: the first interval starts one median period before the first stamp, the median
    # of the stamps given (as before the kernels). A chunk at the record's start has its own median,
    # which moves that start (here by 0.5 us, 0.08 % of a period) and the first rows' increments with it,
    # by (2 - sqrt(3))^k at row k: 1e-15 by row 27.
    first = 32 if form == "increments" else 0
    _close(chunked[first:], whole[first:], CHUNK_REL, np.abs(y).max())


def _scipy_sync(tel, tau):
    """sync_accelerometers as it was before the kernels (scipy), for the comparison."""
    t_accel = (tel.accel_time_s if tel.accel_time_s is not None else tel.time_s) - tau
    if tel.form == "rates":
        return CubicSpline(t_accel, tel.accel_mps2, axis=0, bc_type="not-a-knot")(tel.time_s)

    def edges(t):
        return np.r_[t[0] - np.median(np.diff(t)), t]

    cum = np.vstack([np.zeros(3), np.cumsum(tel.dvel_mps, axis=0)])
    return np.diff(CubicSpline(edges(t_accel), cum, axis=0, bc_type="not-a-knot")(edges(tel.time_s)), axis=0)


@pytest.mark.parametrize("form", ["rates", "increments"])
def test_sync_accelerometers_keeps_its_meaning(form):
    rng = np.random.default_rng(3)
    n = 500
    t = 10.0 + np.arange(n) * H
    g, a = rng.standard_normal((2, n, 3)) * 0.1 + [0.0, 0.0, 9.81]
    tel = (
        Telemetry(time_s=t, form="rates", gyro_rad_s=g, accel_mps2=a)
        if form == "rates"
        else Telemetry(time_s=t, form="increments", dtheta_rad=g * H, dvel_mps=a * H)
    )
    assert sync_accelerometers(tel) is tel  # nothing to do: the same record
    stamped = replace(tel, accel_time_s=t + rng.uniform(0.1, 0.3, n) * H)
    for record, tau in ((tel, 0.5e-3), (stamped, 0.0), (stamped, -0.2e-3)):
        synced = sync_accelerometers(record, tau)
        assert synced.accel_time_s is None and synced.time_s is record.time_s
        ours = synced.accel_mps2 if form == "rates" else synced.dvel_mps
        scale = np.abs(a).max() if form == "rates" else np.abs(np.cumsum(a * H, axis=0)).max()
        _close(ours, _scipy_sync(record, tau), SPLINE_REL, scale)
        untouched = synced.gyro_rad_s if form == "rates" else synced.dtheta_rad
        assert untouched is (record.gyro_rad_s if form == "rates" else record.dtheta_rad)


def test_resampling_refuses_times_that_do_not_increase():
    y = np.zeros((6, 3))
    x = np.arange(6) * H
    bad = x.copy()
    bad[4] = bad[3]
    with pytest.raises(ValueError, match="increase strictly.*row 4"):
        resample_onto(y, bad, x)
    with pytest.raises(ValueError, match="non-decreasing.*row 2"):
        resample_onto(y, x, x[[0, 3, 2]])
    with pytest.raises(ValueError, match="finite"):
        resample_onto(y, x, np.array([0.0, np.nan]))
    with pytest.raises(ValueError, match="same number"):
        resample_onto(y[:5], x, x)
    with pytest.raises(ValueError, match="increase strictly"):
        resample_increments(y, bad, x)


@pytest.mark.parametrize("n", [2, 3, 4, 5, 1001, 4 * MEDIAN_SAMPLE + 2, 4 * MEDIAN_SAMPLE + 3, 90_001])
@pytest.mark.parametrize("kind", ["jittered", "uniform", "two steps", "spread", "rate change"])
def test_median_step_is_numpys_median_of_the_steps(n, kind):
    rng = np.random.default_rng(n)
    steps = {
        "jittered": H + rng.normal(0, 1e-6, n - 1),
        "uniform": np.full(n - 1, H),
        "two steps": rng.choice([H, 2 * H], n - 1),
        "spread": rng.exponential(H, n - 1),
        "rate change": np.linspace(H, 2 * H, n - 1),
    }[kind]
    t = np.r_[0.0, np.cumsum(steps)]
    assert median_step(t) == np.median(np.diff(t))
    t[n // 2] = np.nan
    assert np.isnan(median_step(t))


# --------------------------------------------------------------------------- Savitzky-Golay


def _savgol_scale(x, window, order, dt):
    return np.abs(savgol_coeffs(window, order, deriv=1, delta=dt)).sum() * np.abs(x).max()


@pytest.mark.parametrize("n", [41, 42, 81, 82, 300])
def test_savgol_matches_its_twin_and_scipy(n):
    rng = np.random.default_rng(n)
    x = rng.standard_normal((n, 3)) + [0.0, 1.0, -3.0]
    ours = savgol(x, H)
    scale = _savgol_scale(x, SAVGOL_WINDOW, 2, H)
    _close(ours, naive.savgol_derivative(x, H), SAVGOL_REL, scale)
    _close(ours, savgol_filter(x, SAVGOL_WINDOW, 2, deriv=1, delta=H, axis=0, mode="interp"), SAVGOL_REL, scale)


@pytest.mark.parametrize("window,order", [(5, 2), (7, 1), (21, 3), (21, 4)])
def test_savgol_other_windows_and_orders(window, order):
    rng = np.random.default_rng(window + order)
    x = rng.standard_normal((120, 3))
    ours = savgol(x, H, window=window, order=order)
    scale = _savgol_scale(x, window, order, H)
    _close(ours, naive.savgol_derivative(x, H, window, order), SAVGOL_REL, scale)
    _close(ours, savgol_filter(x, window, order, deriv=1, delta=H, axis=0, mode="interp"), SAVGOL_REL, scale)


def test_savgol_of_a_50_hz_tone_and_of_a_quadratic():
    t = np.arange(4000) * H
    w = 2 * np.pi * 50.0
    x = np.column_stack([np.sin(w * t), np.cos(w * t), 0.3 + 2.0 * t - 5.0 * t**2])
    ours = savgol(x, H)
    _close(
        ours,
        savgol_filter(x, SAVGOL_WINDOW, 2, deriv=1, delta=H, axis=0),
        SAVGOL_REL,
        _savgol_scale(x, SAVGOL_WINDOW, 2, H),
    )
    np.testing.assert_allclose(ours[:, 2], 2.0 - 10.0 * t, rtol=0, atol=1e-9)  # exact for a quadratic, ends too


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(SAVGOL_WINDOW, 400),
    cuts=st.lists(st.floats(0, 1), max_size=4),
    slack=st.integers(0, 5),
    seed=st.integers(0, 2**32 - 1),
)
def test_savgol_chunk_by_chunk_is_the_whole_bit_for_bit(n, cuts, slack, seed):
    x = np.random.default_rng(seed).standard_normal((n, 3))
    whole = savgol(x, H)
    m = SAVGOL_WINDOW // 2
    edges = sorted({0, n, *(int(c * n) for c in cuts)})
    parts = []
    for j0, j1 in zip(edges[:-1], edges[1:]):
        lo, hi = max(0, j0 - m - slack), min(n, j1 + m + slack)
        if j0 < m:
            hi = max(hi, SAVGOL_WINDOW)
        if j1 > n - m:
            lo = min(lo, n - SAVGOL_WINDOW)
        parts.append(savgol_rows(x[lo:hi], lo, n, j0, j1, H))
    np.testing.assert_array_equal(np.concatenate(parts), whole)


def test_savgol_rows_refuses_rows_it_was_not_given():
    x = np.zeros((200, 3))
    savgol_rows(x[80:140], 80, 200, 100, 120, H)  # [80, 140) holds [100 - 20, 120 + 20)
    with pytest.raises(ValueError, match=r"need rows \[80, 140\); given \[81, 140\)"):
        savgol_rows(x[81:140], 81, 200, 100, 120, H)
    with pytest.raises(ValueError, match=r"need rows \[0, 41\)"):
        savgol_rows(x[0:30], 0, 200, 0, 5, H)  # an end row: the whole end window
    with pytest.raises(ValueError, match="needs at least 41"):
        savgol(x[:40], H)
    with pytest.raises(ValueError, match="odd number"):
        savgol(x, H, window=40)
