"""Size-effect compensation (Morozov & Bogdanov 2024, eqs. 1-3), rate and increment domains.

Accelerometer i at ``r_i`` with sensitive axis ``u_i`` reads, besides the specific
force at the reference point, ``u_i . (omegadot x r_i + omega x (omega x r_i))``:
the tangential and centripetal terms (the paper's ``u_i^T Omegadot r_i`` and
``u_i^T Omega^2 r_i``). These kernels subtract them.
"""

from __future__ import annotations

from .jit import kernel


@kernel
def _lever_along(u0, u1, u2, rx, ry, rz, wx, wy, wz, tx, ty, tz, w_scale, centripetal, tangential):
    """``u . (t x r + w_scale * w x (w x r))`` with the terms switched as asked."""
    lx = ly = lz = 0.0
    if tangential:
        lx += ty * rz - tz * ry
        ly += tz * rx - tx * rz
        lz += tx * ry - ty * rx
    if centripetal:
        wr = wx * rx + wy * ry + wz * rz
        w2 = wx * wx + wy * wy + wz * wz
        lx += w_scale * (wx * wr - w2 * rx)
        ly += w_scale * (wy * wr - w2 * ry)
        lz += w_scale * (wz * wr - w2 * rz)
    return u0 * lx + u1 * ly + u2 * lz


@kernel
def compensate_rates(accel, omega, omegadot, arms, axes, centripetal, tangential, out):
    """``out[k, i] = accel[k, i] - u_i . (omegadot_k x r_i + omega_k x (omega_k x r_i))``.

    accel, omega, omegadot, out : float64 [N, 3] (m/s^2, rad/s, rad/s^2, body axes)
    arms : [3, 3] rows r_x, r_y, r_z [m]; axes : [3, 3] rows u_x, u_y, u_z (unit)
    centripetal, tangential : bool, which terms to remove.
    """
    for k in range(accel.shape[0]):
        for i in range(3):
            out[k, i] = accel[k, i] - _lever_along(
                axes[i, 0],
                axes[i, 1],
                axes[i, 2],
                arms[i, 0],
                arms[i, 1],
                arms[i, 2],
                omega[k, 0],
                omega[k, 1],
                omega[k, 2],
                omegadot[k, 0],
                omegadot[k, 1],
                omegadot[k, 2],
                1.0,
                centripetal,
                tangential,
            )


@kernel
def compensate_increments(dvel, dtheta, omega_edges, dt, arms, axes, centripetal, tangential, out):
    """Increment domain: ``out[k, i] = dvel[k, i] - u_i . (tangential_k + centripetal_k)``.

    The tangential term integrates exactly to ``(omega(t_k) - omega(t_{k-1})) x r_i``:
    a difference of rates at the interval edges (``omega_edges [N + 1, 3]``), with no
    division by dt and so no amplification of gyro noise. The centripetal term is
    ``dt omega x (omega x r_i)`` with the interval's mean rate ``dtheta / dt``
    (second order).
    """
    for k in range(dvel.shape[0]):
        for i in range(3):
            out[k, i] = dvel[k, i] - _lever_along(
                axes[i, 0],
                axes[i, 1],
                axes[i, 2],
                arms[i, 0],
                arms[i, 1],
                arms[i, 2],
                dtheta[k, 0] / dt,
                dtheta[k, 1] / dt,
                dtheta[k, 2] / dt,
                omega_edges[k + 1, 0] - omega_edges[k, 0],
                omega_edges[k + 1, 1] - omega_edges[k, 1],
                omega_edges[k + 1, 2] - omega_edges[k, 2],
                dt,
                centripetal,
                tangential,
            )


@kernel
def compensate_increments_edges(dvel, dtheta, dt, arms, axes, centripetal, tangential, out):
    """:func:`compensate_increments` with the edge rates of ``edges_from_increments`` formed on the
    fly: one pass over the data, each edge computed once, no ``[N + 1, 3]`` temporary (N >= 2).

    Rates are ``dtheta * (1 / dt)``: within an ulp of the two-pass version.
    """
    n = dvel.shape[0]
    inv = 1.0 / dt
    ex = 1.5 * (dtheta[0, 0] * inv) - 0.5 * (dtheta[1, 0] * inv)
    ey = 1.5 * (dtheta[0, 1] * inv) - 0.5 * (dtheta[1, 1] * inv)
    ez = 1.5 * (dtheta[0, 2] * inv) - 0.5 * (dtheta[1, 2] * inv)
    for k in range(n):
        wx, wy, wz = dtheta[k, 0] * inv, dtheta[k, 1] * inv, dtheta[k, 2] * inv
        if k + 1 < n:
            nx = 0.5 * (dtheta[k + 1, 0] * inv + wx)
            ny = 0.5 * (dtheta[k + 1, 1] * inv + wy)
            nz = 0.5 * (dtheta[k + 1, 2] * inv + wz)
        else:
            nx = 1.5 * wx - 0.5 * (dtheta[k - 1, 0] * inv)
            ny = 1.5 * wy - 0.5 * (dtheta[k - 1, 1] * inv)
            nz = 1.5 * wz - 0.5 * (dtheta[k - 1, 2] * inv)
        tx, ty, tz = nx - ex, ny - ey, nz - ez
        for i in range(3):
            out[k, i] = dvel[k, i] - _lever_along(
                axes[i, 0],
                axes[i, 1],
                axes[i, 2],
                arms[i, 0],
                arms[i, 1],
                arms[i, 2],
                wx,
                wy,
                wz,
                tx,
                ty,
                tz,
                dt,
                centripetal,
                tangential,
            )
        ex, ey, ez = nx, ny, nz
