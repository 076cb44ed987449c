"""PSINS records: the ring-laser text log (``.imu``) and the MEMS + FOG-INS ``.mat``.

PSINS conventions (data README, PSINS toolbox): body axes Right-Forward-Up,
navigation frame East-North-Up, ``C_nb = Rz(yaw) Rx(pitch) Ry(roll)`` with yaw
counter-clockwise (so heading = -yaw). Converted here to body FRD and NED with
:mod:`sizefx.frames`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..constants import ARCSEC, DEG
from ..errors import SourceError
from ..frames import MAT_FRD_RFU, enu_to_ned, mat_nb_from_enu_body, psins_mat_enu_rfu
from ..io.telemetry import Reference, Site, Telemetry
from ..rotation import mat_to_quat
from . import as_array, load_mat, provenance

CREDITS = "PSINS toolbox sample data, Yan Gongmin (psins.org.cn); BSD-2 licence"


def _rfu_to_frd(v):
    return np.asarray(v, dtype=float) @ MAT_FRD_RFU.T


def _mat_nb(pitch, roll, yaw):
    """``mat_nb`` (FRD to NED) of PSINS angles [rad]."""
    return mat_nb_from_enu_body(psins_mat_enu_rfu(pitch, roll, yaw), MAT_FRD_RFU.T)


def load_imu(path: Path) -> Telemetry:
    """The PSINS text log of integer increments (``% comments``, three header lines, then counts)."""
    try:
        text = Path(path).read_text("ascii")
    except UnicodeDecodeError:
        raise SourceError(path, "is not a text file; expected a PSINS .imu log") from None
    rows = [
        (k + 1, line.split())
        for k, line in enumerate(text.splitlines())
        if line.strip() and not line.lstrip().startswith("%")
    ]
    if len(rows) < 5:
        raise SourceError(path, f"has {len(rows)} non-comment lines; a PSINS .imu log has 3 header lines and data")
    header = []
    for (lineno, fields), width in zip(rows[:3], (6, 6, 6)):
        try:
            values = [float(f) for f in fields]
        except ValueError:
            raise SourceError(path, f"header line {lineno} is not numeric") from None
        if len(values) != width:
            raise SourceError(path, f"header line {lineno} has {len(values)} values, expected {width}")
        header.append(values)
    pitch0, roll0, yaw0, ve0, vn0, vu0 = header[0]
    lat_deg, lon_deg, h_m, t0, interval_ms, g_mps2 = header[1]
    gf_arcsec = np.array(header[2][:3])
    af_ugs = np.array(header[2][3:])
    if not (interval_ms > 0 and 9.7 < g_mps2 < 9.9 and abs(lat_deg) <= 90):
        raise SourceError(
            path, f"header line {rows[1][0]} (lat, lon, h, t0, interval ms, g) is implausible: {header[1]}"
        )
    data = rows[3:]
    bad = next(((ln, f) for ln, f in data if len(f) != 6), None)
    if bad is not None:
        raise SourceError(
            path,
            f"line {bad[0]} has {len(bad[1])} values, expected 6 integer counts "
            "(gx gy gz ax ay az); the file may be truncated",
        )
    try:
        counts = np.array([f for _, f in data], dtype=np.int64)
    except ValueError:
        lineno = next(ln for ln, f in data if not all(x.lstrip("+-").isdigit() for x in f))
        raise SourceError(path, f"line {lineno} holds non-integer counts") from None
    dt = interval_ms * 1e-3
    n = counts.shape[0]
    t = t0 + dt * np.arange(1, n + 1)  # increment k covers (t0 + k dt, t0 + (k + 1) dt]
    dtheta = _rfu_to_frd(counts[:, :3] * gf_arcsec * ARCSEC)
    dvel = _rfu_to_frd(counts[:, 3:] * af_ugs * 1e-6 * g_mps2)
    site = Site(lat_deg * DEG, lon_deg * DEG, h_m)
    mat_nb = _mat_nb(pitch0 * DEG, roll0 * DEG, yaw0 * DEG)
    q = np.tile(mat_to_quat(mat_nb), (2, 1))
    v_n = np.tile(enu_to_ned([ve0, vn0, vu0]), (2, 1))
    ref = Reference(
        time_s=np.array([t0, t[-1]]),
        quat_nb=q,
        lat_rad=np.full(2, site.lat_rad),
        lon_rad=np.full(2, site.lon_rad),
        height_m=np.full(2, h_m),
        velocity_n_mps=v_n,
    )
    heading = -yaw0
    description = (
        f"PSINS ring-laser IMU log {Path(path).name}: {n} increments at {1 / dt:g} Hz, RFU axes converted "
        f"to body FRD; counts x {gf_arcsec[0]:g} arcsec and x {af_ugs[0]:g} ug s (g = {g_mps2} m/s^2 "
        f"from the header). /reference is the header's approximate attitude (heading {heading:.1f} deg) "
        f"and site, held constant. Credit: {CREDITS}"
    )
    return Telemetry(
        time_s=t,
        form="increments",
        dtheta_rad=dtheta,
        dvel_mps=dvel,
        reference=ref,
        site=site,
        description=description,
        source=provenance(
            path,
            "psins-imu",
            CREDITS,
            body_axes="RFU",
            header_pitch_roll_yaw_deg=[pitch0, roll0, yaw0],
            header_heading_deg=heading,
            header_g_mps2=g_mps2,
            gyro_lsb_arcsec=gf_arcsec.tolist(),
            accel_lsb_ug_s=af_ugs.tolist(),
            reference_is_approximate=True,
        ),
    )


def load_mat_record(path: Path) -> Telemetry:
    """The MEMS IMU + FOG-INS reference record: ``mimu``, ``fogavp``, ``eb0``, ``db0``, ``mu0``."""
    mat = load_mat(path)
    for name in ("mimu", "fogavp"):
        if name not in mat:
            raise SourceError(path, f"variable '{name}' is missing; not a PSINS MEMS/FOG record")
    mimu = as_array(path, "mimu", mat["mimu"], (7,))
    avp = as_array(path, "fogavp", mat["fogavp"], (10,))
    # row 0 is t = 0 and carries no interval (data README)
    if mimu.shape[0] < 3:
        raise SourceError(path, "variable 'mimu' has fewer than 3 rows")
    mimu = mimu[1:]
    t = mimu[:, 6]
    mat_nb = _mat_nb(avp[:, 0], avp[:, 1], avp[:, 2])
    ref = Reference(
        time_s=avp[:, 9],
        quat_nb=mat_to_quat(mat_nb),
        lat_rad=avp[:, 6],
        lon_rad=avp[:, 7],
        height_m=avp[:, 8],
        velocity_n_mps=enu_to_ned(avp[:, 3:6]),
    )
    extra = {}
    for name, key, unit in (
        ("eb0", "gyro_bias", "rad_s"),
        ("db0", "accel_bias", "mps2"),
        ("mu0", "mounting_misalignment_rotvec", "rad"),
    ):
        if name in mat:
            v = as_array(path, name, np.asarray(mat[name]).reshape(1, -1), (3,))[0]
            extra[f"{key}_{unit}_frd"] = _rfu_to_frd(v).tolist()
            extra[f"psins_{name}_{unit}_rfu"] = v.tolist()
    description = (
        f"PSINS MEMS IMU with FOG-INS reference ({Path(path).name}): {t.size} increments, RFU axes "
        "converted to body FRD; reference attitude, ENU velocity (now NED) and position of the FOG-INS "
        "(its body frame differs from the MEMS frame by /source mounting_misalignment_rotvec_rad_frd); "
        f"given sensor biases in /source. Credit: {CREDITS}"
    )
    return Telemetry(
        time_s=t,
        form="increments",
        dtheta_rad=_rfu_to_frd(mimu[:, :3]),
        dvel_mps=_rfu_to_frd(mimu[:, 3:6]),
        reference=ref,
        site=Site(float(avp[0, 6]), float(avp[0, 7]), float(avp[0, 8])),
        description=description,
        source=provenance(path, "psins-mat", CREDITS, body_axes="RFU", **extra),
    )
