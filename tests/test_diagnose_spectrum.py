"""The estimates' covariance from the residual's spectrum (``sizefx.diagnose.spectrum``), against
Monte Carlo: least squares on white noise, and on white noise plus a random walk, with a fast and a
slow regressor beside a constant; with the walk's part (``sizefx.diagnose.drift``), each counted once."""

import numpy as np
import pytest
from test_diagnose_drift import _flicker

from sizefx.diagnose.drift import WALK_BINS, basis, intensity, prior_variances, walk_covariance
from sizefx.diagnose.spectrum import BlockNoise, block_covariance, fit_spectrum, haar_splits, levels_for, spectral_meat

BLOCKS, PER_BLOCK, DT = 100, 20, 0.01


def _design():
    n = BLOCKS * PER_BLOCK
    t = np.arange(n) * DT
    fast = np.sin(2 * np.pi * 7.3 * t)  # 7.3 Hz: many cycles per block
    slow = np.where(t < t[-1] / 2, -1.0, 1.0)  # a step half-way: the shape of a turntable's dwell
    return t, np.column_stack([np.ones(n), fast, slow])


def _noise_of(t, H, r):
    """BlockNoise of one channel (channel 0; the others hold nothing), unit weights."""
    B, L = BLOCKS, PER_BLOCK
    P = H.shape[1]
    levels = levels_for(L)
    edges = np.arange(0, B * L + 1, L)
    G = np.zeros((6, B, P))
    G[0] = H.reshape(B, L, P).sum(axis=1)
    D = np.zeros((6, levels, P, P))
    u = np.zeros((6, levels))
    D[0], usum, ucount = haar_splits(H, r, edges, levels)
    u[0] = usum / ucount
    rbar = np.zeros((B, 6))
    rbar[:, 0] = r.reshape(B, L).mean(axis=1)
    return BlockNoise(G, D, u, np.full(B, float(L)), rbar, t[::L].copy(), L * DT)


def test_the_splits_and_the_block_means_span_the_rows():
    """Haar's completeness: the splits' D summed over the levels plus the block means' part is H'H."""
    rng = np.random.default_rng(1)
    H = rng.standard_normal((300, 3))
    edges = np.array([0, 7, 100, 163, 300])  # parts of any length
    D, _, _ = haar_splits(H, rng.standard_normal(300), edges, levels_for(137))
    sums = np.add.reduceat(H, edges[:-1], axis=0)
    means_part = (sums / np.diff(edges)[:, None]).T @ sums
    assert D.sum(axis=0) + means_part == pytest.approx(H.T @ H, rel=1e-12, abs=1e-9)


def _monte_carlo(walk_per_step: float, trials: int = 300):
    t, H = _design()
    rng = np.random.default_rng(7)
    inv = np.linalg.inv(H.T @ H)
    estimates, predicted = [], []
    for _ in range(trials):
        e = rng.standard_normal(t.size) + np.cumsum(walk_per_step * rng.standard_normal(t.size))
        x = inv @ (H.T @ e)
        r = e - H @ x
        estimates.append(x)
        predicted.append(np.diag(inv @ spectral_meat(_noise_of(t, H, r), [0, 1, 2]) @ inv))
    return np.var(estimates, axis=0), np.mean(predicted, axis=0), np.diag(inv)


def test_white_noise_gives_the_white_covariance():
    empirical, predicted, white = _monte_carlo(0.0, trials=200)
    # 200 trials estimate a variance to +-10 % (sqrt(2/200)); the spectrum's fit adds a little
    assert predicted[1:] == pytest.approx(white[1:], rel=0.15)
    assert empirical[1:] == pytest.approx(predicted[1:], rel=0.3)


def test_a_walk_widens_the_slow_regressor_only():
    empirical, predicted, white = _monte_carlo(0.05)
    # the slow step sees the walk: its variance is many times the white one, and predicted
    assert empirical[2] > 5 * white[2]
    assert 0.7 < predicted[2] / empirical[2] < 1.4
    # the fast regressor does not: white within its scatter
    assert 0.7 < predicted[1] / empirical[1] < 1.4
    assert predicted[1] < 1.5 * white[1]


def test_spectrum_fit_tells_white_from_a_walk():
    rng = np.random.default_rng(3)
    A, C, _ = fit_spectrum(rng.standard_normal(200))
    assert C < 0.2 * A
    _, C, shape = fit_spectrum(np.cumsum(rng.standard_normal(200)))
    assert C > 0 and shape[0] == "power" and shape[1] >= 1.5


def test_block_covariance_of_white_noise_is_diagonal():
    rng = np.random.default_rng(5)
    x = rng.standard_normal(100)
    R = block_covariance(x, np.arange(100) * 0.5, 0.5)
    assert np.diag(R) == pytest.approx(np.var(x), rel=0.3)
    assert np.max(np.abs(R - np.diag(np.diag(R)))) < 0.2 * np.var(x)


