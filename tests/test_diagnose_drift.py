"""The walk of a bias (sizefx.diagnose.drift): its series, its measure and its share of the estimates' covariance."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from sizefx.diagnose import drift as D


def test_the_sine_series_holds_the_walks_variance():
    """Brownian motion of intensity q has variance q t; the series' first TERMS terms hold
    sum_k 2T/((k-1/2) pi)^2 sin^2(...) of it: 97.5 % at the span's end, zero at its start."""
    span = 300.0
    t = np.array([0.0, 75.0, 150.0, 300.0])
    var = (D.basis(t, 0.0, span) ** 2) @ D.prior_variances(span)
    assert var[0] == 0.0
    # the tail beyond TERMS terms holds under 3 % of the variance at the end, more in the middle (the
    # high terms' sines peak there): 6 % is the bound at t = T/4 for 8 terms
    np.testing.assert_allclose(var[1:], t[1:], rtol=0.06)
    assert var[-1] == pytest.approx(0.975 * span, rel=0.002)


def _equations(rng, q, m=600, span=120.0, white=0.5):
    """A small regression with a walk: the normal equations of H (a constant, a slow sine and a
    fast one) and of the walk's basis, as sizefx.diagnose.normal.normal_equations sums them."""
    t = np.linspace(0.0, span, m)
    H = np.column_stack([np.ones(m), np.sin(2 * np.pi * t / 90.0), np.sin(2 * np.pi * t / 2.0)])
    Z = D.basis(t, 0.0, span)
    walk = np.concatenate([[0.0], np.cumsum(rng.normal(size=m - 1))]) * np.sqrt(q * span / (m - 1))
    y = H @ np.array([0.3, -0.2, 0.1]) + walk + rng.normal(size=m) * white
    W = 1.0 / white**2
    return H, Z, y, W * H.T @ H, W * H.T @ y, W * H.T @ Z, W * Z.T @ Z, W * Z.T @ y


def test_the_walks_intensity_is_measured_beside_the_model():
    """Over 40 draws, the maximum-likelihood intensity's median is within 35 % of the drawn one
    (one record holds about 8 coefficients' worth of the walk: a single draw scatters by a factor
    of two); with no walk, most draws measure none and the rest little."""
    found, none = [], []
    for seed in range(40):
        for q, out in ((0.02, found), (0.0, none)):
            _, _, _, N, b, NU, UU, bU = _equations(np.random.default_rng(seed + (1000 if q == 0 else 0)), q)
            out.append(D.intensity(N, b, {0: NU}, {0: UU}, {0: bU}, [0], 0.0, 120.0).q[0])
    assert np.median(found) == pytest.approx(0.02, rel=0.35)
    assert np.mean(np.array(none) == 0.0) >= 0.5
    assert np.median(none) < 0.002


def test_the_walks_part_is_the_estimates_scatter_under_a_walk():
    """Least squares under white noise and a true walk (a cumulative sum, not the series): over 400
    draws, the estimates scatter as N^-1 plus the walk's part, within the 10 % the draws allow
    (sqrt(2/400) = 7 % per variance); the fast regressor's error takes little from the walk."""
    q = 0.02
    est = []
    for seed in range(400):
        H, Z, y, N, b, NU, UU, bU = _equations(np.random.default_rng(seed), q)
        est.append(np.linalg.solve(N, b))
    inv = np.linalg.inv(N)
    walk = D.walk_covariance(D.Drift(np.array([q, 0, 0, 0, 0, 0]), 0.0, 120.0, {0: NU}), [0, 1, 2], inv)
    predicted = np.diag(inv + walk)
    np.testing.assert_allclose(np.var(est, axis=0), predicted, rtol=0.15)
    assert np.diag(walk)[0] > 10 * np.diag(inv)[0]  # the constant is the walk's own
    assert np.diag(walk)[2] < 0.15 * np.diag(inv)[2]  # a sine of 60 periods leaks little onto the slow basis
    assert D.walk_covariance(D.NO_DRIFT, [0, 1, 2], inv) is None


# long tier: a diagnosis (1.1 s); fast twin: test_the_walks_intensity_is_measured_beside_the_model
@pytest.mark.slow
def test_diagnose_measures_an_accelerometer_bias_walk():
    """A one-minute tumble with a bias walk of 300 ug/sqrt(h) on the accelerometers: diagnose reports
    each accelerometer's walk within a factor of 4. One record holds about 8 coefficients' worth of
    a walk, fewer beside the parameters fitted with them, so that the measure scatters: seeds 4, 5
    and 6 gave 76-361 ug/sqrt(h). A walk ten times too small or large, or none, fails."""
    from sizefx import diagnose as Dg
    from sizefx import scenarios
    from sizefx.effects import IDEAL, load_effects
    from sizefx.simulate import simulate_in_memory

    walk_ug = 300.0
    fx = load_effects(
        base=IDEAL,
        overrides={
            "lever_arm": {"enabled": True, "preset": "high-precision", "d_y_m": [0.003, 0.0274, -0.002]},
            "accel_noise": {"enabled": True, "bias_rw_ug_per_sqrt_h": walk_ug},
            "gyro_noise": {"enabled": True, "rrw_deg_per_h_per_sqrt_h": 0.0},
        },
    )
    tel = simulate_in_memory(scenarios.tumble(60.0, axes="zyx"), fx, rate_hz=100.0, form="rates", seed=4)
    nominal = Dg.theta_from_model(load_effects(base=IDEAL, overrides={"lever_arm": {"enabled": True}}))
    d = Dg.diagnose(tel, nominal, keep_series=False)
    accel_ug = d.bias_walk[3:] / 9.80665e-6 * 60.0  # m/s^2/sqrt(s) -> ug/sqrt(h)
    assert np.all((accel_ug > walk_ug / 4) & (accel_ug < walk_ug * 4)), accel_ug
    assert "lever_arm" in {e.id for e in d.effects}


