"""What the simulation of a record gets wrong, named and measured: ``sizefx diagnose``.

The loop (Morozov & Bogdanov 2024 fit one effect, the lever arms; this generalises it):

1. **Predict.** From the record's ``/reference`` motion, predict what the gyros and
   accelerometers would read under the current model ``theta`` (start: the nominal
   geometry, no delays, no sensor errors; or a model file). The sensor model is the
   simulator's (:mod:`sizefx.simulate`), evaluated on the reference instead of an
   analytic trajectory:

   - reference attitude, body rate and (when present) velocity and position are
     interpolated by C2 splines (scipy's ``RotationSpline`` for attitude, whose
     rates come out in body axes; ``CubicSpline`` for position and velocity);
   - gyro ``(1 + s_g) (u_g . omega_ib) + b_g + G f_b`` with the reference motion at
     ``t + tau_ref`` (reference rows stamped t hold the motion at t - tau_ref) and the
     attitude tilted by ``R(phi)``;
   - accelerometer ``(1 + s_a) a + K2 a^2 + b_a``, ``a = u_i . (f_b + omegadot x r_i +
     omega x (omega x r_i))``, all at ``t - tau_acc``. ``f_b`` comes from the reference;
     the lever terms use the *gyros* (corrected by the model's gyro errors) and their
     Savitzky-Golay derivative over 25 ms, as compensation uses measured rates: a
     motion-capture reference differentiated twice would bury omegadot in noise;
   - increments records are compared as interval means: the prediction at each
     interval's midpoint plus ``dt^2 / 24`` times its second derivative (the mean of a
     smooth signal over the interval, to ``dt^4``).
2. **Residual** ``y = measured - predicted`` on the six channels.
3. **Candidates.** Every effect of :data:`CANDIDATES` is a group of parameters whose
   regressors are the partial derivatives of the prediction (analytic; a numerical
   twin checks them in the tests).
4. **Select.** Forward selection on the weighted normal equations, linearised at the
   current estimate, with parameters not selected pinned at their nominal values. A
   candidate enters only when (a) it lowers the weighted residual by more than the
   Bayesian information criterion's ``k ln(n)`` (for one parameter 3.7 sigma at 1e6
   rows, 3.45 sigma at 1.5e5; a false alarm rate near 2e-4 per candidate and step on
   white noise) and (b) it lowers the
   five-fold cross-validated error (interleaved one-second folds). Of the candidates that
   pass, the one that improves the criterion most enters (a bias, one parameter, beats a
   three-parameter g-sensitivity that mimics it through a mostly one-signed gravity
   component); when a more common effect (:data:`PRIORITY`: biases, geometry, clocks,
   then sensor-error terms) scores within one parameter's penalty of the best, it enters
   instead. Before a candidate
   is scored, parameters the motion does not excite are removed from it: their
   regressor's RMS, divided by the square root of its variance inflation factor given
   the effects already selected, is under :data:`Param.min_excitation`. The record
   cannot reveal them whatever the noise, and the report says so (naming the selected effect it is confused with, or
   that the motion does not excite it) instead of guessing.
5. **Iterate.** The model is updated with the selected estimates, the prediction and
   regressors are recomputed there (Gauss-Newton), the channel weights are
   re-estimated from the new residual (``1 / (sigma_c^2 kappa_c)``, ``kappa_c`` the
   largest variance inflation of block means from 0.5 s to a twentieth of the record:
   coloured residuals, such as a bias random walk, count as fewer samples),
   and the selection is repeated until it no longer changes.
6. **Measure.** The final model is written as a ``sizefx/effects/1`` TOML file; the
   record is re-simulated with it and the residual RMS per channel is reported
   before and after, with each effect's share of the residual it explains.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.spatial.transform import Rotation, RotationSpline

from .. import __version__, earth
from ..constants import ARCSEC, DEG, STANDARD_GRAVITY_MPS2
from ..effects import EFFECTS_SCHEMA, IDEAL, EffectModel, load_effects
from ..errors import ConfigError, SizefxError
from ..io.files import atomic_output, check_output_path
from ..omegadot import savgol
from ..rotation import rotvec_to_mat
from ..io.schema import check_document
from ..io.telemetry import Telemetry, read_telemetry

__all__ = ["CANDIDATES", "DIAGNOSIS_SCHEMA", "PARAMS", "DiagnoseError", "Diagnosis", "diagnose", "format_report",
           "model_toml", "run", "start_model", "theta_from_model", "to_json"]

DIAGNOSIS_SCHEMA = "sizefx/diagnosis/1"
CHANNELS = ("gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z")
UG = STANDARD_GRAVITY_MPS2 * 1e-6
DEG_PER_H = DEG / 3600.0

#: Fewest usable samples: the gyro derivative window with room, and enough blocks for the folds.
MIN_SAMPLES = 400
#: Rows kept for the fit after block averaging: a two-minute record at 1600 Hz is fitted sample
#: by sample; longer records are averaged in blocks (y and regressors alike, so the model stays exact).
MAX_ROWS = 250_000
#: Samples this close to the ends of the reference, or to a reference or IMU gap, are left out [s]:
#: room for delays up to 50 ms; and at least :data:`EDGE_REFERENCE_PERIODS` reference periods, where
#: the splines' end conditions still pull (5e-3 rad/s at one 20 Hz period from the end).
EDGE_S = 0.05
EDGE_REFERENCE_PERIODS = 10
#: Fewest reference rows: a spline through fewer cannot stand for the motion.
MIN_REFERENCE_ROWS = 20
#: Most IMU samples diagnosed at once: the prediction and regressors take about 3 kB per sample.
MAX_SAMPLES = 3_000_000
#: A reference step longer than this many median periods is a gap (motion-capture dropout).
REFERENCE_GAP_FACTOR = 3.0
#: Cross-validation: folds and the length of the interleaved blocks [s].
FOLDS = 5
FOLD_BLOCK_S = 1.0
#: Shortest block for the variance inflation kappa of a channel's residual [s]; longer ones, by
#: factors of 4, up to a twentieth of the record.
KAPPA_BLOCK_S = 0.5
#: Gauss-Newton passes at most; selection and estimates settle in two or three.
MAX_PASSES = 6


class DiagnoseError(SizefxError):
    """The record cannot be diagnosed (no reference, too short, no overlap)."""


# --------------------------------------------------------------------------- the parameters


@dataclass(frozen=True)
class Param:
    """One scalar of the model vector ``theta`` (SI)."""

    effect: str
    label: str  #: e.g. "r_y[x]", "x"
    unit: str  #: report unit
    per_unit: float  #: SI value of one report unit
    step: float  #: SI step of the numerical derivative
    min_excitation: float  #: RMS of its regressor (SI), after what the selected effects explain, below which
    #: the record "cannot reveal" the parameter, whatever the noise
    primary: tuple = ()  #: channels whose regressor measures the excitation (default: all it acts on)


def _params():
    """The model vector's layout. Excitation floors, in the regressor's SI units: a tenth of a
    constant for a bias; 0.1 m/s^2 of changing specific force for scale factors, misalignments
    and the tilt (1 % of g); 0.01 s^-2 of omega^2 or omegadot for the arms (6 deg/s); 0.03 m/s^3
    of d f/dt for the accelerometer delay (a tilting table gives g omega, ~3 m/s^3; rotation about
    the vertical only gives d(omega^2 r)/dt, ~0.003 m/s^3); 0.003 rad/s^2 of omegadot for the
    reference delay; 0.01 rad/s of rate for the gyro scale factors and misalignments."""
    p = []
    axes = "xyz"
    gyros, accels = (0, 1, 2), (3, 4, 5)
    for a in axes:
        p.append(Param("accel_bias", a, "ug", UG, 1e-4, 0.1))
    for a in axes:
        p.append(Param("accel_scale_factor", a, "ppm", 1e-6, 1e-4, 0.1))
    for i in range(3):
        for j in range(3):
            if i != j:
                p.append(Param("accel_misalignment", f"{axes[i]}->{axes[j]}", "arcsec", ARCSEC, 1e-5, 0.1))
    k2_unit = UG / STANDARD_GRAVITY_MPS2**2
    for a in axes:
        p.append(Param("accel_quadratic", a, "ug/g^2", k2_unit, 1e-4, 1.0))
    for i in range(3):
        for j in range(3):
            p.append(Param("lever_arm", f"r_{axes[i]}[{axes[j]}]", "mm", 1e-3, 1e-3, 0.01))
    p.append(Param("accel_delay", "tau", "us", 1e-6, 1e-5, 0.03, accels))
    p.append(Param("reference_delay", "tau", "us", 1e-6, 1e-5, 0.003, gyros))
    p.append(Param("level_tilt", "north", "arcsec", ARCSEC, 1e-5, 0.1, accels))
    p.append(Param("level_tilt", "east", "arcsec", ARCSEC, 1e-5, 0.1, accels))
    for a in axes:
        p.append(Param("gyro_bias", a, "deg/h", DEG_PER_H, 1e-6, 0.1))
    for a in axes:
        p.append(Param("gyro_scale_factor", a, "ppm", 1e-6, 1e-4, 0.01))
    for i in range(3):
        for j in range(3):
            if i != j:
                p.append(Param("gyro_misalignment", f"{axes[i]}->{axes[j]}", "arcsec", ARCSEC, 1e-5, 0.01))
    g_unit = DEG_PER_H / STANDARD_GRAVITY_MPS2
    for i in range(3):
        for j in range(3):
            p.append(Param("gyro_g_sensitivity", f"{axes[i]}<-f_{axes[j]}", "deg/h/g", g_unit, 1e-6, 0.1))
    return tuple(p)


PARAMS = _params()
NP = len(PARAMS)
_IDX = {}
for _k, _p in enumerate(PARAMS):
    _IDX.setdefault(_p.effect, []).append(_k)
A_BIAS, A_SF, A_MIS, A_K2, LEVER = (np.array(_IDX[k]) for k in
                                    ("accel_bias", "accel_scale_factor", "accel_misalignment", "accel_quadratic",
                                     "lever_arm"))
TAU_A, TAU_R = _IDX["accel_delay"][0], _IDX["reference_delay"][0]
TILT = np.array(_IDX["level_tilt"])
G_BIAS, G_SF, G_MIS, G_G = (np.array(_IDX[k]) for k in
                            ("gyro_bias", "gyro_scale_factor", "gyro_misalignment", "gyro_g_sensitivity"))
_OFFDIAG = [(i, j) for i in range(3) for j in range(3) if i != j]


@dataclass(frozen=True)
class Candidate:
    """One effect to test: an identifier, the channel it acts on (or None) and its parameters."""

    id: str
    channel: str | None
    idx: tuple

    @property
    def key(self) -> str:
        return self.id if self.channel is None else f"{self.id}:{self.channel}"


def _candidates():
    c = []
    for i, a in enumerate("xyz"):
        c.append(Candidate("accel_bias", f"accel_{a}", (A_BIAS[i],)))
        c.append(Candidate("accel_scale_factor", f"accel_{a}", (A_SF[i],)))
        c.append(Candidate("accel_misalignment", f"accel_{a}", tuple(A_MIS[2 * i:2 * i + 2])))
        c.append(Candidate("accel_quadratic", f"accel_{a}", (A_K2[i],)))
        c.append(Candidate("lever_arm", f"accel_{a}", tuple(LEVER[3 * i:3 * i + 3])))
    c.append(Candidate("accel_delay", None, (TAU_A,)))
    c.append(Candidate("reference_delay", None, (TAU_R,)))
    c.append(Candidate("level_tilt", None, tuple(TILT)))
    for i, a in enumerate("xyz"):
        c.append(Candidate("gyro_bias", f"gyro_{a}", (G_BIAS[i],)))
        c.append(Candidate("gyro_scale_factor", f"gyro_{a}", (G_SF[i],)))
        c.append(Candidate("gyro_misalignment", f"gyro_{a}", tuple(G_MIS[2 * i:2 * i + 2])))
        c.append(Candidate("gyro_g_sensitivity", f"gyro_{a}", tuple(G_G[3 * i:3 * i + 3])))
    return tuple(c)


CANDIDATES = _candidates()
#: Which explanation is the ordinary one when the data cannot tell two apart (see :func:`_select`):
#: biases and the geometry first, then clocks, the table, and the sensor-error terms.
PRIORITY = ("accel_bias", "gyro_bias", "lever_arm", "accel_delay", "reference_delay", "level_tilt",
            "accel_scale_factor", "gyro_scale_factor", "accel_misalignment", "gyro_misalignment",
            "accel_quadratic", "gyro_g_sensitivity")


def theta_from_model(fx: EffectModel) -> np.ndarray:
    """The model vector (SI) of an effect model's deterministic terms."""
    th = np.zeros(NP)
    th[A_BIAS] = fx.value_or_zero("accel_bias", "bias_mps2")
    th[A_SF] = fx.value_or_zero("accel_scale_factor", "scale_factor")
    m = fx.value_or_zero("accel_misalignment", "angles_rad", (3, 3))
    th[A_MIS] = [m[i, j] for i, j in _OFFDIAG]
    th[A_K2] = fx.value_or_zero("accel_quadratic", "k2_per_mps2")
    th[LEVER] = fx.arms_total_m().ravel()
    th[TAU_A] = fx.get("accel_delay", "tau_s") if fx.enabled("accel_delay") else 0.0
    th[TAU_R] = fx.get("reference_delay", "tau_s") if fx.enabled("reference_delay") else 0.0
    th[TILT] = fx.tilt_rad()[:2]
    th[G_BIAS] = fx.value_or_zero("gyro_bias", "bias_rad_s")
    th[G_SF] = fx.value_or_zero("gyro_scale_factor", "scale_factor")
    m = fx.value_or_zero("gyro_misalignment", "angles_rad", (3, 3))
    th[G_MIS] = [m[i, j] for i, j in _OFFDIAG]
    th[G_G] = fx.value_or_zero("gyro_g_sensitivity", "rad_s_per_mps2", (3, 3)).ravel()
    return th


