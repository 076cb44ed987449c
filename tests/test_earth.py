"""WGS-84 model against published values and against its own derivatives."""

from __future__ import annotations

import numpy as np
import pytest

from sizefx import earth


def test_normal_gravity_at_equator_and_pole_matches_nima_tr8350():
    # NIMA TR8350.2 Table 3.4: gamma_e = 9.7803253359, gamma_p = 9.8321849378 m/s^2
    g = earth.gravity_n(np.array([0.0, np.pi / 2]), np.zeros(2))
    np.testing.assert_allclose(g[:, 2], [9.7803253359, 9.8321849378], atol=1e-9)
    np.testing.assert_allclose(g[:, 0], 0.0)


def test_free_air_gradient_is_about_3_086e_6_per_metre():
    lat = np.radians(45.0)
    dg = earth.gravity_n(lat, 0.0)[2] - earth.gravity_n(lat, 1000.0)[2]
    assert dg / 1000.0 == pytest.approx(3.086e-6, rel=2e-3)


def test_radii_at_equator():
    r_mer, r_tr = earth.radii_m(0.0)
    assert r_tr == pytest.approx(6378137.0, abs=1e-6)
    assert r_mer == pytest.approx(6378137.0 * (1 - 6.69437999014e-3), abs=1e-3)


def test_earth_rate_components():
    lat = np.radians(57.9825)
    w = earth.omega_ie_n(lat)
    assert np.linalg.norm(w) == pytest.approx(7.292115e-5, rel=1e-15)
    assert w[1] == 0.0 and w[2] < 0  # up component is positive, i.e. NED down is negative


def test_omegadot_in_n_is_the_derivative_of_omega_in_n():
    # a point moving with acceleration; compare with a central difference
    lat0, h0, v0, a = 0.9, 500.0, np.array([60.0, -40.0, 3.0]), np.array([0.5, 1.2, -0.3])

    def state(t):
        v = v0 + a * t
        r_mer, _ = earth.radii_m(lat0)
        lat = lat0 + (v0[0] * t + 0.5 * a[0] * t * t) / (r_mer + h0)
        h = h0 - (v0[2] * t + 0.5 * a[2] * t * t)
        return lat, h, v

    def w_in(t):
        lat, h, v = state(t)
        return earth.omega_ie_n(lat) + earth.omega_en_n(lat, h, v)

    dt = 1e-3
    fd = (w_in(dt) - w_in(-dt)) / (2 * dt)
    lat, h, v = state(0.0)
    got = earth.omegadot_in_n(lat, h, v, a)
    # the finite difference also differentiates the approximate lat(t) above; the
    # meridian-radius change over 1 ms is negligible: agreement to 1e-13 rad/s^2
    np.testing.assert_allclose(got, fd, atol=1e-13)
