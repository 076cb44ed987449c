"""Errors of a navigation solution against a reference, step by step (the navigation loop's step 5).

At each navigation step the reference is interpolated as :func:`sizefx.navigate.reference.reference_at`
does it (position, height and velocity linearly, attitude by slerp the shorter way round; times
outside the reference take its end rows), and the solution's north and east position errors
[m] on the local radii of curvature, its velocity error [m/s] and its attitude error [rad] are
formed. The NumPy twin is ``reference_at`` with the same formulas (``tests/test_navigate_errors.py``);
this kernel exists because the NumPy version took a third of a whole-flight run.
"""

from __future__ import annotations

import math

from .earth import radii_m
from .jit import kernel

__all__ = ["ERROR_COLUMNS", "navigation_errors", "compared_steps"]

#: Columns of the kernel's output.
ERROR_COLUMNS = ("north_m", "east_m", "horizontal_m", "v_north_mps", "v_east_mps", "v_down_mps", "attitude_rad")


@kernel
def _slerp_angle(q0, q1, u, q_nav):
    """Attitude angle [rad] between ``q_nav`` and the slerp of unit quaternions q0 -> q1 at u."""
    a0, a1, a2, a3 = q0[0], q0[1], q0[2], q0[3]
    b0, b1, b2, b3 = q1[0], q1[1], q1[2], q1[3]
    if a0 * b0 + a1 * b1 + a2 * b2 + a3 * b3 < 0.0:  # the shorter way round
        b0, b1, b2, b3 = -b0, -b1, -b2, -b3
    # rel = conj(q0) * q1
    r0 = a0 * b0 + a1 * b1 + a2 * b2 + a3 * b3
    r1 = a0 * b1 - a1 * b0 - a2 * b3 + a3 * b2
    r2 = a0 * b2 + a1 * b3 - a2 * b0 - a3 * b1
    r3 = a0 * b3 - a1 * b2 + a2 * b1 - a3 * b0
    vn = math.sqrt(r1 * r1 + r2 * r2 + r3 * r3)
    angle = 2.0 * math.atan2(vn, r0)
    if vn > 1e-300:
        x1, x2, x3 = r1 / vn, r2 / vn, r3 / vn
    else:
        x1 = x2 = x3 = 0.0
    half = 0.5 * angle * u
    c, s = math.cos(half), math.sin(half)
    s1, s2, s3 = s * x1, s * x2, s * x3
    # ref = q0 * step, normalised
    p0 = a0 * c - a1 * s1 - a2 * s2 - a3 * s3
    p1 = a0 * s1 + a1 * c + a2 * s3 - a3 * s2
    p2 = a0 * s2 - a1 * s3 + a2 * c + a3 * s1
    p3 = a0 * s3 + a1 * s2 - a2 * s1 + a3 * c
    norm = math.sqrt(p0 * p0 + p1 * p1 + p2 * p2 + p3 * p3)
    p0, p1, p2, p3 = p0 / norm, p1 / norm, p2 / norm, p3 / norm
    # conj(ref) * q_nav
    n0, n1, n2, n3 = q_nav[0], q_nav[1], q_nav[2], q_nav[3]
    e0 = p0 * n0 + p1 * n1 + p2 * n2 + p3 * n3
    e1 = p0 * n1 - p1 * n0 - p2 * n3 + p3 * n2
    e2 = p0 * n2 + p1 * n3 - p2 * n0 - p3 * n1
    e3 = p0 * n3 - p1 * n2 + p2 * n1 - p3 * n0
    return 2.0 * math.atan2(math.sqrt(e1 * e1 + e2 * e2 + e3 * e3), abs(e0))


@kernel
def navigation_errors(
    t, quat_nb, v_n, lat, lon, ref_t, ref_q, ref_lat, ref_lon, ref_h, ref_v, position, velocity, attitude, out
):
    """Fill ``out [N, 7]`` (:data:`ERROR_COLUMNS`) at the increasing times ``t [N]``.

    ``ref_*``: the reference rows (at least 2); ``position``, ``velocity``, ``attitude``: which
    errors to form (the others' columns are left as they are).
    """
    n_ref = ref_t.shape[0]
    k = 0
    for i in range(t.shape[0]):
        ti = t[i]
        while k < n_ref - 2 and ref_t[k + 1] <= ti:
            k += 1
        span = ref_t[k + 1] - ref_t[k]
        u = min(1.0, max(0.0, (ti - ref_t[k]) / span))
        if position:
            r_lat = ref_lat[k] + (ref_lat[k + 1] - ref_lat[k]) * u
            r_lon = ref_lon[k] + (ref_lon[k + 1] - ref_lon[k]) * u
            r_h = ref_h[k] + (ref_h[k + 1] - ref_h[k]) * u
            r_mer, r_tr = radii_m(r_lat)
            dn = (lat[i] - r_lat) * (r_mer + r_h)
            de = (lon[i] - r_lon) * (r_tr + r_h) * math.cos(r_lat)
            out[i, 0] = dn
            out[i, 1] = de
            out[i, 2] = math.sqrt(dn * dn + de * de)
        if velocity:
            for j in range(3):
                out[i, 3 + j] = v_n[i, j] - (ref_v[k, j] + (ref_v[k + 1, j] - ref_v[k, j]) * u)
        if attitude:
            out[i, 6] = _slerp_angle(ref_q[k], ref_q[k + 1], u, quat_nb[i])


@kernel
def compared_steps(t, ref_t, first_s, last_s, sparse, tol_s, idx):
    """The navigation steps the reference is compared at: fills ``idx`` with the indices of the
    increasing times ``t`` that lie within ``[first_s, last_s + 1e-9]`` (the whole reference's span)
    and, where ``sparse`` and the window ``ref_t`` (increasing) has two rows or more, lie within
    ``tol_s`` of its nearest row; returns how many.

    The neighbours of ``t[i]`` are ``ref_t[k - 1]`` and ``ref_t[k]``, ``k`` the first row at or after it
    clipped to ``1 .. len - 1`` (``numpy.searchsorted``, side left), found by one walk along both
    arrays instead of a search per step. The NumPy twin is in ``tests/test_navigate_errors.py``.
    """
    n_ref = ref_t.shape[0]
    check = sparse and n_ref > 1
    m = 0
    k = 0
    for i in range(t.shape[0]):
        ti = t[i]
        if not (ti >= first_s and ti <= last_s + 1e-9):
            continue
        if check:
            while k < n_ref and ref_t[k] < ti:
                k += 1
            j = min(max(k, 1), n_ref - 1)
            if not min(abs(ref_t[j] - ti), abs(ref_t[j - 1] - ti)) < tol_s:
                continue
        idx[m] = i
        m += 1
    return m
