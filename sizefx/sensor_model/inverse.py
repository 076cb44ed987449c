"""Inverse: readings -> ``omega_ib_b`` and ``f_b``, the deterministic errors and the lever arms undone."""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError
from ..omegadot import ESTIMATORS, central, edges_from_increments, savgol
from .table import MAX_AXES_CONDITION, SensorParams

__all__ = ["inverse", "invert_channels", "remove_lever_terms", "check_invertible", "check_estimator"]


def check_invertible(p: SensorParams):
    """Refuse a model whose gains or axes cannot be inverted, naming the section; return
    ``(1 + s_a, 1 + s_g)`` [3] each."""
    gains = []
    for sensor, axes in (("accel", p.accel_axes()), ("gyro", p.gyro_axes())):
        one_plus_s = 1.0 + getattr(p, f"{sensor}_scale_factor")
        if np.any(one_plus_s <= 0.0):
            raise ConfigError(
                f"{p.source}: [{sensor}_scale_factor] gives 1 + scale factor = {one_plus_s.tolist()}; "
                "every channel needs a positive gain (scale factors are in ppm)"
            )
        cond = np.linalg.cond(axes)
        if not cond < MAX_AXES_CONDITION:
            raise ConfigError(
                f"{p.source}: [{sensor}_misalignment] makes the sensor axes nearly dependent (condition "
                f"{cond:.3g}, limit {MAX_AXES_CONDITION:g}); misalignments are in arcsec"
            )
        gains.append(one_plus_s)
    return gains[0], gains[1]


def _invert_accel_channels(rate_mps2, one_plus_s, k2, bias, time_s):
    """``a`` [N, 3] from readings ``m`` [N, 3] (m/s^2): the root of ``(1+s) a + K2 a^2 + b = m`` nearest m,
    written ``2 (m - b) / ((1 + s) + sqrt((1 + s)^2 + 4 K2 (m - b)))`` so that it stays accurate for
    small and zero ``K2``."""
    x = rate_mps2 - bias
    disc = one_plus_s**2 + 4.0 * k2 * x
    if np.any(disc < 0.0):
        k, i = np.argwhere(disc < 0.0)[0]
        at = f" at t = {time_s[k]:.6f} s" if time_s is not None else f" in sample {k}"
        raise ConfigError(
            f"accelerometer {'xyz'[i]} reads {rate_mps2[k, i]:.6g} m/s^2{at}, "
            f"where (1 + s) a + K2 a^2 + b with K2 = {k2[i]:.6g} s^2/m has no real inverse; "
            "check [accel_quadratic] (ug_per_g2) of the model"
        )
    return 2.0 * x / (one_plus_s + np.sqrt(disc))


def check_estimator(form: str, estimator: str):
    """Refuse an angular-acceleration estimator that does not fit the record's form."""
    if estimator not in ESTIMATORS:
        raise ConfigError(f"estimator '{estimator}': use one of {', '.join(ESTIMATORS)}")
    if form == "increments" and estimator != "increments":
        raise ConfigError("increment data are compensated with --estimator increments (no derivative is formed)")
    if form == "rates" and estimator == "increments":
        raise ConfigError("rate data take --estimator central or savgol")


def remove_lever_terms(
    accel_like,
    omega_like,
    arms,
    axes,
    *,
    form: str,
    dt: float,
    estimator: str,
    centripetal: bool = True,
    tangential: bool = True,
):
    """``a_i - u_i . (omegadot x r_i + omega x (omega x r_i))`` [N, 3], in the record's own domain.

    Rates: ``omegadot`` from ``omega`` by the estimator (:mod:`sizefx.omegadot`). Increments: the
    tangential term as a difference of edge rates, the centripetal from the interval's mean rate
    (:mod:`sizefx.kernels.sizeeffect`). ``arms``, ``axes``: rows ``r_i`` [m], ``u_i``.
    ``centripetal``, ``tangential``: which of the two terms to remove (both, unless a study
    asks for one alone: ``sizefx compensate --no-centripetal``).
    """
    # the kernels are imported here: Numba costs 0.3 s at start-up, which simulate (forward only) need not pay
    from ..kernels.sizeeffect import compensate_increments, compensate_increments_edges, compensate_rates

    check_estimator(form, estimator)
    accel_like = np.ascontiguousarray(accel_like, dtype=float)
    omega_like = np.ascontiguousarray(omega_like, dtype=float)
    arms, axes = np.ascontiguousarray(arms, dtype=float), np.ascontiguousarray(axes, dtype=float)
    out = np.empty_like(accel_like)
    if form == "rates":
        omegadot = central(omega_like, dt) if estimator == "central" else savgol(omega_like, dt)
        compensate_rates(
            accel_like, omega_like, np.ascontiguousarray(omegadot), arms, axes, centripetal, tangential, out
        )
    elif accel_like.shape[0] < 2:
        compensate_increments(
            accel_like, omega_like, edges_from_increments(omega_like, dt), dt, arms, axes, centripetal, tangential, out
        )
    else:
        compensate_increments_edges(accel_like, omega_like, dt, arms, axes, centripetal, tangential, out)
    return out


