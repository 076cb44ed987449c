"""Two-speed strapdown mechanisation in the local-level NED frame on WGS-84.

The IMU increments are sub-samples. Every ``n_sub`` of them form one
navigation interval of length ``T``. Within it, multi-subsample coning and
sculling corrections are accumulated. Then attitude, velocity and position
are updated once.

- Rotation vector (Bortz), with the Miller/Ignagni/Lee coefficients ``k_ij``:
  ``phi = sum(a_i) + sum_{i<j} k_ij a_i x a_j``.
- Sculling, by the coning/sculling duality (Ignagni 1998):
  ``dv_b = sum(u_i) + 1/2 (a x u) + sum_{i<j} k_ij (a_i x u_j + u_i x a_j)``,
  where ``a_i`` and ``u_i`` are the angle and velocity increments.
- Attitude: ``q_k = q(-zeta) * q_{k-1} * q(phi)``, with
  ``zeta = (omega_ie_n + omega_en_n) T`` at the interval midpoint. Both small
  rotations are applied exactly (closed-form quaternion of a rotation vector).
  The quaternion is normalised every step.
- Velocity: ``v_k = v_{k-1} + (I - 1/2 [zeta x]) C_nb(k-1) dv_b
  + (g_n - (2 omega_ie_n + omega_en_n) x v) T``. The Earth and transport terms,
  gravity and the velocity in the Coriolis term are taken at the interval
  midpoint, extrapolated from the two previous steps (Savage 1998, sec. 7.2).
- Position: trapezoidal in velocity with midpoint radii; Groves eqs. 5.56-5.57.
  Latitude and longitude are summed with Kahan compensation: a 400 Hz step of a
  slow drift (1e-17 rad at 3e-8 m/s) lies below the float64 spacing of a latitude
  near 1 rad (2e-16) and would otherwise be lost, step after step.

References
----------
P. G. Savage, "Strapdown inertial navigation integration algorithm design",
JGCD 21(1-2), 1998. M. B. Ignagni, "Efficient class of optimized coning
compensation algorithms", JGCD 19(2), 1996, and "Duality of optimal strapdown
sculling and coning compensation algorithms", Navigation 45(2), 1998.
D. Titterton & J. Weston, *Strapdown Inertial Navigation Technology*, 2nd ed.,
ch. 11. P. D. Groves, *Principles of GNSS, Inertial, and Multisensor Integrated
Navigation Systems*, 2nd ed., ch. 5.
"""

from __future__ import annotations

import math

import numpy as np

from ..constants import OMEGA_EARTH_RAD_S
from .earth import gravity_ned, radii_m
from .jit import kernel
from .modes import VERTICAL_FREE, VERTICAL_HELD, VERTICAL_REFERENCE

__all__ = [
    "coning_coefficients",
    "STATE_SIZE",
    "VERTICAL_FREE",
    "VERTICAL_HELD",
    "VERTICAL_REFERENCE",
    "strapdown",
    "pack_state",
]

#: layout of the state vector carried between calls (chunks)
#: q[0:4], v_n[4:7], lat, lon, h [7:10], lat_prev, h_prev [10:12], v_prev [12:15], have_prev [15],
#: Kahan compensation of lat, lon [16:18]
STATE_SIZE = 18

#: Coning coefficients k_ij (i < j), optimal for pure coning: Miller 1983 (2 and 3
#: sub-samples as in Ignagni 1990), Lee et al. 1990 (4 sub-samples).
_CONING = {
    1: {},
    2: {(0, 1): 2.0 / 3.0},
    3: {(0, 2): 33.0 / 80.0, (0, 1): 57.0 / 80.0, (1, 2): 57.0 / 80.0},
    4: {
        (0, 1): 736.0 / 945.0,
        (2, 3): 736.0 / 945.0,
        (0, 2): 334.0 / 945.0,
        (1, 3): 334.0 / 945.0,
        (0, 3): 526.0 / 945.0,
        (1, 2): 654.0 / 945.0,
    },
}


def coning_coefficients(n_sub: int) -> np.ndarray:
    """Upper-triangular ``[n_sub, n_sub]`` matrix of k_ij; ``n_sub`` from 1 to 4."""
    if n_sub not in _CONING:
        raise ValueError(f"sub-samples must be 1, 2, 3 or 4, got {n_sub}")
    k = np.zeros((n_sub, n_sub))
    for (i, j), value in _CONING[n_sub].items():
        k[i, j] = value
    return k


def pack_state(quat_nb, v_n, lat_rad, lon_rad, h_m) -> np.ndarray:
    """Initial state vector for :func:`strapdown`."""
    s = np.zeros(STATE_SIZE)
    s[0:4] = np.asarray(quat_nb, dtype=float) / np.linalg.norm(quat_nb)
    s[4:7] = v_n
    s[7], s[8], s[9] = lat_rad, lon_rad, h_m
    return s


