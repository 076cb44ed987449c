"""The navigation-error kernel against its NumPy twin (``reference_at`` and the formulas it replaced)."""

from __future__ import annotations

import numpy as np
import pytest

from sizefx import earth
from sizefx.io.telemetry import Reference
from sizefx.kernels.errors import compared_steps, navigation_errors
from sizefx.navigate.reference import reference_at
from sizefx.rotation import mat_to_quat, quat_angle_between, rotvec_to_mat


def random_track(rng, n, t0=100.0, step=0.01):
    t = t0 + step * np.arange(n) + rng.uniform(0, 0.3 * step, n)  # uneven, increasing
    q = mat_to_quat(rotvec_to_mat(np.cumsum(rng.normal(0, 0.05, (n, 3)), axis=0)))
    q *= np.where(rng.random(n) < 0.3, -1.0, 1.0)[:, None]  # sign flips: the same attitudes
    lat = np.radians(52.0) + np.cumsum(rng.normal(0, 1e-7, n))
    lon = np.radians(13.0) + np.cumsum(rng.normal(0, 1e-7, n))
    h = 40.0 + np.cumsum(rng.normal(0, 0.1, n))
    v = rng.normal(0, 20, (n, 3))
    return Reference(time_s=t, quat_nb=q, lat_rad=lat, lon_rad=lon, height_m=h, velocity_n_mps=v)


def twin(ref, t, q, v, lat, lon):
    """The NumPy formulas (as sizefx.navigate computed them before the kernel)."""
    r = reference_at(ref, t)
    r_mer, r_tr = earth.radii_m(r["lat"])
    dn = (lat - r["lat"]) * (r_mer + r["h"])
    de = (lon - r["lon"]) * (r_tr + r["h"]) * np.cos(r["lat"])
    return np.column_stack([dn, de, np.hypot(dn, de), v - r["v_n"], quat_angle_between(r["quat_nb"], q)])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_kernel_equals_its_numpy_twin(seed):
    rng = np.random.default_rng(seed)
    ref = random_track(rng, 300)
    nav = random_track(rng, 2000, t0=ref.time_s[0] - 0.05, step=np.ptp(ref.time_s) / 1900)  # past both ends too
    t = nav.time_s
    q, v = nav.quat_nb, nav.velocity_n_mps
    lat = ref.lat_rad[0] + rng.normal(0, 1e-6, t.size)  # metres of error
    lon = ref.lon_rad[0] + rng.normal(0, 1e-6, t.size)
    out = np.full((t.size, 7), np.nan)
    navigation_errors(
        t,
        q,
        v,
        lat,
        lon,
        ref.time_s,
        ref.quat_nb,
        ref.lat_rad,
        ref.lon_rad,
        ref.height_m,
        ref.velocity_n_mps,
        True,
        True,
        True,
        out,
    )
    expected = twin(ref, t, q, v, lat, lon)
    # positions: metres to 1e-9 m (rounding of two interpolation formulas on ~1e7 m radii);
    # velocity to 1e-12 m/s; attitude to 1e-12 rad (slerp and angle in the same order of operations)
    np.testing.assert_allclose(out[:, :3], expected[:, :3], rtol=0, atol=1e-9)
    np.testing.assert_allclose(out[:, 3:6], expected[:, 3:6], rtol=0, atol=1e-12)
    np.testing.assert_allclose(out[:, 6], expected[:, 6], rtol=0, atol=1e-12)


def test_columns_not_asked_for_are_left_alone():
    rng = np.random.default_rng(5)
    ref = random_track(rng, 50)
    t = np.linspace(ref.time_s[0], ref.time_s[-1], 80)
    out = np.full((t.size, 7), -7.0)
    navigation_errors(
        t,
        np.tile([1.0, 0, 0, 0], (80, 1)),
        np.zeros((80, 3)),
        np.zeros(80),
        np.zeros(80),
        ref.time_s,
        ref.quat_nb,
        np.zeros(2),
        np.zeros(2),
        np.zeros(2),
        np.zeros((2, 3)),
        False,
        False,
        True,
        out,
    )
    assert np.all(out[:, :6] == -7.0) and np.all(out[:, 6] >= 0.0)


def compared_twin(t, ref_t, first_s, last_s, sparse, tol_s):
    """The NumPy steps the kernel replaced (sizefx.navigate.reference.Errors.add before it)."""
    covered = (t >= first_s) & (t <= last_s + 1e-9)
    if sparse and ref_t.size > 1:
        k = np.clip(np.searchsorted(ref_t, t), 1, ref_t.size - 1)
        nearest = np.minimum(np.abs(ref_t[k] - t), np.abs(ref_t[k - 1] - t))
        covered &= nearest < tol_s
    return np.flatnonzero(covered)


@pytest.mark.parametrize("seed", range(6))
def test_compared_steps_equal_their_numpy_twin(seed):
    """Steps at 400 Hz against a reference at 100 Hz with jitter, rows that coincide exactly, a window
    shorter than the chunk, one row and none; steps before and after the reference."""
    rng = np.random.default_rng(seed)
    t = 10.0 + 0.0025 * np.arange(4000)
    ref_t = 10.3 + 0.01 * np.arange(int(rng.integers(0, 900)))
    ref_t = np.sort(ref_t + np.where(rng.random(ref_t.size) < 0.3, rng.normal(0, 2e-6, ref_t.size), 0.0))
    t = t[:: int(rng.integers(1, 3))]  # a strided view, as the loop passes it
    first, last = (ref_t[0], ref_t[-1]) if ref_t.size else (10.5, 17.0)
    for sparse in (True, False):
        for tol in (2.5e-6, 1e-2):
            idx = np.empty(t.size, dtype=np.int64)
            m = compared_steps(t, ref_t, first, last, sparse, tol, idx)
            np.testing.assert_array_equal(idx[:m], compared_twin(t, ref_t, first, last, sparse, tol))
