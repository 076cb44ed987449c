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

Inside those ranges, a parameter the record cannot reveal is not equally likely anywhere: a part
meets its data sheet. :data:`DATASHEET` holds the data-sheet figure of each grade (data sheets state
them as one standard deviation), and :func:`prior_sigma` makes it the prior of a parameter that
diagnose leaves out but must carry in the errors of its findings. Where no data sheet speaks (the
geometry, the clocks, the level and the mount of a test), the prior spreads evenly over the range
above.

=====================  ==========  =========  ============  =====================================
effect                 navigation  tactical   industrial    unit (examples of the grade)
=====================  ==========  =========  ============  =====================================
accel_bias             100         1 000      60 000        ug   (HG9900 25, HG1700 1 000)
accel_scale_factor     300         1 000      10 000        ppm  (HG9900 100, FSAS 300)
accel_misalignment     30          300        1 800         arcsec
accel_quadratic        30          100        1 000         ug/g^2
gyro_bias              0.01        10         18 000        deg/h (HG9900 0.0035, HG1700 1)
gyro_scale_factor      50          300        10 000        ppm  (HG9900 5, FSAS 300)
gyro_misalignment      30          300        2 000         arcsec
gyro_g_sensitivity     0.5         10         360           deg/h/g
=====================  ==========  =========  ============  =====================================

Each navigation figure is the worst of the grade's data-sheet span in the range table above; the
tactical figures come from tactical-grade units (Honeywell HG1700, iMAR FSAS), the industrial ones
from the MEMS span above. None was chosen by a validation run.

