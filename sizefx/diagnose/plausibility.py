"""What a sensor of a given grade can plausibly show: the ranges an estimate must lie in to be a finding.

An estimate outside its range is not a sensor property to be written into a model: a bias of
-33 mg on a navigation-grade accelerometer, a gyro g-sensitivity of 5 000 deg/h/g or a lever arm
of two metres say that something else went wrong (the reference, an effect outside the model, a
unit). :func:`judge` refuses such estimates and says what is more likely.

Ranges (largest magnitude of any parameter of the effect, in the report unit) per grade; the
sources are typical data-sheet limits with room (a factor 3-10 above the worst part of the grade),
so that a real but poor part is still accepted and only the absurd is refused:

=====================  ==========  =========  ============  =====================================
effect                 navigation  tactical   industrial    unit (and the data-sheet figure)
=====================  ==========  =========  ============  =====================================
accel_bias             2 000       20 000     200 000       ug   (nav 25-100 ug, MEMS up to 60 mg)
accel_scale_factor     1 000       5 000      30 000        ppm  (nav 50-300, MEMS 0.3-1 %)
accel_misalignment     300         1 500      7 200         arcsec (nav 10-30, MEMS 0.5 deg)
accel_quadratic        300         2 000      20 000        ug/g^2 (nav 5-30, MEMS ~1 000)
lever_arm              1 000       1 000      1 000         mm from the reference point
accel_delay            10 000      10 000     20 000        us
reference_delay        100 000     100 000    100 000       us (a clock that far off is a timestamp bug)
level_tilt             3 600       3 600      3 600         arcsec (a table or mount off level by 1 deg)
gyro_bias              1           300        20 000        deg/h (nav 0.003-0.01, MEMS 1-5 deg/s)
gyro_scale_factor      300         3 000      20 000        ppm  (nav 5-50, MEMS 0.5-1 %)
gyro_misalignment      300         1 500      5 000         arcsec (MEMS cross-axis 1 % = 2 000)
gyro_g_sensitivity     2           50         1 000         deg/h/g (nav 0.1-0.5, MEMS 0.1 deg/s/g)
reference_mount        18 000      18 000     18 000        arcsec (a marker body or fixture: 5 deg)
=====================  ==========  =========  ============  =====================================

The grade is given (``--grade``) or inferred from the gyro and accelerometer white-noise densities
the record shows (:func:`infer_grade`; the coarser of the two: a noisy reference makes the IMU look
worse, which only widens the ranges).
"""

from __future__ import annotations

import math

from ..constants import ARCSEC, DEG, STANDARD_GRAVITY_MPS2
from ..errors import ConfigError

__all__ = ["GRADES", "RANGES", "infer_grade", "judge", "likely_cause", "check_grade"]

GRADES = ("navigation", "tactical", "industrial")
_UG = STANDARD_GRAVITY_MPS2 * 1e-6
_DPH = DEG / 3600.0
#: Per effect: (SI per report unit, report unit, (navigation, tactical, industrial) in report units).
RANGES = {
    "accel_bias": (_UG, "ug", (2e3, 2e4, 2e5)),
    "accel_scale_factor": (1e-6, "ppm", (1e3, 5e3, 3e4)),
    "accel_misalignment": (ARCSEC, "arcsec", (300.0, 1500.0, 7200.0)),
    "accel_quadratic": (_UG / STANDARD_GRAVITY_MPS2**2, "ug/g^2", (300.0, 2e3, 2e4)),
    "lever_arm": (1e-3, "mm", (1e3, 1e3, 1e3)),
    "accel_delay": (1e-6, "us", (1e4, 1e4, 2e4)),
    "reference_delay": (1e-6, "us", (1e5, 1e5, 1e5)),
    "level_tilt": (ARCSEC, "arcsec", (3600.0, 3600.0, 3600.0)),
    "gyro_bias": (_DPH, "deg/h", (1.0, 300.0, 2e4)),
    "gyro_scale_factor": (1e-6, "ppm", (300.0, 3e3, 2e4)),
    "gyro_misalignment": (ARCSEC, "arcsec", (300.0, 1500.0, 5000.0)),
    "gyro_g_sensitivity": (_DPH / STANDARD_GRAVITY_MPS2, "deg/h/g", (2.0, 50.0, 1e3)),
    "reference_mount": (ARCSEC, "arcsec", (1.8e4, 1.8e4, 1.8e4)),
}
#: White-noise densities that separate the grades: gyro angle random walk [deg/sqrt(h)] and
#: accelerometer noise [ug/sqrt(Hz)]; a part at or under the first is navigation grade, under the
#: second tactical, above it industrial (MEMS). Navigation gyros: 0.001-0.005 deg/sqrt(h); tactical
#: 0.01-0.1; MEMS 0.1-1. Accelerometers: 5-25, 25-100, 100-400 ug/sqrt(Hz).
ARW_LIMITS_DEG_SQRT_H = (0.01, 0.15)
VRW_LIMITS_UG_SQRT_HZ = (30.0, 150.0)


