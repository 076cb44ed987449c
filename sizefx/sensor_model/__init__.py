"""The sensor model: how each effect changes what the IMU reads, written once.

The package: :mod:`.table` (the effects, the parameters, the motion), :mod:`.forward`,
:mod:`.inverse`, :mod:`.jacobian`; everything is imported from here.

The effects
-----------
:data:`EFFECTS` is the table every function here reads. One row per effect; the name is the
section of ``data-schemas/effects-1.json`` (the TOML file's ``[section]``), the field of
:class:`SensorParams` and the identifier ``sizefx diagnose`` reports. SI inside (the TOML
keys carry their own units; :mod:`sizefx.effects` converts). Body axes x forward, y right,
z down; ``e_i`` the body axis i, ``omega = omega_ib_b``, ``f = f_b`` at the reference point::

    effect               sensor     parameters (theta)                 enters
    accel_bias           accel      b_i [m/s^2], 3                     m_i = (1 + s_i) a_i + K2_i a_i^2 + b_i
    accel_scale_factor   accel      s_i [1], 3                         (the same line)
    accel_misalignment   accel      m_ij [rad], 6 off-diagonal         u_i = normalise(e_i + sum_j m_ij e_j),
                                                                       a_i = u_i . f_i
    accel_quadratic      accel      K2_i [s^2/m], 3                    (the m_i line)
    lever_arm            accel      r_i [m], 9 (rows r_x, r_y, r_z)    f_i = f + omegadot x r_i + omega x (omega x r_i)
    accel_delay          accel      tau_a [s], 1                       accelerometers sample the motion at t - tau_a
    reference_delay      reference  tau_r [s], 1                       the reference row stamped t reports the true
                                                                       motion at t - tau_r
    level_tilt           reference  (phi_N, phi_E) [rad], 2            true attitude = R(phi) x reported attitude
    gyro_bias            gyro       b_g [rad/s], 3                     g = diag(1 + s_g) U_g omega + b_g + G f
    gyro_scale_factor    gyro       s_g [1], 3                         (the same line)
    gyro_misalignment    gyro       m_ij [rad], 6 off-diagonal         rows of U_g: normalise(e_i + sum_j m_ij e_j)
    gyro_g_sensitivity   gyro       G [rad/s per m/s^2], 9             (the g line; f at the gyros' instants)
    reference_mount      reference  psi [rad], 3                       the IMU's axes are the reference's body axes
                                                                       turned by psi: omega, omegadot, f in b are
                                                                       C_b_b' times the reference's, C_b_b' =
                                                                       exp(-[psi x]) ~ I - [psi x]
    accel_noise          accel      random (simulate only)             white noise, a bias random walk,
                                                                       a Gauss-Markov coloured part
    gyro_noise           gyro       random (simulate only)             angle and rate random walk
    quantisation         both       random (simulate only)             outputs rounded to a count

The model vector ``theta`` (:data:`PARAMS`, 52 scalars) lists the deterministic rows'
parameters in the table's order; it is the vector ``sizefx diagnose`` fits.

The reference side
------------------
Two effects are not errors of the IMU but of what the motion's reporter says: the IMU reads
the *true* motion, the reference reports another. ``level_tilt``: the true attitude is
``R(phi) mat_nb_reported`` (:func:`true_attitude`; a tilted table, a reference misaligned from
the level), so the true ``f_b`` and ``omega_ib_b`` are formed with the tilted attitude before
:func:`forward`. ``reference_delay``: the reference row stamped t reports the true motion at
``t - tau_r`` (:func:`reported_time`); a predictor that starts from the reference evaluates it
at ``t + tau_r``. ``reference_mount``: the IMU's axes b are the reference's body axes b' turned
by ``psi`` (a motion-capture marker body, a turntable fixture; :func:`mount_matrix` states the
sign), so the true attitude is ``R(phi) mat_nb_reported C_b'_b`` (:func:`true_attitude` applies
both) and the rates and specific force in IMU axes are the reference's times ``C_b_b'``. It turns
the gyros and the accelerometers together, like a rigid rotation of both triads: on one record
it is the common antisymmetric part of ``gyro_misalignment`` and ``accel_misalignment``, and
diagnose prefers it. None of the three is inverted: correcting a record does not change its
reference (the lever terms are formed from the measured gyros, which are already in IMU axes).

The three maps
--------------
- :func:`forward` (true motion -> readings), per instant; :func:`sample` evaluates a motion
  function at the instants each sensor samples (the accelerometers ``tau_a`` early), which is
  how the accelerometer delay enters. Used by :mod:`sizefx.simulate`.
- :func:`inverse` (readings -> ``omega_ib_b`` and ``f_b``): the deterministic sensor errors and
  the lever arms undone, steps 2-6 of :mod:`sizefx.correct`'s docstring; step 1, the delay, is
  a resampling of the whole series, done by :func:`sizefx.sync.sync_accelerometers`
  before (the one place that resamples). Used by :func:`sizefx.correct.correct_imu`.
- :class:`Correction`: what navigation removes, resolved once from a levers file or a model: the
  sync, steps 2-5 (:func:`invert_channels`) on the chunk's readings and step 6 on its increments.
- :func:`jacobian`: the partial derivatives of :func:`forward`'s readings with respect to each
  parameter of ``theta``, analytic, at any ``theta``. Used by :mod:`sizefx.calibrate`'s joint
  fit; ``tests/test_sensor_model.py`` checks each column against finite differences of
  :func:`forward` (and :func:`sample` for the delays).

How to add an effect
--------------------
1. Its section in ``data-schemas/effects-1.json`` (keys with units; :func:`sizefx.effects.load_effects`
   then reads and checks a TOML file for it).
2. A row in :data:`EFFECTS` and a field of the same name in :class:`SensorParams` (its SI value;
   ``si_key`` tells :meth:`SensorParams.from_effects` where the value is).
3. Its term in :func:`forward` (:func:`gyro_readings`, :func:`accel_inputs` or
   :func:`accel_readings`), its undoing in :func:`inverse` (or ``inverse=None`` in its row, with
   the reason), its columns in :func:`jacobian`.
``tests/test_sensor_model.py`` then checks the row against the schema, that :func:`forward`
moves with each of its parameters, that :func:`jacobian` has each column and that it matches
finite differences, and that ``inverse(forward(x)) = x`` with it switched on.
"""

from .correction import Correction
from .forward import accel_inputs, accel_readings, forward, gyro_readings, sample, specific_force_at
from .inverse import check_estimator, check_invertible, inverse, invert_channels, remove_lever_terms
from .jacobian import Jacobian, jacobian
from .table import (
    CHANNELS,
    EFFECTS,
    INVERTED,
    NOT_INVERTED,
    NP,
    OFFDIAG,
    PARAMS,
    Effect,
    Motion,
    Param,
    SensorParams,
    cross,
    mount_matrix,
    param_index,
    reported_time,
    true_attitude,
    unit_axes,
)

__all__ = [
    "EFFECTS",
    "Effect",
    "PARAMS",
    "Param",
    "NP",
    "SensorParams",
    "Motion",
    "Jacobian",
    "forward",
    "sample",
    "gyro_readings",
    "accel_inputs",
    "accel_readings",
    "specific_force_at",
    "inverse",
    "invert_channels",
    "remove_lever_terms",
    "Correction",
    "check_invertible",
    "check_estimator",
    "jacobian",
    "true_attitude",
    "reported_time",
    "mount_matrix",
    "unit_axes",
    "param_index",
    "cross",
    "INVERTED",
    "NOT_INVERTED",
    "CHANNELS",
    "OFFDIAG",
]