def test_the_report_gives_the_walk_in_a_data_sheets_units():
    """rad/s/sqrt(s) and m/s^2/sqrt(s) inside; deg/h/sqrt(h) and ug/sqrt(h) in the text, channels
    that do not walk left out, flicker named."""
    from sizefx.diagnose.report import _walk_words

    walk = np.zeros(6)
    walk[1] = 0.19 * np.pi / 180 / 3600 / 60  # 0.19 deg/h/sqrt(h)
    walk[5] = 15.3 * 9.80665e-6 / 60  # 15.3 ug/sqrt(h)
    slope = np.full(6, 2.0)
    assert _walk_words(walk, slope) == "gyro_y 0.19 deg/h/sqrt(h), accel_z 15.3 ug/sqrt(h)"
    slope[5] = 1.0
    assert _walk_words(walk, slope) == "gyro_y 0.19 deg/h/sqrt(h), accel_z 15.3 ug/sqrt(h) (flicker)"
    assert _walk_words(np.zeros(6), slope) == ""


def _flicker(rng, m: int) -> np.ndarray:
    """Unit-scale 1/f noise of m samples: white noise shaped by f^-1/2 in amplitude."""
    spec = np.fft.rfft(rng.normal(size=2 * m))
    f = np.arange(spec.size, dtype=float)
    spec[1:] /= np.sqrt(f[1:])
    spec[0] = 0.0
    return np.fft.irfft(spec, n=2 * m)[:m] * np.sqrt(m)


def test_the_slope_of_the_slow_noise_tells_flicker_from_a_walk():
    """A walk's coefficients fall as (k - 1/2)^-2, flicker's as (k - 1/2)^-1: over 30 draws of each,
    most walks are read as walks and most flicker as flicker (sizefx.diagnose.drift.SLOPES). Flicker read as a walk would put
    several times its power into the slowest term, which the slowest regressors take up."""
    slopes = {"walk": [], "flicker": []}
    for seed in range(30):
        rng = np.random.default_rng(seed)
        _, _, y0, N, b, NU, UU, bU = _equations(rng, 0.05)
        slopes["walk"].append(D.intensity(N, b, {0: NU}, {0: UU}, {0: bU}, [0], 0.0, 120.0).slope[0])
        H, Z, _, N, _, NU, UU, _ = _equations(rng, 0.0)
        y = H @ np.array([0.3, -0.2, 0.1]) + 0.5 * rng.normal(size=H.shape[0]) + 0.2 * _flicker(rng, H.shape[0])
        W = 1.0 / 0.5**2
        d = D.intensity(N, W * H.T @ y, {0: NU}, {0: UU}, {0: W * Z.T @ y}, [0], 0.0, 120.0)
        if d.q[0] > 0:
            slopes["flicker"].append(d.slope[0])
    # eight coefficients tell the two slopes apart only so far: each is read rightly in at least two
    # draws of three (these seeds: 25 of 30 walks, 21 of 30 flicker series)
    assert np.mean(np.array(slopes["walk"]) == 2.0) >= 2 / 3
    assert len(slopes["flicker"]) >= 20 and np.mean(np.array(slopes["flicker"]) == 1.0) >= 2 / 3


def test_a_channel_read_as_flicker_adds_no_walks_part():
    """Flicker is the spectrum's model's (sizefx.diagnose.spectrum): a channel whose slow noise reads
    as flicker is measured and reported, but adds no walk's part to the errors; one read as a walk does."""
    _, _, _, N, _, NU, _, _ = _equations(np.random.default_rng(2), 0.02)
    inv = np.linalg.inv(N)
    walk = D.Drift(np.array([0.02, 0, 0, 0, 0, 0]), 0.0, 120.0, {0: NU})
    flicker = dataclasses.replace(walk, slope=np.array([1.0, 2, 2, 2, 2, 2]))
    assert walk.walking.tolist() == [True, False, False, False, False, False]
    assert not flicker.walking.any()
    assert D.walk_covariance(walk, [0, 1, 2], inv) is not None
    assert D.walk_covariance(flicker, [0, 1, 2], inv) is None