def _axes(offdiag) -> np.ndarray:
    """Unit rows ``normalise(e_i + sum_j m_ij e_j)`` (the simulator's misalignment model)."""
    m = np.eye(3)
    for (i, j), v in zip(_OFFDIAG, offdiag):
        m[i, j] = v
    return m / np.linalg.norm(m, axis=1, keepdims=True)


# --------------------------------------------------------------------------- the reference motion


class ReferenceMotion:
    """The record's ``/reference`` as smooth functions of time (IMU clock).

    ``evaluate(t)`` gives ``C_bn`` (untilted), ``omega_nb_b``, ``omega_in_n`` and the
    specific force ``f_n`` of the reference point. Without position the site is static.
    """

    def __init__(self, tel: Telemetry):
        ref = tel.reference
        self.t = ref.time_s
        self.rot = RotationSpline(ref.time_s, Rotation.from_quat(ref.quat_nb[:, [1, 2, 3, 0]]))
        if ref.has_position:
            self.lat = CubicSpline(ref.time_s, ref.lat_rad)
            self.h = CubicSpline(ref.time_s, ref.height_m)
            if ref.velocity_n_mps is not None:
                v = ref.velocity_n_mps
            else:  # from the position spline's derivative
                rn, re = earth.radii_m(ref.lat_rad)
                lon = CubicSpline(ref.time_s, np.unwrap(ref.lon_rad))
                v = np.column_stack([(rn + ref.height_m) * self.lat(ref.time_s, 1),
                                     (re + ref.height_m) * np.cos(ref.lat_rad) * lon(ref.time_s, 1),
                                     -self.h(ref.time_s, 1)])
            self.v = CubicSpline(ref.time_s, v, axis=0)
            self.static = None
        else:
            site = tel.site
            self.static = (site.lat_rad, site.height_m)

    def evaluate(self, t):
        mat_nb = self.rot(t).as_matrix()
        w_nb = self.rot(t, 1)
        if self.static is None:
            lat, h, v, vdot = self.lat(t), self.h(t), self.v(t), self.v(t, 1)
        else:
            lat = np.full(t.shape, self.static[0])
            h = np.full(t.shape, self.static[1])
            v = np.zeros((t.size, 3))
            vdot = np.zeros((t.size, 3))
        w_ie = earth.omega_ie_n(lat)
        w_en = earth.omega_en_n(lat, h, v)
        f_n = vdot + np.cross(2.0 * w_ie + w_en, v) - earth.gravity_n(lat, h)
        return {"C_bn": np.swapaxes(mat_nb, 1, 2), "w_nb": w_nb, "w_in": w_ie + w_en, "f_n": f_n}


# --------------------------------------------------------------------------- prediction


