"""The strapdown kernel's vertical-channel modes (:mod:`sizefx.kernels.strapdown`), in a module of their
own: the options that name them (``sizefx.navigate.config``) are read without loading Numba."""

from __future__ import annotations

__all__ = ["VERTICAL_FREE", "VERTICAL_HELD", "VERTICAL_REFERENCE"]

VERTICAL_FREE = 0  #: integrate the vertical channel (unstable over minutes, like any INS)
VERTICAL_HELD = 1  #: height fixed at a known value, vertical velocity zero (turntable, sway, a site)
VERTICAL_REFERENCE = 2  #: height and vertical velocity replaced by the reference at each step
