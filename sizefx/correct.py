"""Correct a record with an effect model: ``sizefx compensate --model`` and ``navigate --model``.

The model is a ``sizefx/effects/1`` TOML file (:mod:`sizefx.effects`), such as
the extended model that ``sizefx diagnose`` writes. :func:`correct_imu` inverts
the deterministic part of the simulator's sensor model (:mod:`sizefx.simulate`),
SI units, body axes x forward, y right, z down::

    gyro            g   = diag(1 + s_g) U_g omega_ib_b + b_g + G f_b
    accelerometer i m_i = (1 + s_i) a_i + K2_i a_i^2 + b_i,   read tau_s late,
                    a_i = u_i . (f_b + omegadot_ib_b x r_i + omega_ib_b x (omega_ib_b x r_i))

``U_g`` and ``U`` have the unit input axes (rows) of the gyros and the
accelerometers, ``f_b`` is the specific force at the reference point and
``r_i`` the lever arm of accelerometer i. The order of operations, each step
on the output of the one before:

1. Sync (``[accel_delay]``, and ``/imu/accel_time`` when the file has one):
   :func:`sizefx.compensate.sync_accelerometers` puts the accelerometers on
   the gyro time base. The delay commutes with the per-sample map of step 2,
   so undoing it first is exact up to the spline.
2. Accelerometer scale factor, quadratic term and bias, per channel: the root
   of ``K2 a^2 + (1 + s) a + (b - m) = 0`` nearest ``m``, written
   ``a = 2 (m - b) / ((1 + s) + sqrt((1 + s)^2 + 4 K2 (m - b)))`` so that it
   stays accurate for small and zero ``K2`` (then ``a = (m - b) / (1 + s)``).
   Increments: the same on the interval's mean rate ``dvel / dt`` (bias
   ``b``, i.e. ``b dt`` per increment), then times ``dt``; this treats the
   quadratic term as ``K2 (mean a)^2``, short by ``K2 var(a)`` over the
   interval: 1.3e-9 m/s^2 (1e-4 ug) for 1 m/s^2 of 32 Hz vibration at
   1600 Hz with K2 = 10 ug/g^2.
3. Provisional gyro: ``omega~ = (diag(1 + s_g) U_g)^-1 (g - b_g - G f~)``
   with ``f~ = U^-1 a`` from step 2, the size-effect terms still in.
4. Specific force at the reference point, for the gyro's ``G f_b`` only:
   ``f_b = U^-1 (a - size-effect terms)``, the terms (arms ``r_i``) formed
   with ``omega~``.
5. Gyro: ``omega = (diag(1 + s_g) U_g)^-1 (g - b_g - G f_b)``.
6. Size effect and accelerometer misalignment: the tangential and
   centripetal terms are removed with ``omega`` of step 5 by
   :func:`sizefx.compensate.compensate` (its kernels and estimators), arms
   ``r_i`` (:meth:`EffectModel.arms_total_m`) for ``mode "center"``, ``d_i``
   (:meth:`EffectModel.arms_d_m`) for ``"triad"``, axes
   :meth:`EffectModel.accel_axes`. Then ``a_i = u_i . f``, so ``f = U^-1 a``
   (rows of ``U`` the ``u_i``).

``G f_b`` is small (0.01 deg/h/g by default), so one pass through the
accelerometers is enough for it: ``omega~`` is off by ``G`` times the size
effect (below 1e-6 rad/s for G = 2 deg/h/g and 1 m/s^2 of size effect), which
moves the step-4 terms by about ``2 |omega| 1e-6 rad/s |r_i|`` (3e-7 m/s^2 at
2 rad/s and 8 cm) and so ``omega`` by G times that, 3e-13 rad/s. The gyro's
``G f_b`` takes ``f_b`` at the reference point in both modes, as the
simulator does.

Not corrected, because they are not errors of the IMU's outputs:
``[reference_delay]`` (the reference's clock), ``[level_tilt]`` (the table,
not the sensors) and the random part, ``[accel_noise]``, ``[gyro_noise]`` and
``[quantisation]``. A section the model switches off contributes nothing; load
models with :func:`load_model` so that a section the file omits is off.
"""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np

from .compensate import compensate, read_continuous, segment_note, sync_accelerometers
from .effects import IDEAL, EffectModel, load_effects
from .errors import ConfigError
from .levers import Levers
from .io.telemetry import Telemetry, write_telemetry

__all__ = ["CORRECTED_SECTIONS", "IGNORED_SECTIONS", "correct_imu", "load_model", "run"]

