"""The extended model diagnose writes: the model vector as a complete ``sizefx/effects/1`` document.

:func:`model_document` / :func:`model_toml`: written with :mod:`sizefx.io.toml`; loaded in memory
with ``load_effects(base=IDEAL, overrides=model_document(theta))``, no file in between.
"""

from __future__ import annotations

import numpy as np

from .. import __version__
from ..constants import ARCSEC, DEG_PER_H, MICRO_G, STANDARD_GRAVITY_MPS2
from ..effects import EFFECTS_SCHEMA
from ..geometry import triad_point
from ..io.toml import dumps_toml
from ..sensor_model import SensorParams
from .theta import A_BIAS, A_K2, A_MIS, A_SF, G_BIAS, G_G, G_MIS, G_SF, LEVER, MOUNT, OFFDIAG, TAU_A, TAU_R, TILT

__all__ = ["model_document", "model_header", "model_toml"]


def _matrix(offdiag=None, full=None) -> list:
    """A 3x3 list of lists: ``full``, or zeros with the six misalignment terms ``offdiag`` off the diagonal."""
    m = np.zeros((3, 3)) if full is None else np.array(full, dtype=float)
    if offdiag is not None:
        for (i, j), v in zip(OFFDIAG, offdiag):
            m[i, j] = v
    return m.tolist()


def model_document(theta: np.ndarray) -> dict:
    """The model vector [NP] as a complete ``sizefx/effects/1`` document (every deterministic section explicit).

    Noise and quantisation are switched off: the document states what the IMU gets wrong
    deterministically, which ``navigate --model`` and ``compensate --model`` undo. The arms
    ``r_i = r + d_i`` are split at the triad point ``r`` (where the accelerometer normals meet,
    as calibrate splits them), so that navigate/compensate ``--mode triad`` and ``center``
    keep their meaning: ``d_i`` from the triad point, ``r_vehicle_m`` the triad point.
    """
    theta = np.asarray(theta, dtype=float)
    arms = theta[LEVER].reshape(3, 3)
    offset = triad_point(arms, SensorParams.from_vector(theta).accel_axes()) if np.any(arms) else np.zeros(3)
    d_arms = arms - offset
    on = {
        name: bool(np.any(theta[idx] != 0.0))
        for name, idx in (
            ("accel_bias", A_BIAS),
            ("accel_scale_factor", A_SF),
            ("accel_misalignment", A_MIS),
            ("accel_quadratic", A_K2),
            ("accel_delay", [TAU_A]),
            ("reference_delay", [TAU_R]),
            ("level_tilt", TILT),
            ("gyro_bias", G_BIAS),
            ("gyro_scale_factor", G_SF),
            ("gyro_misalignment", G_MIS),
            ("gyro_g_sensitivity", G_G),
            ("reference_mount", MOUNT),
        )
    }
    k2_unit = MICRO_G / STANDARD_GRAVITY_MPS2**2
    g_unit = DEG_PER_H / STANDARD_GRAVITY_MPS2
    return {
        "schema": EFFECTS_SCHEMA,
        "lever_arm": {
            "enabled": True,
            "preset": "none",
            **{f"d_{a}_m": d_arms[i].tolist() for i, a in enumerate("xyz")},
            "r0_m": [0.0, 0.0, 0.0],
            "r_plate_m": [0.0, 0.0, 0.0],
            "r_vehicle_m": offset.tolist(),
        },
        "accel_delay": {"enabled": on["accel_delay"], "tau_s": float(theta[TAU_A])},
        "reference_delay": {"enabled": on["reference_delay"], "tau_s": float(theta[TAU_R])},
        "level_tilt": {
            "enabled": on["level_tilt"],
            "north_arcsec": float(theta[TILT[0]] / ARCSEC),
            "east_arcsec": float(theta[TILT[1]] / ARCSEC),
        },
        "reference_mount": {"enabled": on["reference_mount"], "arcsec": (theta[MOUNT] / ARCSEC).tolist()},
        "accel_bias": {"enabled": on["accel_bias"], "bias_ug": (theta[A_BIAS] / MICRO_G).tolist()},
        "accel_scale_factor": {"enabled": on["accel_scale_factor"], "ppm": (theta[A_SF] * 1e6).tolist()},
        "accel_misalignment": {"enabled": on["accel_misalignment"], "arcsec": _matrix(offdiag=theta[A_MIS] / ARCSEC)},
        "accel_quadratic": {"enabled": on["accel_quadratic"], "ug_per_g2": (theta[A_K2] / k2_unit).tolist()},
        "gyro_bias": {"enabled": on["gyro_bias"], "deg_per_h": (theta[G_BIAS] / DEG_PER_H).tolist()},
        "gyro_scale_factor": {"enabled": on["gyro_scale_factor"], "ppm": (theta[G_SF] * 1e6).tolist()},
        "gyro_misalignment": {"enabled": on["gyro_misalignment"], "arcsec": _matrix(offdiag=theta[G_MIS] / ARCSEC)},
        "gyro_g_sensitivity": {
            "enabled": on["gyro_g_sensitivity"],
            "deg_per_h_per_g": _matrix(full=theta[G_G].reshape(3, 3) / g_unit),
        },
        "accel_noise": {"enabled": False},
        "gyro_noise": {"enabled": False},
        "quantisation": {"enabled": False},
    }


def model_header(source: str = "") -> str:
    """The comment lines above the extended model's TOML."""
    return "\n".join(
        [
            f"sizefx {__version__} diagnose: the extended model{(' of ' + source) if source else ''}.",
            "Arms r_i from the reference point of the motion (body axes x forward, y right, z down):",
            "[lever_arm] d_i from the triad point to accelerometer i, r_vehicle_m from the reference "
            "point to the triad point.",
        ]
    )


def model_toml(theta: np.ndarray, source: str = "") -> str:
    """:func:`model_document` as TOML text, with a header naming the record it was found in."""
    return dumps_toml(model_document(theta), header=model_header(source))
