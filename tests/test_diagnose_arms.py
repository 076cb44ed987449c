"""The fitted arms split at the triad point (sizefx.diagnose.arms): the same split as the model file
and calibrate (sizefx.geometry.triad_point), and errors that match a Monte Carlo of the arms."""

from __future__ import annotations

import numpy as np
import pytest

from sizefx.diagnose.arms import split_arms
from sizefx.geometry import triad_point
from sizefx.rotation import rotvec_to_mat

ARMS_M = np.array([[0.0060, 0.0010, 0.0242], [0.0, -0.0172, 0.0], [0.0, 0.0, -0.0212]]) + [0.3, -0.1, 0.05]


@pytest.mark.parametrize("tilted", [False, True])
def test_split_is_the_triad_point_and_errors_match_monte_carlo(tilted):
    rng = np.random.default_rng(5)
    # sensitive axes a few degrees off the body axes: the split must use the same axes as triad_point
    axes = rotvec_to_mat(np.radians([2.0, -3.0, 4.0])) if tilted else np.eye(3)
    A = rng.normal(size=(9, 9))
    cov = (A @ A.T) * 1e-8 / 9  # correlated arms, ~0.1 mm each
    g = split_arms(ARMS_M, cov, axes)
    C = triad_point(ARMS_M, axes)
    np.testing.assert_allclose(g["triad_point_m"], C, rtol=0, atol=1e-15)
    np.testing.assert_allclose(g["d_m"], ARMS_M - C, rtol=0, atol=1e-15)
    draws = rng.multivariate_normal(ARMS_M.ravel(), cov, size=20000)
    Cs = np.array([triad_point(r.reshape(3, 3), axes) for r in draws])
    ds = draws.reshape(-1, 3, 3) - Cs[:, None, :]
    # 20 000 draws: a standard deviation is known to 0.5 %; 3 % leaves room without hiding a wrong term
    np.testing.assert_allclose(g["triad_point_sigma_m"], Cs.std(axis=0), rtol=0.03)
    np.testing.assert_allclose(g["d_sigma_m"], ds.std(axis=0), rtol=0.03)


def test_arms_held_fixed_carry_no_error():
    cov = np.zeros((9, 9))
    cov[4, 4] = 1e-8  # only r_y[y] fitted
    g = split_arms(ARMS_M, cov)
    # C = (mean(r_y[x], r_z[x]), mean(r_x[y], r_z[y]), mean(r_x[z], r_y[z])) for orthogonal axes
    assert g["triad_point_sigma_m"] == [0.0, 0.0, 0.0]
    assert g["d_sigma_m"][1][1] == pytest.approx(1e-4) and sum(map(sum, g["d_sigma_m"])) == pytest.approx(1e-4)
