"""The fitted arms split into what belongs to the IMU and what belongs to the test set-up.

Diagnose fits each accelerometer's position ``r_i`` from the reference point of the motion (a
motion-capture body's origin, a turntable's centre, a reference INS). Those nine numbers mix two
things of different standing:

- the **triad point** ``C`` (where the accelerometer normals meet, :func:`sizefx.geometry.triad_point`,
  the paper's point C and calibrate's split): the offset between the reference's tracked point and
  the IMU. It is a property of the set-up and is only as repeatable as the set-up (a re-defined
  marker-body origin, a re-seated IMU, a fixture moved on the table);
- the arms **from the triad point** ``d_i = r_i - C``: the size effect itself, the IMU's own geometry,
  which ``navigate --mode triad`` and ``compensate`` undo and which must agree across records of one
  unit.

:func:`split_arms` gives both with standard errors from the fit's covariance (propagated linearly:
``C`` is linear in the arms for given sensitive axes; the axes' own uncertainty, arcsec on mm, is
left out). The model file written by diagnose uses the same split (``d_*_m``, ``r_vehicle_m``).
"""

from __future__ import annotations

import numpy as np

from ..geometry import triad_point

__all__ = ["split_arms"]


def _split_matrix(axes: np.ndarray) -> np.ndarray:
    """J [12, 9]: (C, d_x, d_y, d_z) = J @ (r_x, r_y, r_z), for accelerometer sensitive axes ``axes``."""
    T = np.column_stack([triad_point(e.reshape(3, 3), axes) for e in np.eye(9)])  # [3, 9]
    return np.vstack([T, np.eye(9) - np.vstack([T, T, T])])


def split_arms(arms_m: np.ndarray, cov_m2: np.ndarray, axes: np.ndarray | None = None) -> dict:
    """The triad point and the arms from it, with their standard errors.

    ``arms_m`` [3, 3]: rows r_x, r_y, r_z from the reference point [m], body axes; ``cov_m2`` [9, 9]:
    their covariance (rows of ``arms_m`` flattened; zero rows for arms held at a fixed value);
    ``axes`` [3, 3]: the sensitive axes (rows); None: the body axes.

    Returns ``{"triad_point_m": [3], "triad_point_sigma_m": [3], "d_m": [3, 3], "d_sigma_m": [3, 3]}``
    (lists, SI).
    """
    J = _split_matrix(np.eye(3) if axes is None else np.asarray(axes, dtype=float))
    value = J @ np.asarray(arms_m, dtype=float).ravel()
    sigma = np.sqrt(np.clip(np.einsum("ij,jk,ik->i", J, np.asarray(cov_m2, dtype=float), J), 0.0, None))
    return {
        "triad_point_m": value[:3].tolist(),
        "triad_point_sigma_m": sigma[:3].tolist(),
        "d_m": value[3:].reshape(3, 3).tolist(),
        "d_sigma_m": sigma[3:].reshape(3, 3).tolist(),
    }
