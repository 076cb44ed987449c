"""What navigation removes from the readings, resolved once before the first chunk.

A levers file (the size effect alone) and an effect model (every deterministic error of the IMU,
the arms among them) become one :class:`Correction`, and every chunk goes through the same three
calls on arrays, with no file, JSON or ``Telemetry`` inside the loop:

1. :meth:`Correction.synced`: the accelerometers on the gyros' time base (their own stamps and
   the known delay undone);
2. :meth:`Correction.channels`: a model's per-channel errors and its gyro errors undone (steps 2-5
   of :func:`sizefx.sensor_model.inverse`), in the record's form; nothing for a levers file;
3. :meth:`Correction.on_increments`: once the increments are formed, the lever terms of the arms of
   ``mode`` removed with the gyros' rates at each interval's edges, then a model's accelerometer
   axes undone (``f = U^-1 a``, step 6).

Both corrections take the lever terms from the increments, as the strapdown integration sees
them: the tangential term is then a difference of edge rates, exact for any motion the gyros
resolve. A derivative of the rates (Savitzky-Golay, as ``sizefx compensate`` writes a corrected
record of rates) smooths vibration away, and with the arms of ``center`` (tens of centimetres on a
vehicle) what it misses integrates into metres (``tests/test_navigate_correction.py``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .inverse import check_invertible, invert_channels, remove_lever_terms
from .table import INVERTED, NOT_INVERTED, SensorParams

__all__ = ["Correction", "model_correction_record"]


def model_correction_record(fx, p: SensorParams, mode: str, estimator: str) -> dict:
    """What undoing the effect model ``fx`` (an :class:`sizefx.effects.EffectModel`, its parameters
    ``p``) in ``mode`` corrects, as a run records it: the model's source, the mode, the angular
    acceleration's estimator, the sections corrected and ignored, the delay, the arms and the axes."""
    return {
        "model": fx.source,
        "mode": mode,
        "estimator": estimator,
        "corrected": [name for name in INVERTED if fx.enabled(name)],
        "ignored": [name for name in NOT_INVERTED if fx.enabled(name)],
        "accel_delay_s": p.accel_delay,
        "arms_m": p.arms(mode).tolist(),
        "accel_axes": p.accel_axes().tolist(),
    }


@dataclass(frozen=True, eq=False)
class Correction:
    """The correction of one navigation run. Build it with :meth:`of_arms` (a levers file) or
    :meth:`of_model` (an effect model's :class:`SensorParams`)."""

    mode: str  #: triad | center: the point the accelerometers are brought to
    arms_m: np.ndarray  #: [3, 3] rows: the arm of each accelerometer from that point [m], body axes
    axes: np.ndarray  #: [3, 3] rows u_i: each accelerometer's input axis (the lever terms' direction)
    accel_delay_s: float  #: how late the accelerometers read [s], undone with their own stamps
    params: SensorParams | None = None  #: a model's errors (None: the size effect alone)
    #: what to name in the run's configuration: {"levers": path} or the model's source and sections
    described: dict | None = None
    #: [3, 3] U^-1, rows of U the axes: a model's step 6 (f = U^-1 a), formed once; None for levers
    axes_inverse: np.ndarray | None = None

    @classmethod
    def of_arms(cls, arms_m, axes, accel_delay_s: float | None, mode: str, described: dict | None) -> Correction:
        """The size effect alone: a levers file's arms for ``mode`` and axes, and its delay."""
        return cls(
            mode,
            np.ascontiguousarray(arms_m, dtype=float),
            np.ascontiguousarray(axes, dtype=float),
            float(accel_delay_s or 0.0),
            None,
            described,
        )

    @classmethod
    def of_model(cls, p: SensorParams, mode: str, described: dict) -> Correction:
        """Every deterministic error of an effect model; refused here, before any chunk, when its
        gains or axes cannot be inverted."""
        check_invertible(p)
        axes = p.accel_axes()
        return cls(mode, p.arms(mode), axes, float(p.accel_delay), p, described, np.linalg.inv(axes))

    def synced(self, time_s, accel_like, accel_time_s, form: str) -> np.ndarray:
        """Step 1: ``accel_like`` on the gyros' ``time_s``."""
        from ..sync import synced_accel  # the sync kernels (Numba) only when a record is corrected

        return synced_accel(time_s, accel_like, accel_time_s, self.accel_delay_s, form)

    def channels(self, gyro_like, accel_like, *, form: str, dt: float, time_s=None):
        """Steps 2-5: ``(omega_like, a_like)`` with a model's per-channel and gyro errors undone, the
        lever terms and the axes still in; the arrays themselves for the size effect alone."""
        if self.params is None:
            return gyro_like, accel_like
        estimator = "increments" if form == "increments" else "savgol"
        return invert_channels(self.params, gyro_like, accel_like, form=form, dt=dt, estimator=estimator, time_s=time_s)

    def on_increments(self, dtheta, dvel, dt: float) -> np.ndarray:
        """Step 6 on increments ``[N, 3]``: ``dvel`` with the lever terms of :attr:`arms_m` removed
        (edge rates from ``dtheta``) and, for a model, the accelerometer axes undone."""
        out = remove_lever_terms(dvel, dtheta, self.arms_m, self.axes, form="increments", dt=dt, estimator="increments")
        return out if self.axes_inverse is None else out @ self.axes_inverse.T
