"""Slow, obviously correct twins of the Numba kernels (compared in tests; stumpy's tests/naive.py habit).

Written with sizefx.earth (vectorised NumPy) and sizefx.rotation, one step at
a time, so a kernel slip in the hand-unrolled scalar code shows up as a mismatch.
"""

from __future__ import annotations

import numpy as np

from sizefx import earth
from sizefx.kernels.strapdown import VERTICAL_HELD, VERTICAL_REFERENCE
from sizefx.rotation import quat_multiply, quat_to_mat


def rates_to_increments(rates, dt):
    """Integral over each interval of the cubic (quadratic at the ends) through the nearest samples."""
    n = rates.shape[0]
    out = np.empty((n - 1, rates.shape[1]))
    for k in range(1, n):
        if k == 1:
            w = np.array([5.0, 8.0, -1.0]) / 12.0
            out[k - 1] = dt * w @ rates[0:3]
        elif k == n - 1:
            w = np.array([-1.0, 8.0, 5.0]) / 12.0
            out[k - 1] = dt * w @ rates[n - 3 : n]
        else:
            w = np.array([-1.0, 13.0, 13.0, -1.0]) / 24.0
            out[k - 1] = dt * w @ rates[k - 2 : k + 2]
    return out


def quat_of_rotvec(v):
    angle = np.linalg.norm(v)
    if angle == 0.0:
        return np.array([1.0, 0.0, 0.0, 0.0])
    return np.r_[np.cos(angle / 2), np.sin(angle / 2) * v / angle]