The grade is given (``--grade``) or inferred from the gyro and accelerometer white-noise densities
of the readings themselves, at the top of their band (:func:`noise_density`, :func:`infer_grade`;
the coarser of the two).
"""

from __future__ import annotations

import math

import numpy as np

from ..constants import ARCSEC, DEG, DEG_PER_H, GRADES, MICRO_G, SQRT_SECONDS_PER_HOUR, STANDARD_GRAVITY_MPS2

__all__ = [
    "DATASHEET",
    "GRADES",
    "NOISE_BAND",
    "RANGES",
    "infer_grade",
    "judge",
    "likely_cause",
    "noise_density",
    "prior_sigma",
]

#: Per effect: (SI per report unit, report unit, (navigation, tactical, industrial) in report units).
RANGES = {
    "accel_bias": (MICRO_G, "ug", (2e3, 2e4, 2e5)),
    "accel_scale_factor": (1e-6, "ppm", (1e3, 5e3, 3e4)),
    "accel_misalignment": (ARCSEC, "arcsec", (300.0, 1500.0, 7200.0)),
    "accel_quadratic": (MICRO_G / STANDARD_GRAVITY_MPS2**2, "ug/g^2", (300.0, 2e3, 2e4)),
    "lever_arm": (1e-3, "mm", (1e3, 1e3, 1e3)),
    "accel_delay": (1e-6, "us", (1e4, 1e4, 2e4)),
    "reference_delay": (1e-6, "us", (1e5, 1e5, 1e5)),
    "level_tilt": (ARCSEC, "arcsec", (3600.0, 3600.0, 3600.0)),
    "gyro_bias": (DEG_PER_H, "deg/h", (1.0, 300.0, 2e4)),
    "gyro_scale_factor": (1e-6, "ppm", (300.0, 3e3, 2e4)),
    "gyro_misalignment": (ARCSEC, "arcsec", (300.0, 1500.0, 5000.0)),
    "gyro_g_sensitivity": (DEG_PER_H / STANDARD_GRAVITY_MPS2, "deg/h/g", (2.0, 50.0, 1e3)),
    "reference_mount": (ARCSEC, "arcsec", (1.8e4, 1.8e4, 1.8e4)),
}
#: Per effect: one standard deviation of a part of each grade (navigation, tactical, industrial), in
#: the report unit of :data:`RANGES`, from data sheets (the module's second table).
DATASHEET = {
    "accel_bias": (100.0, 1e3, 6e4),
    "accel_scale_factor": (300.0, 1e3, 1e4),
    "accel_misalignment": (30.0, 300.0, 1800.0),
    "accel_quadratic": (30.0, 100.0, 1e3),
    "gyro_bias": (0.01, 10.0, 1.8e4),
    "gyro_scale_factor": (50.0, 300.0, 1e4),
    "gyro_misalignment": (30.0, 300.0, 2e3),
    "gyro_g_sensitivity": (0.5, 10.0, 360.0),
}
#: White-noise densities that separate the grades: gyro angle random walk [deg/sqrt(h)] and
#: accelerometer noise [ug/sqrt(Hz)]; a part at or under the first is navigation grade, under the
#: second tactical, above it industrial (MEMS). Navigation gyros: 0.001-0.005 deg/sqrt(h); tactical
#: 0.01-0.1; MEMS 0.1-1. Accelerometers: 5-25, 25-100, 100-400 ug/sqrt(Hz).
ARW_LIMITS_DEG_SQRT_H = (0.01, 0.15)
#: Lowest frequency, as a share of the Nyquist frequency, where the noise plateau is looked for
#: (at 1600 Hz: 80 Hz; at 286 Hz: 14 Hz), whatever the motion's band.
NOISE_BAND = 0.1
VRW_LIMITS_UG_SQRT_HZ = (30.0, 150.0)


def noise_density(measured, mask, dt_s: float) -> np.ndarray:
    """Per channel, the IMU's own white-noise density ``sigma sqrt(dt)`` (rad/s*sqrt(s), m/s^2*sqrt(s)),
    from the measured readings' Welch spectrum above the motion.

    The spectrum is that of the readings' first differences, divided by the difference's gain
    ``(2 sin(pi f dt))^2``: the same spectrum, but the window's leakage from the motion (whose power
    is many orders of magnitude above the noise's) falls with it. Without it, a tumble at 100 Hz
    leaked 0.0014 deg/sqrt(h) of its motion into the octave above 5 Hz, four times a navigation
    gyro's noise. The motion's band ends where 99 % of the channel's power lies below; from twice
    that (and at least :data:`NOISE_BAND` of the Nyquist frequency) up, the spectrum is cut into
    octaves and the largest of their medians is the noise plateau. The median passes over vibration
    lines; the largest octave passes over an anti-alias filter's roll-off towards Nyquist, which
    would otherwise make a tactical part look navigation grade (and shrink its plausible ranges
    tenfold).

    Measured on the readings themselves, not on the residual: a motion-capture reference's
    differentiated noise fills the residual (an "ARW" of 25 deg/sqrt(h) on BROAD) and would make any
    IMU look industrial.

    ``measured``: [n, 6] readings (rad/s, m/s^2), or a function ``(lo, hi) ->`` those of the samples
    ``lo:hi`` (then only a bounded piece of the longest usable stretch is held at a time).
    """
    ok = np.asarray(mask, dtype=bool)
    if callable(measured):
        get = measured
    else:
        readings = np.asarray(measured)

        def get(lo, hi):
            return readings[lo:hi]

    edges = np.flatnonzero(np.diff(np.concatenate(([0], ok.astype(np.int8), [0]))))
    starts, stops = edges[::2], edges[1::2]
    k = int(np.argmax(stops - starts)) if starts.size else 0
    lo, hi = (int(starts[k]), int(stops[k])) if starts.size else (0, ok.size)
    nper = int(min(4096, max(64, (hi - lo) // 8)))
    f, pxx = _welch(lambda a, b: np.diff(get(a, b + 1), axis=0), lo, hi - 1, min(nper, hi - lo - 1), 1.0 / dt_s)
    gain = (2.0 * np.sin(np.pi * f * dt_s)) ** 2  # of the first difference
    pxx = np.divide(pxx, gain[:, None], out=np.zeros_like(pxx), where=gain[:, None] > 0)
    out = np.empty(pxx.shape[1])
    for c in range(pxx.shape[1]):
        cum = np.cumsum(pxx[:, c])
        f_motion = f[min(int(np.searchsorted(cum, 0.99 * cum[-1])), f.size - 1)]
        lo = max(2.0 * f_motion, NOISE_BAND * f[-1])
        plateau = []
        while lo < f[-1]:
            band = (f >= lo) & (f < 2.0 * lo)
            if band.sum() >= 4:
                plateau.append(np.median(pxx[band, c]))
            lo *= 2.0
        level = max(plateau) if plateau else float(np.median(pxx[f >= (1.0 - NOISE_BAND) * f[-1], c]))
        out[c] = np.sqrt(level / 2.0)  # one-sided PSD = 2 sigma^2 dt
    return out


#: Welch segments transformed at once by :func:`_welch`: 256 of 4096 samples of six channels, 50 MiB.
_WELCH_SEGMENTS = 256


def _welch(get, lo: int, hi: int, nper: int, fs_hz: float):
    """``scipy.signal.welch(x[lo:hi], fs_hz, nperseg=nper, axis=0)`` of the samples ``get(a, b) -> [b - a,
    C]``, a bounded number of segments at a time: the mean of the segments' periodograms is the mean
    of the pieces' means, weighted by their segments (to rounding), and only one piece is held."""
    from scipy.signal import welch

    step = nper - nper // 2  # scipy's default overlap, nper // 2
    total = (hi - lo - nper) // step + 1
    f, acc = None, 0.0
    for k0 in range(0, total, _WELCH_SEGMENTS):
        count = min(_WELCH_SEGMENTS, total - k0)
        a = lo + k0 * step
        f, pxx = welch(get(a, a + (count - 1) * step + nper), fs=fs_hz, nperseg=nper, axis=0)
        acc = acc + pxx * count
    return f, acc / total