#: Sections :func:`correct_imu` inverts (the deterministic sensor errors and the lever arms).
CORRECTED_SECTIONS = ("accel_delay", "accel_bias", "accel_scale_factor", "accel_quadratic", "accel_misalignment",
                      "lever_arm", "gyro_bias", "gyro_scale_factor", "gyro_misalignment", "gyro_g_sensitivity")
#: Sections it leaves alone: not errors of the IMU's outputs, or random.
IGNORED_SECTIONS = ("reference_delay", "level_tilt", "accel_noise", "gyro_noise", "quantisation")

#: Largest condition number accepted for a sensor-axes matrix (``U``, ``U_g``). Misalignments
#: of a few arc minutes give 1.001; 10 means two axes only 11 deg apart: not a misalignment but
#: a wrong file, whose inverse would amplify errors tenfold.
MAX_AXES_CONDITION = 10.0


def load_model(path) -> EffectModel:
    """The effect model in ``path`` with every section the file omits switched off.

    (Starting from the schema's defaults instead would silently add the default
    lever arms and noise to a model that does not mention them.)
    """
    return load_effects(path, base=IDEAL)


def _check_sensor(fx: EffectModel, scale_section: str, axes_section: str, axes: np.ndarray) -> np.ndarray:
    """``1 + s`` [3], after checking that it and ``axes`` can be inverted."""
    one_plus_s = 1.0 + fx.value_or_zero(scale_section, "scale_factor")
    if np.any(one_plus_s <= 0.0):
        raise ConfigError(f"{fx.source}: [{scale_section}] gives 1 + scale factor = {one_plus_s.tolist()}; "
                          "every channel needs a positive gain (scale factors are in ppm)")
    cond = np.linalg.cond(axes)
    if not cond < MAX_AXES_CONDITION:
        raise ConfigError(f"{fx.source}: [{axes_section}] makes the sensor axes nearly dependent (condition "
                          f"{cond:.3g}, limit {MAX_AXES_CONDITION:g}); misalignments are in arcsec")
    return one_plus_s


def _invert_accel_channels(rate_mps2, one_plus_s, k2, bias, time_s):
    """``a`` [N, 3] from readings ``m`` [N, 3] (m/s^2): the root of ``(1+s) a + K2 a^2 + b = m`` nearest m."""
    x = rate_mps2 - bias
    disc = one_plus_s**2 + 4.0 * k2 * x
    if np.any(disc < 0.0):
        k, i = np.argwhere(disc < 0.0)[0]
        raise ConfigError(f"accelerometer {'xyz'[i]} reads {rate_mps2[k, i]:.6g} m/s^2 at t = {time_s[k]:.6f} s, "
                          f"where (1 + s) a + K2 a^2 + b with K2 = {k2[i]:.6g} s^2/m has no real inverse; "
                          "check [accel_quadratic] (ug_per_g2) of the model")
    return 2.0 * x / (one_plus_s + np.sqrt(disc))


