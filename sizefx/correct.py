"""Correct a record with an effect model: ``sizefx compensate --model`` and ``navigate --model``.

The model is a ``sizefx/effects/1`` TOML file (:mod:`sizefx.effects`), such as
the extended model that ``sizefx diagnose`` writes. :func:`correct_imu` inverts
the deterministic part of the sensor model (:mod:`sizefx.sensor_model`, whose forward
map the simulator uses), SI units, body axes x forward, y right, z down::

    gyro            g   = diag(1 + s_g) U_g omega_ib_b + b_g + G f_b
    accelerometer i m_i = (1 + s_i) a_i + K2_i a_i^2 + b_i,   read tau_s late,
                    a_i = u_i . (f_b + omegadot_ib_b x r_i + omega_ib_b x (omega_ib_b x r_i))

``U_g`` and ``U`` have the unit input axes (rows) of the gyros and the
accelerometers, ``f_b`` is the specific force at the reference point and
``r_i`` the lever arm of accelerometer i. The order of operations, each step
on the output of the one before (step 1 here, steps 2-6 :func:`sizefx.sensor_model.inverse`):

1. Sync (``[accel_delay]``, and ``/imu/accel_time`` when the file has one):
   :func:`sizefx.sync.sync_accelerometers` puts the accelerometers on
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
   :func:`sizefx.sensor_model.remove_lever_terms` (the size-effect kernels and the
   angular-acceleration estimators of ``sizefx compensate``), arms
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
``[quantisation]`` (:data:`sizefx.sensor_model.NOT_INVERTED`). A section the model
switches off contributes nothing; load models with :func:`load_model` so that a section
the file omits is off.
"""

from __future__ import annotations

from dataclasses import replace

from .effects import IDEAL, EffectModel, load_effects
from .errors import ConfigError
from .io.telemetry import Provenance, Telemetry
from .omegadot import SAVGOL_WINDOW
from .sensor_model import INVERTED, NOT_INVERTED, check_estimator, check_invertible, inverse
from .sensor_model.correction import model_correction_record
from .sensor_model.table import MAX_AXES_CONDITION
from .sync import sync_accelerometers

__all__ = ["CORRECTED_SECTIONS", "IGNORED_SECTIONS", "MAX_AXES_CONDITION", "correct_imu", "load_model"]

#: Sections :func:`correct_imu` inverts (the deterministic sensor errors and the lever arms).
CORRECTED_SECTIONS = INVERTED
#: Sections it leaves alone: not errors of the IMU's outputs, or random.
IGNORED_SECTIONS = NOT_INVERTED


def load_model(path) -> EffectModel:
    """The effect model in ``path`` with every section the file omits switched off.

    (Starting from the schema's defaults instead would silently add the default
    lever arms and noise to a model that does not mention them.)
    """
    return load_effects(path, base=IDEAL)


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
        gains :attr:`~sizefx.io.provenance.Provenance.correction`: what was applied (and the
        segment, for a record read as one).
    """
    if mode not in ("center", "triad"):
        raise ConfigError(f"correction mode '{mode}': use center or triad")
    if estimator is None:
        estimator = "increments" if tel.form == "increments" else "savgol"
    p = fx.sensor_params()
    check_estimator(tel.form, estimator)  # every refusal before the work
    check_invertible(p)
    if tel.n_samples < 4 * SAVGOL_WINDOW:
        raise ConfigError(f"{tel.path}: {tel.n_samples} samples; compensation needs at least {4 * SAVGOL_WINDOW}")

    tel_in, tel = tel, sync_accelerometers(tel, p.accel_delay)  # step 1
    gyro_like, accel_like = tel.imu_arrays()
    omega_like, f_like = inverse(
        p,
        gyro_like,
        accel_like,
        form=tel.form,
        dt=tel.sample_period_s,
        mode=mode,
        estimator=estimator,
        time_s=tel.time_s,
    )  # steps 2-6
    applied = {**model_correction_record(fx, p, mode, estimator), "effects": fx.truth()}
    if tel_in.segment is not None:  # what was corrected is a segment of the record
        applied.update(tel_in.segment.note())
    names = ("gyro_rad_s", "accel_mps2") if tel.form == "rates" else ("dtheta_rad", "dvel_mps")
    return replace(
        tel,
        **dict(zip(names, (omega_like, f_like))),
        source=replace(tel_in.source or Provenance(), correction=applied),
        description=(tel_in.description + " | " if tel_in.description else "")
        + f"corrected with effect model {fx.source} ({mode}, {estimator})",
    )
