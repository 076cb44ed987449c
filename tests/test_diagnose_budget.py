"""The error budget's estimators (:mod:`sizefx.diagnose.normal`, :mod:`sizefx.diagnose.consistency`):
the long-run sandwich of correlated block scores and the random effect of the record's parts."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import lfilter

from sizefx import diagnose as D
from sizefx.diagnose.consistency import block_consistency
from sizefx.diagnose.normal import Normal, hac_lag, long_run_meat


def _ar1(rng, rho, size):
    return lfilter([1.0], [1.0, -rho], rng.normal(size=size), axis=0)


def test_the_long_run_meat_sees_the_correlation_of_neighbouring_blocks():
    """AR(1) scores with rho = 0.8 over 400 blocks: the plain sum of squares gives 1 / (1 - rho^2) =
    2.8 per block, the long-run variance is 1 / (1 - rho)^2 = 25; over 200 draws the Bartlett
    estimate's mean lies within its known downward bias (Andrews 1991: about 25 % at this length),
    far from the plain sum. White scores keep the plain sum (lag 0 or close to it)."""
    rng = np.random.default_rng(5)
    ratios, plain = [], []
    for _ in range(200):
        s = _ar1(rng, 0.8, (400, 1))
        s -= s.mean()
        ratios.append(float(long_run_meat(s)[0, 0]) / 400 / 25.0)
        plain.append(float((s.T @ s)[0, 0]) / 400 / 25.0)
    assert 0.65 < np.mean(ratios) <= 1.05, np.mean(ratios)
    assert np.mean(plain) < 0.15
    white = rng.normal(size=(400, 3))
    assert hac_lag(white) <= 2
    assert np.allclose(np.diag(long_run_meat(white)) / np.diag(white.T @ white * 400 / 399), 1.0, atol=0.2)


def test_blocks_gathered_from_the_record_pair_only_with_their_neighbours_in_time():
    """Scores of blocks 0, 1 and 50, 51: the lag products pair 0 with 1 and 50 with 51, never 1
    with 50 (they are far apart in time), whatever the order the blocks are given in."""
    s = np.array([[1.0], [1.0], [1.0], [-1.0]])
    a = long_run_meat(s, at=[0, 1, 50, 51])
    b = long_run_meat(s[[2, 0, 3, 1]], at=[50, 0, 51, 1])
    assert a == pytest.approx(b)
    far = long_run_meat(s, at=[0, 10, 20, 30])  # no neighbours at all: the plain sum
    assert far == pytest.approx(s.T @ s * 4 / 3)


def _parts_normal(estimates, info):
    """Normal equations of one parameter over blocks, each block of information ``info`` whose
    own estimate is ``estimates[k]``: N_k = info, b_k = info * x_k."""
    B = estimates.size
    N = np.zeros((B, D.NP, D.NP))
    b = np.zeros((B, D.NP))
    j = D.A_BIAS[0]
    N[:, j, j] = info
    b[:, j] = info * estimates
    for k in range(D.NP):  # the other parameters pinned: give them some information so N is regular
        if k != j:
            N[:, k, k] = 1.0
    return Normal(N, b, np.zeros(B), B, np.ones(D.NP), 1.0, np.arange(B, dtype=float)), j


def test_parts_that_agree_widen_nothing_and_parts_with_an_effect_each_widen_by_it():
    """Eight parts, each the mean of 10 blocks of unit noise: parts whose estimates scatter as
    their noise says widen nothing (the random effect counts only beyond chance: 0.33 % of such
    records, so at most 2 of 100 here, allowing for chance); parts each shifted by an effect of its
    own with sigma 3 times a part's error give the DerSimonian-Laird widening, close to sqrt(1 + 9)
    for the whole record's estimate (each part weighs 1/8, a part's variance is 8 times the
    record's)."""
    rng = np.random.default_rng(2)
    info = 1.0
    factors_null, factors_effect = [], []
    for _ in range(100):
        noise = rng.normal(size=80)  # each block's estimate: unit variance
        nrm, j = _parts_normal(noise, info)
        sigma = {j: 1.0 / np.sqrt(80.0)}
        _, out = block_consistency(nrm, np.array([j]), np.zeros(D.NP), sigma, sigma)
        factors_null.append(out[j]["factor"])
        part_sigma = 1.0 / np.sqrt(10.0)
        shifts = np.repeat(rng.normal(scale=3.0 * part_sigma, size=8), 10)
        nrm, j = _parts_normal(noise + shifts, info)
        _, out = block_consistency(nrm, np.array([j]), np.zeros(D.NP), sigma, sigma)
        factors_effect.append(out[j]["factor"])
    assert min(factors_null) >= 1.0 and sum(f > 1.0 for f in factors_null) <= 2, factors_null
    assert 2.4 < np.median(factors_effect) < 3.8, np.median(factors_effect)