def correct_imu(tel: Telemetry, fx: EffectModel, *, mode: str = "center", estimator: str | None = None) -> Telemetry:
    """A copy of ``tel`` with the model's deterministic IMU errors and size effect removed.

    Parameters
    ----------
    tel : Telemetry
        Rates (``gyro_rad_s``, ``accel_mps2`` [N, 3], rad/s and m/s^2) or
        increments (``dtheta_rad``, ``dvel_mps`` [N, 3], rad and m/s), body axes.
    fx : EffectModel
        The model (:func:`load_model`). Sections that are off contribute nothing;
        ``IGNORED_SECTIONS`` are ignored (see the module docstring).
    mode : {"center", "triad"}
        Bring the accelerometers to the reference point (arms ``r_i``) or to the
        triad point (arms ``d_i``), as in :func:`sizefx.compensate.compensate`.
    estimator : {"central", "savgol", "increments"} or None
        Angular acceleration for the tangential term (:mod:`sizefx.omegadot`):
        ``central`` or ``savgol`` for rates, ``increments`` for increments;
        None picks ``savgol`` or ``increments`` by the record's form.

    Returns
    -------
    Telemetry
        Same form and time stamps; gyros read ``omega_ib_b``, accelerometers
        ``f_b`` at the reference point (``center``) or the triad point
        (``triad``), on the gyro time base (``accel_time_s`` None). ``source``
        gains ``correction_json``: what was applied.
    """
    if mode not in ("center", "triad"):
        raise ConfigError(f"correction mode '{mode}': use center or triad")
    if estimator is None:
        estimator = "increments" if tel.form == "increments" else "savgol"
    accel_axes = fx.accel_axes()
    gyro_axes = fx.gyro_axes()
    accel_gain = _check_sensor(fx, "accel_scale_factor", "accel_misalignment", accel_axes)
    gyro_gain = _check_sensor(fx, "gyro_scale_factor", "gyro_misalignment", gyro_axes)
    mat_gyro_inv = np.linalg.inv(np.diag(gyro_gain) @ gyro_axes)  # (diag(1 + s_g) U_g)^-1
    accel_axes_inv = np.linalg.inv(accel_axes)  # U^-1: f = U^-1 a
    gyro_bias = fx.value_or_zero("gyro_bias", "bias_rad_s")
    gyro_g = fx.value_or_zero("gyro_g_sensitivity", "rad_s_per_mps2", (3, 3))
    accel_bias = fx.value_or_zero("accel_bias", "bias_mps2")
    accel_k2 = fx.value_or_zero("accel_quadratic", "k2_per_mps2")
    tau = float(fx.get("accel_delay", "tau_s")) if fx.enabled("accel_delay") else 0.0

    tel_in, tel = tel, sync_accelerometers(tel, tau)  # step 1
    gyro_like, accel_like = tel.imu_arrays()
    # Per sample: 1 for rates, dt for increments (a rate bias b adds b dt to each increment).
    per_sample = 1.0 if tel.form == "rates" else tel.sample_period_s
    a = _invert_accel_channels(accel_like / per_sample, accel_gain, accel_k2, accel_bias,
                               tel.time_s) * per_sample  # step 2

    def gyro_from(f_like):
        # rows: omega = M^-1 (g - b_g - G f), M = diag(1 + s_g) U_g (per sample: b_g dt, G dv for increments)
        return (gyro_like - gyro_bias * per_sample - f_like @ gyro_g.T) @ mat_gyro_inv.T

    def without_size_effect(omega_like, lever_mode):
        # compensate() with delay 0 (the sync is done); it validates the estimator for the form
        if tel.form == "rates":
            staged = replace(tel, gyro_rad_s=omega_like, accel_mps2=a)
        else:
            staged = replace(tel, dtheta_rad=omega_like, dvel_mps=a)
        return compensate(staged, levers, lever_mode, estimator=estimator, accel_delay_s=0.0).imu_arrays()[1]

    levers = Levers(arms_total=fx.arms_total_m(), offset=fx.offset_m(), arms_triad=fx.arms_d_m(), axes=accel_axes)
    omega_provisional = gyro_from(a @ accel_axes_inv.T)  # step 3
    f_reference = without_size_effect(omega_provisional, "center") @ accel_axes_inv.T  # step 4
    omega_like = gyro_from(f_reference)  # step 5
    f_like = without_size_effect(omega_like, mode) @ accel_axes_inv.T  # step 6
    if tel.form == "rates":
        new = replace(tel, gyro_rad_s=omega_like, accel_mps2=f_like)
    else:
        new = replace(tel, dtheta_rad=omega_like, dvel_mps=f_like)

    applied = {"model": fx.source, "mode": mode, "estimator": estimator,
               "corrected": [name for name in CORRECTED_SECTIONS if fx.enabled(name)],
               "ignored": [name for name in IGNORED_SECTIONS if fx.enabled(name)],
               "accel_delay_s": tau, "arms_m": levers.arms_for(mode).tolist(), "accel_axes": accel_axes.tolist(),
               "effects": fx.truth()}
    new.source = {**(tel_in.source or {}), "correction_json": json.dumps(applied)}
    new.description = (tel_in.description + " | " if tel_in.description else "") + \
        f"corrected with effect model {fx.source} ({mode}, {estimator})"
    return new


def run(path, model_path, out, *, mode: str = "triad", estimator: str | None = None, allow_gaps: bool = False,
        force: bool = False, segment: int | None = None) -> dict:
    """Entry point of ``sizefx compensate --model``: read, correct, write ``out`` (same form)."""
    tel = read_continuous(path, allow_gaps=allow_gaps, segment=segment, command="compensate")
    fx = load_model(model_path)
    new = correct_imu(tel, fx, mode=mode, estimator=estimator)
    if tel.segment is not None:
        new.source["correction_json"] = json.dumps({**json.loads(new.source["correction_json"]),
                                                    **segment_note(tel)})
    write_telemetry(out, new, inputs=[path, model_path], force=force)
    applied = json.loads(new.source["correction_json"])
    return {"path": str(out), "samples": new.n_samples,
            **{k: applied[k] for k in ("model", "mode", "estimator", "corrected", "ignored", "accel_delay_s")}}