def test_the_colour_under_the_walks_bins_is_left_out():
    """``above``: the block means' colour under that bin is left to the walk's part, the rest kept.
    A walk's block means put nearly all their power into the slowest bins: a constant across the
    blocks loses it all, blocks alternating in sign keep most of theirs (the record's finite span
    leaks a little of the slow power to every bin); white noise has no colour to leave."""
    rng = np.random.default_rng(11)
    t0 = np.arange(100) * 0.5
    walk = np.cumsum(rng.standard_normal(100)) + 0.3 * rng.standard_normal(100)
    whole, cut = block_covariance(walk, t0, 0.5), block_covariance(walk, t0, 0.5, above=WALK_BINS)
    slow, fast = np.ones(100), (-1.0) ** np.arange(100)
    assert slow @ cut @ slow < 0.01 * (slow @ whole @ slow)
    assert fast @ cut @ fast > 0.5 * (fast @ whole @ fast)
    white = rng.standard_normal(100)
    np.testing.assert_array_equal(block_covariance(white, t0, 0.5, above=WALK_BINS), block_covariance(white, t0, 0.5))


def _fits_with_slow_noise(slow, trials: int = 300):
    """``trials`` least-squares fits of the design above under white noise plus ``slow(rng, n)``:
    per draw the estimates, the residual's block sums (:func:`_noise_of`) and its slow noise
    measured beside the model (``sizefx.diagnose.drift.intensity``); with ``N^-1``, the span and
    the regressors against the walk's basis."""
    t, H = _design()
    rng = np.random.default_rng(7)
    inv = np.linalg.inv(H.T @ H)
    span = float(t[-1] - t[0])
    Z = basis(t, t[0], span)
    draws = []
    for _ in range(trials):
        e = rng.standard_normal(t.size) + slow(rng, t.size)
        x = inv @ (H.T @ e)
        r = e - H @ x
        drift = intensity(H.T @ H, H.T @ r, {0: H.T @ Z}, {0: Z.T @ Z}, {0: Z.T @ r}, [0], t[0], span)
        draws.append((x, _noise_of(t, H, r), drift))
    return draws, inv, span, H.T @ Z


# long tier: 300 least-squares fits with the walk measured (6 s); fast twin:
# test_the_colour_under_the_walks_bins_is_left_out
@pytest.mark.slow
def test_the_walks_part_and_the_spectrum_count_a_walk_once():
    """White noise plus a walk, the step and the 7.3 Hz sine beside a constant: the spectrum's model
    with the colour under the walk's series left out, plus the walk's part (its intensity measured
    beside the model), predicts the scatter of 300 fits (+-8 % per variance); the two summed whole
    count the slow power twice (about 1.6 times the step's scatter)."""
    draws, inv, _, _ = _fits_with_slow_noise(lambda rng, n: np.cumsum(0.05 * rng.standard_normal(n)))
    free = np.arange(inv.shape[0])
    once, twice = [], []
    for _, noise, drift in draws:
        walk = walk_covariance(drift, free, inv)
        walk = np.zeros_like(inv) if walk is None else walk
        above = np.where(drift.walking, WALK_BINS, 0.0)  # as the budget takes it
        once.append(np.diag(inv @ spectral_meat(noise, free, above) @ inv + walk))
        twice.append(np.diag(inv @ spectral_meat(noise, free) @ inv + walk))
    empirical = np.var([x for x, _, _ in draws], axis=0)
    ratio_once, ratio_twice = np.mean(once, axis=0) / empirical, np.mean(twice, axis=0) / empirical
    # the step: within the draws' scatter and the walk's measure (its intensity from 8 terms of one
    # record scatters by a factor of two); the fast sine: white, untouched by either
    assert 0.65 < ratio_once[2] < 1.2
    assert ratio_twice[2] > 1.35
    assert 0.85 < ratio_once[1] < 1.2


# long tier: 300 least-squares fits with the slow noise measured (6 s); fast twin:
# tests/test_diagnose_drift.py::test_a_channel_read_as_flicker_adds_no_walks_part
@pytest.mark.slow
def test_flicker_is_the_spectrums_not_the_walks():
    """White noise plus flicker (1/f from the record's lowest frequency), the design above: over
    the draws whose slow noise reads as flicker (about 6 in 10), the spectrum's model alone
    predicts the step's scatter (about 0.85 of it). A walk's part with the flicker slope would by
    itself predict about 1.5 times that scatter, on top of the spectrum's: flicker counted twice."""
    draws, inv, span, NU = _fits_with_slow_noise(lambda rng, n: 0.3 * _flicker(rng, n))
    free = np.arange(inv.shape[0])
    spectrum, walks = [], []
    for _, noise, drift in draws:
        if drift.q[0] > 0 and not drift.walking[0]:  # read as flicker
            assert walk_covariance(drift, free, inv) is None
            spectrum.append(np.diag(inv @ spectral_meat(noise, free) @ inv))
            A = NU * np.sqrt(drift.q[0] * prior_variances(span, 1.0))[None, :]
            walks.append(np.diag(inv @ A @ A.T @ inv))
    empirical = np.var([x for x, _, _ in draws], axis=0)
    assert len(spectrum) > 100
    assert 0.65 < np.mean(spectrum, axis=0)[2] / empirical[2] < 1.25
    assert np.mean(walks, axis=0)[2] > 1.2 * empirical[2]
