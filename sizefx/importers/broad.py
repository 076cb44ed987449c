"""BROAD benchmark trials (.mat): IMU at 285.714 Hz with an optical motion-capture reference.

Source conventions (data README, checked on the files): ``imu_gyr`` [rad/s],
``imu_acc`` [m/s^2] in the IMU's own axes, which read +g on z at rest: x
forward, y left, z up (FLU). ``opt_quat`` (w, x, y, z) rotates IMU vectors into
an East-North-Up lab frame; ``opt_pos`` [m] is the tracked marker body's origin
in that frame. No time stamps: ``t = k / sampling_rate``. NaN marks dropouts.

Conversion: body FRD = ``MAT_FRD_FLU`` @ IMU (x kept, y and z negated);
``q_nb = q(MAT_NED_ENU) * opt_quat * q(MAT_FRD_FLU^T)``; positions ENU -> NED,
then to geodetic about a site. The lab's heading is not tied to true north,
and the dataset gives no geodetic position: the site (default TU Berlin,
where BROAD was recorded) is an assumption, stated in the file. Rows with NaN
in the quaternion or position are left out of ``/reference`` (reported as
reference gaps).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..constants import BROAD_SITE_DEG, DEG
from ..errors import SourceError
from ..frames import MAT_FRD_FLU, enu_to_ned, geodetic_from_local_ned, quat_nb_from_enu_body
from ..io.telemetry import Reference, Site, Telemetry
from . import as_array, load_mat, provenance

CREDITS = (
    "D. Laidig, M. Caruso, A. Cereatti, T. Seel, 'BROAD - A Benchmark for Robust Inertial Orientation "
    "Estimation', Data 6(7):72, 2021; licence CC BY 4.0"
)

#: Where BROAD was recorded (:data:`sizefx.constants.BROAD_SITE_DEG`).
DEFAULT_SITE_DEG = BROAD_SITE_DEG


def load(path: Path, *, site_deg=DEFAULT_SITE_DEG) -> Telemetry:
    mat = load_mat(path)
    for name in ("imu_gyr", "imu_acc", "opt_quat", "opt_pos", "sampling_rate"):
        if name not in mat:
            raise SourceError(path, f"variable '{name}' is missing; not a BROAD trial file")
    gyr = as_array(path, "imu_gyr", mat["imu_gyr"], (3,))
    acc = as_array(path, "imu_acc", mat["imu_acc"], (3,))
    quat = as_array(path, "opt_quat", mat["opt_quat"], (4,), allow_nan=True)
    pos = as_array(path, "opt_pos", mat["opt_pos"], (3,), allow_nan=True)
    n = gyr.shape[0]
    for name, arr in (("imu_acc", acc), ("opt_quat", quat), ("opt_pos", pos)):
        if arr.shape[0] != n:
            raise SourceError(path, f"variable '{name}' has {arr.shape[0]} rows, imu_gyr has {n}")
    rate_hz = float(np.asarray(mat["sampling_rate"]).ravel()[0])
    if not 1.0 <= rate_hz <= 1e5:
        raise SourceError(path, f"sampling_rate = {rate_hz} is not a plausible rate in Hz")
    t = np.arange(n) / rate_hz
    mat_b_imu = MAT_FRD_FLU
    valid = np.all(np.isfinite(quat), axis=1) & np.all(np.isfinite(pos), axis=1)
    if valid.sum() < 2:
        raise SourceError(path, "motion-capture reference has fewer than 2 valid rows")
    q_enu = quat[valid] / np.linalg.norm(quat[valid], axis=1, keepdims=True)
    q_nb = quat_nb_from_enu_body(q_enu, mat_b_imu.T)
    lat0, lon0, h0 = site_deg[0] * DEG, site_deg[1] * DEG, float(site_deg[2])
    lat, lon, h = geodetic_from_local_ned(enu_to_ned(pos[valid]), lat0, lon0, h0)
    info = str(np.asarray(mat.get("info", [""])).ravel()[0]) if "info" in mat else ""
    trial = info.split("Trial:")[1].splitlines()[0].strip() if "Trial:" in info else Path(path).stem
    dropped = int(n - valid.sum())
    description = (
        f"BROAD trial {trial}: IMU axes FLU converted to body FRD; motion-capture attitude ENU lab "
        f"frame converted to NED (lab heading not tied to north); position = tracked marker origin, "
        f"placed about an assumed site {site_deg[0]:.4f} N {site_deg[1]:.4f} E {h0:.0f} m; "
        f"{dropped} reference rows with NaN left out. Credit: {CREDITS}"
    )
    return Telemetry(
        time_s=t,
        form="rates",
        gyro_rad_s=gyr @ mat_b_imu.T,
        accel_mps2=acc @ mat_b_imu.T,
        reference=Reference(time_s=t[valid], quat_nb=q_nb, lat_rad=lat, lon_rad=lon, height_m=h),
        site=Site(lat0, lon0, h0),
        description=description,
        source=provenance(
            path,
            "broad",
            CREDITS,
            trial=trial,
            imu_axes="FLU",
            reference_dropout_rows=dropped,
            site_assumed_deg=list(site_deg),
            info=info,
        ),
    )