class _Predictor:
    """Measured record on the IMU samples, and the prediction of it under a model vector."""

    def __init__(self, tel: Telemetry):
        if tel.reference is None:
            raise DiagnoseError(f"{tel.path}: diagnose needs /reference motion (attitude at least) to predict "
                                "the IMU from; record it, or import it with sizefx import")
        if tel.site is None and not tel.reference.has_position:
            raise DiagnoseError(f"{tel.path}: no site: gravity needs latitude and height; add the root attributes "
                                "latitude_deg, longitude_deg, height_m (sizefx import --site-deg)")
        from ..compensate import sync_accelerometers

        if tel.reference.time_s.size < MIN_REFERENCE_ROWS:
            raise DiagnoseError(f"{tel.path}: /reference has {tel.reference.time_s.size} rows; diagnose needs at "
                                f"least {MIN_REFERENCE_ROWS} to interpolate the motion from")
        if tel.n_samples > MAX_SAMPLES:
            raise DiagnoseError(f"{tel.path}: {tel.n_samples} IMU samples; diagnose holds about 3 kB per sample and "
                                f"takes at most {MAX_SAMPLES}: give a part of the record with --from-s/--to-s "
                                "(e.g. 20 minutes)")
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
        # Gyro derivative: a 25 ms Savitzky-Golay window (41 samples at 1600 Hz, 7 at 286 Hz).
        window = max(5, round(0.025 / dt) // 2 * 2 + 1)
        self.window = window
        self.gyro_dot = savgol(self.gyro, dt, window=window)
        self.motion = ReferenceMotion(tel)
        self.mask = self._usable(tel)
        if self.mask.sum() < MIN_SAMPLES:
            raise DiagnoseError(f"{tel.path}: only {int(self.mask.sum())} IMU samples lie inside the reference's "
                                f"span (minus {EDGE_S * 1e3:.0f} ms at ends and gaps); diagnose needs {MIN_SAMPLES}")
        self._kin = {}
        self._gyro_at = {}
        self._spline = None

    def _usable(self, tel):
        t, rt = self.t, tel.reference.time_s
        steps = np.diff(rt)
        edge = max(EDGE_S, EDGE_REFERENCE_PERIODS * float(np.median(steps)))
        ok = (t >= rt[0] + edge) & (t <= rt[-1] - edge)
        limit = REFERENCE_GAP_FACTOR * np.median(steps)
        for k in np.flatnonzero(steps > limit):
            ok &= ~((t > rt[k] - edge) & (t < rt[k + 1] + edge))
        # IMU gaps (accepted with --allow-gaps): the derivative window and the splines span them
        margin = EDGE_S + self.window * self.dt
        for gap in tel.gaps:
            if gap.dataset.startswith("/imu"):
                ok &= ~((t > gap.time_s - margin) & (t < gap.time_s + gap.duration_s + margin))
        half = (self.window - 1) // 2
        ok[:half + 2] = False  # the gyro derivative's end fits, and the shifts' spline ends
        ok[-half - 2:] = False
        return ok

    def kin(self, shift: float):
        key = round(shift, 12)
        if key not in self._kin:
            if len(self._kin) > 8:
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
            if len(self._gyro_at) > 8:
                self._gyro_at.pop(next(iter(self._gyro_at)))
            v = self._spline(np.clip(self.t + shift, self.t[0], self.t[-1]))
            self._gyro_at[key] = (v[:, :3], v[:, 3:])
        return self._gyro_at[key]

    def _parts(self, th: np.ndarray) -> dict:
        """Everything the prediction and its analytic derivatives share, at the model ``th``."""
        r_tilt = rotvec_to_mat(np.array([th[TILT[0]], th[TILT[1]], 0.0]))

        def body(k, vec):
            # true C_bn = C_bn_ref R(phi)^T, so C_bn v = C_bn_ref (R^T v); R^T v per row is v @ R
            return np.einsum("nij,nj->ni", k["C_bn"], vec @ r_tilt)

        kg = self.kin(th[TAU_R])
        w_ib = kg["w_nb"] + body(kg, kg["w_in"])
        f_g = body(kg, kg["f_n"])
        ka = self.kin(th[TAU_R] - th[TAU_A])
        f_a = body(ka, ka["f_n"])
        u_g = _axes(th[G_MIS])
        m_g = np.diag(1.0 + th[G_SF]) @ u_g
        g_sens = th[G_G].reshape(3, 3)
        w_meas, wd_meas = self.gyro_at(-th[TAU_A])
        inv_g = np.linalg.inv(m_g)
        w = (w_meas - th[G_BIAS] - f_a @ g_sens.T) @ inv_g.T  # the gyros, corrected by the model
        wd = wd_meas @ inv_g.T  # (G times the derivative of f is left out: below 1e-9 of the lever terms)
        u_a = _axes(th[A_MIS])
        arms = th[LEVER].reshape(3, 3)
        w2 = np.sum(w * w, axis=1)
        # a_i = u_i . (f + wd x r_i + w (w . r_i) - r_i |w|^2), with u . (wd x r) = wd . (r x u)
        lever = np.column_stack([wd @ np.cross(arms[i], u_a[i]) + (w @ u_a[i]) * (w @ arms[i])
                                 - w2 * (u_a[i] @ arms[i]) for i in range(3)])
        f_i = [f_a + np.cross(wd, arms[i]) + w * (w @ arms[i])[:, None] - w2[:, None] * arms[i] for i in range(3)]
        a = np.column_stack([f_a @ u_a[i] for i in range(3)]) + lever
        return {"w_ib": w_ib, "f_g": f_g, "u_g": u_g, "m_g": m_g, "g_sens": g_sens, "w": w, "wd": wd, "w2": w2,
                "u_a": u_a, "a": a, "f_i": f_i, "f_a": f_a, "kg": kg, "ka": ka, "body": body}

    def predict(self, th: np.ndarray, parts: dict | None = None) -> np.ndarray:
        """Predicted ``[n, 6]`` (gyro x, y, z, accel x, y, z) under the model vector ``th``."""
        p = parts or self._parts(th)
        out = np.empty((self.t.size, 6))
        out[:, :3] = p["w_ib"] @ p["m_g"].T + th[G_BIAS] + p["f_g"] @ p["g_sens"].T
        a = p["a"]
        out[:, 3:] = (1.0 + th[A_SF]) * a + th[A_K2] * a * a + th[A_BIAS]
        if self.increments:  # the interval mean: midpoint value + dt^2/24 x'' (exact to dt^4)
            out += self.dt**2 / 24.0 * np.gradient(np.gradient(out, self.t, axis=0), self.t, axis=0)
        return out

    def jacobian(self, th: np.ndarray, numeric: bool = False):
        """``{param: (channels, [n, len(channels)])}``: the nonzero columns of d(prediction)/d(theta).

        Analytic: exact for the biases, scale factors, misalignments, K2, arms and G; the tilt
        to first order in the tilt (1e-4 relative at 20 arcsec); the delays as time derivatives
        of the predicted series (``numpy.gradient``: relative error (2 pi f dt)^2 / 6 for motion
        at f, 1e-3 at 10 Hz sampled at 286 Hz). Gauss-Newton only needs the directions right:
        the residual itself is always evaluated exactly. ``numeric=True`` differentiates
        everything numerically: the slow twin the tests compare with. The gyro parameters also
        move the accelerometer prediction a little, through the corrected gyro rates in the
        lever terms (relative size 1e-4 of 1e-4); the analytic columns leave that out.
        """
        cols = {}
        p = self._parts(th)

        def numeric_col(j):
            up, dn = th.copy(), th.copy()
            up[j] += PARAMS[j].step
            dn[j] -= PARAMS[j].step
            d = (self.predict(up) - self.predict(dn)) / (2.0 * PARAMS[j].step)
            ch = np.flatnonzero(np.any(d[self.mask] != 0.0, axis=0))
            return ch, d[:, ch]

        if numeric:
            return {j: numeric_col(j) for j in range(NP)}
        n = self.t.size
        one = np.ones((n, 1))
        w_ib, f_g, u_g = p["w_ib"], p["f_g"], p["u_g"]
        for i in range(3):
            cols[G_BIAS[i]] = (np.array([i]), one)
            cols[G_SF[i]] = (np.array([i]), (w_ib @ u_g[i])[:, None])
            v_norm = np.linalg.norm(np.eye(3)[i] + _offdiag_row(th[G_MIS], i))
            for k, (ii, jj) in enumerate(_OFFDIAG):
                if ii == i:  # d u_i / d m_ij = (e_j - u_i u_ij) / |v_i|
                    col = (1.0 + th[G_SF[i]]) * (w_ib[:, jj] - (w_ib @ u_g[i]) * u_g[i, jj]) / v_norm
                    cols[G_MIS[k]] = (np.array([i]), col[:, None])
            for jj in range(3):
                cols[G_G[3 * i + jj]] = (np.array([i]), f_g[:, jj:jj + 1].copy())
        a, u_a, w, wd, w2 = p["a"], p["u_a"], p["w"], p["wd"], p["w2"]
        for i in range(3):
            ch = np.array([3 + i])
            gain = 1.0 + th[A_SF[i]] + 2.0 * th[A_K2[i]] * a[:, i]
            cols[A_BIAS[i]] = (ch, one)
            cols[A_SF[i]] = (ch, a[:, i:i + 1].copy())
            cols[A_K2[i]] = (ch, (a[:, i] ** 2)[:, None])
            v_norm = np.linalg.norm(np.eye(3)[i] + _offdiag_row(th[A_MIS], i))
            f_i = p["f_i"][i]
            for k, (ii, jj) in enumerate(_OFFDIAG):
                if ii == i:
                    col = gain * (f_i[:, jj] - a[:, i] * u_a[i, jj]) / v_norm
                    cols[A_MIS[k]] = (ch, col[:, None])
            # d a_i / d r_i = u x wd + (u . w) w - |w|^2 u
            grad = np.cross(u_a[i], wd) + (w @ u_a[i])[:, None] * w - w2[:, None] * u_a[i]
            for c in range(3):
                cols[LEVER[3 * i + c]] = (ch, (gain * grad[:, c])[:, None])
        gain = 1.0 + th[A_SF] + 2.0 * th[A_K2] * a  # [n, 3] d(output)/d(input) of each accelerometer
        f_u = np.column_stack([p["f_a"] @ u_a[i] for i in range(3)])  # the reference's part of a_i
        m_g, g_sens = p["m_g"], p["g_sens"]
        cols[TAU_R] = (np.arange(6), np.hstack([np.gradient(w_ib @ m_g.T + f_g @ g_sens.T, self.t, axis=0),
                                                 gain * np.gradient(f_u, self.t, axis=0)]))
        cols[TAU_A] = (np.arange(3, 6), -gain * np.gradient(a, self.t, axis=0))
        body, kg, ka = p["body"], p["kg"], p["ka"]
        for k in range(2):  # R(phi)^T v ~ v + v x phi: d/dphi_k = v x e_k
            e = np.eye(3)[k]
            gyro = body(kg, np.cross(kg["w_in"], e)) @ m_g.T + body(kg, np.cross(kg["f_n"], e)) @ g_sens.T
            df = body(ka, np.cross(ka["f_n"], e))
            cols[TILT[k]] = (np.arange(6), np.hstack([gyro, gain * (df @ u_a.T)]))
        return cols


def _offdiag_row(offdiag, i):
    row = np.zeros(3)
    for (ii, jj), v in zip(_OFFDIAG, offdiag):
        if ii == i:
            row[jj] = v
    return row


# --------------------------------------------------------------------------- normal equations


@dataclass
class _Normal:
    """Weighted normal equations per fold: sums over folds give the whole record."""

    N: np.ndarray  #: [F, P, P]
    b: np.ndarray  #: [F, P]
    yy: np.ndarray  #: [F]
    rows: int
    excitation: np.ndarray  #: [P] RMS of each regressor over its primary channels (SI)

    def total(self):
        return self.N.sum(0), self.b.sum(0), float(self.yy.sum())


def _blocks(x, L):
    n = (x.shape[0] // L) * L
    return x[:n].reshape(-1, L, *x.shape[1:]).mean(axis=1)


class _Rows:
    """How the samples become the rows of the fit, the same for the residual and every regressor.

    Without a bandwidth: means over blocks of ``L`` samples (``L = 1`` for records up to
    :data:`MAX_ROWS` samples). With ``bandwidth_hz``: a zero-phase 4th-order Butterworth
    low-pass (``scipy.signal.sosfiltfilt``), then every ``L``-th sample with ``L`` giving
    2.5 samples per period of the cut-off. A linear filter applied to both sides keeps the
    model exact (``F y = (F H) theta + F e``); it is what a reference differentiated from
    noisy motion capture needs, whose noise grows with frequency. Unusable samples are set
    to zero before filtering and their neighbourhood (three periods of the cut-off) is left out.
    """

    def __init__(self, t, mask, dt, bandwidth_hz=None):
        n = t.size
        self.bandwidth_hz = bandwidth_hz
        if bandwidth_hz is not None:
            from scipy.signal import butter

            nyquist = 0.5 / dt
            if not 0.0 < bandwidth_hz < 0.8 * nyquist:
                raise ConfigError(f"--bandwidth-hz {bandwidth_hz:g} must lie between 0 and {0.8 * nyquist:g} Hz "
                                  f"(0.8 times the Nyquist frequency of this {1 / dt:g} Hz record)")
            self.sos = butter(4, bandwidth_hz / nyquist, output="sos")
            self.L = max(1, math.floor(1.0 / (2.5 * bandwidth_hz * dt)), math.ceil(n / MAX_ROWS))
            pad = max(1, round(3.0 / (bandwidth_hz * dt)))
            bad = np.convolve((~mask).astype(float), np.ones(2 * pad + 1), mode="same") > 0
            self.mask = mask
            keep = ~bad[::self.L]
            self.t = t[::self.L]
        else:
            self.L = max(1, math.ceil(n / MAX_ROWS))
            self.mask = mask
            keep = _blocks(mask.astype(float), self.L) == 1.0 if self.L > 1 else mask
            self.t = _blocks(t, self.L) if self.L > 1 else t
        self.keep = keep
        self.dt = dt * self.L

    def __call__(self, x):
        """Rows ``[m, ...]`` of a per-sample series ``x [n, ...]`` (all rows; index with ``keep``)."""
        if self.bandwidth_hz is not None:
            from scipy.signal import sosfiltfilt

            x = np.where(self.mask.reshape(-1, *([1] * (x.ndim - 1))), x, 0.0)
            return sosfiltfilt(self.sos, x, axis=0)[::self.L]
        return _blocks(x, self.L) if self.L > 1 else x


def _normal(rows_of: _Rows, y, cols, weights) -> _Normal:
    keep = rows_of.keep
    t = rows_of.t[keep]
    span = float(t[-1] - t[0]) if t.size > 1 else 0.0
    block = max(min(FOLD_BLOCK_S, span / (2 * FOLDS)), rows_of.dt)  # 1 s, shorter for records under 10 s
    fold = (np.floor((t - t[0]) / block).astype(int)) % FOLDS  # interleaved folds
    order = np.argsort(fold, kind="stable")  # rows grouped by fold: slices instead of masks
    edges = np.searchsorted(fold[order], np.arange(FOLDS + 1))
    rows = np.flatnonzero(keep)[order]

    def prep(x):
        return rows_of(x)[rows]

    yb = prep(y)
    sumsq = np.zeros(NP)
    count = np.zeros(NP)
    N = np.zeros((FOLDS, NP, NP))
    b = np.zeros((FOLDS, NP))
    yy = np.zeros(FOLDS)
    for c in range(6):
        js = [j for j in range(NP) if c in cols[j][0]]
        if not js:
            continue
        H = prep(np.column_stack([cols[j][1][:, list(cols[j][0]).index(c)] for j in js]))
        for k, j in enumerate(js):
            if not PARAMS[j].primary or c in PARAMS[j].primary:
                sumsq[j] += H[:, k] @ H[:, k]
                count[j] += H.shape[0]
        w = weights[c]
        for k in range(FOLDS):
            Hk, yk = H[edges[k]:edges[k + 1]], yb[edges[k]:edges[k + 1], c]
            N[k][np.ix_(js, js)] += w * (Hk.T @ Hk)
            b[k][js] += w * (Hk.T @ yk)
            yy[k] += w * (yk @ yk)
    return _Normal(N, b, yy, int(keep.sum()) * 6, np.sqrt(sumsq / np.maximum(count, 1)))


def _solve(N, b, yy, free, offset):
    """Fit ``free`` with the other parameters held at ``offset``: (x_free, rss, covariance)."""
    pinned = np.setdiff1d(np.arange(NP), free)
    c = offset[pinned]
    bf = b[free] - N[np.ix_(free, pinned)] @ c
    yy_ = yy - 2.0 * c @ b[pinned] + c @ N[np.ix_(pinned, pinned)] @ c
    if len(free) == 0:
        return np.zeros(0), yy_, np.zeros((0, 0))
    Nf = N[np.ix_(free, free)]
    d = np.sqrt(np.where(np.diag(Nf) > 0, np.diag(Nf), 1.0))
    Ns = Nf / np.outer(d, d)
    try:
        inv = np.linalg.inv(Ns) / np.outer(d, d)
    except np.linalg.LinAlgError:
        inv = np.linalg.pinv(Ns) / np.outer(d, d)
    x = inv @ bf
    return x, float(yy_ - bf @ x), inv


def _cv_error(nrm: _Normal, free, offset):
    """Five-fold cross-validated weighted squared error of the model with ``free`` estimated."""
    N, b, yy = nrm.total()
    pinned = np.setdiff1d(np.arange(NP), free)
    c = offset[pinned]
    err = 0.0
    for k in range(FOLDS):
        x, _, _ = _solve(N - nrm.N[k], b - nrm.b[k], yy - nrm.yy[k], free, offset)
        Nk, bk = nrm.N[k], nrm.b[k]
        bf = bk[free] - Nk[np.ix_(free, pinned)] @ c
        yyk = nrm.yy[k] - 2.0 * c @ bk[pinned] + c @ Nk[np.ix_(pinned, pinned)] @ c
        err += yyk - 2.0 * x @ bf + x @ Nk[np.ix_(free, free)] @ x
    return float(err)


@dataclass
class _Chosen:
    cand: Candidate
    active: tuple  #: the parameters of the candidate the record reveals
    hidden: tuple  #: those it cannot


def _select(nrm: _Normal, offset, penalty):
    """Forward selection. Returns (chosen, unrevealed {key: (candidate, hidden params, reason)}, log)."""
    N, b, yy = nrm.total()
    chosen: list[_Chosen] = []
    log = []

    def free_of(ch):
        return np.array(sorted({j for c in ch for j in c.active}), dtype=int)

    _, rss, _ = _solve(N, b, yy, free_of(chosen), offset)
    cv = _cv_error(nrm, free_of(chosen), offset)
    while True:
        scored = []
        for cand in CANDIDATES:
            if any(c.cand == cand for c in chosen):
                continue
            active, hidden = _revealed(nrm, free_of(chosen), cand)
            if not active:
                continue
            trial = chosen + [_Chosen(cand, tuple(active), tuple(hidden))]
            _, rss_new, _ = _solve(N, b, yy, free_of(trial), offset)
            gain = rss - rss_new
            score = gain - penalty * len(active)  # the criterion's improvement: fewer parameters win ties
            if score > 0:
                scored.append((score, PRIORITY.index(cand.id), gain, trial, rss_new))
        if not scored:
            break
        # The best score wins unless a more common effect (PRIORITY) scores within one parameter's
        # penalty of it: near-collinear candidates (a z bias and a z scale factor under constant
        # gravity) are then explained the ordinary way, and the other is named as indistinguishable.
        top = max(s[0] for s in scored)
        score, _, gain, trial, rss_new = min((s for s in scored if s[0] >= top - penalty), key=lambda s: s[1])
        best = (gain, trial, rss_new, score)
        cv_new = _cv_error(nrm, free_of(best[1]), offset)
        if cv_new >= cv:
            log.append(f"{best[1][-1].cand.key}: passes the information criterion but not cross-validation")
            break
        chosen, rss, cv = best[1], best[2], cv_new
        log.append(f"{chosen[-1].cand.key}: chi2 gain {best[0]:.1f} (threshold {penalty * len(chosen[-1].active):.1f})")
    unrevealed = {}
    free = free_of(chosen)
    for cand in CANDIDATES:
        mine = [c for c in chosen if c.cand == cand]
        if mine:
            if mine[0].hidden:
                unrevealed[cand.key] = (cand, mine[0].hidden, _why(nrm, cand, mine[0].hidden, chosen))
            continue
        active, hidden = _revealed(nrm, free, cand)
        if hidden:
            unrevealed[cand.key] = (cand, tuple(hidden), _why(nrm, cand, hidden, chosen))
    return chosen, unrevealed, log


def _sigmas(N, b, yy, free, offset):
    _, _, cov = _solve(N, b, yy, free, offset)
    return dict(zip(free.tolist(), np.sqrt(np.abs(np.diag(cov)))))


def _excitation(nrm: _Normal, free) -> dict:
    """Per parameter of ``free``: its regressor's RMS divided by sqrt(VIF) given the others in ``free``.

    VIF = cov_jj N_jj (1 when the regressor is orthogonal to the others; infinite when
    they explain it). Noise-free: it says what the motion shows, not how well.
    """
    N = nrm.N.sum(0)
    free = np.asarray(free, dtype=int)
    diag = np.diag(N)[free]
    out = {}
    live = diag > 0
    if live.any():
        sub = free[live]
        Nf = N[np.ix_(sub, sub)]
        d = np.sqrt(np.diag(Nf))
        try:
            inv = np.linalg.inv(Nf / np.outer(d, d))
            vif = np.maximum(np.diag(inv), 1.0)
        except np.linalg.LinAlgError:
            vif = np.full(sub.size, np.inf)
        for j, v in zip(sub.tolist(), vif):
            out[j] = float(nrm.excitation[j] / np.sqrt(v)) if np.isfinite(v) and v > 0 else 0.0
    for j in free[~live].tolist():
        out[j] = 0.0
    return out


def _revealed(nrm: _Normal, free, cand):
    """Split the candidate's parameters into those the record reveals (jointly with ``free``) and the rest."""
    active = list(cand.idx)
    while active:
        trial = np.array(sorted(set(free.tolist()) | set(active)), dtype=int)
        ex = _excitation(nrm, trial)
        worst = min(active, key=lambda j: ex[j] / PARAMS[j].min_excitation)
        if ex[worst] >= PARAMS[worst].min_excitation:
            break
        active.remove(worst)
    return active, [j for j in cand.idx if j not in active]


def _why(nrm: _Normal, cand, hidden, chosen):
    """Plain reason a parameter set cannot be revealed: the motion, or confusion with a selected effect."""
    alone = _excitation(nrm, np.array(hidden, dtype=int))
    if any(alone[j] < PARAMS[j].min_excitation for j in hidden):
        return "the motion in this record does not excite it"
    culprits = []
    for c in chosen:
        if c.cand == cand:
            continue
        rest = [o for o in chosen if o is not c and o.cand != cand]
        trial = np.array(sorted({j for o in rest for j in o.active} | set(hidden)), dtype=int)
        ex = _excitation(nrm, trial)
        if all(ex[j] >= PARAMS[j].min_excitation for j in hidden):
            culprits.append(c.cand.key)
    if culprits:
        return "indistinguishable in this record from " + " or ".join(culprits)
    if not [c for c in chosen if c.cand != cand]:
        return "its components cannot be told apart from each other in this record"
    return "indistinguishable in this record from the effects found together"


# --------------------------------------------------------------------------- the loop


@dataclass
class Effect:
    """One effect found: values in SI, absolute (not differences from the nominal)."""

    id: str
    channel: str | None
    params: dict  #: parameter name -> SI value (scalars or lists)
    sigma: dict
    nominal: dict
    explained_fraction: float
    sentence: str
    hidden: list = field(default_factory=list)  #: components the record cannot reveal (kept at nominal)


@dataclass
class Diagnosis:
    path: str
    effects: list
    unrevealed: list  #: [{"id", "channel", "parameters", "reason"}]
    rms_before: dict  #: channel -> SI RMS
    rms_after: dict
    theta_nominal: np.ndarray
    theta: np.ndarray
    sigma_theta: dict
    samples: int
    block: int
    weights_sigma: np.ndarray  #: per-channel noise sigma used in the weights (SI)
    kappa: np.ndarray
    passes: int
    log: list
    wall_s: float
    residual_before: np.ndarray | None = None  #: [n, 6]
    residual_after: np.ndarray | None = None
    t: np.ndarray | None = None
    mask: np.ndarray | None = None
    model_path: str | None = None
    navigation: dict | None = None
    bandwidth_hz: float | None = None
    white_sigma: dict | None = None  #: per channel: the residual's sample-to-sample (first-difference) noise
    rms_full_before: dict | None = None  #: full-band RMS (differs from rms_* when bandwidth_hz is set)
    rms_full_after: dict | None = None


def _noise(rows_of: _Rows, res):
    """Per channel: the residual's sigma and kappa, the variance inflation of its 0.5 s block means.

    Computed on the rows the fit uses. kappa is 1 for white noise and grows with colour
    (drift, unmodelled slow terms, a low-pass): the weights ``1 / (sigma^2 kappa)`` then
    count a coloured channel as fewer independent samples.
    """
    r = rows_of(res)[rows_of.keep]
    r = r - r.mean(axis=0)
    sigma = np.maximum(r.std(axis=0), 1e-300)
    kappa = np.ones(6)
    B = max(2, round(KAPPA_BLOCK_S / rows_of.dt))
    while r.shape[0] // B >= 20:  # 0.5 s, 2 s, 8 s, ...: a random walk shows only in the long blocks
        blocks = _blocks(r, B)
        kappa = np.maximum(kappa, blocks.var(axis=0) * B / sigma**2)
        B *= 4
    return sigma, kappa


def _rms(rows_of: _Rows, res):
    return np.sqrt(np.mean(rows_of(res)[rows_of.keep] ** 2, axis=0))


def _power(rows_of: _Rows, r, weights, chans):
    return float(np.sum(weights[chans] * _rms(rows_of, r)[chans] ** 2))


def diagnose(tel: Telemetry, theta_nominal: np.ndarray, *, bandwidth_hz: float | None = None,
             keep_series: bool = True) -> Diagnosis:
    """Run the loop of the module docstring on one record; ``theta_nominal`` is the start model.

    ``bandwidth_hz`` fits the residual low-passed at that frequency (see :class:`_Rows`):
    for references whose differentiated noise swamps the high band (motion capture).
    """
    started = time.perf_counter()
    pred = _Predictor(tel)
    rows_of = _Rows(pred.t, pred.mask, pred.dt, bandwidth_hz)
    theta0 = np.asarray(theta_nominal, dtype=float).copy()
    residual_before = pred.measured - pred.predict(theta0)
    theta = theta0.copy()
    first = rows_of(residual_before)[rows_of.keep]  # white-noise sigma from first differences to start
    sigma_c = np.maximum(np.sqrt(np.mean(np.diff(first, axis=0) ** 2, axis=0) / 2.0), 1e-300)
    kappa = np.ones(6)
    history = []
    log = []
    residual = residual_before
    for passes in range(1, MAX_PASSES + 1):
        cols = pred.jacobian(theta)
        weights = 1.0 / (sigma_c**2 * kappa)
        nrm = _normal(rows_of, residual, cols, weights)
        penalty = math.log(max(nrm.rows, 2))
        offset = theta0 - theta  # a parameter not selected stays at its nominal value
        chosen, unrevealed, steps = _select(nrm, offset, penalty)
        log.append(f"pass {passes}: " + ("; ".join(steps) if steps else "nothing selected"))
        free = np.array(sorted({j for c in chosen for j in c.active}), dtype=int)
        N, b, yy = nrm.total()
        x, _, cov = _solve(N, b, yy, free, offset)
        new = theta0.copy()
        new[free] = theta[free] + x
        sig = dict(zip(free.tolist(), np.sqrt(np.abs(np.diag(cov)))))
        step = max((abs(new[j] - theta[j]) / sig[j] for j in free.tolist()), default=0.0)
        key = tuple(sorted(c.cand.key for c in chosen))
        theta = new
        residual = pred.measured - pred.predict(theta)
        sigma_c, kappa = _noise(rows_of, residual)
        history.append(key)
        if passes >= 2 and history[-1] == history[-2] and step < 1e-3:
            break
    # Final standard errors with the final weights; the regressors are the last pass's (theta has
    # moved by less than 1e-3 sigma since, when the loop converged).
    weights = 1.0 / (sigma_c**2 * kappa)
    nrm = _normal(rows_of, residual, cols, weights)
    N, b, yy = nrm.total()
    sig = _sigmas(N, b, yy, free, theta0 - theta) if free.size else {}
    mask = pred.mask
    rms_b, rms_a = _rms(rows_of, residual_before), _rms(rows_of, residual)
    effects = []
    for c in chosen:
        # share of the weighted residual power of the channels it acts on that this effect removes,
        # the others staying in the model
        without = theta.copy()
        without[list(c.active)] = theta0[list(c.active)]
        r_wo = pred.measured - pred.predict(without)
        # its channels: where its contribution, in units of each channel's noise, is at least a
        # tenth of its largest (the tilt acts on the gyros too, through Earth rate, but 1e5 times less)
        size = _rms(rows_of, r_wo - residual) / sigma_c
        chans = np.flatnonzero(size >= 0.1 * size.max()) if size.max() > 0 else np.arange(6)
        p0 = _power(rows_of, residual_before, weights, chans)
        frac = max(0.0, (_power(rows_of, r_wo, weights, chans) - _power(rows_of, residual, weights, chans)) / p0) \
            if p0 > 0 else 0.0
        effects.append(_effect(c, theta, theta0, sig, frac))
    effects.sort(key=lambda e: -e.explained_fraction)
    unrev = [{"id": cand.id, "channel": cand.channel, "parameters": [PARAMS[j].label for j in hidden],
              "reason": reason} for cand, hidden, reason in unrevealed.values()]
    return Diagnosis(
        path=str(tel.path), effects=effects, unrevealed=unrev,
        rms_before=dict(zip(CHANNELS, rms_b.tolist())), rms_after=dict(zip(CHANNELS, rms_a.tolist())),
        theta_nominal=theta0, theta=theta, sigma_theta=sig, samples=int(mask.sum()), block=rows_of.L,
        bandwidth_hz=bandwidth_hz,
        white_sigma=dict(zip(CHANNELS, (np.sqrt(np.mean(np.diff(rows_of(residual)[rows_of.keep], axis=0) ** 2, axis=0)
                                                / 2.0)).tolist())),
        rms_full_before=dict(zip(CHANNELS, np.sqrt(np.mean(residual_before[mask] ** 2, axis=0)).tolist())),
        rms_full_after=dict(zip(CHANNELS, np.sqrt(np.mean(residual[mask] ** 2, axis=0)).tolist())),
        weights_sigma=sigma_c, kappa=kappa, passes=passes, log=log, wall_s=time.perf_counter() - started,
        residual_before=residual_before if keep_series else None, residual_after=residual if keep_series else None,
        t=pred.t if keep_series else None, mask=mask if keep_series else None)


# --------------------------------------------------------------------------- naming


def _fmt(v, s, unit, digits=None):
    if digits is None:
        digits = max(0, min(4, 1 - math.floor(math.log10(abs(s))) if s > 0 else 2))
    return f"{v:.{digits}f} +- {s:.{digits}f} {unit}"


def _effect(c: _Chosen, theta, theta0, sig, frac) -> Effect:
    """Parameters in the JSON's names and SI units, and the plain sentence."""
    idx = list(c.cand.idx)
    ps = [PARAMS[j] for j in idx]
    val = [float(theta[j]) for j in idx]
    nom = [float(theta0[j]) for j in idx]
    sg = [float(sig[j]) if j in sig else None for j in idx]
    axis = c.cand.channel[-1] if c.cand.channel else None
    hidden = [PARAMS[j].label for j in c.hidden]
    eid = c.cand.id

    def user(k):
        return val[k] / ps[k].per_unit, (sg[k] or 0.0) / ps[k].per_unit, nom[k] / ps[k].per_unit

    if eid == "lever_arm":
        params, sigma, nominal = {"r_m": val}, {"r_m": sg}, {"r_m": nom}
        comp = []
        for k, a in enumerate("xyz"):
            if sg[k] is None:
                continue
            v, s, n0 = user(k)
            comp.append(f"{a} = {_fmt(v, s, 'mm')} (nominal {n0:.3f} mm, {v - n0:+.3f} mm)")
        moved = float(np.linalg.norm(np.subtract(val, nom))) * 1e3
        sentence = (f"accelerometer {axis} sits {moved:.2f} mm from where the nominal geometry puts it: "
                    + "; ".join(comp) + " from the reference point of the motion")
        if hidden:
            sentence += f" ({', '.join(hidden)} not revealed by this record: kept at nominal)"
    elif eid in ("accel_delay", "reference_delay"):
        v, s, n0 = user(0)
        params, sigma, nominal = {"tau_s": val[0]}, {"tau_s": sg[0]}, {"tau_s": nom[0]}
        if eid == "accel_delay":
            word = "lag" if v >= 0 else "lead"
            sentence = f"the accelerometers {word} the gyros by {_fmt(abs(v), s, 'microseconds')}"
        else:
            word, sign = ("lags", "-") if v >= 0 else ("leads", "+")
            sentence = (f"the reference {word} the IMU by {_fmt(abs(v), s, 'microseconds')} (its rows stamped t "
                        f"hold the motion at t {sign} {abs(v):.1f} us)")
        if n0:
            sentence += f" (nominal {n0:.1f} us)"
    elif eid == "level_tilt":
        (vn, sn, nn), (ve, se, ne) = user(0), user(1)
        params = {"north_arcsec": vn, "east_arcsec": ve}
        sigma = {"north_arcsec": sn, "east_arcsec": se}
        nominal = {"north_arcsec": nn, "east_arcsec": ne}
        sentence = (f"the table (or the reference) is tilted off the local level: {_fmt(vn, sn, 'arcsec')} about "
                    f"north and {_fmt(ve, se, 'arcsec')} about east")
    elif eid in ("accel_bias", "gyro_bias"):
        v, s, n0 = user(0)
        key = "bias_mps2" if eid == "accel_bias" else "bias_rad_s"
        params, sigma, nominal = {key: val[0]}, {key: sg[0]}, {key: nom[0]}
        what = "accelerometer" if eid == "accel_bias" else "gyro"
        sentence = f"{what} {axis} has a bias of {_fmt(v, s, ps[0].unit)}" + (f" (nominal {n0:.3g})" if n0 else "")
    elif eid in ("accel_scale_factor", "gyro_scale_factor"):
        v, s, n0 = user(0)
        params, sigma, nominal = {"ppm": v}, {"ppm": s}, {"ppm": n0}
        what = "accelerometer" if eid.startswith("accel") else "gyro"
        sentence = (f"{what} {axis} reads {_fmt(abs(v), s, 'ppm')} {'too much' if v >= 0 else 'too little'} "
                    "(scale factor)")
    elif eid in ("accel_misalignment", "gyro_misalignment"):
        params = {"arcsec": {ps[k].label: user(k)[0] for k in range(len(ps)) if sg[k] is not None}}
        sigma = {"arcsec": {ps[k].label: user(k)[1] for k in range(len(ps)) if sg[k] is not None}}
        nominal = {"arcsec": {ps[k].label: user(k)[2] for k in range(len(ps))}}
        what = "accelerometer" if eid.startswith("accel") else "gyro"
        parts = [f"{_fmt(user(k)[0], user(k)[1], 'arcsec')} towards {ps[k].label[-1]}"
                 for k in range(len(ps)) if sg[k] is not None]
        sentence = f"the {what} {axis} axis is misaligned: " + " and ".join(parts)
    elif eid == "accel_quadratic":
        v, s, n0 = user(0)
        params, sigma, nominal = {"ug_per_g2": v}, {"ug_per_g2": s}, {"ug_per_g2": n0}
        sentence = f"accelerometer {axis} has a quadratic term K2 = {_fmt(v, s, 'ug/g^2')}"
    elif eid == "gyro_g_sensitivity":
        params = {"deg_per_h_per_g": [user(k)[0] for k in range(3)]}
        sigma = {"deg_per_h_per_g": [user(k)[1] if sg[k] is not None else None for k in range(3)]}
        nominal = {"deg_per_h_per_g": [user(k)[2] for k in range(3)]}
        parts = [f"{_fmt(user(k)[0], user(k)[1], 'deg/h/g')} per g along {'xyz'[k]}" for k in range(3)
                 if sg[k] is not None]
        sentence = f"gyro {axis} responds to specific force: " + ", ".join(parts)
    else:  # pragma: no cover - every candidate id is handled above
        raise AssertionError(eid)
    return Effect(eid, c.cand.channel, params, sigma, nominal, frac, sentence, hidden)


# --------------------------------------------------------------------------- outputs


def model_toml(theta: np.ndarray, source: str = "") -> str:
    """The model vector as a complete ``sizefx/effects/1`` TOML (every deterministic section explicit).

    Noise and quantisation are switched off: the file states what the IMU gets wrong
    deterministically, which ``navigate --model`` and ``compensate --model`` undo.
    """
    def vec(v):
        return "[" + ", ".join(repr(float(x)) for x in v) + "]"

    def mat(offdiag=None, full=None):
        m = np.zeros((3, 3)) if full is None else np.asarray(full)
        if offdiag is not None:
            for (i, j), v in zip(_OFFDIAG, offdiag):
                m[i, j] = v
        return "[" + ", ".join(vec(r) for r in m) + "]"

    arms = theta[LEVER].reshape(3, 3)
    # r_i = r + d_i with r the triad point (where the accelerometer normals meet, as calibrate
    # splits them), so that navigate/compensate --mode triad and center keep their meaning
    from ..geometry import triad_point

    axes = _axes(theta[A_MIS])
    offset = triad_point(arms, axes) if np.any(arms) else np.zeros(3)
    d_arms = arms - offset
    on = {name: bool(np.any(theta[idx] != 0.0)) for name, idx in
          (("accel_bias", A_BIAS), ("accel_scale_factor", A_SF), ("accel_misalignment", A_MIS),
           ("accel_quadratic", A_K2), ("accel_delay", [TAU_A]), ("reference_delay", [TAU_R]),
           ("level_tilt", TILT), ("gyro_bias", G_BIAS), ("gyro_scale_factor", G_SF),
           ("gyro_misalignment", G_MIS), ("gyro_g_sensitivity", G_G))}
    def t(flag):
        return "true" if flag else "false"

    k2_unit = UG / STANDARD_GRAVITY_MPS2**2
    g_unit = DEG_PER_H / STANDARD_GRAVITY_MPS2
    lines = [f"# sizefx {__version__} diagnose: the extended model{(' of ' + source) if source else ''}.",
             "# Arms r_i from the reference point of the motion (body axes x forward, y right, z down).",
             f'schema = "{EFFECTS_SCHEMA}"', "",
             "[lever_arm]", "enabled = true", 'preset = "none"',
             "# d_i: triad point to accelerometer i; r_vehicle_m: reference point to the triad point"] + \
            [f"d_{a}_m = {vec(d_arms[i])}" for i, a in enumerate("xyz")] + [
        "r0_m = [0.0, 0.0, 0.0]", "r_plate_m = [0.0, 0.0, 0.0]", f"r_vehicle_m = {vec(offset)}", "",
        "[accel_delay]", f"enabled = {t(on['accel_delay'])}", f"tau_s = {float(theta[TAU_A])!r}", "",
        "[reference_delay]", f"enabled = {t(on['reference_delay'])}", f"tau_s = {float(theta[TAU_R])!r}", "",
        "[level_tilt]", f"enabled = {t(on['level_tilt'])}", f"north_arcsec = {float(theta[TILT[0]] / ARCSEC)!r}",
        f"east_arcsec = {float(theta[TILT[1]] / ARCSEC)!r}", "",
        "[accel_bias]", f"enabled = {t(on['accel_bias'])}", f"bias_ug = {vec(theta[A_BIAS] / UG)}", "",
        "[accel_scale_factor]", f"enabled = {t(on['accel_scale_factor'])}", f"ppm = {vec(theta[A_SF] * 1e6)}", "",
        "[accel_misalignment]", f"enabled = {t(on['accel_misalignment'])}",
        f"arcsec = {mat(offdiag=theta[A_MIS] / ARCSEC)}", "",
        "[accel_quadratic]", f"enabled = {t(on['accel_quadratic'])}", f"ug_per_g2 = {vec(theta[A_K2] / k2_unit)}", "",
        "[gyro_bias]", f"enabled = {t(on['gyro_bias'])}", f"deg_per_h = {vec(theta[G_BIAS] / DEG_PER_H)}", "",
        "[gyro_scale_factor]", f"enabled = {t(on['gyro_scale_factor'])}", f"ppm = {vec(theta[G_SF] * 1e6)}", "",
        "[gyro_misalignment]", f"enabled = {t(on['gyro_misalignment'])}",
        f"arcsec = {mat(offdiag=theta[G_MIS] / ARCSEC)}", "",
        "[gyro_g_sensitivity]", f"enabled = {t(on['gyro_g_sensitivity'])}",
        f"deg_per_h_per_g = {mat(full=theta[G_G].reshape(3, 3) / g_unit)}", "",
        "[accel_noise]", "enabled = false", "", "[gyro_noise]", "enabled = false", "",
        "[quantisation]", "enabled = false", ""]
    return "\n".join(lines)


def start_model(nominal: str | None = None, model: str | None = None):
    """The model vector the diagnosis starts from, and a phrase saying what it is.

    ``model``: a ``sizefx/effects/1`` TOML (sections it omits are off). Otherwise the
    ``nominal`` geometry (a preset or a ``sizefx/levers/1`` file; default high-precision)
    with no delays and no sensor errors.
    """
    if model is not None and nominal is not None:
        raise ConfigError("give --nominal or --model, not both: a model file carries its own lever arms")
    if model is not None:
        return theta_from_model(load_effects(model, base=IDEAL)), f"model {model}"
    from ..calibrate import nominal_levers

    name = nominal or "high-precision"
    th = np.zeros(NP)
    th[LEVER] = nominal_levers(name).arms_total.ravel()
    return th, f"nominal geometry {name}, no delays, no sensor errors"


def to_json(d: Diagnosis, start: str) -> dict:
    """The ``sizefx/diagnosis/1`` document (checked against ``data-schemas/diagnosis-1.json``)."""
    doc = {
        "schema": DIAGNOSIS_SCHEMA,
        "sizefx_version": __version__,
        "record": d.path,
        "start_model": start,
        "effects": [{"id": e.id, "channel": e.channel, "parameters": e.params, "sigma": e.sigma,
                     "nominal": e.nominal, "explained_fraction": e.explained_fraction, "sentence": e.sentence,
                     "not_revealed": e.hidden} for e in d.effects],
        "not_revealed": d.unrevealed,
        "residual_rms_before": d.rms_before,
        "residual_rms_after": d.rms_after,
        "bandwidth_hz": d.bandwidth_hz,
        "residual_rms_full_band_before": d.rms_full_before,
        "residual_rms_full_band_after": d.rms_full_after,
        "units": {"gyro": "rad/s", "accel": "m/s^2", "lever_arm": "m", "tau_s": "s", "bias_mps2": "m/s^2",
                  "bias_rad_s": "rad/s"},
        "model": d.model_path,
        "samples": d.samples,
        "block_samples": d.block,
        "noise_sigma": dict(zip(CHANNELS, d.weights_sigma.tolist())),
        "kappa": dict(zip(CHANNELS, d.kappa.tolist())),
        "passes": d.passes,
        "selection_log": d.log,
        "navigation": d.navigation,
        "wall_s": d.wall_s,
    }
    _check_document(doc)
    return doc


def _check_document(doc: dict):
    """Our writer against our contract: required keys, known identifiers (a bug if it fails)."""
    check_document(doc, DIAGNOSIS_SCHEMA)


def _rms_line(name, before, after):
    if name.startswith("gyro"):
        return f"  {name:8s} {before / DEG_PER_H:12.5g} -> {after / DEG_PER_H:12.5g} deg/h   ({_gain(before, after)})"
    return f"  {name:8s} {before / UG:12.5g} -> {after / UG:12.5g} ug      ({_gain(before, after)})"


def _gain(before, after):
    if before <= 0:
        return "no residual"
    change = 100.0 * (1.0 - after / before)
    if abs(change) < 0.05:
        return "unchanged"
    return f"{change:.1f} % lower" if change > 0 else f"{-change:.1f} % higher"


def format_report(d: Diagnosis, start: str) -> str:
    how = (f", low-passed at {d.bandwidth_hz:g} Hz (every {d.block} samples)" if d.bandwidth_hz
           else f" in blocks of {d.block}" if d.block > 1 else "")
    lines = [f"sizefx diagnose {d.path}: {d.samples} samples{how}; start: {start}"]
    if d.effects:
        lines.append(f"found {len(d.effects)} effect(s) (forward selection: information criterion and 5-fold "
                     f"cross-validation, {d.passes} Gauss-Newton passes):")
        for k, e in enumerate(d.effects, 1):
            where = f"{e.id}" + (f", {e.channel}" if e.channel else "")
            lines.append(f"  {k}. {e.sentence} [{where}; explains {100 * e.explained_fraction:.1f} % of the "
                         "residual in its channels]")
    else:
        loud = [c for c in CHANNELS if d.white_sigma and d.rms_after[c] > 1.5 * d.white_sigma[c]]
        if loud:
            lines.append("found nothing the data supports beyond the start model; but the residual on "
                         + ", ".join(f"{c} ({d.rms_after[c] / d.white_sigma[c]:.1f} times its sample-to-sample noise)"
                                     for c in loud)
                         + " is more than noise: an effect outside the candidates, or too little motion or data")
        else:
            lines.append("found nothing beyond the start model: the residual is consistent with sensor noise")
    if d.unrevealed:
        lines.append("not revealed by this record (kept at the start model; record more motion to see them):")
        for u in d.unrevealed:
            where = u["id"] + (f" {u['channel']}" if u["channel"] else "")
            lines.append(f"  - {where} ({', '.join(u['parameters'])}): {u['reason']}")
    band = f" (below {d.bandwidth_hz:g} Hz)" if d.bandwidth_hz else ""
    lines.append(f"residual RMS per channel{band}, start model -> extended model:")
    for name in CHANNELS:
        lines.append(_rms_line(name, d.rms_before[name], d.rms_after[name]))
    if d.bandwidth_hz:
        lines.append("full band (the reference's differentiated noise included):")
        for name in CHANNELS:
            lines.append(_rms_line(name, d.rms_full_before[name], d.rms_full_after[name]))
    if d.navigation:
        nav = d.navigation
        lines.append(f"navigation over {nav['duration_s']:.0f} s (free inertial, against /reference): final "
                     f"horizontal error {nav['before']['final_m']:.2f} m -> {nav['after']['final_m']:.2f} m, "
                     f"maximum {nav['before']['max_m']:.2f} m -> {nav['after']['max_m']:.2f} m")
    if d.model_path:
        lines.append(f"extended model -> {d.model_path} (sizefx navigate/compensate/diagnose --model accept it)")
    return "\n".join(lines)


def plot(d: Diagnosis, folder) -> list[str]:
    """Residuals before/after (time series, 0.1 s means) and their spectra (Welch), PNG files in ``folder``."""
    try:
        import matplotlib
    except ImportError:
        raise ConfigError("plots need matplotlib: pip install 'sizefx[plots]'") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from scipy.signal import welch

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    t, m = d.t[d.mask], d.mask
    dt = float(np.median(np.diff(d.t)))
    scale = [1 / DEG_PER_H] * 3 + [1 / UG] * 3
    units = ["deg/h"] * 3 + ["ug"] * 3
    L = max(1, round(0.1 / dt))
    written = []
    fig, axes = plt.subplots(6, 1, figsize=(10, 12), sharex=True, constrained_layout=True)
    for c, ax in enumerate(axes):
        for res, label, lw in ((d.residual_before, "start model", 0.6), (d.residual_after, "extended model", 0.8)):
            ax.plot(_blocks(t, L), _blocks(res[m, c], L) * scale[c], lw=lw, label=label)
        ax.set_ylabel(f"{CHANNELS[c]} [{units[c]}]")
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper right", fontsize=8)
    axes[0].set_title(f"{Path(d.path).name}: measured minus predicted (0.1 s means)")
    axes[-1].set_xlabel("time [s]")
    written.append(_save(fig, folder / "residuals.png"))
    plt.close(fig)
    fig, axes = plt.subplots(2, 3, figsize=(12, 7), constrained_layout=True)
    nper = int(min(m.sum(), 2 ** int(np.log2(max(16, 20.0 / dt)))))
    for c, ax in enumerate(axes.ravel()):
        for res, label in ((d.residual_before, "start model"), (d.residual_after, "extended model")):
            f, pxx = welch(res[m, c] * scale[c], fs=1.0 / dt, nperseg=nper)
            ax.loglog(f[1:], np.sqrt(pxx[1:]), lw=0.8, label=label)
        ax.set_title(CHANNELS[c])
        ax.set_xlabel("frequency [Hz]")
        ax.set_ylabel(f"[{units[c]}/sqrt(Hz)]")
        ax.grid(alpha=0.3, which="both")
    axes[0, 0].legend(fontsize=8)
    fig.suptitle(f"{Path(d.path).name}: residual amplitude spectral density")
    written.append(_save(fig, folder / "spectra.png"))
    plt.close(fig)
    return written


def _save(fig, path: Path) -> str:
    with atomic_output(path, force=True) as tmp:  # run() checked the folder against the inputs
        fig.savefig(tmp, dpi=100, format="png")
    return str(path)


def navigation_gain(tel: Telemetry, theta0: np.ndarray, theta: np.ndarray) -> dict | None:
    """Free-inertial horizontal error against ``/reference`` with the start and the extended model.

    Only for navigation-length records (10 minutes or more, reference with position).
    """
    if tel.reference is None or not tel.reference.has_position or tel.duration_s < NAVIGATION_MIN_S:
        return None
    if any(g.dataset.startswith("/imu") for g in tel.gaps):
        return None  # navigation cannot bridge an IMU gap; diagnose --segment K navigates one segment
    import tempfile

    from ..navigate import NavConfig, navigate

    out = {"duration_s": float(tel.duration_s)}
    with tempfile.TemporaryDirectory() as tmp:
        for name, th in (("before", theta0), ("after", theta)):
            path = Path(tmp) / f"{name}.toml"
            path.write_text(model_toml(th))
            res = navigate(tel, NavConfig(model=load_effects(path, base=IDEAL)))
            err = np.asarray(res.errors["horizontal_m"])
            out[name] = {"final_m": float(err[-1]), "max_m": float(np.max(err))}
    return out


#: Records at least this long, with reference position, are also navigated before and after [s].
NAVIGATION_MIN_S = 600.0


def crop(tel: Telemetry, from_s: float | None, to_s: float | None) -> Telemetry:
    """The part of a record between two times [s] (IMU and reference alike)."""
    if from_s is None and to_s is None:
        return tel
    from dataclasses import replace

    lo = -np.inf if from_s is None else from_s
    hi = np.inf if to_s is None else to_s
    keep = (tel.time_s >= lo) & (tel.time_s <= hi)
    if keep.sum() < MIN_SAMPLES:
        raise DiagnoseError(f"{tel.path}: --from-s/--to-s keep {int(keep.sum())} IMU samples; diagnose needs "
                            f"{MIN_SAMPLES}")
    fields = {k: (getattr(tel, k)[keep] if getattr(tel, k) is not None else None)
              for k in ("time_s", "gyro_rad_s", "accel_mps2", "dtheta_rad", "dvel_mps", "accel_time_s")}
    ref = tel.reference
    rk = (ref.time_s >= lo - 1.0) & (ref.time_s <= hi + 1.0)  # a second more of reference for the splines
    ref = replace(ref, **{k: getattr(ref, k)[rk] for k in ("time_s", "quat_nb", "lat_rad", "lon_rad", "height_m",
                                                           "velocity_n_mps") if getattr(ref, k) is not None})
    gaps = [g for g in tel.gaps if lo <= g.time_s <= hi]
    return replace(tel, reference=ref, gaps=gaps, **fields)


def run(path, *, nominal: str | None = None, model: str | None = None, json_path=None, plots=None,
        model_out=None, bandwidth_hz: float | None = None, from_s: float | None = None, to_s: float | None = None,
        allow_gaps: bool = False, force: bool = False, navigation: bool = True, segment: int | None = None):
    """Entry point of ``sizefx diagnose``: returns ``(Diagnosis, report text, json document)``."""
    inputs = [path] + ([model] if model else [])
    if model_out is None:
        model_out = str(Path(path).with_suffix("")) + ".model.toml"
    outs = [o for o in (json_path, model_out) if o]
    if len({Path(o).resolve() for o in outs}) < len(outs):
        raise ConfigError(f"{json_path}: --json and --model-out name the same file; give two")
    for out in outs:
        check_output_path(out, inputs=inputs, force=force)
    if plots and any(Path(plots).resolve() == Path(p).resolve() for p in inputs):
        raise ConfigError(f"{plots}: --plots names an input file; give a folder")
    if segment is not None and (from_s is not None or to_s is not None):
        raise ConfigError(f"{path}: --segment {segment} and --from-s/--to-s both choose the span; give one "
                          "(sizefx inspect lists each segment's times)")
    theta0, start = start_model(nominal, model)
    tel = read_telemetry(path, allow_gaps=allow_gaps, segment=segment)
    if tel.reference is None:
        raise DiagnoseError(f"{path}: diagnose needs /reference motion (attitude at least) to predict the IMU "
                            "from; record it, or import it with sizefx import")
    d = diagnose(crop(tel, from_s, to_s), theta0, bandwidth_hz=bandwidth_hz, keep_series=bool(plots))
    with atomic_output(model_out, force=force) as tmp:
        Path(tmp).write_text(model_toml(d.theta, source=str(path)))
    d.model_path = str(model_out)
    if navigation:
        d.navigation = navigation_gain(tel, theta0, d.theta)
    doc = to_json(d, start)
    if json_path:
        with atomic_output(json_path, force=force) as tmp:
            Path(tmp).write_text(json.dumps(doc, indent=2))
    if plots:
        doc["plots"] = plot(d, plots)
    return d, format_report(d, start), doc
