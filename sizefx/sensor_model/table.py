"""The table of effects, their parameters in SI, and the true motion the sensors sample.

See the package docstring (:mod:`sizefx.sensor_model`) for the table in words and how to add an effect.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import ConfigError
from ..rotation import rotvec_to_mat

__all__ = [
    "EFFECTS",
    "Effect",
    "PARAMS",
    "Param",
    "NP",
    "SensorParams",
    "Motion",
    "true_attitude",
    "reported_time",
    "mount_matrix",
    "unit_axes",
    "param_index",
    "cross",
    "INVERTED",
    "NOT_INVERTED",
    "CHANNELS",
    "OFFDIAG",
]

#: Channels of the readings, in the order :func:`jacobian` numbers them (diagnose's order).
CHANNELS = ("gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z")
#: The off-diagonal entries ``(i, j)`` of a misalignment matrix, in the order of ``theta``.
OFFDIAG = ((0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1))
#: Largest condition number accepted for a sensor-axes matrix (``U``, ``U_g``). Misalignments
#: of a few arc minutes give 1.001; 10 means two axes only 11 deg apart: not a misalignment but
#: a wrong file, whose inverse would amplify errors tenfold.
MAX_AXES_CONDITION = 10.0

_XYZ = "xyz"


@dataclass(frozen=True)
class Effect:
    """One row of the table: an effect, where it lives and how it enters."""

    name: str  #: TOML section (data-schemas/effects-1.json) = SensorParams field = diagnose's identifier
    sensor: str  #: "accel", "gyro", "reference" (the true motion's side) or "both"
    labels: tuple  #: one per scalar of theta (diagnose's labels); () for a random effect
    shape: tuple  #: shape of its SensorParams field
    si_unit: str  #: unit of its parameters inside sizefx
    toml: str  #: the TOML key(s) that give it, in their file units
    si_key: str | None  #: key of its SI value in EffectModel.sections (None: read by SensorParams.from_effects)
    enters: str  #: how it changes the readings
    inverse: str | None  #: how inverse() undoes it; None: it does not, and why is in ``enters``/NOT_INVERTED

    @property
    def deterministic(self) -> bool:
        return bool(self.labels)


_MIS = tuple(f"{_XYZ[i]}->{_XYZ[j]}" for i, j in OFFDIAG)
EFFECTS = (
    Effect(
        "accel_bias",
        "accel",
        tuple(_XYZ),
        (3,),
        "m/s^2",
        "bias_ug [ug]",
        "bias_mps2",
        "m_i = (1 + s_i) a_i + K2_i a_i^2 + b_i",
        "step 2: the root of K2 a^2 + (1 + s) a + b = m nearest m",
    ),
    Effect(
        "accel_scale_factor",
        "accel",
        tuple(_XYZ),
        (3,),
        "1",
        "ppm [ppm]",
        "scale_factor",
        "m_i = (1 + s_i) a_i + K2_i a_i^2 + b_i",
        "step 2",
    ),
    Effect(
        "accel_misalignment",
        "accel",
        _MIS,
        (3, 3),
        "rad",
        "arcsec [arcsec], 3x3, diagonal ignored",
        "angles_rad",
        "a_i = u_i . f_i, u_i = normalise(e_i + sum_j m_ij e_j)",
        "step 6: f = U^-1 a",
    ),
    Effect(
        "accel_quadratic",
        "accel",
        tuple(_XYZ),
        (3,),
        "s^2/m",
        "ug_per_g2 [ug/g^2]",
        "k2_per_mps2",
        "m_i = (1 + s_i) a_i + K2_i a_i^2 + b_i",
        "step 2",
    ),
    Effect(
        "lever_arm",
        "accel",
        tuple(f"r_{_XYZ[i]}[{_XYZ[j]}]" for i in range(3) for j in range(3)),
        (3, 3),
        "m",
        "preset, d_x_m, d_y_m, d_z_m, r0_m, r_plate_m, r_vehicle_m [m]",
        None,
        "f_i = f + omegadot x r_i + omega x (omega x r_i), r_i = r + d_i",
        "steps 4 and 6: the tangential and centripetal terms removed with the corrected gyros",
    ),
    Effect(
        "accel_delay",
        "accel",
        ("tau",),
        (),
        "s",
        "tau_s [s]",
        "tau_s",
        "the accelerometers sample the motion at t - tau_a (sample())",
        "step 1, before inverse(): sizefx.sync.sync_accelerometers resamples them onto the gyros' times",
    ),
    Effect(
        "reference_delay",
        "reference",
        ("tau",),
        (),
        "s",
        "tau_s [s]",
        "tau_s",
        "the reference row stamped t reports the true motion at t - tau_r (reported_time())",
        None,
    ),
    Effect(
        "level_tilt",
        "reference",
        ("north", "east"),
        (2,),
        "rad",
        "north_arcsec, east_arcsec [arcsec]",
        None,
        "the true attitude is R(phi) mat_nb_reported, phi = (north, east, 0) (true_attitude())",
        None,
    ),
    Effect(
        "gyro_bias",
        "gyro",
        tuple(_XYZ),
        (3,),
        "rad/s",
        "deg_per_h [deg/h]",
        "bias_rad_s",
        "g = diag(1 + s_g) U_g omega + b_g + G f",
        "step 5",
    ),
    Effect(
        "gyro_scale_factor",
        "gyro",
        tuple(_XYZ),
        (3,),
        "1",
        "ppm [ppm]",
        "scale_factor",
        "g = diag(1 + s_g) U_g omega + b_g + G f",
        "step 5",
    ),
    Effect(
        "gyro_misalignment",
        "gyro",
        _MIS,
        (3, 3),
        "rad",
        "arcsec [arcsec], 3x3, diagonal ignored",
        "angles_rad",
        "rows of U_g: normalise(e_i + sum_j m_ij e_j)",
        "step 5",
    ),
    Effect(
        "gyro_g_sensitivity",
        "gyro",
        tuple(f"{_XYZ[i]}<-f_{_XYZ[j]}" for i in range(3) for j in range(3)),
        (3, 3),
        "rad/s per m/s^2",
        "deg_per_h_per_g [deg/h/g]",
        "rad_s_per_mps2",
        "g = ... + G f, f at the reference point and the gyros' instants",
        "step 5, with f from steps 3-4",
    ),
    # last of the deterministic rows, so that the 49 scalars before it keep their places in theta
    Effect(
        "reference_mount",
        "reference",
        tuple(_XYZ),
        (3,),
        "rad",
        "arcsec [arcsec]",
        "angles_rad",
        "the IMU's axes are the reference's body axes turned by psi: omega_ib_b = C omega_ib_b', "
        "f_b = C f_b', mat_nb = mat_nb' C^T, C = C_b_b' = exp(-[psi x]) ~ I - [psi x] (mount_matrix())",
        None,
    ),
    Effect(
        "accel_noise",
        "accel",
        (),
        (),
        "",
        "density_ug_per_sqrt_hz, bias_rw_ug_per_sqrt_h, markov_density_ug_per_sqrt_hz, markov_correlation_s",
        None,
        "white noise, a bias random walk and a Gauss-Markov coloured part, drawn by sizefx.simulate",
        None,
    ),
    Effect(
        "gyro_noise",
        "gyro",
        (),
        (),
        "",
        "arw_deg_per_sqrt_h, rrw_deg_per_h_per_sqrt_h",
        None,
        "angle random walk and a rate random walk, drawn by sizefx.simulate",
        None,
    ),
    Effect(
        "quantisation",
        "both",
        (),
        (),
        "",
        "gyro_lsb_rad, accel_lsb_m_per_s",
        None,
        "outputs rounded to a count by sizefx.simulate (increments carry the remainder)",
        None,
    ),
)
_BY_NAME = {e.name: e for e in EFFECTS}
#: Sections :func:`inverse` (with the caller's sync for the delay) undoes, in the order reports list them.
INVERTED = (
    "accel_delay",
    "accel_bias",
    "accel_scale_factor",
    "accel_quadratic",
    "accel_misalignment",
    "lever_arm",
    "gyro_bias",
    "gyro_scale_factor",
    "gyro_misalignment",
    "gyro_g_sensitivity",
)
#: Sections it leaves alone: not errors of the IMU's outputs (the reference's clock and attitude), or random.
NOT_INVERTED = tuple(e.name for e in EFFECTS if e.inverse is None)
assert set(INVERTED) == {e.name for e in EFFECTS if e.inverse is not None}, "INVERTED must list the inverted rows"


@dataclass(frozen=True)
class Param:
    """One scalar of ``theta``."""

    index: int
    effect: str
    label: str


def _params() -> tuple[Param, ...]:
    out: list[Param] = []
    for e in EFFECTS:
        for label in e.labels:
            out.append(Param(len(out), e.name, label))
    return tuple(out)


PARAMS = _params()
NP = len(PARAMS)
_INDEX: dict[str, list[int]] = {}
for _p in PARAMS:
    _INDEX.setdefault(_p.effect, []).append(_p.index)


def param_index(effect: str) -> np.ndarray:
    """Indices in ``theta`` of an effect's parameters (table order of its labels)."""
    return np.array(_INDEX[effect])