def invert_channels(
    p: SensorParams,
    gyro_like,
    accel_like,
    *,
    form: str,
    dt: float,
    estimator: str | None = None,
    time_s=None,
):
    """Steps 2-5 of :func:`inverse`: ``(omega_like, a_like)`` [N, 3], the gyros corrected and each
    accelerometer channel's scale factor, quadratic term and bias undone, its lever terms and its
    axis (step 6) still in. Step 4's lever terms, for the gyros' ``G f_b`` alone, take ``estimator``."""
    if estimator is None:
        estimator = "increments" if form == "increments" else "savgol"
    check_estimator(form, estimator)
    accel_gain, gyro_gain = check_invertible(p)
    accel_axes = p.accel_axes()
    mat_gyro_inv = np.linalg.inv(np.diag(gyro_gain) @ p.gyro_axes())  # (diag(1 + s_g) U_g)^-1
    accel_axes_inv = np.linalg.inv(accel_axes)  # U^-1: f = U^-1 a
    # per sample: 1 for rates, dt for increments (a rate bias b adds b dt to each increment)
    per_sample = 1.0 if form == "rates" else dt
    a = (
        _invert_accel_channels(accel_like / per_sample, accel_gain, p.accel_quadratic, p.accel_bias, time_s)
        * per_sample
    )  # step 2

    def gyro_from(f_like):  # omega = M^-1 (g - b_g - G f), per sample: b_g dt and G dv for increments
        return (gyro_like - p.gyro_bias * per_sample - f_like @ p.gyro_g_sensitivity.T) @ mat_gyro_inv.T

    omega_provisional = gyro_from(a @ accel_axes_inv.T)  # step 3
    lever_terms_out = remove_lever_terms(
        a, omega_provisional, p.arms("center"), accel_axes, form=form, dt=dt, estimator=estimator
    )
    f_reference = lever_terms_out @ accel_axes_inv.T  # step 4
    return gyro_from(f_reference), a  # step 5


def inverse(
    p: SensorParams,
    gyro_like,
    accel_like,
    *,
    form: str,
    dt: float,
    mode: str = "center",
    estimator: str | None = None,
    time_s=None,
):
    """``(omega_like, f_like)`` [N, 3]: readings with the deterministic errors and the lever arms undone.

    Parameters
    ----------
    p : SensorParams
    gyro_like, accel_like : [N, 3]
        Rates (rad/s, m/s^2) or increments (rad, m/s), the accelerometers already on the gyros'
        time base (step 1: :func:`sizefx.sync.sync_accelerometers` with ``p.accel_delay``).
    form : {"rates", "increments"}
    dt : float
        Sample period [s].
    mode : {"center", "triad"}
        ``f_b`` at the reference point (arms ``r_i``) or at the triad point (arms ``d_i``).
    estimator : {"central", "savgol", "increments"} or None
        Angular acceleration for the tangential term; None: ``savgol`` for rates, ``increments``.
    time_s : [N] or None
        Time stamps, only to say where a reading cannot be inverted.

    Steps (:mod:`sizefx.correct` gives the error analysis of the one pass through ``G f``):
    2. ``a`` per channel from ``m = (1 + s) a + K2 a^2 + b`` (increments: on the mean rate ``dvel / dt``);
    3. provisional gyros ``omega~ = (diag(1 + s_g) U_g)^-1 (g - b_g - G f~)``, ``f~ = U^-1 a``;
    4. ``f_b = U^-1 (a - lever terms of omega~)`` at the reference point, for ``G f_b`` only;
    5. gyros ``omega = (diag(1 + s_g) U_g)^-1 (g - b_g - G f_b)``;
    6. the lever terms of ``omega`` removed (arms of ``mode``), then ``f = U^-1 a``.

    Steps 2-5 are :func:`invert_channels`; navigation takes step 6 on the increments it forms
    (:class:`sizefx.sensor_model.Correction`).
    """
    if estimator is None:
        estimator = "increments" if form == "increments" else "savgol"
    omega_like, a = invert_channels(p, gyro_like, accel_like, form=form, dt=dt, estimator=estimator, time_s=time_s)
    accel_axes = p.accel_axes()
    f_like = remove_lever_terms(a, omega_like, p.arms(mode), accel_axes, form=form, dt=dt, estimator=estimator)
    return omega_like, f_like @ np.linalg.inv(accel_axes).T  # step 6
