"""What a plan lets a calibration reach: the joint fit's Fisher information on the plan's noise-free
motion (:func:`sizefx.calibrate.joint.information`) and the standard errors it gives, the Cramer-Rao
bound a calibration on the plan will state (:func:`predict`)."""

from __future__ import annotations

import numpy as np

from .. import earth, scenarios
from ..calibrate.joint import information, unobservable
from ..calibrate.records import Record
from ..constants import MICRO_G, SQRT_SECONDS_PER_HOUR
from ..effects import IDEAL, load_effects
from ..simulate import true_motion
from .request import PlanError, Prediction

__all__ = ["predict", "PLAN_RATE_HZ"]

#: Rows per second of the plan's motion in the information. The table's changes of rate take 0.5 s
#: or more: on the paper's plan 25, 50 and 12.5 rows a second give the same sigmas to 0.1 %
#: (and the 1600 Hz fit's to 1 %; benchmarks/plan_calibrate.py), 25 at a third of 50's cost.
PLAN_RATE_HZ = 25.0


def _motion_record(traj, name: str) -> Record:
    """A trajectory's noise-free motion as the fit sees it, at :data:`PLAN_RATE_HZ` (true angular acceleration)."""
    t = np.arange(0.0, traj.duration_s, 1.0 / PLAN_RATE_HZ)
    site = traj.evaluate(t[:1])
    motion = true_motion(traj, t, load_effects(base=IDEAL).sensor_params())
    assert motion.mat_nb is not None  # true_motion carries the attitude
    g_n = np.asarray(earth.gravity_n(site.lat_rad[0], site.height_m[0]), dtype=float)
    return Record(name, t, np.zeros((t.size, 3)), motion.omega_ib_b, motion.omegadot_ib_b, motion.mat_nb, g_n)


def _plan_record(plan: scenarios.TurntablePlan) -> Record:
    return _motion_record(scenarios.turntable(plan)[0], "plan")


def _sway_record(sway: scenarios.SwayPlan) -> Record:
    return _motion_record(scenarios.sway(sway)[0], "sway")


def _fisher(
    plan: scenarios.TurntablePlan,
    noise_ug_per_sqrt_hz: float,
    bias_window_s="fit",
    sway=None,
    turntable_record=None,
    colour: dict | None = None,
):
    """``(names, Fisher information)`` of the joint fit's parameters on the plan's motion (with the
    delay's sway, a record of its own, and then the delay); the bias windows the fit's (``"fit"``)
    or one bias per channel and record (None: the information is then a sum over the cycles, which
    :func:`_least_cycles` and :func:`_least_sway` use)."""
    windows = {} if bias_window_s == "fit" else {"bias_window_s": bias_window_s}
    records = [_plan_record(plan) if turntable_record is None else turntable_record] + (
        [_sway_record(sway)] if sway is not None else []
    )
    return information(
        records, noise_ug_per_sqrt_hz * MICRO_G, with_delay=sway is not None, **windows, **(colour or {})
    )


def _sigmas(names, fisher, plan_axes: str) -> np.ndarray:
    """Standard errors from a Fisher information, or :class:`PlanError` naming what is unobservable
    (the fit's own test, :func:`sizefx.calibrate.joint.unobservable`)."""
    _, bad = unobservable(fisher, names)
    if bad:
        raise PlanError(
            f"rotations about {', '.join(plan_axes)} leave unobservable: {', '.join(bad)}; the table "
            "must reach at least two body axes (all three for every arm)"
        )
    scale = 1.0 / np.sqrt(np.diag(fisher))
    return np.sqrt(np.diag(np.linalg.inv(fisher * np.outer(scale, scale)))) * scale


def predict(
    plan: scenarios.TurntablePlan,
    noise_ug_per_sqrt_hz: float,
    sway: scenarios.SwayPlan | None = None,
    *,
    markov_ug_per_sqrt_hz: float = 0.0,
    markov_correlation_s: float = 1.0,
    bias_rw_ug_per_sqrt_h: float = 0.0,
) -> Prediction:
    """The arms' and the tilt's (and with ``sway``, the delay's) standard errors a calibration on
    ``plan`` (and the sway's record) will state, the accelerometers' noise white with this density,
    plus, when given, a first-order Gauss-Markov part and a bias random walk (the
    ``accel_noise`` section's ``markov_*`` and ``bias_rw_*``: the Cramer-Rao bound for that noise).
    Raises :class:`PlanError` naming what the plan leaves unobservable."""
    plan.check()
    duration = plan.duration_s
    if sway is not None:
        sway.check()
        duration += sway.duration_s
    colour = {
        "markov_density_mps2_per_sqrt_hz": markov_ug_per_sqrt_hz * MICRO_G,
        "markov_correlation_s": markov_correlation_s,
        "bias_rw_mps2_per_sqrt_s": bias_rw_ug_per_sqrt_h * MICRO_G / SQRT_SECONDS_PER_HOUR,
    }
    names, fisher = _fisher(plan, noise_ug_per_sqrt_hz, sway=sway, colour=colour)
    sigma = _sigmas(names, fisher, plan.axes)
    tilt = [names.index("tilt_north"), names.index("tilt_east")]
    return Prediction(
        sigma[:9].reshape(3, 3),
        sigma[tilt],
        duration,
        float(sigma[names.index("accel_delay")]) if sway is not None else None,
    )
