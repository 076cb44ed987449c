"""What the fits need from a record: rates, angular acceleration and reference attitude per IMU sample."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import earth
from ..constants import DEG
from ..errors import SizefxError
from ..io.telemetry import Telemetry
from ..omegadot import savgol
from ..rotation import quat_interp, quat_spline, quat_to_mat
from ..sensor_model import Motion, cross
from ..sync import sync_accelerometers

__all__ = [
    "CalibrationError",
    "Record",
    "prepare",
    "reference_attitude",
    "motion_of",
    "MIN_SAMPLES",
    "ROTATING_RAD_S",
    "SPLINE_REFERENCE_STEPS",
]

#: Fewest samples a record may have: the Savitzky-Golay angular-acceleration window, with room.
MIN_SAMPLES = 4 * 41
#: A sample rotates when |omega| exceeds this [rad/s] (1 deg/s: far above Earth rate and noise).
ROTATING_RAD_S = 1.0 * DEG


class CalibrationError(SizefxError):
    """The records cannot give what was asked (no rotation, unobservable components)."""


@dataclass
class Record:
    """What the fits need from one file, per IMU sample (rates domain)."""

    name: str
    t: np.ndarray  #: [N] s
    accel: np.ndarray  #: [N, 3] m/s^2
    omega: np.ndarray  #: [N, 3] rad/s (gyros)
    omegadot: np.ndarray  #: [N, 3] rad/s^2 (Savitzky-Golay, centred)
    mat_nb: np.ndarray  #: [N, 3, 3] reference attitude
    #: normal gravity at the site, NED [3] m/s^2, with its small north component (Groves eq. 2.139:
    #: 0.09 ug at the paper's airfield, 120 m, which a fit that took only the down component would call 0.018 arcsec of tilt)
    g_n: np.ndarray

    @property
    def f_grav(self):
        """C_bn (-g_n) [N, 3]: gravity's specific force in body axes."""
        return _gravity_in_body(self.mat_nb, self.g_n)


def _require_reference_site_samples(path, reference, site, n_samples: int):
    """What a record must hold to be calibrated: /reference attitude, a site (or reference
    position) for normal gravity, and enough samples; a one-line refusal otherwise."""
    if reference is None:
        raise CalibrationError(
            f"{path}: calibration needs /reference attitude (what the table reports); "
            "this record has none (sizefx inspect shows what it holds)"
        )
    if site is None and not reference.has_position:
        raise CalibrationError(
            f"{path}: no site: normal gravity needs latitude and height; add the root "
            "attributes latitude_deg, longitude_deg, height_m (sizefx import --site-deg)"
        )
    if n_samples < MIN_SAMPLES:
        raise CalibrationError(f"{path}: {n_samples} samples; calibration needs at least {MIN_SAMPLES}")


def prepare(tel: Telemetry, name: str = "") -> Record:
    """Rates, angular acceleration and reference attitude on the IMU samples of a record."""
    _require_reference_site_samples(tel.path, tel.reference, tel.site, tel.n_samples)
    tel = sync_accelerometers(tel)  # on the gyro time base before any conversion
    ref = tel.reference
    assert ref is not None  # refused above without one
    dt = tel.sample_period_s
    if tel.form == "rates":
        assert tel.gyro_rad_s is not None and tel.accel_mps2 is not None  # the arrays of the record's form
        t, omega, accel = tel.time_s, tel.gyro_rad_s, tel.accel_mps2
    else:  # increments -> mean rates over each interval, stamped at its midpoint
        assert tel.dtheta_rad is not None and tel.dvel_mps is not None  # the arrays of the record's form
        t, omega, accel = tel.time_s - 0.5 * dt, tel.dtheta_rad / dt, tel.dvel_mps / dt
    mat_nb = quat_to_mat(reference_attitude(ref.time_s, ref.quat_nb, t))
    if tel.site is not None:
        lat, h = tel.site.lat_rad, tel.site.height_m
    else:  # refused above without a reference position
        assert ref.lat_rad is not None and ref.height_m is not None
        lat, h = ref.lat_rad[0], ref.height_m[0]
    return Record(
        name or str(tel.path),
        t,
        accel,
        omega,
        savgol(omega, dt),
        mat_nb,
        np.asarray(earth.gravity_n(lat, h), dtype=float),
    )


def _gravity_in_body(mat_nb, g_n):
    """``C_bn (-g_n)`` [N, 3] for attitudes ``mat_nb`` [N, 3, 3] (body to NED)."""
    return -np.einsum("nji,j->ni", mat_nb, g_n)


#: A reference whose median step exceeds this many IMU steps is interpolated by a C2 rotation
#: spline instead of slerp (:func:`sizefx.rotation.quat_spline`): gravity's direction between
#: two reference samples must be known to the accelerometer noise, and slerp's error grows with
#: the square of the reference step (0.08 mm of arm bias with a 100 Hz reference on a 1 Hz sway).
#: At the IMU rate slerp is exact at the samples and costs a tenth of the spline.
SPLINE_REFERENCE_STEPS = 1.5


def reference_attitude(t_ref, quat_ref, t):
    """Reference attitude ``q_nb`` at the IMU times ``t`` [N, 4]: a rotation spline when the
    reference is slower than the IMU (:data:`SPLINE_REFERENCE_STEPS`), slerp otherwise."""
    step_ref = float(np.median(np.diff(t_ref)))
    step_imu = float(np.median(np.diff(t))) if len(t) > 1 else step_ref
    if len(t_ref) >= 4 and step_ref > SPLINE_REFERENCE_STEPS * step_imu:
        return quat_spline(t_ref, quat_ref, t)
    return quat_interp(t_ref, quat_ref, t)


def motion_of(rec: Record, sl: slice, *, with_rate: bool = False) -> Motion:
    """The motion the calibration model assumes on samples ``sl``: the gyros' rates and their derivative,
    and gravity's specific force in the reported attitude (a table at rest on the Earth; its own
    acceleration is the lever terms). ``with_rate``: ``d f_b/dt = -omega x f_b`` (gravity is fixed in
    NED) and the angular jerk, for the delay's column."""
    w, f = rec.omega[sl], _gravity_in_body(rec.mat_nb[sl], rec.g_n)  # Record.f_grav on the slice alone
    if not with_rate:
        return Motion(w, rec.omegadot[sl], f, mat_nb=rec.mat_nb[sl])
    # the angular jerk (the delay's lever terms): central differences of the filtered derivative,
    # with a neighbour either side of the slice where the record has one
    lo, hi = max(sl.start - 1, 0), min(sl.stop + 1, rec.t.size)
    jerk = np.gradient(rec.omegadot[lo:hi], rec.t[lo:hi], axis=0)[sl.start - lo : sl.stop - lo]
    return Motion(w, rec.omegadot[sl], f, mat_nb=rec.mat_nb[sl], fdot_b=-cross(w, f), omegaddot_ib_b=jerk)
