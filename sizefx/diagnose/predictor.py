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
  motion-capture reference differentiated twice would bury omegadot in noise. The derivative is a
  quartic's (:data:`GYRO_DOT_ORDER`), within 0.1 % of the true one up to 10 Hz, so that the arms
  estimated are the physical ones; at a step of angular acceleration (a turntable's start and
  stop) it departs from the true one, as any smoothed derivative does.

:class:`Predictor` holds the measured record on its samples and evaluates the model there;
increments records are compared as interval means (the prediction at each interval's midpoint
plus ``dt^2 / 24`` times its second derivative: the mean of a smooth signal over the interval,
to ``dt^4``).
"""

from __future__ import annotations

import contextlib
import math

import numpy as np
from scipy.interpolate import CubicSpline

from .. import sensor_model as sm
from ..constants import STANDARD_GRAVITY_MPS2
from ..io.telemetry import Telemetry
from ..omegadot import savgol_rows
from .reference import EDGE_S, MIN_SAMPLES, DiagnoseError, ReferenceMotion, check_record, usable_mask
from .theta import TAU_A, TAU_R

__all__ = ["Predictor", "predict_readings", "GYRO_DOT_WINDOW_S"]

#: Span of the Savitzky-Golay gyro derivative [s]: 41 samples at 1600 Hz, 7 at 286 Hz.
GYRO_DOT_WINDOW_S = 0.025
#: Order of its polynomial. A quadratic's derivative falls short of ``i 2 pi f`` by about
#: ``(2 pi f W)^2 / 10`` (``W`` the half span): 0.25 % at 2 Hz, and an arm's tangential term takes
#: that up as a longer arm (development seed 9, a heading sway at 200 Hz: r_y[x] 98 um off, z 2.9).
#: A quartic's shortfall is of order ``(2 pi f W)^4``, under 0.1 % up to 10 Hz (the quadratic's: 4-7 %
#: there, at 200-1600 Hz); its noise gain is 2.5-3 times the quadratic's, which on the regressor of a
#: navigation-grade gyro is still nothing.
GYRO_DOT_ORDER = 4
#: Memory for the cached reference motion at the time shifts the delays ask for (each pass moves
#: them a little, and judging an effect evaluates the model without it): as many whole-record
#: shifts as fit, at 144 bytes per sample each, when at least three do (a 51 000-sample BROAD trial
#: keeps 36; a two-minute 1600 Hz record 9); a record over 620 000 samples caches none and
#: evaluates the splines span by span instead.
_CACHE_BYTES = 256 * 2**20
_MIN_CACHED_SHIFTS = 3
#: What the reference motion at one shift takes per sample: C_bn (9), w_nb, w_in, f_n (3 each) [bytes].
_KIN_BYTES_PER_SAMPLE = 18 * 8
#: Samples beyond the delay's reach on each side of a span for the measured gyros' cubic spline: a
#: not-a-knot spline's response to a change decays by 2 - sqrt(3) = 0.27 per knot, 1e-36 after 64.
_SPLINE_MARGIN = 64


def predict_readings(
    theta: np.ndarray, kin_gyro: dict, kin_accel: dict, gyro_b: np.ndarray, gyro_dot_b: np.ndarray
) -> tuple[np.ndarray, dict]:
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
    # a partial motion (see Returns): the gyro readings do not use omegadot; jacobian_columns fills it in
    at_gyro = sm.Motion(w_ib, None, f_g, mat_nb=mat_g, omega_in_b=w_in_b)  # type: ignore[arg-type]
    at_accel = sm.Motion(w, wd, f_a, mat_nb=mat_a)
    out = np.empty((w_ib.shape[0], 6))
    out[:, :3] = sm.gyro_readings(p, at_gyro)
    out[:, 3:] = sm.accel_readings(p, sm.accel_inputs(p, at_accel))
    return out, {"params": p, "at_gyro": at_gyro, "at_accel": at_accel}


class Predictor:
    """Measured record on the IMU samples, and the prediction of it under a model vector.

    ``t`` [n] (s; interval midpoints for increments), ``gyro`` and ``accel`` [n, 3] (rad/s,
    m/s^2; mean rates for increments), ``mask`` [n] the samples the fit may use
    (:func:`sizefx.diagnose.reference.usable_mask`). ``breaks_s``: times where the reference is
    discontinuous (:func:`sizefx.diagnose.integrity.check_reference`); the motion is splined per
    segment and the samples near each break are left out.

    Bounded memory: besides the record itself the predictor holds nothing per sample but the mask.
    Everything else is evaluated on a span of samples at a time (:meth:`predict_span`,
    :meth:`terms_span`, :meth:`measured_span`), and each span gives exactly what the whole record
    would give there (the derivatives and the gyro's spline get enough samples either side; see
    ``tests/test_diagnose.py::test_spans_equal_the_whole_record``). :meth:`predict`, :meth:`terms`
    and :attr:`measured` give the whole record at once (tests, short records).
    """

    def __init__(self, tel: Telemetry, breaks_s=()):
        check_record(tel)
        from ..sync import sync_accelerometers

        tel = sync_accelerometers(tel)  # separate accelerometer stamps are a known sync, not an effect
        dt = tel.sample_period_s
        if tel.form == "rates":
            t, gyro, accel = tel.time_s, tel.gyro_rad_s, tel.accel_mps2
        else:  # mean rates over each interval, stamped at its midpoint (predict() predicts the mean)
            assert tel.dtheta_rad is not None and tel.dvel_mps is not None  # the arrays of the record's form
            t, gyro, accel = tel.time_s - 0.5 * dt, tel.dtheta_rad / dt, tel.dvel_mps / dt
        self.increments = tel.form == "increments"
        self.path = tel.path
        self.dt = dt
        self.t = np.asarray(t, dtype=float)
        self.n = self.t.size
        self.gyro = np.asarray(gyro, dtype=float)
        self.accel = np.asarray(accel, dtype=float)
        window = max(5, round(GYRO_DOT_WINDOW_S / dt) // 2 * 2 + 1)
        self.window = window
        self.motion = ReferenceMotion(tel, breaks_s=breaks_s)
        self.mask = usable_mask(self.t, tel, window=window, dt=dt, breaks_s=breaks_s)
        if self.mask.sum() < MIN_SAMPLES:
            raise DiagnoseError(
                f"{tel.path}: only {int(self.mask.sum())} IMU samples lie inside the reference's "
                f"span (minus {EDGE_S * 1e3:.0f} ms at ends and gaps); diagnose needs {MIN_SAMPLES}"
            )
        # the whole record's motion is cached per shift only while three shifts fit in _CACHE_BYTES;
        # a longer record evaluates the splines span by span (nothing cached, nothing per sample)
        fits = _CACHE_BYTES // (_KIN_BYTES_PER_SAMPLE * max(1, self.n))
        self._cached_shifts = fits if fits >= _MIN_CACHED_SHIFTS else 0
        self._motion_statistics: tuple[np.ndarray, np.ndarray] | None = None  #: motion_statistics(), once formed
        self._kin: dict[float, dict[str, np.ndarray]] = {}  #: shift (rounded) -> the motion at the samples

    # ------------------------------------------------------------------ the whole record

    @property
    def measured(self) -> np.ndarray:
        """``[n, 6]`` gyro x, y, z (rad/s), accelerometer x, y, z (m/s^2): a new array each time."""
        return self.measured_span(0, self.n)

    @property
    def gyro_dot(self) -> np.ndarray:
        """``[n, 3]`` the gyros' Savitzky-Golay derivative (rad/s^2): a new array each time."""
        return self._gyro_dot(0, self.n)

    def kin(self, shift: float) -> dict:
        """The reference motion at ``t + shift`` (clipped to the reference's span), whole record."""
        return self._kin_span(shift, 0, self.n)

    def terms(self, th: np.ndarray) -> dict:
        """The sensor model's intermediate terms at ``th`` (for the Jacobian columns), whole record."""
        return self.terms_span(th, 0, self.n)

    def predict(self, th: np.ndarray) -> np.ndarray:
        """Predicted ``[n, 6]`` (gyro x, y, z, accel x, y, z) under the model vector ``th``, whole record."""
        return self.predict_span(th, 0, self.n)

    # ------------------------------------------------------------------ a span of samples

    def measured_span(self, lo: int, hi: int) -> np.ndarray:
        """Measured ``[hi - lo, 6]`` of the samples ``lo:hi``."""
        return np.hstack([self.gyro[lo:hi], self.accel[lo:hi]])

    def motion_statistics(self, span: int) -> tuple[np.ndarray, np.ndarray]:
        """``([n], [n])``: the reference's squared rotation rate [(rad/s)^2] and how far its specific
        force is from standard gravity [m/s^2], per sample, unshifted: what the record's parts by
        rotation and by translation are sorted by. Formed once per record, ``span`` samples at a time
        (they depend on the reference alone)."""
        if self._motion_statistics is None:
            rate, translation = np.empty(self.n), np.empty(self.n)
            for lo in range(0, self.n, span):
                hi = min(self.n, lo + span)
                kin = self._kin_span(0.0, lo, hi)
                rate[lo:hi] = np.sum(kin["w_nb"] ** 2, axis=1)
                translation[lo:hi] = np.abs(np.linalg.norm(kin["f_n"], axis=1) - STANDARD_GRAVITY_MPS2)
            self._motion_statistics = (rate, translation)
        return self._motion_statistics

    def terms_span(self, th: np.ndarray, lo: int, hi: int) -> dict:
        """:meth:`terms` of the samples ``lo:hi``."""
        return self._evaluate(th, lo, hi)[1]

    def predict_span(self, th: np.ndarray, lo: int, hi: int) -> np.ndarray:
        """:meth:`predict` of the samples ``lo:hi``, equal to the whole record's there."""
        if not self.increments:
            return self._evaluate(th, lo, hi)[0]
        # the interval mean: midpoint value + dt^2/24 x'' (exact to dt^4); two gradients need two
        # samples more on each side for the span's values to be the whole record's
        a, b = max(0, lo - 2), min(self.n, hi + 2)
        out = self._evaluate(th, a, b)[0]
        t = self.t[a:b]
        out += self.dt**2 / 24.0 * np.gradient(np.gradient(out, t, axis=0), t, axis=0)
        return out[lo - a : hi - a]

    @contextlib.contextmanager
    def uncached(self):
        """Within it, the reference motion at a new shift is evaluated span by span and not cached: for
        a prediction of a few spans under a model met once (a held-out fold's), where evaluating and
        keeping the whole record's motion would cost more than the spans themselves."""
        kept, self._cached_shifts = self._cached_shifts, 0
        try:
            yield self
        finally:
            self._cached_shifts = kept

    def _kin_span(self, shift: float, lo: int, hi: int) -> dict:
        key = round(shift, 12)
        if key in self._kin:  # cached earlier, even inside uncached()
            whole = self._kin[key]
            return whole if (lo, hi) == (0, self.n) else {k: v[lo:hi] for k, v in whole.items()}
        if self._cached_shifts:
            if len(self._kin) >= self._cached_shifts:
                self._kin.pop(next(iter(self._kin)))
            tt = np.clip(self.t + shift, self.motion.t[0], self.motion.t[-1])
            whole = self._kin[key] = self.motion.evaluate(tt)
            return whole if (lo, hi) == (0, self.n) else {k: v[lo:hi] for k, v in whole.items()}
        return self.motion.evaluate(np.clip(self.t[lo:hi] + shift, self.motion.t[0], self.motion.t[-1]))

    def _gyro_dot(self, lo: int, hi: int) -> np.ndarray:
        """The Savitzky-Golay derivative of the gyros on ``lo:hi``, from the samples its windows need."""
        w = self.window
        a = 0 if lo < w else lo - w
        b = self.n if hi > self.n - w else hi + w
        if hi > self.n - w:
            a = max(0, min(a, self.n - w))
        if lo < w:
            b = min(self.n, max(b, w))
        return savgol_rows(self.gyro[a:b], a, self.n, lo, hi, self.dt, window=w, order=GYRO_DOT_ORDER)

    def gyro_at(self, shift: float, lo: int = 0, hi: int | None = None):
        """Measured rate and its derivative at ``t + shift`` on the samples ``lo:hi`` (cubic spline
        between samples, through :data:`_SPLINE_MARGIN` samples beyond the shift on either side: the
        not-a-knot spline of the whole record and of that stretch differ by 0.27 to the power of the
        margin, nothing in float64)."""
        hi = self.n if hi is None else hi
        key = round(shift, 12)
        if key == 0.0:
            return self.gyro[lo:hi], self._gyro_dot(lo, hi)
        reach = math.ceil(abs(key) / self.dt) + _SPLINE_MARGIN
        a, b = max(0, lo - reach), min(self.n, hi + reach)
        spline = CubicSpline(self.t[a:b], np.hstack([self.gyro[a:b], self._gyro_dot(a, b)]), axis=0)
        v = spline(np.clip(self.t[lo:hi] + shift, self.t[0], self.t[-1]))
        return v[:, :3], v[:, 3:]

    def _evaluate(self, th: np.ndarray, lo: int, hi: int):
        w_meas, wd_meas = self.gyro_at(-th[TAU_A], lo, hi)
        return predict_readings(
            th, self._kin_span(th[TAU_R], lo, hi), self._kin_span(th[TAU_R] - th[TAU_A], lo, hi), w_meas, wd_meas
        )