def check_grade(grade: str | None) -> str | None:
    """``--grade``: one of :data:`GRADES` or None (infer); anything else is refused."""
    if grade is None or grade == "auto":
        return None
    if grade not in GRADES:
        raise ConfigError(f"--grade {grade}: give one of {', '.join(GRADES)} or auto (inferred from the noise)")
    return grade


def infer_grade(white_sigma, dt_s: float) -> tuple[str, str]:
    """The grade the record's white noise suggests, and a sentence saying how it was inferred.

    ``white_sigma`` [6]: the per-sample white noise of gyro x, y, z (rad/s) and accelerometer x, y,
    z (m/s^2) at sample period ``dt_s``; densities are sigma * sqrt(dt).
    """
    arw = min(white_sigma[:3]) * math.sqrt(dt_s) / DEG * 60.0  # rad/s/sqrt(Hz) -> deg/sqrt(h)
    vrw = min(white_sigma[3:]) * math.sqrt(dt_s) / _UG
    g = sum(arw > lim for lim in ARW_LIMITS_DEG_SQRT_H)
    a = sum(vrw > lim for lim in VRW_LIMITS_UG_SQRT_HZ)
    grade = GRADES[max(g, a)]
    return grade, (f"grade {grade}, inferred from the quietest channels' white noise: gyro {arw:.3g} deg/sqrt(h), "
                   f"accelerometer {vrw:.3g} ug/sqrt(Hz)")


def judge(effect: str, values_si, grade: str) -> str | None:
    """None when every value of ``effect`` lies in its range for ``grade``; otherwise the reason.

    Lever arms are judged by the arm's length, every other effect by its largest component.
    """
    per_unit, unit, limits = RANGES[effect]
    limit = limits[GRADES.index(grade)]
    vals = [abs(float(v)) for v in values_si]
    size = math.sqrt(sum(v * v for v in vals)) if effect == "lever_arm" else max(vals, default=0.0)
    if size / per_unit <= limit:
        return None
    return f"{size / per_unit:,.0f} {unit} is outside what a {grade}-grade sensor shows (at most {limit:,.0f} {unit})"


def likely_cause(effect: str) -> str:
    """What an implausible estimate of ``effect`` more likely is, in one phrase."""
    if effect in ("accel_scale_factor", "gyro_scale_factor", "accel_quadratic"):
        return ("a reference or unit problem (the reference scaled, filtered or in other units than the IMU), "
                "or noise in a reference differentiated beyond its bandwidth")
    if effect in ("accel_bias", "level_tilt", "accel_misalignment", "gyro_misalignment", "reference_mount"):
        return "a reference attitude error (jumps, a wrong frame or mounting) or the IMU in other units"
    if effect == "gyro_bias":
        return "a reference attitude that drifts or jumps, or gyro output in other units (deg/s for rad/s)"
    if effect == "gyro_g_sensitivity":
        return "a reference attitude error that follows the specific force, or an effect outside the model"
    if effect == "lever_arm":
        return "noise in the reference's position differentiated twice, or the wrong reference point"
    return "a timestamp problem in the record (clocks), not a sensor property"
