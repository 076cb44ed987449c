"""The true motion of the IMU and the ideal readings it makes: the trajectory with the level tilt and
the reference's mount (:func:`true_motion`), and the ideal gyro rates and accelerometer inputs at each
instant (:func:`kinematics`), before the sensors' errors and any integration."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import earth
from ..effects import EffectModel
from ..motion import Trajectory
from ..sensor_model import Motion, SensorParams, accel_inputs, mount_matrix, true_attitude

__all__ = ["ImuKinematics", "kinematics", "true_motion"]


@dataclass
class ImuKinematics:
    """Ideal inertial quantities at ``n`` instants."""

    omega_ib_b: np.ndarray  #: [n,3] rad/s
    omegadot_ib_b: np.ndarray  #: [n,3] rad/s^2
    f_b: np.ndarray  #: [n,3] m/s^2, specific force at the reference point
    accel_input: np.ndarray  #: [n,3] m/s^2, u_i . f_i: what ideal accelerometer i at r_i reads


def _params(effects) -> SensorParams:
    return effects if isinstance(effects, SensorParams) else effects.sensor_params()


def true_motion(traj: Trajectory, t, params: SensorParams) -> Motion:
    """The true motion of the reference point at times ``t`` [n], IMU axes: the trajectory with the
    level tilt and the reference's mount.

    Carries ``mat_nb`` and ``omega_in_b`` as well, for :func:`sizefx.sensor_model.jacobian`'s tilt columns.
    """
    st = traj.evaluate(t)
    mat_nb = true_attitude(params, st.mat_nb)
    mat_bn = np.swapaxes(mat_nb, -1, -2)
    w_ie = earth.omega_ie_n(st.lat_rad)
    w_en = earth.omega_en_n(st.lat_rad, st.height_m, st.v_n)
    w_in_b = np.einsum("nij,nj->ni", mat_bn, w_ie + w_en)
    wdot_in_n = earth.omegadot_in_n(st.lat_rad, st.height_m, st.v_n, st.vdot_n)
    w_nb, wdot_nb = st.omega_nb_b, st.omegadot_nb_b  # the trajectory's body axes: the reference's
    if np.any(params.reference_mount):  # a constant mount turns them into the IMU's (C (a x b) = Ca x Cb)
        mount = mount_matrix(params)
        w_nb, wdot_nb = w_nb @ mount.T, wdot_nb @ mount.T
    omega = w_nb + w_in_b
    omegadot = wdot_nb - np.cross(w_nb, w_in_b) + np.einsum("nij,nj->ni", mat_bn, wdot_in_n)
    f_n = st.vdot_n + np.cross(2.0 * w_ie + w_en, st.v_n) - earth.gravity_n(st.lat_rad, st.height_m)
    f_b = np.einsum("nij,nj->ni", mat_bn, f_n)
    return Motion(omega, omegadot, f_b, mat_nb=mat_nb, omega_in_b=w_in_b)


def kinematics(traj: Trajectory, t, effects: EffectModel | SensorParams) -> ImuKinematics:
    """Ideal gyro rates and accelerometer inputs at times ``t`` (true attitude includes the level tilt)."""
    p = _params(effects)
    m = true_motion(traj, t, p)
    return ImuKinematics(m.omega_ib_b, m.omegadot_ib_b, m.f_b, accel_inputs(p, m))
