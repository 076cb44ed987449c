"""The paper's per-rotation least squares (Morozov & Bogdanov 2024, section "Calibration").

For rotation about one vertical body axis ``a``, the sensor model's lever-arm columns
(:func:`sizefx.sensor_model.jacobian`) of a horizontal channel i reduce to ``-omega_a^2`` (for
``r_i[i]``) and ``eps(i, a, j) omegadot_a`` (for ``r_i[j]``): the paper's ``H = [1, omega^2,
omegadot]``. Kept as the paper wrote it, to compare with; it ignores the tilt.
"""

from __future__ import annotations

import numpy as np

from ..constants import DEG
from .records import ROTATING_RAD_S, Record

__all__ = ["detect_rotations", "per_rotation_fit", "VERTICAL_WITHIN_RAD"]


#: A body axis counts as vertical within this angle of the down direction in the reported
#: attitude (36 arcsec: the table reports the axis vertical during a block; within 1 deg,
#: gravity would already leak 17 000 ug into a "horizontal" channel at the block's edge).
VERTICAL_WITHIN_RAD = 0.01 * DEG


def detect_rotations(rec: Record, min_s: float = 5.0):
    """Blocks ``[(axis, i0, i1)]`` in which body axis ``axis`` stays vertical and the table turns about it.

    Segmenting by the reference attitude, not by the gyros, keeps repositioning
    (where gravity sweeps through every channel) out of the blocks.
    """
    down = np.abs(rec.mat_nb[:, 2, :])  # |cosine| between each body axis and the vertical
    axis = np.argmax(down, axis=1)
    vertical = down[np.arange(axis.size), axis] > np.cos(VERTICAL_WITHIN_RAD)
    label = np.where(vertical, axis, -1)
    dt = float(np.median(np.diff(rec.t)))
    blocks = []
    edges = np.flatnonzero(np.diff(label) != 0) + 1
    for i0, i1 in zip(np.r_[0, edges], np.r_[edges, label.size]):
        a = label[i0]
        if a < 0:
            continue
        turning = np.abs(rec.omega[i0:i1, a]) > ROTATING_RAD_S
        if turning.sum() * dt >= min_s:
            blocks.append((int(a), int(i0), int(i1)))
    return blocks


def per_rotation_fit(rec: Record):
    """The paper's fit: per block and horizontal channel, ``a_i = b + c2 omega_a^2 + c3 omegadot_a``.

    A block is a stretch in which body axis ``a`` is vertical (static lead-in and
    dwell included) and the table turns about it.

    Returns a list of dicts with the block, channel, the coefficients and the lever-arm
    components they stand for: ``c2 = -r_i[i]`` (centripetal), ``c3 = eps(i, a, j) r_i[j]``
    (tangential, j the third axis), as rigid-body kinematics gives them.
    """
    out = []
    for a, i0, i1 in detect_rotations(rec):
        wa = rec.omega[i0:i1, a]
        H = np.column_stack([np.ones(i1 - i0), wa**2, rec.omegadot[i0:i1, a]])
        for i in range(3):
            if i == a:
                continue
            j = 3 - a - i
            eps = np.sign(np.linalg.det(np.eye(3)[[i, a, j]]))  # Levi-Civita symbol eps(i, a, j)
            coef, *_ = np.linalg.lstsq(H, rec.accel[i0:i1, i], rcond=None)
            resid = rec.accel[i0:i1, i] - H @ coef
            cov = np.linalg.inv(H.T @ H) * resid.var()
            out.append(
                {
                    "axis": "xyz"[a],
                    "channel": "xyz"[i],
                    "t0": float(rec.t[i0]),
                    "t1": float(rec.t[i1 - 1]),
                    "bias": float(coef[0]),
                    "r_own": float(-coef[1]),
                    "r_other": float(eps * coef[2]),
                    "other_component": "xyz"[j],
                    "sigma_r_own": float(np.sqrt(cov[1, 1])),
                    "sigma_r_other": float(np.sqrt(cov[2, 2])),
                }
            )
    return out
