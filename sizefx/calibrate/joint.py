"""The joint weighted least squares over every sample of every record, with its observability checks.

The design is the sensor model's (:mod:`sizefx.sensor_model`): the prediction at zero arms, biases,
tilt and delay is gravity in the reported attitude (:func:`~sizefx.sensor_model.accel_readings`),
and the columns are the partial derivatives of the accelerometer readings with respect to the
arms, the biases, the tilt and the delay (:func:`~sizefx.sensor_model.jacobian`). The model is
linear in the arms and the biases, and the tilt and the delay enter to first order.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..constants import ARCSEC
from ..sensor_model import SensorParams, accel_inputs, accel_readings, jacobian, param_index
from .records import ROTATING_RAD_S, CalibrationError, Record, motion_of

__all__ = ["CalibrationResult", "joint_fit", "UNOBSERVABLE_EIG", "BIAS_WINDOW_S", "UNDETERMINED_SIGMA",
           "PARAMS_R", "FIT_EFFECTS"]

#: Relative eigenvalue of the scaled normal matrix below which a direction is unobservable:
#: determined 1000 times worse than the best. Earth rate (5e-5 rad/s) against the table's
#: 0.35 rad/s "observes" a missing axis at ~1e-8: in practice, not at all.
UNOBSERVABLE_EIG = 1e-6
#: The accelerometer biases are modelled piecewise constant over windows of this length [s].
#: A bias random walk (2 ug/sqrt(h) by default) drifts ~0.7 ug over the paper's plan; one
#: constant per channel would pass that drift into the centripetal estimate (~0.1 mm, 4 sigma).
BIAS_WINDOW_S = 120.0
#: Standard errors beyond which a parameter counts as not determined. Column scaling makes a
#: parameter seen only through Earth rate look well conditioned, so the check is in physical
#: units: arms are known to ~0.02-0.05 mm from a proper plan; 1 mm is no calibration.
UNDETERMINED_SIGMA = {"arm_m": 1e-3, "tilt_rad": 60 * ARCSEC, "delay_s": 1e-3}
PARAMS_R = [f"r_{a}[{c}]" for a in "xyz" for c in "xyz"]
#: The linearisation point: no arms, biases, tilt or delay (the fit's model is linear in them).
_ZERO = SensorParams()


def _fit_effects(with_tilt: bool, with_delay: bool) -> list:
    """The sensor model's effects the joint fit estimates, in the order of :func:`_design`'s columns."""
    return ["lever_arm", "accel_bias"] + (["level_tilt"] if with_tilt else []) + (["accel_delay"] if with_delay else [])


#: The effects the fit can estimate (the others of :data:`sizefx.sensor_model.EFFECTS` are taken as absent).
FIT_EFFECTS = tuple(_fit_effects(True, True))


@dataclass
class CalibrationResult:
    """The joint fit's estimates (SI) and their standard errors; the stage's result is
    :class:`sizefx.calibrate.CalibrateResult`."""

    arms: np.ndarray  #: [3, 3] r_i
    sigma_arms: np.ndarray  #: [3, 3]
    biases: np.ndarray  #: [n_records, 3] m/s^2, the mean of each record's bias windows
    tilt_rad: np.ndarray | None  #: [2] (north, east)
    sigma_tilt_rad: np.ndarray | None
    delay_s: float | None
    sigma_delay_s: float | None
    condition: float
    residual_rms: np.ndarray  #: [3] m/s^2 per channel
    samples: int
    names: list = field(default_factory=list)
    covariance: np.ndarray | None = None


def _windows(rec: Record, window_s):
    """Bias window index of every sample (0 .. n-1) and the number of windows."""
    if not window_s:
        return np.zeros(rec.t.size, dtype=int), 1
    idx = np.floor((rec.t - rec.t[0]) / window_s).astype(int)
    n = int(idx[-1]) + 1
    if n > 1 and (rec.t[-1] - rec.t[0]) - (n - 1) * window_s < 0.5 * window_s:
        idx[idx == n - 1] = n - 2  # fold a short last window into the previous one
        n -= 1
    return idx, n


def _design(rec: Record, sl: slice, with_tilt: bool, with_delay: bool):
    """Design rows of each channel i for samples ``sl`` in their active columns only:
    ``[(H_i, y_i)]`` with ``H_i = [r_i (3) | bias_i (1) | tilt (2) | delay (1)]`` and ``y_i`` the reading
    less the prediction at the linearisation point (gravity).

    Every other column of the full design (the other channels' arms, the other bias windows)
    is zero on these rows, so the normal equations are accumulated from these few columns
    (see :func:`_columns`): 7 columns a row instead of 9 + 3 * windows + 3.
    """
    motion = motion_of(rec, sl, with_rate=with_delay)
    jac = jacobian(_ZERO, motion, effects=_fit_effects(with_tilt, with_delay), sensors=("accel",))
    predicted = accel_readings(_ZERO, accel_inputs(_ZERO, motion))
    arms, bias = param_index("lever_arm"), param_index("accel_bias")
    shared = [j for effect in _fit_effects(with_tilt, with_delay)[2:] for j in param_index(effect)]  # tilt, delay
    return [(jac.block(3 + i, [*arms[3 * i:3 * i + 3], bias[i], *shared]), rec.accel[sl, i] - predicted[:, i])
            for i in range(3)]


def _columns(i: int, window: int, n_bias: int, with_tilt: bool, with_delay: bool) -> np.ndarray:
    """Indices in the full parameter vector of :func:`_design`'s columns for channel i, bias window ``window``."""
    cols = [3 * i, 3 * i + 1, 3 * i + 2, 9 + 3 * window + i]
    c = 9 + 3 * n_bias
    if with_tilt:
        cols += [c, c + 1]
        c += 2
    if with_delay:
        cols.append(c)
    return np.array(cols)


def _spans(bias_index: np.ndarray, chunk: int):
    """``(window, slice)`` pieces of at most ``chunk`` samples, each inside one bias window
    (the windows are contiguous runs of samples, in time order)."""
    edges = np.flatnonzero(np.diff(bias_index)) + 1
    for s0, s1 in zip(np.r_[0, edges], np.r_[edges, bias_index.size]):
        for a in range(s0, s1, chunk):
            yield int(bias_index[s0]), slice(a, min(s1, a + chunk))


def _names(window_labels, with_tilt, with_delay):
    names = list(PARAMS_R) + [f"bias_{a} ({label})" for label in window_labels for a in "xyz"]
    if with_tilt:
        names += ["tilt_north", "tilt_east"]
    if with_delay:
        names += ["accel_delay"]
    return names


def joint_fit(records: list[Record], *, with_tilt: bool = True, with_delay: bool = False,
              bias_window_s: float | None = BIAS_WINDOW_S, chunk: int = 1 << 16) -> CalibrationResult:
    """Weighted least squares over all samples of all records; weights 1 / (channel noise variance).

    Biases are piecewise constant over ``bias_window_s`` windows of each record (None: one per record).
    """
    n_rec = len(records)
    bias_index, labels, first = [], [], 0
    for rec in records:
        idx, n = _windows(rec, bias_window_s)
        bias_index.append(idx + first)
        labels += [f"{Path(rec.name).name} window {j}" for j in range(n)]
        first += n
    n_bias = first
    names = _names(labels, with_tilt, with_delay)
    p = len(names)
    # a record (or a segment between gaps) at rest adds to the biases and the tilt; only a fit in
    # which nothing rotates has nothing to say about the arms
    if not any(np.any(np.linalg.norm(rec.omega, axis=1) > ROTATING_RAD_S) for rec in records):
        names = ", ".join(rec.name for rec in records)
        raise CalibrationError(f"{names}: the record never rotates (|omega| stays under 1 deg/s); "
                               "no lever arm is observable: record rotations about at least two body axes")
    variance = np.ones(3)
    for _ in range(2):  # unweighted, then weighted with each channel's residual variance
        N = np.zeros((p, p))
        b = np.zeros(p)
        for k, rec in enumerate(records):
            for window, sl in _spans(bias_index[k], chunk):
                for i, (H, y) in enumerate(_design(rec, sl, with_tilt, with_delay)):
                    cols = _columns(i, window, n_bias, with_tilt, with_delay)
                    N[np.ix_(cols, cols)] += H.T @ H / variance[i]
                    b[cols] += H.T @ y / variance[i]
        scale = 1.0 / np.sqrt(np.where(np.diag(N) > 0, np.diag(N), 1.0))
        Ns = N * np.outer(scale, scale)
        eigval, eigvec = np.linalg.eigh(Ns)
        weak = eigval < UNOBSERVABLE_EIG * eigval.max()
        if weak.any() or np.any(np.diag(N) == 0):
            bad = set(np.flatnonzero(np.diag(N) == 0))
            for v in eigvec[:, weak].T:
                bad |= set(np.flatnonzero(np.abs(v) > 0.3))
            listed = ", ".join(names[j] for j in sorted(bad))
            raise CalibrationError(f"the rotations in the record(s) leave unobservable: {listed}; "
                                   "record rotations about at least two body axes (the paper rotates about Y, X "
                                   "and Z in turn)" + (", and about horizontal axes for the delay" if with_delay else ""))
        x = scale * np.linalg.solve(Ns, scale * b)
        ss = np.zeros(3)
        count = np.zeros(3)
        for k, rec in enumerate(records):
            for window, sl in _spans(bias_index[k], chunk):
                for i, (H, y) in enumerate(_design(rec, sl, with_tilt, with_delay)):
                    r = y - H @ x[_columns(i, window, n_bias, with_tilt, with_delay)]
                    ss[i] += r @ r
                    count[i] += r.size
        variance = ss / np.maximum(count - p / 3.0, 1.0)
    cov = np.linalg.inv(N)  # weights are 1 / variance: the normal matrix inverse is the covariance
    sig = np.sqrt(np.diag(cov))
    limits = np.full(p, np.inf)
    limits[:9] = UNDETERMINED_SIGMA["arm_m"]
    for j, name in enumerate(names):
        if name.startswith("tilt"):
            limits[j] = UNDETERMINED_SIGMA["tilt_rad"]
        elif name == "accel_delay":
            limits[j] = UNDETERMINED_SIGMA["delay_s"]
    loose = np.flatnonzero(sig > limits)
    if loose.size:
        listed = ", ".join(f"{names[j]} (sigma {sig[j] * (1e3 if j < 9 else 1):.3g}{' mm' if j < 9 else ''})"
                           for j in loose)
        raise CalibrationError(f"the rotations in the record(s) leave unobservable: {listed}; record rotations "
                               "about at least two body axes (the paper rotates about Y, X and Z in turn)"
                               + (", and about horizontal axes for the delay" if with_delay else ""))
    c = 9 + 3 * n_bias
    windows = x[9:c].reshape(n_bias, 3)
    per_record = np.array([windows[np.unique(bias_index[k])].mean(axis=0) for k in range(n_rec)])
    res = CalibrationResult(
        arms=x[:9].reshape(3, 3), sigma_arms=sig[:9].reshape(3, 3), biases=per_record,
        tilt_rad=x[c:c + 2] if with_tilt else None, sigma_tilt_rad=sig[c:c + 2] if with_tilt else None,
        delay_s=float(x[-1]) if with_delay else None, sigma_delay_s=float(sig[-1]) if with_delay else None,
        condition=float(eigval.max() / eigval.min()), residual_rms=np.sqrt(ss / count),
        samples=int(sum(r.t.size for r in records)), names=names, covariance=cov)
    return res

