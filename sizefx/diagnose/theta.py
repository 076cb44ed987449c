"""The model vector ``theta``: every scalar diagnose can fit, in SI, and where each one sits.

Layout (index arrays of this module; :data:`PARAMS` gives each scalar its label, report unit,
numerical step and excitation floor)::

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

49 scalars in all (:data:`NP`). :func:`theta_from_model` fills it from an effect model; the
extended-model TOML (:func:`sizefx.diagnose.report.model_document`) writes it back.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..constants import ARCSEC, DEG, STANDARD_GRAVITY_MPS2
from ..effects import EffectModel

__all__ = ["A_BIAS", "A_K2", "A_MIS", "A_SF", "CHANNELS", "DEG_PER_H", "G_BIAS", "G_G", "G_MIS", "G_SF", "LEVER",
           "NP", "OFFDIAG", "PARAMS", "TAU_A", "TAU_R", "TILT", "UG", "Param", "misaligned_axes", "offdiag_row",
           "theta_from_model"]

#: The six channels of a prediction or residual, in column order.
CHANNELS = ("gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z")
#: One micro-g [m/s^2] and one degree per hour [rad/s]: the report units of biases.
UG = STANDARD_GRAVITY_MPS2 * 1e-6
DEG_PER_H = DEG / 3600.0


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
_IDX: dict = {}
for _k, _p in enumerate(PARAMS):
    _IDX.setdefault(_p.effect, []).append(_k)
A_BIAS, A_SF, A_MIS, A_K2, LEVER = (np.array(_IDX[k]) for k in
                                    ("accel_bias", "accel_scale_factor", "accel_misalignment", "accel_quadratic",
                                     "lever_arm"))
TAU_A, TAU_R = _IDX["accel_delay"][0], _IDX["reference_delay"][0]
TILT = np.array(_IDX["level_tilt"])
G_BIAS, G_SF, G_MIS, G_G = (np.array(_IDX[k]) for k in
                            ("gyro_bias", "gyro_scale_factor", "gyro_misalignment", "gyro_g_sensitivity"))
#: The (i, j) of each misalignment scalar, in the order of A_MIS and G_MIS.
OFFDIAG = tuple((i, j) for i in range(3) for j in range(3) if i != j)


def theta_from_model(fx: EffectModel) -> np.ndarray:
    """The model vector (SI) of an effect model's deterministic terms."""
    th = np.zeros(NP)
    th[A_BIAS] = fx.value_or_zero("accel_bias", "bias_mps2")
    th[A_SF] = fx.value_or_zero("accel_scale_factor", "scale_factor")
    m = fx.value_or_zero("accel_misalignment", "angles_rad", (3, 3))
    th[A_MIS] = [m[i, j] for i, j in OFFDIAG]
    th[A_K2] = fx.value_or_zero("accel_quadratic", "k2_per_mps2")
    th[LEVER] = fx.arms_total_m().ravel()
    th[TAU_A] = fx.get("accel_delay", "tau_s") if fx.enabled("accel_delay") else 0.0
    th[TAU_R] = fx.get("reference_delay", "tau_s") if fx.enabled("reference_delay") else 0.0
    th[TILT] = fx.tilt_rad()[:2]
    th[G_BIAS] = fx.value_or_zero("gyro_bias", "bias_rad_s")
    th[G_SF] = fx.value_or_zero("gyro_scale_factor", "scale_factor")
    m = fx.value_or_zero("gyro_misalignment", "angles_rad", (3, 3))
    th[G_MIS] = [m[i, j] for i, j in OFFDIAG]
    th[G_G] = fx.value_or_zero("gyro_g_sensitivity", "rad_s_per_mps2", (3, 3)).ravel()
    return th


def misaligned_axes(offdiag) -> np.ndarray:
    """Unit rows ``normalise(e_i + sum_j m_ij e_j)`` [3, 3] of six misalignments (the simulator's model)."""
    m = np.eye(3)
    for (i, j), v in zip(OFFDIAG, offdiag):
        m[i, j] = v
    return m / np.linalg.norm(m, axis=1, keepdims=True)


def offdiag_row(offdiag, i: int) -> np.ndarray:
    """Row ``i`` [3] of the misalignment matrix whose off-diagonal terms are ``offdiag`` (zero diagonal)."""
    row = np.zeros(3)
    for (ii, jj), v in zip(OFFDIAG, offdiag):
        if ii == i:
            row[jj] = v
    return row
