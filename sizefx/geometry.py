"""Accelerometer geometry presets from Morozov & Bogdanov (2024).

``d_i`` is the arm of accelerometer i from the triad point C (where the
normals of the sensitive masses meet), body axes, metres, taken from the
assembly drawings quoted in the paper (section "Analysis of the designs").
"""

from __future__ import annotations

import numpy as np

from .errors import ConfigError

__all__ = ["PRESETS", "preset_arms_m", "triad_point"]

PRESETS = {
    # High-precision INS: each mass 24.9 mm out along its own axis.
    "high-precision": np.array([[0.0249, 0.0, 0.0], [0.0, 0.0249, 0.0], [0.0, 0.0, 0.0249]]),
    # Compact INS: arms with cross components; rows d_x, d_y, d_z.
    "compact": np.array([[0.0060, 0.0010, 0.0242], [0.0, -0.0172, 0.0], [0.0, 0.0, -0.0212]]),
    # A point IMU: all masses at the triad point.
    "none": np.zeros((3, 3)),
}


def preset_arms_m(name: str) -> np.ndarray:
    """Rows ``d_x, d_y, d_z`` [3, 3] of a named preset (a copy)."""
    try:
        return PRESETS[name].copy()
    except KeyError:
        raise ConfigError(f"unknown geometry preset '{name}'; use one of {', '.join(PRESETS)}") from None


def triad_point(arms: np.ndarray, axes: np.ndarray | None = None, how: str = "normals") -> np.ndarray:
    """The triad point C as a vector from the reference point [m].

    ``normals``: the point nearest (least squares) to the three lines through each
    accelerometer along its sensitive axis (the paper's point C, where the normals
    meet); ``x-accelerometer``: accelerometer x itself (the paper's alternative).
    ``axes`` [3, 3]: the sensitive axes (rows); None: the body axes.
    """
    if how == "x-accelerometer":
        return arms[0].copy()
    if how != "normals":
        raise ConfigError(f"triad point '{how}': use normals or x-accelerometer")
    A = np.zeros((3, 3))
    rhs = np.zeros(3)
    for r, u in zip(arms, np.eye(3) if axes is None else axes):
        P = np.eye(3) - np.outer(u, u)
        A += P
        rhs += P @ r
    return np.linalg.solve(A, rhs)
