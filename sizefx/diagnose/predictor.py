"""What the IMU should have read: the sensor model evaluated on the reference motion.

:func:`predict_readings` evaluates :mod:`sizefx.sensor_model` (the one model simulate,
calibrate and correct use) on the record's reference instead of an analytic trajectory. What
is diagnose's own is only which motion it feeds the model:

- the gyros see the reference motion at ``t + tau_ref`` (reference rows stamped t hold the
  motion at t - tau_ref; :func:`sizefx.sensor_model.reported_time`), the accelerometers at
  ``t + tau_ref - tau_acc``, both with the attitude tilted by ``R(phi)``
  (:func:`sizefx.sensor_model.true_attitude`);
- the accelerometers' lever terms use the *gyros*, corrected by the model's gyro errors, and
  their Savitzky-Golay derivative over 25 ms, as compensation uses measured rates: a
  motion-capture reference differentiated twice would bury omegadot in noise.

:class:`Predictor` holds the measured record on its samples and evaluates the model there;
increments records are compared as interval means (the prediction at each interval's midpoint
plus ``dt^2 / 24`` times its second derivative: the mean of a smooth signal over the interval,
to ``dt^4``).
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline

from .. import sensor_model as sm
from ..io.telemetry import Telemetry
from ..omegadot import savgol
from .reference import EDGE_S, MIN_SAMPLES, DiagnoseError, ReferenceMotion, check_record, usable_mask
from .theta import TAU_A, TAU_R

__all__ = ["Predictor", "predict_readings", "GYRO_DOT_WINDOW_S"]

#: Span of the Savitzky-Golay gyro derivative [s]: 41 samples at 1600 Hz, 7 at 286 Hz.
GYRO_DOT_WINDOW_S = 0.025
#: Memory for the cached reference motion at the time shifts the delays ask for (each pass moves
#: them a little, and judging an effect evaluates the model without it): as many shifts as fit, at
#: about 150 bytes per sample each, and at least three (a 51 000-sample BROAD trial keeps 35; a
#: two-minute 1600 Hz record 9; three million samples 3).
_CACHE_BYTES = 256 * 2**20
_MIN_CACHED_SHIFTS = 3


def predict_readings(theta: np.ndarray, kin_gyro: dict, kin_accel: dict, gyro_b: np.ndarray,
                     gyro_dot_b: np.ndarray) -> tuple[np.ndarray, dict]:
    """The sensor model's readings under the model vector ``theta``, on the reference motion.

    Parameters
    ----------
    theta : [NP] the model vector (SI; :data:`sizefx.sensor_model.PARAMS`).
    kin_gyro, kin_accel : the reference motion (:meth:`ReferenceMotion.evaluate`) at the gyros'
        time ``t + tau_ref`` and the accelerometers' ``t + tau_ref - tau_acc``.
    gyro_b, gyro_dot_b : [n, 3] measured rates (rad/s) and their derivative (rad/s^2) at
        ``t - tau_acc``, the IMU's axes: the lever terms' omega and omegadot.

    The reference gives its body axes b'; with ``reference_mount`` the IMU's axes b are turned
    against them (:func:`sizefx.sensor_model.mount_matrix`): the attitude is turned by
    :func:`sizefx.sensor_model.true_attitude` (so ``f_b`` and ``C_bn omega_in`` come out in b)
    and the reference's body rates ``w_nb`` by ``C_b_b'``. The measured gyros are already in b.

    Returns
    -------
    readings : [n, 6] gyro x, y, z (rad/s), accelerometer x, y, z (m/s^2), point values.
    terms : ``{"params": SensorParams, "at_gyro": Motion, "at_accel": Motion}``, the true motion
        at each sensor's instants, which the Jacobian columns
        (:func:`sizefx.diagnose.candidates.jacobian_columns`) complete with time derivatives.
        ``at_gyro.omegadot_ib_b`` is None here (the readings do not use it).
    """
    p = sm.SensorParams.from_vector(theta)
    kg, ka = kin_gyro, kin_accel
    mat_g = sm.true_attitude(p, kg["C_bn"].swapaxes(1, 2))
    mat_a = sm.true_attitude(p, ka["C_bn"].swapaxes(1, 2))
    w_in_b = np.einsum("nji,nj->ni", mat_g, kg["w_in"])
    # a constant tilt leaves omega_nb as the reference gives it; a constant mount turns it into b
    w_nb = kg["w_nb"] @ sm.mount_matrix(p).T if np.any(p.reference_mount) else kg["w_nb"]
    w_ib = w_nb + w_in_b
    f_g = np.einsum("nji,nj->ni", mat_g, kg["f_n"])
    f_a = np.einsum("nji,nj->ni", mat_a, ka["f_n"])
    # the measured gyros with the model's gyro errors undone (G times the derivative of f is left
    # out of omegadot: G g omega against omegadot, 1e-5 relative per deg/h/g of G on the tumble)
    inv_g = np.linalg.inv(p.gyro_matrix())
    w = (gyro_b - p.gyro_bias - f_a @ p.gyro_g_sensitivity.T) @ inv_g.T
    wd = gyro_dot_b @ inv_g.T
    at_gyro = sm.Motion(w_ib, None, f_g, mat_nb=mat_g, omega_in_b=w_in_b)
    at_accel = sm.Motion(w, wd, f_a, mat_nb=mat_a)
    out = np.empty((w_ib.shape[0], 6))
    out[:, :3] = sm.gyro_readings(p, at_gyro)
    out[:, 3:] = sm.accel_readings(p, sm.accel_inputs(p, at_accel))
    return out, {"params": p, "at_gyro": at_gyro, "at_accel": at_accel}


class Predictor:
    """Measured record on the IMU samples, and the prediction of it under a model vector.

    ``t`` [n] (s; interval midpoints for increments), ``measured`` [n, 6] (rad/s, m/s^2: gyro
    x, y, z, accelerometer x, y, z; mean rates for increments), ``mask`` [n] the samples the
    fit may use (:func:`sizefx.diagnose.reference.usable_mask`). ``breaks_s``: times where the
    reference is discontinuous (:func:`sizefx.diagnose.integrity.check_reference`); the motion
    is splined per segment and the samples near each break are left out.
    """

    def __init__(self, tel: Telemetry, breaks_s=()):
        check_record(tel)
        from ..sync import sync_accelerometers

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
        self.motion = ReferenceMotion(tel, breaks_s=breaks_s)
        self.mask = usable_mask(self.t, tel, window=window, dt=dt, breaks_s=breaks_s)
        if self.mask.sum() < MIN_SAMPLES:
            raise DiagnoseError(f"{tel.path}: only {int(self.mask.sum())} IMU samples lie inside the reference's "
                                f"span (minus {EDGE_S * 1e3:.0f} ms at ends and gaps); diagnose needs {MIN_SAMPLES}")
        self._cached_shifts = max(_MIN_CACHED_SHIFTS, _CACHE_BYTES // (150 * max(1, self.t.size)))
        self._kin = {}
        self._gyro_at = {}
        self._spline = None

    def kin(self, shift: float) -> dict:
        """The reference motion at ``t + shift`` (clipped to the reference's span)."""
        key = round(shift, 12)
        if key not in self._kin:
            if len(self._kin) > self._cached_shifts:
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
            if len(self._gyro_at) > self._cached_shifts:
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