def unit_axes(misalignment: np.ndarray) -> np.ndarray:
    """Rows ``u_i = normalise(e_i + sum_{j != i} m_ij e_j)`` [3, 3] (the diagonal of ``m`` is ignored)."""
    m = np.asarray(misalignment, dtype=float)
    axes = np.eye(3) + m - np.diag(np.diag(m))
    return axes / np.linalg.norm(axes, axis=1, keepdims=True)


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a x b`` over the last axis (3), broadcast: ``numpy.cross``'s arithmetic, operation for
    operation (so the results are the same to the bit), without its axis handling and copies,
    which made it a third of the joint fit's time."""
    a1, a2, a0 = a[..., 1], a[..., 2], a[..., 0]
    b1, b2, b0 = b[..., 1], b[..., 2], b[..., 0]
    out = np.empty(np.broadcast_shapes(np.shape(a), np.shape(b)))
    np.multiply(a1, b2, out=out[..., 0])
    out[..., 0] -= a2 * b1
    np.multiply(a2, b0, out=out[..., 1])
    out[..., 1] -= a0 * b2
    np.multiply(a0, b1, out=out[..., 2])
    out[..., 2] -= a1 * b0
    return out


def _zeros(shape):
    return lambda: np.zeros(shape)


@dataclass(frozen=True)
class SensorParams:
    """The deterministic effects in SI, one field per row of :data:`EFFECTS` (zero: absent)."""

    accel_bias: np.ndarray = field(default_factory=_zeros(3))  #: [3] m/s^2
    accel_scale_factor: np.ndarray = field(default_factory=_zeros(3))  #: [3]
    accel_misalignment: np.ndarray = field(default_factory=_zeros((3, 3)))  #: [3, 3] rad, m_ij (row i, column j)
    accel_quadratic: np.ndarray = field(default_factory=_zeros(3))  #: [3] s^2/m
    lever_arm: np.ndarray = field(default_factory=_zeros((3, 3)))  #: [3, 3] m, rows r_x, r_y, r_z
    accel_delay: float = 0.0  #: s
    reference_delay: float = 0.0  #: s
    level_tilt: np.ndarray = field(default_factory=_zeros(2))  #: [2] rad, (north, east)
    gyro_bias: np.ndarray = field(default_factory=_zeros(3))  #: [3] rad/s
    gyro_scale_factor: np.ndarray = field(default_factory=_zeros(3))  #: [3]
    gyro_misalignment: np.ndarray = field(default_factory=_zeros((3, 3)))  #: [3, 3] rad
    gyro_g_sensitivity: np.ndarray = field(default_factory=_zeros((3, 3)))  #: [3, 3] rad/s per m/s^2
    #: [3] rad, psi: the IMU frame b turned against the reference's body frame b' (:func:`mount_matrix`)
    reference_mount: np.ndarray = field(default_factory=_zeros(3))
    #: [3] m, the reference point to the triad point (r of r_i = r + d_i): not a parameter of the
    #: readings, only where inverse(mode="triad") brings the accelerometers
    triad_offset: np.ndarray = field(default_factory=_zeros(3))
    source: str = "the model"  #: what the values came from, for messages

    @classmethod
    def from_effects(cls, fx) -> SensorParams:
        """The deterministic part of an :class:`sizefx.effects.EffectModel` (a section that is off gives zeros)."""
        values = {}
        for e in EFFECTS:
            if not e.deterministic:
                continue
            if e.name == "lever_arm":  # preset, single rows and the offset chain: the effect model resolves them
                values[e.name] = fx.arms_total_m()
                values["triad_offset"] = fx.offset_m()
            elif e.name == "level_tilt":
                values[e.name] = fx.tilt_rad()[:2]
            elif not fx.enabled(e.name):
                values[e.name] = 0.0 if e.shape == () else np.zeros(e.shape)
            elif e.shape == ():
                values[e.name] = float(fx.get(e.name, e.si_key))
            else:
                values[e.name] = np.asarray(fx.get(e.name, e.si_key), dtype=float)
        return cls(**values, source=str(fx.source))

    @classmethod
    def from_vector(cls, theta, *, triad_offset=None, source: str = "theta") -> SensorParams:
        """The parameters of a model vector ``theta`` [NP] (diagnose's); misalignment diagonals zero."""
        theta = np.asarray(theta, dtype=float)
        values: dict[str, Any] = {}  # the dataclass's keywords: a float or an array, by field
        for e in EFFECTS:
            if not e.deterministic:
                continue
            v = theta[param_index(e.name)]
            if e.shape == ():
                values[e.name] = float(v[0])
            elif len(e.labels) == 6:  # the off-diagonal entries of a misalignment matrix
                m = np.zeros((3, 3))
                for (i, j), x in zip(OFFDIAG, v):
                    m[i, j] = x
                values[e.name] = m
            else:
                values[e.name] = v.reshape(e.shape)
        offset = np.zeros(3) if triad_offset is None else np.asarray(triad_offset, dtype=float)
        return cls(**values, triad_offset=offset, source=source)

    def vector(self) -> np.ndarray:
        """``theta`` [NP] in the table's order."""
        out: list[float] = []
        for e in EFFECTS:
            if not e.deterministic:
                continue
            v = np.asarray(getattr(self, e.name), dtype=float)
            out.extend([v[i, j] for i, j in OFFDIAG] if len(e.labels) == 6 else v.ravel())
        return np.array(out, dtype=float)

    def accel_axes(self) -> np.ndarray:
        """Rows ``u_x, u_y, u_z`` [3, 3]: unit sensitive axes of the accelerometers."""
        return unit_axes(self.accel_misalignment)

    def gyro_axes(self) -> np.ndarray:
        """Rows [3, 3]: unit input axes of the gyros (``U_g``)."""
        return unit_axes(self.gyro_misalignment)

    def gyro_matrix(self) -> np.ndarray:
        """``diag(1 + s_g) U_g`` [3, 3]."""
        return np.diag(1.0 + self.gyro_scale_factor) @ self.gyro_axes()

    def arms(self, mode: str = "center") -> np.ndarray:
        """Rows [3, 3]: ``r_i`` from the reference point (``center``) or ``d_i = r_i - r`` from the triad point."""
        if mode == "center":
            return self.lever_arm
        if mode == "triad":
            return self.lever_arm - self.triad_offset
        raise ConfigError(f"correction mode '{mode}': use center or triad")


