"""Size-effect compensation (Morozov & Bogdanov 2024, eqs. 1-3), rate and increment domains.

Accelerometer i at ``r_i`` with sensitive axis ``u_i`` reads, besides the specific
force at the reference point, ``u_i . (omegadot x r_i + omega x (omega x r_i))``:
the tangential and centripetal terms (the paper's ``u_i^T Omegadot r_i`` and
``u_i^T Omega^2 r_i``). These kernels subtract them.
"""

from __future__ import annotations

from .jit import kernel


@kernel
def compensate_rates(accel, omega, omegadot, arms, axes, centripetal, tangential, out):
    """``out[k, i] = accel[k, i] - u_i . (omegadot_k x r_i + omega_k x (omega_k x r_i))``.

    accel, omega, omegadot, out : float64 [N, 3] (m/s^2, rad/s, rad/s^2, body axes)
    arms : [3, 3] rows r_x, r_y, r_z [m]; axes : [3, 3] rows u_x, u_y, u_z (unit)
    centripetal, tangential : bool, which terms to remove.
    """
    for k in range(accel.shape[0]):
        wx, wy, wz = omega[k, 0], omega[k, 1], omega[k, 2]
        ax, ay, az = omegadot[k, 0], omegadot[k, 1], omegadot[k, 2]
        w2 = wx * wx + wy * wy + wz * wz
        for i in range(3):
            rx, ry, rz = arms[i, 0], arms[i, 1], arms[i, 2]
            lx = ly = lz = 0.0
            if tangential:
                lx += ay * rz - az * ry
                ly += az * rx - ax * rz
                lz += ax * ry - ay * rx
            if centripetal:
                wr = wx * rx + wy * ry + wz * rz
                lx += wx * wr - w2 * rx
                ly += wy * wr - w2 * ry
                lz += wz * wr - w2 * rz
            out[k, i] = accel[k, i] - (axes[i, 0] * lx + axes[i, 1] * ly + axes[i, 2] * lz)


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
        wx, wy, wz = dtheta[k, 0] / dt, dtheta[k, 1] / dt, dtheta[k, 2] / dt
        dx = omega_edges[k + 1, 0] - omega_edges[k, 0]
        dy = omega_edges[k + 1, 1] - omega_edges[k, 1]
        dz = omega_edges[k + 1, 2] - omega_edges[k, 2]
        w2 = wx * wx + wy * wy + wz * wz
        for i in range(3):
            rx, ry, rz = arms[i, 0], arms[i, 1], arms[i, 2]
            lx = ly = lz = 0.0
            if tangential:
                lx += dy * rz - dz * ry
                ly += dz * rx - dx * rz
                lz += dx * ry - dy * rx
            if centripetal:
                wr = wx * rx + wy * ry + wz * rz
                lx += dt * (wx * wr - w2 * rx)
                ly += dt * (wy * wr - w2 * ry)
                lz += dt * (wz * wr - w2 * rz)
            out[k, i] = dvel[k, i] - (axes[i, 0] * lx + axes[i, 1] * ly + axes[i, 2] * lz)
