"""What the IMU should have read: the sensor model evaluated on the reference motion.

:func:`predict_readings` is the sensor model, in one function (the simulator's,
:mod:`sizefx.simulate`, evaluated on the record's reference instead of an analytic trajectory):

- gyro ``(1 + s_g) (u_g . omega_ib) + b_g + G f_b`` with the reference motion at
  ``t + tau_ref`` (reference rows stamped t hold the motion at t - tau_ref) and the attitude
  tilted by ``R(phi)``;
- accelerometer ``(1 + s_a) a + K2 a^2 + b_a``, ``a = u_i . (f_b + omegadot x r_i + omega x
  (omega x r_i))``, all at ``t - tau_acc``. ``f_b`` comes from the reference; the lever terms use
  the *gyros* (corrected by the model's gyro errors) and their Savitzky-Golay derivative over
  25 ms, as compensation uses measured rates: a motion-capture reference differentiated twice
  would bury omegadot in noise.

:class:`Predictor` holds the measured record on its samples and evaluates the model there;
increments records are compared as interval means (the prediction at each interval's midpoint
plus ``dt^2 / 24`` times its second derivative: the mean of a smooth signal over the interval,
to ``dt^4``).
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline

from ..io.telemetry import Telemetry
from ..omegadot import savgol
from ..rotation import rotvec_to_mat
from .reference import EDGE_S, MIN_SAMPLES, DiagnoseError, ReferenceMotion, check_record, usable_mask
from .theta import A_BIAS, A_K2, A_MIS, A_SF, G_BIAS, G_G, G_MIS, G_SF, LEVER, TAU_A, TAU_R, TILT, misaligned_axes

__all__ = ["Predictor", "predict_readings", "tilted_to_body", "GYRO_DOT_WINDOW_S"]

#: Span of the Savitzky-Golay gyro derivative [s]: 41 samples at 1600 Hz, 7 at 286 Hz.
GYRO_DOT_WINDOW_S = 0.025
#: Most cached evaluations per time shift (the delays move a little each Gauss-Newton pass).
_CACHED_SHIFTS = 8


def tilted_to_body(kin: dict, vec_n: np.ndarray, r_tilt: np.ndarray) -> np.ndarray:
    """``C_bn R(phi)^T v`` per row [n, 3]: an NED vector ``vec_n`` [n, 3] in the tilted body axes.

    The true ``C_bn`` is ``C_bn_ref R(phi)^T``; ``R^T v`` per row is ``v @ R``.
    """
    return np.einsum("nij,nj->ni", kin["C_bn"], vec_n @ r_tilt)


def predict_readings(theta: np.ndarray, kin_gyro: dict, kin_accel: dict, gyro_b: np.ndarray,
                     gyro_dot_b: np.ndarray) -> tuple[np.ndarray, dict]:
    """The sensor model: predicted gyro and accelerometer readings under the model vector ``theta``.

    Parameters
    ----------
    theta : [NP] the model vector (SI; layout in :mod:`sizefx.diagnose.theta`).
    kin_gyro, kin_accel : the reference motion (:meth:`ReferenceMotion.evaluate`) at the gyros'
        time ``t + tau_ref`` and the accelerometers' ``t + tau_ref - tau_acc``.
    gyro_b, gyro_dot_b : [n, 3] measured rates (rad/s) and their derivative (rad/s^2) at
        ``t - tau_acc``, body axes: the lever terms' omega and omegadot.

    Returns
    -------
    readings : [n, 6] gyro x, y, z (rad/s), accelerometer x, y, z (m/s^2), point values.
    terms : the intermediate terms (rates, specific forces, axes, gains) that the Jacobian
        columns (:func:`sizefx.diagnose.candidates.jacobian_columns`) reuse.
    """
    th = theta
    r_tilt = rotvec_to_mat(np.array([th[TILT[0]], th[TILT[1]], 0.0]))
    kg, ka = kin_gyro, kin_accel
    w_ib = kg["w_nb"] + tilted_to_body(kg, kg["w_in"], r_tilt)
    f_g = tilted_to_body(kg, kg["f_n"], r_tilt)
    f_a = tilted_to_body(ka, ka["f_n"], r_tilt)
    u_g = misaligned_axes(th[G_MIS])
    m_g = np.diag(1.0 + th[G_SF]) @ u_g
    g_sens = th[G_G].reshape(3, 3)
    inv_g = np.linalg.inv(m_g)
    w = (gyro_b - th[G_BIAS] - f_a @ g_sens.T) @ inv_g.T  # the gyros, corrected by the model
    wd = gyro_dot_b @ inv_g.T  # (G times the derivative of f is left out: below 1e-9 of the lever terms)
    u_a = misaligned_axes(th[A_MIS])
    arms = th[LEVER].reshape(3, 3)
    w2 = np.sum(w * w, axis=1)
    # a_i = u_i . (f + wd x r_i + w (w . r_i) - r_i |w|^2), with u . (wd x r) = wd . (r x u)
    lever = np.column_stack([wd @ np.cross(arms[i], u_a[i]) + (w @ u_a[i]) * (w @ arms[i])
                             - w2 * (u_a[i] @ arms[i]) for i in range(3)])
    f_i = [f_a + np.cross(wd, arms[i]) + w * (w @ arms[i])[:, None] - w2[:, None] * arms[i] for i in range(3)]
    a = np.column_stack([f_a @ u_a[i] for i in range(3)]) + lever
    out = np.empty((w_ib.shape[0], 6))
    out[:, :3] = w_ib @ m_g.T + th[G_BIAS] + f_g @ g_sens.T
    out[:, 3:] = (1.0 + th[A_SF]) * a + th[A_K2] * a * a + th[A_BIAS]
    terms = {"w_ib": w_ib, "f_g": f_g, "u_g": u_g, "m_g": m_g, "g_sens": g_sens, "w": w, "wd": wd, "w2": w2,
             "u_a": u_a, "a": a, "f_i": f_i, "f_a": f_a, "kg": kg, "ka": ka, "r_tilt": r_tilt}
    return out, terms


class Predictor:
    """Measured record on the IMU samples, and the prediction of it under a model vector.

    ``t`` [n] (s; interval midpoints for increments), ``measured`` [n, 6] (rad/s, m/s^2: gyro
    x, y, z, accelerometer x, y, z; mean rates for increments), ``mask`` [n] the samples the
    fit may use (:func:`sizefx.diagnose.reference.usable_mask`).
    """

    def __init__(self, tel: Telemetry):
        check_record(tel)
        from ..compensate import sync_accelerometers

        tel = sync_accelerometers(tel)  # separate accelerometer stamps are a known sync, not an effect
        dt = tel.sample_period_s
        if tel.form == "rates":
            t, gyro, accel = tel.time_s, tel.gyro_rad_s, tel.accel_mps2
        else:  # mean rates over each interval, stamped at its midpoint (predict() predicts the mean)
            t, gyro, accel = tel.time_s - 0.5 * dt, tel.dtheta_rad / dt, tel.dvel_mps / dt
        self.increments = tel.form == "increments"
        self.path = tel.path
        self.dt = dt
        self.t = np.asarray(t, dtype=float)
        self.gyro = np.asarray(gyro, dtype=float)
        self.accel = np.asarray(accel, dtype=float)
        self.measured = np.hstack([self.gyro, self.accel])
        window = max(5, round(GYRO_DOT_WINDOW_S / dt) // 2 * 2 + 1)
        self.window = window
        self.gyro_dot = savgol(self.gyro, dt, window=window)
        self.motion = ReferenceMotion(tel)
        self.mask = usable_mask(self.t, tel, window=window, dt=dt)
        if self.mask.sum() < MIN_SAMPLES:
            raise DiagnoseError(f"{tel.path}: only {int(self.mask.sum())} IMU samples lie inside the reference's "
                                f"span (minus {EDGE_S * 1e3:.0f} ms at ends and gaps); diagnose needs {MIN_SAMPLES}")
        self._kin = {}
        self._gyro_at = {}
        self._spline = None

    def kin(self, shift: float) -> dict:
        """The reference motion at ``t + shift`` (clipped to the reference's span)."""
        key = round(shift, 12)
        if key not in self._kin:
            if len(self._kin) > _CACHED_SHIFTS:
                self._kin.pop(next(iter(self._kin)))
            tt = np.clip(self.t + shift, self.motion.t[0], self.motion.t[-1])
            self._kin[key] = self.motion.evaluate(tt)
        return self._kin[key]

    def gyro_at(self, shift: float):
        """Measured rate and its derivative at ``t + shift`` (cubic spline between samples)."""
        key = round(shift, 12)
        if key == 0.0:
            return self.gyro, self.gyro_dot
        if key not in self._gyro_at:
            if self._spline is None:
                self._spline = CubicSpline(self.t, np.hstack([self.gyro, self.gyro_dot]), axis=0)
            if len(self._gyro_at) > _CACHED_SHIFTS:
                self._gyro_at.pop(next(iter(self._gyro_at)))
            v = self._spline(np.clip(self.t + shift, self.t[0], self.t[-1]))
            self._gyro_at[key] = (v[:, :3], v[:, 3:])
        return self._gyro_at[key]

    def _evaluate(self, th: np.ndarray):
        w_meas, wd_meas = self.gyro_at(-th[TAU_A])
        return predict_readings(th, self.kin(th[TAU_R]), self.kin(th[TAU_R] - th[TAU_A]), w_meas, wd_meas)

    def terms(self, th: np.ndarray) -> dict:
        """The sensor model's intermediate terms at ``th`` (for the Jacobian columns)."""
        return self._evaluate(th)[1]

    def predict(self, th: np.ndarray) -> np.ndarray:
        """Predicted ``[n, 6]`` (gyro x, y, z, accel x, y, z) under the model vector ``th``."""
        out = self._evaluate(th)[0]
        if self.increments:  # the interval mean: midpoint value + dt^2/24 x'' (exact to dt^4)
            out += self.dt**2 / 24.0 * np.gradient(np.gradient(out, self.t, axis=0), self.t, axis=0)
        return out
