"""The model vector ``theta``: every scalar diagnose can fit, in SI, and where each one sits.

``theta`` is the sensor model's (:data:`sizefx.sensor_model.PARAMS`: the same 52 scalars in the
same order, with the same labels); this module adds what diagnose needs to report and select
them (report unit, numerical step, excitation floor) and the index arrays of the layout::

    A_BIAS   [3]  accelerometer biases b_a                      m/s^2
    A_SF     [3]  accelerometer scale factors s_a               1
    A_MIS    [6]  accelerometer misalignments m_ij, i != j      rad   (row-major: x->y, x->z, y->x, ...)
    A_K2     [3]  accelerometer quadratic terms K2              1/(m/s^2)
    LEVER    [9]  arms r_i from the reference point, rows x, y, z, each (x, y, z) in body axes   m
    TAU_A    [1]  accelerometer delay behind the gyros           s
    TAU_R    [1]  reference delay (rows stamped t hold the motion at t - tau_ref)   s
    TILT     [2]  level tilt about north, about east             rad
    G_BIAS   [3]  gyro biases b_g                                rad/s
    G_SF     [3]  gyro scale factors s_g                         1
    G_MIS    [6]  gyro misalignments m_ij, i != j                rad
    G_G      [9]  gyro g-sensitivity G[i, j] (gyro i per f_b along j), row-major   rad/s per m/s^2
    MOUNT    [3]  the IMU's axes against the reference's body axes, psi about x, y, z   rad

52 scalars in all (:data:`NP`). :func:`theta_from_model` fills it from an effect model; the
extended-model TOML (:func:`sizefx.diagnose.extended.model_document`) writes it back.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import sensor_model as sm
from ..constants import ARCSEC, DEG_PER_H, MICRO_G, STANDARD_GRAVITY_MPS2
from ..effects import EffectModel

__all__ = [
    "A_BIAS",
    "A_K2",
    "A_MIS",
    "A_SF",
    "CHANNELS",
    "G_BIAS",
    "G_G",
    "G_MIS",
    "G_SF",
    "LEVER",
    "MOUNT",
    "NP",
    "OFFDIAG",
    "PARAMS",
    "TAU_A",
    "TAU_R",
    "TILT",
    "Param",
    "theta_from_model",
]

#: The six channels of a prediction or residual, in column order (the sensor model's).
CHANNELS = sm.CHANNELS
#: The (i, j) of each misalignment scalar, in the order of A_MIS and G_MIS (the sensor model's).
OFFDIAG = sm.OFFDIAG


@dataclass(frozen=True)
class Param:
    """One scalar of the model vector ``theta`` (SI): the sensor model's parameter and how diagnose treats it."""

    effect: str
    label: str  #: e.g. "r_y[x]", "x"
    unit: str  #: report unit
    per_unit: float  #: SI value of one report unit
    step: float  #: SI step of the numerical derivative
    min_excitation: float  #: RMS of its regressor (SI), after what the selected effects explain, below which
    #: the record "cannot reveal" the parameter, whatever the noise
    primary: tuple = ()  #: channels whose regressor measures the excitation (default: all it acts on)


_GYROS, _ACCELS = (0, 1, 2), (3, 4, 5)
#: Per effect: (report unit, SI per report unit, numerical step, excitation floor, primary channels).
#: Excitation floors, in the regressor's SI units: a tenth of a constant for a bias; 0.1 m/s^2 of
#: changing specific force for scale factors, misalignments and the tilt (1 % of g); 0.01 s^-2 of
#: omega^2 or omegadot for the arms (6 deg/s); 0.03 m/s^3 of d f/dt for the accelerometer delay (a
#: tilting table gives g omega, ~3 m/s^3; rotation about the vertical only gives d(omega^2 r)/dt,
#: ~0.003 m/s^3); 0.003 rad/s^2 of omegadot for the reference delay; 0.01 rad/s of rate for the
#: gyro scale factors and misalignments, and for the reference's mount, measured on the gyros
#: (omega x e_k): rotation is what tells a mount from a level tilt and the accelerometer biases,
#: which a constant gravity projection alone cannot (a record that only translates leaves it
#: unrevealed, however much its specific force changes; the conservative side of the issue's
#: "0.01 rad/s or 0.1 m/s^2", which one floor per parameter cannot state).
_TREATMENT = {
    "accel_bias": ("ug", MICRO_G, 1e-4, 0.1, ()),
    "accel_scale_factor": ("ppm", 1e-6, 1e-4, 0.1, ()),
    "accel_misalignment": ("arcsec", ARCSEC, 1e-5, 0.1, ()),
    "accel_quadratic": ("ug/g^2", MICRO_G / STANDARD_GRAVITY_MPS2**2, 1e-4, 1.0, ()),
    "lever_arm": ("mm", 1e-3, 1e-3, 0.01, ()),
    "accel_delay": ("us", 1e-6, 1e-5, 0.03, _ACCELS),
    "reference_delay": ("us", 1e-6, 1e-5, 0.003, _GYROS),
    "level_tilt": ("arcsec", ARCSEC, 1e-5, 0.1, _ACCELS),
    "gyro_bias": ("deg/h", DEG_PER_H, 1e-6, 0.1, ()),
    "gyro_scale_factor": ("ppm", 1e-6, 1e-4, 0.01, ()),
    "gyro_misalignment": ("arcsec", ARCSEC, 1e-5, 0.01, ()),
    "gyro_g_sensitivity": ("deg/h/g", DEG_PER_H / STANDARD_GRAVITY_MPS2, 1e-6, 0.1, ()),
    "reference_mount": ("arcsec", ARCSEC, 1e-5, 0.01, _GYROS),
}
#: The sensor model's ``theta`` (:data:`sizefx.sensor_model.PARAMS`), each scalar with diagnose's treatment.
PARAMS = tuple(Param(q.effect, q.label, *_TREATMENT[q.effect]) for q in sm.PARAMS)
NP = len(PARAMS)
A_BIAS, A_SF, A_MIS, A_K2, LEVER = (
    sm.param_index(k)
    for k in ("accel_bias", "accel_scale_factor", "accel_misalignment", "accel_quadratic", "lever_arm")
)
TAU_A, TAU_R = int(sm.param_index("accel_delay")[0]), int(sm.param_index("reference_delay")[0])
TILT = sm.param_index("level_tilt")
G_BIAS, G_SF, G_MIS, G_G = (
    sm.param_index(k) for k in ("gyro_bias", "gyro_scale_factor", "gyro_misalignment", "gyro_g_sensitivity")
)
MOUNT = sm.param_index("reference_mount")


def theta_from_model(fx: EffectModel) -> np.ndarray:
    """The model vector (SI) of an effect model's deterministic terms."""
    return sm.SensorParams.from_effects(fx).vector()
