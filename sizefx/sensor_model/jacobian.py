"""Jacobian: the partial derivatives of the forward readings with respect to ``theta``."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from .forward import specific_force_at
from .table import EFFECTS, OFFDIAG, Motion, SensorParams, cross, param_index

__all__ = ["Jacobian", "jacobian"]

#: Below this rotation angle [rad] the left Jacobian's coefficients are taken from their series
#: (to theta^2; the next term is theta^4 / 720, 1e-19 here): the closed forms' ``1 - cos`` and
#: ``theta - sin`` lose their digits to cancellation for small angles such as a table's tilt.
SERIES_BELOW_RAD = 1e-3


class Jacobian(Mapping):
    """``{index in PARAMS: (channels [k], columns [n, k])}``: the nonzero columns of d(readings)/d(theta).

    Channels are numbered as :data:`CHANNELS` (gyros 0-2, accelerometers 3-5); the layout is the
    one ``sizefx diagnose`` uses for its regressors. The columns are kept one by one and stacked
    only when asked for, by parameter (``jac[j]``) or by channel (:meth:`block`).
    """

    def __init__(self, columns: dict):
        self._columns = columns  #: {j: {channel: [n]}}

    def __getitem__(self, j):
        by_channel = self._columns[j]
        channels = np.array(sorted(by_channel))
        return channels, np.column_stack([by_channel[c] for c in channels])

    def __iter__(self):
        return iter(sorted(self._columns))

    def __len__(self):
        return len(self._columns)

    def block(self, channel: int, indices) -> np.ndarray:
        """Columns [n, len(indices)] of ``channel`` for the parameters ``indices`` (zero where one is absent)."""
        n = next(iter(next(iter(self._columns.values())).values())).shape[0]
        out = np.empty((n, len(indices)))
        for k, j in enumerate(indices):
            out[:, k] = self._columns.get(int(j), {}).get(channel, 0.0)
        return out


def _need(m: Motion, name: str, effect: str):
    value = getattr(m, name)
    if value is None:
        raise ValueError(f"jacobian: the {effect} columns need Motion.{name}")
    return value


def _left_jacobian(phi) -> np.ndarray:
    """``J(phi)`` [3, 3], the left Jacobian of SO(3) (Sola et al. 2018, "A micro Lie theory", eq. 144):
    ``exp([(phi + dphi) x]) = exp([J(phi) dphi x]) exp([phi x])`` to first order in ``dphi``."""
    phi = np.asarray(phi, dtype=float)
    theta = float(np.linalg.norm(phi))
    if theta == 0.0:
        return np.eye(3)
    k = np.array([[0.0, -phi[2], phi[1]], [phi[2], 0.0, -phi[0]], [-phi[1], phi[0], 0.0]])
    if theta < SERIES_BELOW_RAD:
        a, b = 0.5 - theta**2 / 24.0, 1.0 / 6.0 - theta**2 / 120.0
    else:
        a, b = (1.0 - np.cos(theta)) / theta**2, (theta - np.sin(theta)) / theta**3
    return np.eye(3) + a * k + b * (k @ k)


def _tilt_axes(p: SensorParams, mat_nb):
    """``c_k = C_bn J(phi) e_k`` [n, 3] for k = north, east: ``d(C_bn_ref R(phi)^T v_n) / d phi_k = v_b x c_k``.

    ``R(phi) = exp([phi x])`` moves by ``[J(phi) dphi x] R(phi)`` (:func:`_left_jacobian`), so
    ``R^T v`` moves by ``R^T (v x J dphi)``; ``mat_nb`` is the true (tilted, mounted) attitude. At
    zero tilt ``J = I`` and ``c_k`` is the NED axis k in body axes.
    """
    jac = _left_jacobian(np.array([p.level_tilt[0], p.level_tilt[1], 0.0]))
    return [jac[:, c] @ mat_nb for c in range(2)]


def _mount_axes(p: SensorParams) -> np.ndarray:
    """Rows ``c_k = J(-psi) e_k`` [3, 3], k = x, y, z: ``d(C_b_b' v_b') / d psi_k = v_b x c_k``.

    ``C_b_b' = exp(-[psi x])`` (:func:`~sizefx.sensor_model.table.mount_matrix`) moves by
    ``-[J(-psi) dpsi x] C_b_b'``, so a vector ``v_b = C_b_b' v_b'`` moves by ``v_b x J(-psi) dpsi``;
    at zero mount ``c_k = e_k`` and the column is ``[v_b x] e_k`` (the first-order ``I - [psi x]``).
    """
    return _left_jacobian(-np.asarray(p.reference_mount, dtype=float)).T


def jacobian(
    p: SensorParams,
    at_gyro: Motion,
    at_accel: Motion | None = None,
    *,
    effects=None,
    sensors=("gyro", "accel"),
    measured_lever_rates: bool = False,
) -> Jacobian:
    """Partial derivatives of :func:`forward`'s readings with respect to ``theta``, at ``p``.

    Parameters
    ----------
    p : SensorParams
        Where to linearise.
    at_gyro, at_accel : Motion
        The true motion at the gyros' and the accelerometers' instants, as for :func:`forward`
        (``at_accel`` None: the gyros' instants).
    effects : iterable of str or None
        The effects whose columns are wanted (None: every deterministic one).
    sensors : tuple of {"gyro", "accel"}
        The channels wanted (calibrate fits the accelerometers only).
    measured_lever_rates : bool
        True when ``at_accel``'s ``omega_ib_b`` and ``omegadot_ib_b`` are measured gyro rates
        (diagnose's predictor), which the reference's mount does not turn: the mount's
        accelerometer columns are then the specific force's alone. False (the true motion): the
        lever terms turn with it too.

    Exact for the biases, scale factors, misalignments, quadratic terms, arms and G (each reading
    is linear in them, or its derivative is written out). The tilt through ``f_b`` and the gyros'
    ``C_bn omega_in``; the lever terms also move with it, through ``omega_ib`` and ``omegadot_ib``,
    by ``|omega| |r| |omega_in|`` (1e-6 of the ``g`` the accelerometers' tilt columns hold), left out.
    The delays by the chain rule, ``d/dtau_a = -d/dt`` of the accelerometer readings and
    ``d/dtau_r = +d/dt`` of all readings, from ``fdot_b`` and, when given,
    ``omegaddot_ib_b`` for the lever terms' rate of change (without it, the specific force's
    alone: the lever terms change 1e-3 times as fast as ``g omega`` on a turntable).
    The mount exactly: every vector of the motion is the reference's turned by ``C_b_b'``, so
    ``omega``, ``omegadot`` and ``f`` move by ``v x c_k`` (:func:`_mount_axes`), and the readings
    through the gyro matrix, ``G`` and the accelerometers' lever terms.
    """
    deterministic = {e.name for e in EFFECTS if e.deterministic}
    wanted = deterministic if effects is None else set(effects)
    if not wanted <= deterministic or not set(sensors) <= {"gyro", "accel"}:
        raise ValueError(f"jacobian: effects {sorted(wanted - deterministic)} or sensors {sensors} unknown")
    cols: dict = {}

    def put(effect, k, channel, column):
        cols.setdefault(int(param_index(effect)[k]), {})[channel] = column

    if "gyro" in sensors:
        _gyro_columns(p, at_gyro, wanted, put)
    if "accel" in sensors:
        _accel_columns(p, at_gyro if at_accel is None else at_accel, wanted, put, measured_lever_rates)
    return Jacobian(cols)


def _misalignment_columns(gain, vec, proj, axes, misalignment, put, effect, offset):
    """``d/dm_ij`` of ``gain_i (u_i . vec_i)``: ``gain_i (vec_ij - (u_i . vec_i) u_ij) / |v_i|``,
    ``v_i = e_i + m_i`` (the derivative of a normalised vector)."""
    for k, (i, j) in enumerate(OFFDIAG):
        row = np.eye(3)[i] + misalignment[i] - np.diag(misalignment)[i] * np.eye(3)[i]
        v_norm = np.linalg.norm(row)
        put(effect, k, offset + i, gain[i] * (vec[i][:, j] - proj[:, i] * axes[i, j]) / v_norm)


def _gyro_columns(p: SensorParams, m: Motion, wanted, put):
    w = m.omega_ib_b
    u_g = p.gyro_axes()
    proj = w @ u_g.T  # [n, 3] u_g,i . omega
    one = np.ones(w.shape[0])
    for i in range(3):
        if "gyro_bias" in wanted:
            put("gyro_bias", i, i, one)
        if "gyro_scale_factor" in wanted:
            put("gyro_scale_factor", i, i, proj[:, i])
        if "gyro_g_sensitivity" in wanted:
            for j in range(3):
                put("gyro_g_sensitivity", 3 * i + j, i, m.f_b[:, j])
    if "gyro_misalignment" in wanted:
        _misalignment_columns(
            1.0 + p.gyro_scale_factor, [w] * 3, proj, u_g, p.gyro_misalignment, put, "gyro_misalignment", 0
        )
    m_g, g_sens = p.gyro_matrix(), p.gyro_g_sensitivity
    if "level_tilt" in wanted:
        mat = _need(m, "mat_nb", "level_tilt")
        w_in = _need(m, "omega_in_b", "level_tilt")
        for k, c_k in enumerate(_tilt_axes(p, mat)):  # omega_ib = omega_nb + C_bn omega_in: the second moves
            d = cross(w_in, c_k) @ m_g.T + cross(m.f_b, c_k) @ g_sens.T
            for i in range(3):
                put("level_tilt", k, i, d[:, i])
    if "reference_mount" in wanted:  # omega and f turn with the mount: d/dpsi_k = M (omega x c_k) + G (f x c_k)
        for k, c_k in enumerate(_mount_axes(p)):
            d = cross(w, c_k) @ m_g.T + cross(m.f_b, c_k) @ g_sens.T
            for i in range(3):
                put("reference_mount", k, i, d[:, i])
    if "reference_delay" in wanted:
        rate = m.omegadot_ib_b @ m_g.T + _need(m, "fdot_b", "reference_delay") @ g_sens.T
        for i in range(3):
            put("reference_delay", 0, i, rate[:, i])


def _accel_columns(p: SensorParams, m: Motion, wanted, put, measured_lever_rates=False):
    u = p.accel_axes()
    w, wd = m.omega_ib_b, m.omegadot_ib_b
    n = w.shape[0]
    needs_inputs = bool(wanted & {"accel_scale_factor", "accel_quadratic", "accel_misalignment"}) or bool(
        np.any(p.accel_quadratic != 0.0)
    )
    f_i: list[np.ndarray] | None = None  # [3] of [n, 3]: the specific force at each accelerometer
    a: np.ndarray | None = None  # [n, 3]: the input of each accelerometer
    if needs_inputs:
        f_i = [specific_force_at(m, p.lever_arm[i]) for i in range(3)]
        a = np.column_stack([f_i[i] @ u[i] for i in range(3)])
    if np.any(p.accel_quadratic != 0.0):
        assert a is not None  # a non-zero quadratic sets needs_inputs
        gain = 1.0 + p.accel_scale_factor + 2.0 * p.accel_quadratic * a  # [n, 3] d(reading)/d(input)
    else:
        gain = np.broadcast_to(1.0 + p.accel_scale_factor, (n, 3))
    one = np.ones(n)
    w2 = np.sum(w * w, axis=1)
    for i in range(3):
        c = 3 + i
        if "accel_bias" in wanted:
            put("accel_bias", i, c, one)
        if "accel_scale_factor" in wanted:
            assert a is not None  # wanting the scale factor sets needs_inputs
            put("accel_scale_factor", i, c, a[:, i])
        if "accel_quadratic" in wanted:
            assert a is not None  # wanting the quadratic sets needs_inputs
            put("accel_quadratic", i, c, a[:, i] ** 2)
        if "lever_arm" in wanted:  # d a_i / d r_i = u_i x omegadot + (u_i . omega) omega - |omega|^2 u_i
            grad = cross(u[i], wd) + (w @ u[i])[:, None] * w - w2[:, None] * u[i]
            for k in range(3):
                put("lever_arm", 3 * i + k, c, gain[:, i] * grad[:, k])
    if "accel_misalignment" in wanted:
        _misalignment_columns(gain.T, f_i, a, u, p.accel_misalignment, put, "accel_misalignment", 3)
    if "level_tilt" in wanted:
        mat = _need(m, "mat_nb", "level_tilt")
        for k, c_k in enumerate(_tilt_axes(p, mat)):
            d = cross(m.f_b, c_k)
            for i in range(3):
                put("level_tilt", k, 3 + i, gain[:, i] * (d @ u[i]))
    if "reference_mount" in wanted:
        for k, c_k in enumerate(_mount_axes(p)):
            df = cross(m.f_b, c_k)
            if not measured_lever_rates:  # the lever terms turn with the true omega and omegadot
                dw, dwd = cross(w, c_k), cross(wd, c_k)
            for i in range(3):
                r = p.lever_arm[i]
                d = df
                if not measured_lever_rates and np.any(r):
                    d = d + cross(dwd, r) + cross(dw, cross(w, r)) + cross(w, cross(dw, r))
                put("reference_mount", k, 3 + i, gain[:, i] * (d @ u[i]))
    if wanted & {"accel_delay", "reference_delay"}:
        fdot = _need(m, "fdot_b", "delay")
        rate = np.empty((n, 3))  # d a_i / dt
        for i in range(3):
            r = p.lever_arm[i]
            d = fdot
            if m.omegaddot_ib_b is not None:
                d = d + cross(m.omegaddot_ib_b, r) + cross(wd, cross(w, r)) + cross(w, cross(wd, r))
            rate[:, i] = d @ u[i]
        for i in range(3):
            if "accel_delay" in wanted:
                put("accel_delay", 0, 3 + i, -gain[:, i] * rate[:, i])
            if "reference_delay" in wanted:
                put("reference_delay", 0, 3 + i, gain[:, i] * rate[:, i])
