"""Rotations: skew matrices, quaternions, direction cosine matrices, Euler angles.

Quaternions are scalar-first and Hamilton (``q = [q0, q1, q2, q3]``,
``i*j = k``); a quaternion ``q_nb`` rotates body vectors into NED,
``v_n = q_nb * v_b * conj(q_nb)``, and corresponds to ``mat_nb`` with
``v_n = mat_nb @ v_b``. Every function is vectorised over leading axes.
This is the convention of scipy's ``Rotation.from_quat(q, scalar_first=True)``
(which ``tests/test_conventions.py`` uses as an independent check).
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "skew",
    "quat_multiply",
    "quat_conjugate",
    "quat_to_mat",
    "mat_to_quat",
    "rotvec_to_mat",
    "mat_to_rotvec",
    "axis_angle_mat",
    "euler_to_mat",
    "mat_to_euler",
    "quat_interp",
    "quat_spline",
    "quat_angle_between",
]


def skew(v):
    """Skew-symmetric matrix ``[v x]`` with ``skew(a) @ b == cross(a, b)``; shape ``[..., 3, 3]``."""
    v = np.asarray(v, dtype=float)
    out = np.zeros(v.shape[:-1] + (3, 3))
    out[..., 0, 1] = -v[..., 2]
    out[..., 0, 2] = v[..., 1]
    out[..., 1, 0] = v[..., 2]
    out[..., 1, 2] = -v[..., 0]
    out[..., 2, 0] = -v[..., 1]
    out[..., 2, 1] = v[..., 0]
    return out


def quat_multiply(p, q):
    """Hamilton product ``p * q`` of scalar-first quaternions."""
    p = np.asarray(p, dtype=float)
    q = np.asarray(q, dtype=float)
    p0, p1, p2, p3 = p[..., 0], p[..., 1], p[..., 2], p[..., 3]
    q0, q1, q2, q3 = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack(
        [
            p0 * q0 - p1 * q1 - p2 * q2 - p3 * q3,
            p0 * q1 + p1 * q0 + p2 * q3 - p3 * q2,
            p0 * q2 - p1 * q3 + p2 * q0 + p3 * q1,
            p0 * q3 + p1 * q2 - p2 * q1 + p3 * q0,
        ],
        axis=-1,
    )


def quat_conjugate(q):
    """Conjugate (inverse, for unit quaternions) of scalar-first quaternions."""
    q = np.array(q, dtype=float, copy=True)
    q[..., 1:] *= -1.0
    return q


def quat_to_mat(q):
    """Direction cosine matrix ``mat_nb`` of unit quaternion ``q_nb``; shape ``[..., 3, 3]``."""
    q = np.asarray(q, dtype=float)
    q0, q1, q2, q3 = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    out = np.empty(q.shape[:-1] + (3, 3))
    out[..., 0, 0] = q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3
    out[..., 0, 1] = 2.0 * (q1 * q2 - q0 * q3)
    out[..., 0, 2] = 2.0 * (q1 * q3 + q0 * q2)
    out[..., 1, 0] = 2.0 * (q1 * q2 + q0 * q3)
    out[..., 1, 1] = q0 * q0 - q1 * q1 + q2 * q2 - q3 * q3
    out[..., 1, 2] = 2.0 * (q2 * q3 - q0 * q1)
    out[..., 2, 0] = 2.0 * (q1 * q3 - q0 * q2)
    out[..., 2, 1] = 2.0 * (q2 * q3 + q0 * q1)
    out[..., 2, 2] = q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3
    return out


def mat_to_quat(mat):
    """Unit quaternion (scalar-first, ``q0 >= 0``) of rotation matrices ``[..., 3, 3]``.

    Shepperd's method: the largest of the four candidate divisors is used, so
    the result is accurate for every rotation.
    """
    m = np.asarray(mat, dtype=float)
    shape = m.shape[:-2]
    m = m.reshape(-1, 3, 3)
    tr = m[:, 0, 0] + m[:, 1, 1] + m[:, 2, 2]
    cand = np.stack([tr, m[:, 0, 0], m[:, 1, 1], m[:, 2, 2]], axis=1)
    pick = np.argmax(cand, axis=1)
    q = np.empty((m.shape[0], 4))
    for k in range(4):
        sel = pick == k
        if not np.any(sel):
            continue
        a = m[sel]
        if k == 0:
            s = 2.0 * np.sqrt(1.0 + tr[sel])
            q[sel] = np.stack(
                [0.25 * s, (a[:, 2, 1] - a[:, 1, 2]) / s, (a[:, 0, 2] - a[:, 2, 0]) / s, (a[:, 1, 0] - a[:, 0, 1]) / s],
                axis=1,
            )
        elif k == 1:
            s = 2.0 * np.sqrt(1.0 + a[:, 0, 0] - a[:, 1, 1] - a[:, 2, 2])
            q[sel] = np.stack(
                [(a[:, 2, 1] - a[:, 1, 2]) / s, 0.25 * s, (a[:, 0, 1] + a[:, 1, 0]) / s, (a[:, 0, 2] + a[:, 2, 0]) / s],
                axis=1,
            )
        elif k == 2:
            s = 2.0 * np.sqrt(1.0 + a[:, 1, 1] - a[:, 0, 0] - a[:, 2, 2])
            q[sel] = np.stack(
                [(a[:, 0, 2] - a[:, 2, 0]) / s, (a[:, 0, 1] + a[:, 1, 0]) / s, 0.25 * s, (a[:, 1, 2] + a[:, 2, 1]) / s],
                axis=1,
            )
        else:
            s = 2.0 * np.sqrt(1.0 + a[:, 2, 2] - a[:, 0, 0] - a[:, 1, 1])
            q[sel] = np.stack(
                [(a[:, 1, 0] - a[:, 0, 1]) / s, (a[:, 0, 2] + a[:, 2, 0]) / s, (a[:, 1, 2] + a[:, 2, 1]) / s, 0.25 * s],
                axis=1,
            )
    q *= np.where(q[:, :1] < 0.0, -1.0, 1.0)
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    return q.reshape(shape + (4,))


def rotvec_to_mat(rotvec):
    """Rotation matrix ``exp([phi x])`` of rotation vectors ``phi`` [rad] (Rodrigues)."""
    phi = np.asarray(rotvec, dtype=float)
    angle = np.linalg.norm(phi, axis=-1)[..., None, None]
    small = angle < 1e-4
    # Series for small angles keeps full precision (truncation error < 1e-20).
    a2 = angle**2
    with np.errstate(invalid="ignore", divide="ignore"):
        sin_term = np.where(small, 1.0 - a2 / 6.0 + a2 * a2 / 120.0, np.sin(angle) / angle)
        cos_term = np.where(small, 0.5 - a2 / 24.0 + a2 * a2 / 720.0, (1.0 - np.cos(angle)) / a2)
    k = skew(phi)
    return np.eye(3) + sin_term * k + cos_term * (k @ k)


def mat_to_rotvec(mat):
    """Rotation vector [rad] of rotation matrices (via the quaternion; exact near 0 and pi)."""
    q = mat_to_quat(mat)
    vec = q[..., 1:]
    s = np.linalg.norm(vec, axis=-1)
    angle = 2.0 * np.arctan2(s, q[..., 0])
    with np.errstate(invalid="ignore", divide="ignore"):
        scale = np.where(s < 1e-12, 2.0 / np.maximum(q[..., 0], 1e-300), angle / s)
    return vec * scale[..., None]


def axis_angle_mat(axis, angle_rad):
    """Rotation matrices about a fixed unit ``axis`` [3] by ``angle_rad`` [...]; shape ``[..., 3, 3]``."""
    axis = np.asarray(axis, dtype=float)
    angle = np.asarray(angle_rad, dtype=float)[..., None, None]
    k = skew(axis)
    return np.eye(3) + np.sin(angle) * k + (1.0 - np.cos(angle)) * (k @ k)


def euler_to_mat(roll_rad, pitch_rad, heading_rad):
    """``mat_nb = Rz(heading) @ Ry(pitch) @ Rx(roll)`` (z-y-x Euler angles)."""
    cr, sr = np.cos(roll_rad), np.sin(roll_rad)
    cp, sp = np.cos(pitch_rad), np.sin(pitch_rad)
    ch, sh = np.cos(heading_rad), np.sin(heading_rad)
    shape = np.broadcast(cr, cp, ch).shape
    out = np.empty(shape + (3, 3))
    out[..., 0, 0] = cp * ch
    out[..., 0, 1] = sr * sp * ch - cr * sh
    out[..., 0, 2] = cr * sp * ch + sr * sh
    out[..., 1, 0] = cp * sh
    out[..., 1, 1] = sr * sp * sh + cr * ch
    out[..., 1, 2] = cr * sp * sh - sr * ch
    out[..., 2, 0] = -sp
    out[..., 2, 1] = sr * cp
    out[..., 2, 2] = cr * cp
    return out


def mat_to_euler(mat):
    """Roll, pitch, heading [rad] of ``mat_nb``; heading in (-pi, pi]."""
    m = np.asarray(mat, dtype=float)
    roll = np.arctan2(m[..., 2, 1], m[..., 2, 2])
    pitch = -np.arcsin(np.clip(m[..., 2, 0], -1.0, 1.0))
    heading = np.arctan2(m[..., 1, 0], m[..., 0, 0])
    return roll, pitch, heading


def quat_interp(t_ref, quat_ref, t):
    """Attitude at times ``t`` by spherical linear interpolation of unit quaternions ``quat_ref`` at ``t_ref``.

    ``t`` outside ``[t_ref[0], t_ref[-1]]`` takes the end rows.
    """
    t_ref = np.asarray(t_ref, dtype=float)
    q = np.asarray(quat_ref, dtype=float)
    t = np.asarray(t, dtype=float)
    k = np.clip(np.searchsorted(t_ref, t, side="right") - 1, 0, t_ref.size - 2)
    span = t_ref[k + 1] - t_ref[k]
    u = np.clip((t - t_ref[k]) / span, 0.0, 1.0)[:, None]
    q0, q1 = q[k], q[k + 1].copy()
    q1 *= np.where(np.sum(q0 * q1, axis=1, keepdims=True) < 0.0, -1.0, 1.0)  # the shorter way round
    rel = quat_multiply(quat_conjugate(q0), q1)
    vec_norm = np.linalg.norm(rel[:, 1:], axis=1, keepdims=True)
    angle = 2.0 * np.arctan2(vec_norm, rel[:, :1])
    with np.errstate(invalid="ignore", divide="ignore"):
        axis = np.where(vec_norm > 1e-300, rel[:, 1:] / vec_norm, 0.0)
    half = 0.5 * angle * u
    step = np.column_stack([np.cos(half), np.sin(half) * axis])
    out = quat_multiply(q0, step)
    return out / np.linalg.norm(out, axis=1, keepdims=True)


def quat_spline(t_ref, quat_ref, t):
    """Attitude at times ``t`` from a C2 rotation spline through unit quaternions ``quat_ref`` at ``t_ref``.

    scipy's ``RotationSpline`` (cubic in the rotation vector, continuous angular rate and
    acceleration): its error falls with the fourth power of the reference step, where
    :func:`quat_interp`'s falls with the second. Use it when the reference is much slower
    than the times asked for: linear interpolation of a 1 Hz, 30 deg/s sway sampled at
    100 Hz misplaces gravity by 40 ug, enough to bias calibrated lever arms by 0.08 mm
    (``tests/test_sizeeffect.py::test_slow_reference_gives_the_same_arms``).
    ``t`` outside ``[t_ref[0], t_ref[-1]]`` takes the end rows.
    """
    from scipy.spatial.transform import Rotation, RotationSpline  # scipy at call time: start-up cost

    t_ref = np.asarray(t_ref, dtype=float)
    q = np.asarray(quat_ref, dtype=float)
    # scipy's quaternions are scalar-last (its scalar_first keyword needs scipy 1.14)
    spline = RotationSpline(t_ref, Rotation.from_quat(q[:, [1, 2, 3, 0]]))
    return spline(np.clip(np.asarray(t, dtype=float), t_ref[0], t_ref[-1])).as_quat()[:, [3, 0, 1, 2]]


def quat_angle_between(q_a, q_b):
    """Rotation angle [rad] taking attitude ``q_a`` to ``q_b`` (both scalar-first, [..., 4])."""
    rel = quat_multiply(quat_conjugate(q_a), q_b)
    return 2.0 * np.arctan2(np.linalg.norm(rel[..., 1:], axis=-1), np.abs(rel[..., 0]))