# --------------------------------------------------------------------------- the reference side


def mount_matrix(p: SensorParams) -> np.ndarray:
    """``C_b_b'`` [3, 3]: the reference's body axes b' to the IMU's axes b, ``v_b = C_b_b' v_b'``.

    Sign convention (``tests/test_sensor_model.py::test_the_mount_turns_the_imu_by_psi`` pins it):
    ``psi`` [3] rad is the rotation vector that turns the reference's body axes into the IMU's,
    ``C_b'_b = exp([psi x])``, so ``C_b_b' = exp(-[psi x]) = I - [psi x]`` to first order and a
    vector fixed in b' reads ``v_b = v_b' - psi x v_b'`` in IMU axes. A positive ``psi_z`` yaws the
    IMU to the right of the reference (x forward, y right, z down): its heading is the
    reference's plus ``psi_z``. The exact rotation (not ``I - [psi x]``) keeps ``mat_nb`` orthonormal;
    the two differ by ``|psi|^2 / 2``, 5e-9 at 30 arcsec.
    """
    return rotvec_to_mat(-np.asarray(p.reference_mount, dtype=float))


def true_attitude(p: SensorParams, mat_nb_reported: np.ndarray) -> np.ndarray:
    """``R(phi) mat_nb_reported C_b'_b`` [..., 3, 3]: the attitude the IMU feels, ``phi = (north, east, 0)``.

    ``mat_nb_reported`` maps the reference's body axes b' to NED; the level tilt turns NED, the
    mount (:func:`mount_matrix`) the body axes.
    """
    tilted = rotvec_to_mat(np.array([p.level_tilt[0], p.level_tilt[1], 0.0])) @ mat_nb_reported
    if not np.any(p.reference_mount):  # no mount: the same bits as before it existed
        return tilted
    return tilted @ mount_matrix(p).T