def test_the_parts_random_effect_is_the_same_at_any_scale_of_the_parameter():
    """A parameter the record hardly holds (one nearly collinear with another fitted beside it) has
    errors near the float limit: the sums of its parts' inverse squared errors underflowed to zero
    (a division by zero on a development-range record) or overflowed. In units of the whole
    record's error the random effect, the chi-square and the widening do not depend on the
    parameter's scale."""
    rng = np.random.default_rng(4)
    estimates = rng.normal(size=80) + np.repeat(rng.normal(scale=1.0, size=8), 10)
    results = []
    for scale in (1.0, 1e-150, 1e150):
        nrm, j = _parts_normal(estimates * scale, 1.0 / scale**2)
        sigma = {j: scale / np.sqrt(80.0)}
        _, out = block_consistency(nrm, np.array([j]), np.zeros(D.NP), sigma, sigma)
        results.append(out[j])
    for r in results[1:]:
        assert r["chi2_dof"] == pytest.approx(results[0]["chi2_dof"], rel=1e-9)
        assert r["factor"] == pytest.approx(results[0]["factor"], rel=1e-9)
        assert r["inflated"] == results[0]["inflated"]
    assert results[0]["inflated"] and results[0]["factor"] > 2.0
    assert results[1]["tau"] == pytest.approx(results[0]["tau"] * 1e-150, rel=1e-9)


def test_the_noise_between_two_bands_is_the_difference_of_their_blocks():
    """The band part (:func:`sizefx.diagnose.budget.band_part`) counts as systematic only the shift
    between two bands' estimates beyond the noise of their difference, taken as the long-run sum
    of the blocks' differences (:func:`sizefx.diagnose.normal.block_scores`, the second band's
    blocks cut where the first's start). One regressor (sines at 2, 5 and 9 Hz) in white noise,
    fitted at 8 Hz and a third of an octave above: over 120 noise draws the mean of that variance
    matches the scatter of the difference within 25 % (the scatter itself is known to +-13 %
    with 120 draws, each draw's estimate to +-14 % with 100 blocks; it came to 1.07 times the scatter,
    and Hausman's ``|s_b^2 - s^2|``, which holds for an efficient estimator only, to 2.4 times). The
    same band twice cuts the same blocks: no difference at all."""
    from sizefx.diagnose.normal import Rows, block_scores, normal_equations

    rng = np.random.default_rng(11)
    dt, n = 0.005, 20_000
    t = np.arange(n) * dt
    mask = np.ones(n, dtype=bool)
    j = D.LEVER[0]
    x = np.sin(2 * np.pi * 2.0 * t) + np.sin(2 * np.pi * 5.0 * t + 1.0) + np.sin(2 * np.pi * 9.0 * t + 2.0)
    cols = {k: ((), np.zeros((n, 0))) for k in range(D.NP)} | {j: ((3,), x[:, None])}
    rows0, rows1 = Rows(t, mask, dt, 8.0), Rows(t, mask, dt, 8.0 * 2.0 ** (1.0 / 3.0))
    weights, offset, free = np.ones(6), np.zeros(D.NP), np.array([j])
    shifts, noise = [], []
    for _ in range(120):
        y = np.zeros((n, 6))
        y[:, 3] = rng.normal(size=n)
        nrm0 = normal_equations(rows0, rows0(y), cols, weights)
        nrm1 = normal_equations(rows1, rows1(y), cols, weights, blocks_of=nrm0)
        x0, inv0, s0 = block_scores(nrm0, free, offset)
        x1, inv1, s1 = block_scores(nrm1, free, offset)
        assert s1.shape == s0.shape
        shifts.append(float(x1[0] - x0[0]))
        noise.append(float(long_run_meat(s1 @ inv1 - s0 @ inv0)[0, 0]))
    assert np.mean(noise) == pytest.approx(np.var(shifts), rel=0.25)
    same = normal_equations(rows0, rows0(y), cols, weights, blocks_of=nrm0)
    assert np.allclose(block_scores(same, free, offset)[2], s0)