def strapdown(
    dtheta, dvel, n_sub, coeffs, dt_nav, quat0, v0, lat0, lon0, h0, vertical=0, h_hold=0.0, h_ref=None, vd_ref=None
):
    """The mechanisation of sizefx.kernels.strapdown, step by step with vectors and matrices."""
    q = np.asarray(quat0, dtype=float) / np.linalg.norm(quat0)
    v = np.asarray(v0, dtype=float).copy()
    lat, lon, h = lat0, lon0, h0
    prev = None
    c_lat = c_lon = 0.0  # Kahan compensation, as in the kernel
    out = []
    for step in range(dtheta.shape[0] // n_sub):
        a = dtheta[step * n_sub : (step + 1) * n_sub]
        u = dvel[step * n_sub : (step + 1) * n_sub]
        cone = np.zeros(3)
        scul = np.zeros(3)
        for i in range(n_sub):
            for j in range(i + 1, n_sub):
                cone += coeffs[i, j] * np.cross(a[i], a[j])
                scul += coeffs[i, j] * (np.cross(a[i], u[j]) + np.cross(u[i], a[j]))
        phi = a.sum(axis=0) + cone
        dv_b = u.sum(axis=0) + 0.5 * np.cross(a.sum(axis=0), u.sum(axis=0)) + scul
        if prev is None:
            lat_m, h_m, v_m = lat, h, v
        else:
            lat_m, h_m, v_m = 1.5 * lat - 0.5 * prev[0], 1.5 * h - 0.5 * prev[1], 1.5 * v - 0.5 * prev[2]
        w_ie = earth.omega_ie_n(lat_m)
        w_en = earth.omega_en_n(lat_m, h_m, v_m)
        zeta = (w_ie + w_en) * dt_nav
        g = earth.gravity_n(lat_m, h_m)
        dv_n = quat_to_mat(q) @ dv_b
        dv_n = dv_n - 0.5 * np.cross(zeta, dv_n)
        v_new = v + dv_n + (g - np.cross(2 * w_ie + w_en, v_m)) * dt_nav
        q = quat_multiply(quat_multiply(quat_of_rotvec(-zeta), q), quat_of_rotvec(phi))
        q = q / np.linalg.norm(q)
        if vertical == VERTICAL_HELD:
            v_new[2], h_new = 0.0, h_hold
        elif vertical == VERTICAL_REFERENCE:
            v_new[2], h_new = vd_ref[step], h_ref[step]
        else:
            h_new = h - 0.5 * (v[2] + v_new[2]) * dt_nav
        r_mer, r_tr = earth.radii_m(lat_m)
        h_mid = 0.5 * (h + h_new)
        y = 0.5 * (v[0] + v_new[0]) * dt_nav / (r_mer + h_mid) - c_lat
        lat_new = lat + y
        c_lat = (lat_new - lat) - y
        y = 0.5 * (v[1] + v_new[1]) * dt_nav / ((r_tr + h_mid) * np.cos(lat_m)) - c_lon
        lon_new = lon + y
        c_lon = (lon_new - lon) - y
        prev = (lat, h, v)
        lat, lon, h, v = lat_new, lon_new, h_new, v_new
        out.append(np.r_[q, v, lat, lon, h])
    return np.array(out)


def compensate_rates(accel, omega, omegadot, arms, axes, centripetal=True, tangential=True):
    """a_i - u_i . (omegadot x r_i + omega x (omega x r_i)), sample by sample."""
    out = np.array(accel, dtype=float)
    for k in range(accel.shape[0]):
        for i in range(3):
            lever = np.zeros(3)
            if tangential:
                lever += np.cross(omegadot[k], arms[i])
            if centripetal:
                lever += np.cross(omega[k], np.cross(omega[k], arms[i]))
            out[k, i] -= axes[i] @ lever
    return out


def compensate_increments(dvel, dtheta, omega_edges, dt, arms, axes, centripetal=True, tangential=True):
    out = np.array(dvel, dtype=float)
    for k in range(dvel.shape[0]):
        w = dtheta[k] / dt
        for i in range(3):
            lever = np.zeros(3)
            if tangential:
                lever += np.cross(omega_edges[k + 1] - omega_edges[k], arms[i])
            if centripetal:
                lever += dt * np.cross(w, np.cross(w, arms[i]))
            out[k, i] -= axes[i] @ lever
    return out


def spline_not_a_knot(x, y, t):
    """The not-a-knot cubic spline through ``(x_i, y_i [C])`` at ``t``, from its definition.

    One cubic ``a + b e + c e^2 + d e^3`` per interval in ``e = (x - x_i) / h_i``, 4 (n - 1)
    unknowns: it passes through both knots of its interval, its first and second derivatives
    are continuous at the inner knots, and so is the third at ``x_1`` and ``x_{n-2}`` (not a
    knot). One dense solve. Two knots give the straight line and three the parabola (the
    not-a-knot conditions coincide there), as scipy. Beyond the ends the end cubics go on.
    """
    x, y, t = np.asarray(x, float), np.asarray(y, float), np.asarray(t, float)
    n = x.size
    if n == 2:
        return y[0] + np.multiply.outer((t - x[0]) / (x[1] - x[0]), y[1] - y[0])
    if n == 3:
        coef = np.polynomial.polynomial.polyfit(x - x[0], y, 2)
        return np.polynomial.polynomial.polyval(t - x[0], coef).T.reshape(t.shape + y.shape[1:])
    h = np.diff(x)
    m = 4 * (n - 1)
    a = np.zeros((m, m))
    b = np.zeros((m,) + y.shape[1:])
    row = 0

    def col(i, power):
        return 4 * i + power

    for i in range(n - 1):  # through both knots
        a[row, col(i, 0)] = 1.0
        b[row] = y[i]
        row += 1
        a[row, col(i, 0) : col(i, 0) + 4] = 1.0
        b[row] = y[i + 1]
        row += 1
    for i in range(n - 2):  # p_i' and p_i'' at e = 1 equal p_{i+1}' and p_{i+1}'' at e = 0 (times h_i^k)
        r = h[i] / h[i + 1]
        a[row, col(i, 1)], a[row, col(i, 2)], a[row, col(i, 3)] = 1.0, 2.0, 3.0
        a[row, col(i + 1, 1)] = -r
        row += 1
        a[row, col(i, 2)], a[row, col(i, 3)] = 2.0, 6.0
        a[row, col(i + 1, 2)] = -2.0 * r**2
        row += 1
    for i in (0, n - 3):  # not a knot: the third derivative continuous at x_1 and x_{n-2}
        a[row, col(i, 3)] = 6.0
        a[row, col(i + 1, 3)] = -6.0 * (h[i] / h[i + 1]) ** 3
        row += 1
    coef = np.linalg.solve(a, b).reshape((n - 1, 4) + y.shape[1:])
    i = np.clip(np.searchsorted(x, t, side="right") - 1, 0, n - 2)
    e = (t - x[i]) / h[i]
    powers = np.stack([np.ones_like(e), e, e**2, e**3], axis=-1)
    return np.einsum("kp,kp...->k...", powers, coef[i])


def resample_increments(incr, t_end_from, t_end_to):
    """Increments over ``(t_from[k-1], t_from[k]]`` -> over ``(t_to[k-1], t_to[k]]``: the spline
    of their cumulative sum at the target edges, differenced (the first interval of each
    starts one median period before its first stamp)."""

    def edges(t):
        return np.r_[t[0] - np.median(np.diff(t)), t]

    cum = np.vstack([np.zeros(incr.shape[1]), np.cumsum(incr, axis=0)])
    return np.diff(spline_not_a_knot(edges(t_end_from), cum, edges(t_end_to)), axis=0)


def savgol_derivative(x, dt, window=41, order=2):
    """Row by row: the slope at row k of the polynomial of ``order`` fitted by least squares
    to the ``window`` rows centred on k, or to the first (last) ``window`` rows for the rows
    within ``window // 2`` of an end (scipy's ``mode="interp"``)."""
    x = np.asarray(x, float)
    n, half = x.shape[0], window // 2
    out = np.empty_like(x)
    for k in range(n):
        start = min(max(k - half, 0), n - window)
        u = np.arange(start, start + window) - k  # positions relative to row k
        coef = np.polynomial.polynomial.polyfit(u, x[start : start + window], order)
        out[k] = coef[1] / dt  # d/du at u = 0
    return out