def reported_time(p: SensorParams, t):
    """The instant whose true motion the reference row stamped ``t`` reports: ``t - tau_r``."""
    return t - p.reference_delay


# --------------------------------------------------------------------------- the true motion


@dataclass(frozen=True)
class Motion:
    """The true motion of the reference point at ``n`` instants, the IMU's body axes (b: with the
    reference's mount applied, :func:`mount_matrix`): what ideal, co-located sensors would read.
    Only :func:`jacobian`'s tilt and delay columns need the optional fields."""

    omega_ib_b: np.ndarray  #: [n, 3] rad/s
    omegadot_ib_b: np.ndarray  #: [n, 3] rad/s^2
    f_b: np.ndarray  #: [n, 3] m/s^2, specific force at the reference point
    mat_nb: np.ndarray | None = None  #: [n, 3, 3] true attitude, body to NED (tilt columns)
    omega_in_b: np.ndarray | None = None  #: [n, 3] rad/s, rate of the NED frame in body axes (gyros' tilt columns)
    fdot_b: np.ndarray | None = None  #: [n, 3] m/s^3, d f_b / dt in body axes (delay columns)
    omegaddot_ib_b: np.ndarray | None = None  #: [n, 3] rad/s^3 (delay columns' lever terms; None leaves them out)