def test_the_selection_at_a_neighbouring_band_goes_on_from_the_final_model():
    """At a neighbouring band the selection goes on from the final model (``select(start=...)``):
    what the model holds stays, however little that band says of it (a bias of nothing here), and
    an effect of 40 standard errors is taken beside it."""
    from sizefx.diagnose.candidates import CANDIDATES
    from sizefx.diagnose.normal import Normal
    from sizefx.diagnose.selection import Chosen, select

    strong = next(c for c in CANDIDATES if c.key == "accel_bias:accel_x")
    weak = next(c for c in CANDIDATES if c.key == "accel_bias:accel_y")
    rng = np.random.default_rng(4)
    B, rows = 60, 50
    N = np.zeros((B, D.NP, D.NP))
    b = np.zeros((B, D.NP))
    yy = np.zeros(B)
    for k in range(B):
        X = np.zeros((rows, D.NP))
        X[: rows // 2, strong.idx[0]] = 1.0  # the x channel's rows
        X[rows // 2 :, weak.idx[0]] = 1.0  # the y channel's, in the same block for brevity
        y = rng.normal(size=rows)
        y[: rows // 2] += 40.0 / np.sqrt(B * rows / 2)  # 40 standard errors over the record
        N[k] = X.T @ X + 1e-9 * np.eye(D.NP)  # the other candidates: no information, not singular
        b[k] = X.T @ y
        yy[k] = y @ y
    nrm = Normal(N, b, yy, B * rows, np.ones(D.NP), 1.0, np.arange(B, dtype=float))
    chosen, _, _ = select(nrm, np.zeros(D.NP), np.log(B * rows), start=[Chosen(weak, weak.idx, ())])
    assert [c.cand for c in chosen] == [weak, strong]
    fresh, _, _ = select(nrm, np.zeros(D.NP), np.log(B * rows))
    assert [c.cand for c in fresh] == [strong]


def test_a_shift_between_bands_within_chance_is_no_systematic_part():
    """:func:`sizefx.diagnose.budget.systematic_shift` counts a shift as systematic only beyond
    chance at the family-wise level, shared among the record's parameters
    (:func:`sizefx.diagnose.budget.shift_chi2`). Shifts of noise only (unit variance): of one
    parameter (20 000 draws), the variance added is 0.075 on average (``E[(Z^2 - 1) 1{Z^2 > 6.63}]``;
    its sampling error here is about 0.006), against 0.48 without the test, and 1 % of them count
    at all; of fifteen parameters (4 000 records), 1 % of the records get a part anywhere (14 % at
    the one-parameter point). A shift of ten noise standard deviations keeps ``sqrt(D^2 - V)``, with
    its sign."""
    from sizefx.diagnose.budget import SHIFT_CHI2, shift_chi2, systematic_shift

    rng = np.random.default_rng(5)
    shift = rng.normal(size=20_000)
    part = np.array([systematic_shift(x[None], np.ones(1))[0] for x in shift])
    assert shift_chi2(1) == SHIFT_CHI2
    assert np.mean(part**2) == pytest.approx(0.075, abs=0.02)
    assert np.mean(part != 0) == pytest.approx(0.01, abs=0.003)
    assert np.all(part[np.abs(shift) <= np.sqrt(SHIFT_CHI2)] == 0.0)
    records = rng.normal(size=(4_000, 15))
    parts = np.array([systematic_shift(x, np.ones(15)) for x in records])
    assert np.mean(parts.any(axis=1)) == pytest.approx(0.01, abs=0.004)
    assert np.mean((records**2 > SHIFT_CHI2).any(axis=1)) > 0.1  # what one parameter's point gave
    big = systematic_shift(np.array([-10.0, 10.0, 0.0]), np.array([1.0, 1.0, 0.0]))
    assert big == pytest.approx([-np.sqrt(99.0), np.sqrt(99.0), 0.0])


def _tilt_on_a_flight(r0_m: float):
    """A 450 s helicopter flight at 100 Hz (one 180 deg turn at 10 deg/s, rotor vibration) with a
    level tilt of 15 and -10 arcsec, navigation-grade white noise (seed 3), and the rotation centre
    ``r0_m`` from the drawing along body x and y: ``(level tilt's sigma, its white sigma, the fit's
    log)`` [arcsec]. The turn's omega^2 stays under the arms' excitation floor: their components
    are fitted beside the tilt as weak parameters, and at 25 mm they leave tens of ug in the
    accelerometers' residual where they are not fitted."""
    from sizefx import scenarios as S
    from sizefx.effects import IDEAL, load_effects
    from sizefx.simulate import simulate_in_memory

    plan = S.FlightPlan(
        duration_s=450.0,
        align_s=30.0,
        speed_mps=20.0,
        turn_rate_dps=10.0,
        altitude_m=100.0,
        weave_deg=0.0,
        climb_step_m=0.0,
    )
    arms = {"enabled": True, "preset": "high-precision"}
    fx = load_effects(
        base=IDEAL,
        overrides={
            "lever_arm": arms | {"r0_m": [r0_m, r0_m, 0.0]},
            "level_tilt": {"enabled": True, "north_arcsec": 15.0, "east_arcsec": -10.0},
            "accel_noise": {"enabled": True, "density_ug_per_sqrt_hz": 5.0},
            "gyro_noise": {"enabled": True, "arw_deg_per_sqrt_h": 0.001},
        },
    )
    tel = simulate_in_memory(S.flight(plan)[0], fx, rate_hz=100.0, form="rates", seed=3)
    d = D.diagnose(tel, D.theta_from_model(load_effects(base=IDEAL, overrides={"lever_arm": arms})), keep_series=False)
    assert "level_tilt" in {e.id for e in d.effects}
    north = D.TILT[0]
    unit = D.PARAMS[north].per_unit
    return d.sigma_theta[north] / unit, d.sigma_white[north] / unit, d.log


def test_the_step_beside_the_model_is_the_joint_least_squares_solution():
    """The fast twin of the two flights below. :func:`sizefx.diagnose.aliases.hidden_fit` steps the
    model and the parameters fitted beside it to the solution of their joint normal equations with
    the priors, also where the model's own scores are not nil (the fit's final weights are not
    those its last pass solved at): before, the model moved only by the shift the others give it
    and stayed off by its own ``N_ff^-1 b_f``. Random equations of two model parameters and two
    fitted beside with priors (the priors about the start values, the estimate away from them);
    1e-9: one solve against another."""
    from sizefx.diagnose.aliases import _prior, hidden_fit
    from sizefx.diagnose.candidates import CANDIDATES

    rng = np.random.default_rng(8)
    arm = next(c for c in CANDIDATES if c.key == "lever_arm:accel_x")
    free = np.array(arm.idx[:2])
    beside = [(next(c for c in CANDIDATES if c.key == "accel_scale_factor:accel_x"), [D.A_SF[0]], True)]
    beside.append((next(c for c in CANDIDATES if c.key == "accel_delay"), [D.TAU_A], True))
    idx = np.array([D.A_SF[0], D.TAU_A])
    X = rng.normal(size=(300, D.NP)) * 1e-3
    N = X.T @ X + np.eye(D.NP) * 1e-12
    b = rng.normal(size=D.NP) * 1e-6
    from sizefx.diagnose.normal import Normal

    nrm = Normal(N[None], b[None], np.zeros(1), 300, np.ones(D.NP), 1.0, np.zeros(1))
    offset = np.zeros(D.NP)
    offset[idx] = (2e-5, -1e-4)  # the start values minus the estimate
    dx, dh, _ = hidden_fit(nrm, free, beside, "navigation", offset)
    P = np.diag(1.0 / np.concatenate([_prior(c.id, 1, "navigation") for c, _, _ in beside]) ** 2)
    joint = np.concatenate([free, idx])
    A = N[np.ix_(joint, joint)].copy()
    A[2:, 2:] += P
    rhs = b[joint].copy()
    rhs[2:] += P @ offset[idx]
    step = np.linalg.solve(A, rhs)
    assert np.allclose(dx, step[:2], rtol=1e-9, atol=0.0)
    assert np.allclose(dh, step[2:], rtol=1e-9, atol=0.0)


@pytest.mark.slow
def test_what_the_parameters_fitted_beside_the_model_explain_is_no_noise_in_the_errors():
    """With the arms 25 mm from the drawing, fitted beside the tilt, the tilt's error stays within
    its white one at the fit's weights (0.54 of it here: the misfit the fit began with lowered the
    accelerometers' weights, and the white error takes them as given), where the arms' slow misfit
    counted as coloured noise made it 3.7 times as large."""
    sigma, white, log = _tilt_on_a_flight(0.025)
    assert any(line.startswith("weak, fitted beside the findings") and "lever_arm" in line for line in log)
    assert sigma < white, (sigma, white)


@pytest.mark.slow
def test_the_tilts_error_does_not_grow_with_a_misfit_the_model_fits_beside_it():
    """The flight above with the same noise with the rotation centre on the drawing and 25 mm from it: the
    level tilt's error grows by the arms' own part only, 2.0 times here (their uncertainty is taken
    at the fit's weights, which the misfit it began with lowered), where the misfit counted as
    coloured noise made it 13.6 times as large. 2.5: that part's, with room for the noise model's
    estimate on two residuals."""
    on, _, _ = _tilt_on_a_flight(0.0)
    off, _, _ = _tilt_on_a_flight(0.025)
    assert off < 2.5 * on, (off, on)


def test_the_honest_covariance_is_finite_where_a_robust_variance_is_nil():
    """:func:`sizefx.diagnose.selection.honest` keeps the block sandwich's correlations at the
    larger of its and the white variances. Where a parameter's block scores are all nil its robust
    variance is 0, and scaling its row by ``sqrt(w / r)`` (r clamped at 1e-300) overflowed to inf
    and, times the nil row, to NaN; it now takes its white variance and no correlation. Elsewhere
    the result is the row-and-column scaling, to rounding (1e-15)."""
    import warnings

    from sizefx.diagnose.selection import honest

    white = np.array([[1.0, 0.3, 0.1], [0.3, 2.0, 0.2], [0.1, 0.2, 1e-20]])
    robust = np.array([[4.0, 0.9, 0.0], [0.9, 0.25, 0.0], [0.0, 0.0, 0.0]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # an overflow is an error here
        out = honest(white, robust)
        tiny = honest(white * 1e200, robust * 1e-200)
    assert np.all(np.isfinite(out)) and np.all(np.isfinite(tiny))
    assert out[2, 2] == pytest.approx(white[2, 2], rel=1e-15) and not out[2, :2].any() and not out[:2, 2].any()
    d = np.sqrt(np.maximum(1.0, np.diag(white)[:2] / np.diag(robust)[:2]))
    assert np.allclose(out[:2, :2], robust[:2, :2] * np.outer(d, d), rtol=1e-15, atol=0.0)
    # the robust variance a hundred orders under the white one: the white variance, the robust correlation
    assert np.allclose(np.diag(tiny)[:2], 1e200 * np.diag(white)[:2], rtol=1e-15)
    assert tiny[0, 1] / np.sqrt(tiny[0, 0]) / np.sqrt(tiny[1, 1]) == pytest.approx(0.9 / np.sqrt(4.0 * 0.25))