@kernel
def _quat_of_rotvec(x, y, z):
    """Scalar-first quaternion of the rotation vector (x, y, z) [rad]; series below 1e-4 rad."""
    a2 = x * x + y * y + z * z
    if a2 < 1e-8:
        c = 1.0 - a2 / 8.0 + a2 * a2 / 384.0
        s = 0.5 - a2 / 48.0 + a2 * a2 / 3840.0
    else:
        a = math.sqrt(a2)
        c = math.cos(0.5 * a)
        s = math.sin(0.5 * a) / a
    return c, s * x, s * y, s * z


@kernel
def strapdown(
    dtheta,
    dvel,
    n_sub,
    coeffs,
    dt_nav,
    state,
    vertical_mode,
    h_hold,
    h_ref,
    vd_ref,
    out_quat,
    out_v,
    out_lat,
    out_lon,
    out_h,
):
    """Integrate ``n_steps = len(out_lat)`` navigation intervals; update ``state`` in place.

    Parameters
    ----------
    dtheta, dvel : float64 [n_steps * n_sub, 3]
        Angle [rad] and velocity [m/s] increments, body FRD.
    n_sub : int
        Sub-samples per navigation interval (1..4).
    coeffs : float64 [n_sub, n_sub]
        Coning/sculling coefficients (:func:`coning_coefficients`).
    dt_nav : float
        Navigation interval T [s] (n_sub sample periods).
    state : float64 [STATE_SIZE]
        In: the state at the start; out: at the end (see ``STATE_SIZE``).
    vertical_mode : int
        VERTICAL_FREE, VERTICAL_HELD (height ``h_hold``) or VERTICAL_REFERENCE
        (``h_ref``, ``vd_ref`` [n_steps]: height and down velocity at each step end).
    out_quat [n_steps, 4], out_v [n_steps, 3], out_lat, out_lon, out_h [n_steps]
        The state at the end of each interval.
    """
    n_steps = out_lat.shape[0]
    T = dt_nav
    q0, q1, q2, q3 = state[0], state[1], state[2], state[3]
    vn, ve, vd = state[4], state[5], state[6]
    lat, lon, h = state[7], state[8], state[9]
    lat_p, h_p = state[10], state[11]
    vn_p, ve_p, vd_p = state[12], state[13], state[14]
    have_prev = state[15] > 0.5
    c_lat, c_lon = state[16], state[17]
    for step in range(n_steps):
        j0 = step * n_sub
        # -- sums, coning and sculling over the sub-samples
        ax = ay = az = ux = uy = uz = 0.0
        cx = cy = cz = sx = sy = sz = 0.0
        for i in range(n_sub):
            aix, aiy, aiz = dtheta[j0 + i, 0], dtheta[j0 + i, 1], dtheta[j0 + i, 2]
            uix, uiy, uiz = dvel[j0 + i, 0], dvel[j0 + i, 1], dvel[j0 + i, 2]
            ax += aix
            ay += aiy
            az += aiz
            ux += uix
            uy += uiy
            uz += uiz
            for j in range(i + 1, n_sub):
                k = coeffs[i, j]
                ajx, ajy, ajz = dtheta[j0 + j, 0], dtheta[j0 + j, 1], dtheta[j0 + j, 2]
                ujx, ujy, ujz = dvel[j0 + j, 0], dvel[j0 + j, 1], dvel[j0 + j, 2]
                cx += k * (aiy * ajz - aiz * ajy)
                cy += k * (aiz * ajx - aix * ajz)
                cz += k * (aix * ajy - aiy * ajx)
                sx += k * ((aiy * ujz - aiz * ujy) + (uiy * ajz - uiz * ajy))
                sy += k * ((aiz * ujx - aix * ujz) + (uiz * ajx - uix * ajz))
                sz += k * ((aix * ujy - aiy * ujx) + (uix * ajy - uiy * ajx))
        phix, phiy, phiz = ax + cx, ay + cy, az + cz
        # body-frame velocity increment: sum + rotation compensation + sculling
        dbx = ux + 0.5 * (ay * uz - az * uy) + sx
        dby = uy + 0.5 * (az * ux - ax * uz) + sy
        dbz = uz + 0.5 * (ax * uy - ay * ux) + sz

        # -- midpoint of the interval, extrapolated from the previous step
        if have_prev:
            lat_m = lat + 0.5 * (lat - lat_p)
            h_m = h + 0.5 * (h - h_p)
            vn_m = vn + 0.5 * (vn - vn_p)
            ve_m = ve + 0.5 * (ve - ve_p)
            vd_m = vd + 0.5 * (vd - vd_p)
        else:
            lat_m, h_m, vn_m, ve_m, vd_m = lat, h, vn, ve, vd
        r_mer, r_tr = radii_m(lat_m)
        sl, cl = math.sin(lat_m), math.cos(lat_m)
        wie_n, wie_d = OMEGA_EARTH_RAD_S * cl, -OMEGA_EARTH_RAD_S * sl
        wen_n = ve_m / (r_tr + h_m)
        wen_e = -vn_m / (r_mer + h_m)
        wen_d = -ve_m * sl / cl / (r_tr + h_m)
        zx, zy, zz = (wie_n + wen_n) * T, wen_e * T, (wie_d + wen_d) * T
        g_n, g_d = gravity_ned(lat_m, h_m)

        # -- velocity: rotate dv_b with the attitude at the start, then the frame-rotation term
        r00 = q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3
        r01 = 2.0 * (q1 * q2 - q0 * q3)
        r02 = 2.0 * (q1 * q3 + q0 * q2)
        r10 = 2.0 * (q1 * q2 + q0 * q3)
        r11 = q0 * q0 - q1 * q1 + q2 * q2 - q3 * q3
        r12 = 2.0 * (q2 * q3 - q0 * q1)
        r20 = 2.0 * (q1 * q3 - q0 * q2)
        r21 = 2.0 * (q2 * q3 + q0 * q1)
        r22 = q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3
        dnx = r00 * dbx + r01 * dby + r02 * dbz
        dny = r10 * dbx + r11 * dby + r12 * dbz
        dnz = r20 * dbx + r21 * dby + r22 * dbz
        fx = dnx - 0.5 * (zy * dnz - zz * dny)
        fy = dny - 0.5 * (zz * dnx - zx * dnz)
        fz = dnz - 0.5 * (zx * dny - zy * dnx)
        # Coriolis and transport: (2 omega_ie + omega_en) x v at the midpoint
        wx, wy, wz = 2.0 * wie_n + wen_n, wen_e, 2.0 * wie_d + wen_d
        cor_x = wy * vd_m - wz * ve_m
        cor_y = wz * vn_m - wx * vd_m
        cor_z = wx * ve_m - wy * vn_m
        vn_new = vn + fx + (g_n - cor_x) * T
        ve_new = ve + fy + (0.0 - cor_y) * T
        vd_new = vd + fz + (g_d - cor_z) * T

        # -- attitude: q <- q(-zeta) * q * q(phi), normalised
        b0, b1, b2, b3 = _quat_of_rotvec(phix, phiy, phiz)
        t0 = q0 * b0 - q1 * b1 - q2 * b2 - q3 * b3
        t1 = q0 * b1 + q1 * b0 + q2 * b3 - q3 * b2
        t2 = q0 * b2 - q1 * b3 + q2 * b0 + q3 * b1
        t3 = q0 * b3 + q1 * b2 - q2 * b1 + q3 * b0
        n0, n1, n2, n3 = _quat_of_rotvec(-zx, -zy, -zz)
        q0 = n0 * t0 - n1 * t1 - n2 * t2 - n3 * t3
        q1 = n0 * t1 + n1 * t0 + n2 * t3 - n3 * t2
        q2 = n0 * t2 - n1 * t3 + n2 * t0 + n3 * t1
        q3 = n0 * t3 + n1 * t2 - n2 * t1 + n3 * t0
        norm = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
        q0 /= norm
        q1 /= norm
        q2 /= norm
        q3 /= norm

        # -- vertical channel
        if vertical_mode == VERTICAL_HELD:
            vd_new = 0.0
            h_new = h_hold
        elif vertical_mode == VERTICAL_REFERENCE:
            vd_new = vd_ref[step]
            h_new = h_ref[step]
        else:
            h_new = h - 0.5 * (vd + vd_new) * T
        # -- position, trapezoidal in velocity with midpoint radii
        h_mid = 0.5 * (h + h_new)
        y = 0.5 * (vn + vn_new) * T / (r_mer + h_mid) - c_lat
        lat_new = lat + y
        c_lat = (lat_new - lat) - y
        y = 0.5 * (ve + ve_new) * T / ((r_tr + h_mid) * cl) - c_lon
        lon_new = lon + y
        c_lon = (lon_new - lon) - y

        lat_p, h_p, vn_p, ve_p, vd_p = lat, h, vn, ve, vd
        have_prev = True
        lat, lon, h, vn, ve, vd = lat_new, lon_new, h_new, vn_new, ve_new, vd_new
        out_quat[step, 0] = q0
        out_quat[step, 1] = q1
        out_quat[step, 2] = q2
        out_quat[step, 3] = q3
        out_v[step, 0] = vn
        out_v[step, 1] = ve
        out_v[step, 2] = vd
        out_lat[step] = lat
        out_lon[step] = lon
        out_h[step] = h
    state[0], state[1], state[2], state[3] = q0, q1, q2, q3
    state[4], state[5], state[6] = vn, ve, vd
    state[7], state[8], state[9] = lat, lon, h
    state[10], state[11] = lat_p, h_p
    state[12], state[13], state[14] = vn_p, ve_p, vd_p
    state[15] = 1.0 if have_prev else 0.0
    state[16], state[17] = c_lat, c_lon