def infer_grade(density) -> tuple[str, str]:
    """The grade the IMU's white noise suggests (``density`` [6] from :func:`noise_density`: gyro x, y,
    z in rad/s*sqrt(s), accelerometer x, y, z in m/s^2*sqrt(s)), and a sentence saying how it was
    inferred: the coarser of what the quietest gyro and the quietest accelerometer say."""
    arw = float(min(density[:3])) / DEG * SQRT_SECONDS_PER_HOUR  # rad/sqrt(s) -> deg/sqrt(h)
    vrw = float(min(density[3:])) / MICRO_G
    g = sum(arw > lim for lim in ARW_LIMITS_DEG_SQRT_H)
    a = sum(vrw > lim for lim in VRW_LIMITS_UG_SQRT_HZ)
    grade = GRADES[max(g, a)]
    return grade, (
        f"grade {grade}, inferred from the IMU's own noise (the plateau of its spectrum above the "
        f"motion): gyro {arw:.3g} deg/sqrt(h), accelerometer {vrw:.3g} ug/sqrt(Hz)"
    )


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


def prior_sigma(effect: str, grade: str) -> float:
    """The prior standard deviation [SI] of one parameter of ``effect`` on a part of ``grade`` about
    its start value: the data-sheet figure (:data:`DATASHEET`) where data sheets give one, otherwise
    that of a value spread evenly over the plausible range (:data:`RANGES`, ``limit / sqrt(3)``)."""
    per_unit, _, limits = RANGES[effect]
    k = GRADES.index(grade)
    if effect in DATASHEET:
        return DATASHEET[effect][k] * per_unit
    return limits[k] * per_unit / math.sqrt(3.0)


def likely_cause(effect: str) -> str:
    """What an implausible estimate of ``effect`` more likely is, in one phrase."""
    if effect in ("accel_scale_factor", "gyro_scale_factor", "accel_quadratic"):
        return (
            "a reference or unit problem (the reference scaled, filtered or in other units than the IMU), "
            "or noise in a reference differentiated beyond its bandwidth"
        )
    if effect in ("accel_bias", "level_tilt", "accel_misalignment", "gyro_misalignment", "reference_mount"):
        return "a reference attitude error (jumps, a wrong frame or mounting) or the IMU in other units"
    if effect == "gyro_bias":
        return "a reference attitude that drifts or jumps, or gyro output in other units (deg/s for rad/s)"
    if effect == "gyro_g_sensitivity":
        return "a reference attitude error that follows the specific force, or an effect outside the model"
    if effect == "lever_arm":
        return "noise in the reference's position differentiated twice, or the wrong reference point"
    return "a timestamp problem in the record (clocks), not a sensor property"
