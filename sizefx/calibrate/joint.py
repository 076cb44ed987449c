"""The joint fit over every record, with its observability checks, its noise model and its bound.

The design is the sensor model's (:mod:`sizefx.sensor_model`): the prediction at zero arms, biases,
tilt and delay is gravity in the reported attitude (:func:`~sizefx.sensor_model.accel_readings`),
and the columns are the partial derivatives of the accelerometer readings with respect to the
arms, the biases, the tilt and the delay (:func:`~sizefx.sensor_model.jacobian`). The model is
linear in the arms and the biases, and the tilt and the delay enter to first order (the delay's
column carries the lever terms at the first estimate of the arms, and its second-order term is
taken off the readings).

Three choices make the estimate unbiased and its errors honest:

- **The increment domain.** The rows are means over 20 ms intervals, in which the tangential
  term's angular acceleration is the interval's exact mean, ``delta omega / T``, from the gyros'
  rates at its edges. A derivative of the gyros (Savitzky-Golay, 25 ms) is an estimate with its
  own errors, which enter the arms as errors in the regressor: up to 1.5 sigma on a noiseless
  record (``tests/test_calibrate_bound.py``). Increment records (PSINS-style logs) fit the same way.
- **A noise model.** Each record's and channel's residuals are an AR process (order by BIC,
  :mod:`sizefx.noise_model`); the rows are prewhitened by it (generalised least squares), so the
  standard errors hold on coloured noise (vibration, a bias wandering inside its window).
- **The bound.** :func:`cramer_rao_fisher` gives the Fisher information on the same rows with
  the noise's spectrum measured by an AR sieve: the smallest standard error any unbiased
  estimator can state; the report prints it beside each estimate. :func:`information` gives
  the same for white noise of a stated density on a plan's motion (:mod:`sizefx.plan`).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..constants import ARCSEC
from ..noise_model import (
    WHITE,
    ARNoise,
    Autocovariance,
    ChainedNoise,
    StateNoise,
    fit_ar,
    fit_state,
    state_log_likelihood,
)
from ..omegadot import SAVGOL_WINDOW
from ..sensor_model import SensorParams, accel_inputs, accel_readings, jacobian, param_index
from .records import ROTATING_RAD_S, CalibrationError, Record, motion_of

__all__ = [
    "CalibrationResult",
    "joint_fit",
    "UNOBSERVABLE_EIG",
    "BIAS_WINDOW_S",
    "UNDETERMINED_SIGMA",
    "PARAMS_R",
    "FIT_EFFECTS",
    "INTERVAL_S",
    "AR_MAX_ORDER",
    "cramer_rao_fisher",
    "information",
    "unobservable",
    "interval_samples",
    "mean_angular_acceleration",
    "steps_in_angular_acceleration",
    "STEP_FLOOR_RAD_S2",
    "STEP_SIGMAS",
]

#: Relative eigenvalue of the scaled normal matrix below which a direction is unobservable:
#: determined 1000 times worse than the best. Earth rate (5e-5 rad/s) against the table's
#: 0.35 rad/s "observes" a missing axis at ~1e-8: in practice, not at all.
UNOBSERVABLE_EIG = 1e-6
#: The increment domain's interval [s] (32 samples at 1600 Hz). Within 20 ms the design moves
#: little (0.4 deg of table rotation at 20 deg/s), so the interval means keep the information of
#: the samples (the efficiency against the bound is printed), while the tangential term's angular
#: acceleration is the interval's exact mean, not a filtered derivative.
INTERVAL_S = 0.02
#: Smallest residual level [m/s^2 per row] the noise model takes as measured: 0.01 ug, far below
#: any accelerometer. A simulated record without noise leaves residuals of rounding size, whose
#: fitted "noise" would weight its channels 1e10 times over the others.
NOISE_FLOOR_MPS2 = 1e-7
#: Highest AR order of the interval rows' noise model: 8 intervals (160 ms) of memory covers
#: table vibration and the bias's wander inside its window; BIC usually picks fewer.
AR_MAX_ORDER = 8
#: The accelerometer biases are modelled piecewise constant over windows of this length [s].
#: A bias random walk (2 ug/sqrt(h) by default) drifts ~0.7 ug over the paper's plan; one
#: constant per channel would pass that drift into the centripetal estimate (~0.1 mm, 4 sigma).
BIAS_WINDOW_S = 120.0
#: Steps in angular acceleration (a sway or a table's acceleration switched on at once) are left
#: out of a fit with the delay: the delay's lever terms need the angular jerk, a spike at a step,
#: which the gyros' filtered derivative smears over its 25 ms window (a 2 rad/s^2 sway start left
#: in costs 0.24 % of the delay). A step shows as a third difference of the intervals'
#: mean angular acceleration of at least half its size; one under this [rad/s^2] stays in (a step
#: under 0.04 rad/s^2 costs under 2 % of that 0.24 %), and a 1 Hz, 20 deg/s sway's own smooth
#: change of angular acceleration has a third difference of 0.004 rad/s^2, five times below it.
STEP_FLOOR_RAD_S2 = 0.02
#: ... and one within this many robust standard deviations of the record's third differences
#: (the gyros' noise, or a fast motion's own smooth change) is not told from them.
STEP_SIGMAS = 8.0
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
    #: Cramer-Rao bound of every parameter (the order of ``names``): the smallest standard error any
    #: unbiased estimator reaches on these records' motion and measured noise (:func:`joint_fit`)
    bound_sigma: np.ndarray | None = None
    interval_s: float | None = None  #: the increment domain's interval; None: the rates domain
    noise: list = field(default_factory=list)  #: per record, per channel: the noise model fitted
    #: with the delay: the steps in angular acceleration whose neighbourhood the fit left out
    #: (:func:`steps_in_angular_acceleration`), and the time left out [s]
    left_out_steps: int = 0
    left_out_s: float = 0.0

    @property
    def bound_arms(self) -> np.ndarray:
        """The bound of the arms [3, 3] m."""
        assert self.bound_sigma is not None  # joint_fit sets it
        return self.bound_sigma[:9].reshape(3, 3)

    def bias_windows(self, of=None) -> np.ndarray:
        """Standard errors (default) or bounds (``of=self.bound_sigma``) of every bias window [w, 3] m/s^2."""
        values = of
        if of is None:
            assert self.covariance is not None  # joint_fit sets it
            values = np.sqrt(np.diag(self.covariance))
        index = [j for j, name in enumerate(self.names) if name.startswith("bias_")]
        return values[index].reshape(-1, 3)

    @property
    def efficiency(self) -> np.ndarray:
        """Bound over stated standard error, per parameter (1: the bound reached)."""
        assert self.bound_sigma is not None and self.covariance is not None  # joint_fit sets both
        return self.bound_sigma / np.sqrt(np.diag(self.covariance))


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


def interval_samples(rec: Record, interval_s: float | None = INTERVAL_S) -> int:
    """Samples per interval of the increment domain (1, the rates domain, for ``interval_s`` None or 0)."""
    if not interval_s:
        return 1
    dt = float(np.median(np.diff(rec.t)))
    return max(1, int(round(interval_s / dt)))


def mean_angular_acceleration(rec: Record, starts: np.ndarray, stop: int) -> np.ndarray:
    """Mean angular acceleration ``(omega(end) - omega(start)) / T`` [m, 3] rad/s^2 over the intervals
    ``[starts[k], starts[k + 1])`` of samples (the last ends at ``stop``), each sample standing for
    its own period (so an interval's edges lie midway between samples).

    No derivative of the gyros is formed: the interval's tangential term integrates to
    ``delta omega x r`` exactly, whatever the motion does inside it. The edge rates are the means
    of the two samples either side (for increment records, whose samples are interval means, this
    is :func:`sizefx.omegadot.edges_from_increments`' estimate); at a record's ends, the linear
    extrapolation of the first or last two.
    """
    t, w, n = rec.t, rec.omega, rec.t.size
    edges = np.append(starts, stop)
    lo, hi = np.clip(edges - 1, 0, n - 1), np.clip(edges, 0, n - 1)
    t_e, w_e = 0.5 * (t[lo] + t[hi]), 0.5 * (w[lo] + w[hi])
    first, last = edges == 0, edges >= n
    t_e[first], w_e[first] = t[0] - 0.5 * (t[1] - t[0]), w[0] - 0.5 * (w[1] - w[0])
    t_e[last], w_e[last] = t[-1] + 0.5 * (t[-1] - t[-2]), w[-1] + 0.5 * (w[-1] - w[-2])
    return np.diff(w_e, axis=0) / np.diff(t_e)[:, None]


def steps_in_angular_acceleration(rec: Record) -> np.ndarray:
    """Samples [n] bool near a step in angular acceleration, where a fit with the delay leaves its
    rows out (:data:`STEP_FLOOR_RAD_S2`).

    A step shows in the third difference of the intervals' exact mean angular acceleration
    (:func:`mean_angular_acceleration`, :data:`INTERVAL_S`): at least half the step on one of four
    intervals, against ``T^3`` times the third derivative for smooth motion. An interval is flagged
    where that difference on any axis exceeds :data:`STEP_FLOOR_RAD_S2` and :data:`STEP_SIGMAS`
    robust standard deviations of the record's own (the median absolute deviation, so the steps
    themselves do not widen it); the flag covers the four intervals it spans and the filtered
    derivative's reach either side (half its window and the jerk's central difference).
    """
    n = rec.t.size
    block = interval_samples(rec, INTERVAL_S)
    m = n // block
    flagged = np.zeros(n, dtype=bool)
    if m < 8:
        return flagged
    d3 = np.diff(mean_angular_acceleration(rec, np.arange(0, m * block, block), m * block), n=3, axis=0)
    spread = 1.4826 * np.median(np.abs(d3 - np.median(d3, axis=0)), axis=0)
    over = np.any(np.abs(d3) > np.maximum(STEP_FLOOR_RAD_S2, STEP_SIGMAS * spread), axis=1)
    reach = SAVGOL_WINDOW // 2 + 1
    for j in np.flatnonzero(over):  # d3[j] spans intervals j .. j + 3
        flagged[max(0, j * block - reach) : min(n, (j + 4) * block + reach)] = True
    return flagged


def _runs(keep: np.ndarray):
    """``(start, stop)`` of every run of True in ``keep``."""
    edges = np.flatnonzero(np.diff(np.r_[False, keep, False].astype(np.int8)))
    return zip(edges[::2], edges[1::2])


def _design(rec: Record, sl: slice, with_tilt: bool, with_delay: bool, block: int = 1, arms=None, delay_s: float = 0.0):
    """Design rows of each channel i for samples ``sl`` in their active columns only:
    ``[(H_i, y_i)]`` with ``H_i = [r_i (3) | bias_i (1) | tilt (2) | delay (1)]`` and ``y_i`` the reading
    less the prediction at the linearisation point (gravity).

    ``block`` 1 (the rates domain): a row per sample, the angular acceleration the gyros'
    Savitzky-Golay derivative (:attr:`Record.omegadot`). ``block`` > 1 (the increment domain;
    ``sl`` a whole number of blocks): a row per interval of ``block`` samples, the means of the
    readings and of the design over it, with the tangential term's angular acceleration the
    interval's exact mean (:func:`mean_angular_acceleration`) instead of a filtered derivative,
    whose errors (its noise, its response to the table's changes of acceleration) would enter the
    arms as errors in the regressor.

    ``arms`` [3, 3] (with the delay): where the delay's column is formed. The accelerometers read
    the lever terms late too, ``-tau d/dt (omegadot x r + omega x (omega x r))``, a product of the
    delay and the arms: :func:`joint_fit` forms that column at its first estimate of the arms and
    solves again (0.5 ms on 1 Hz sway at 0.1 m from the table's centre is 0.7 mm/s^2, half the
    delay's own signal). ``delay_s``: the delay's second-order term, ``tau^2 / 2 d^2 f / dt^2``
    (gravity's part, ``f'' = -omegadot x f + omega x (omega x f)``), taken off the readings: 1.7 ug
    for 0.5 ms on that sway, a bias of half a sigma on the arms the sway shows best.

    Every other column of the full design (the other channels' arms, the other bias windows)
    is zero on these rows, so the normal equations are accumulated from these few columns
    (see :func:`_columns`): 7 columns a row instead of 9 + 3 * windows + 3.
    """
    motion = motion_of(rec, sl, with_rate=with_delay)
    at = _ZERO if arms is None else SensorParams(lever_arm=np.asarray(arms, dtype=float))
    m = (sl.stop - sl.start) // block
    if block > 1:
        mean_wdot = mean_angular_acceleration(rec, np.arange(sl.start, sl.stop, block), sl.stop)
        motion = replace(motion, omegadot_ib_b=np.repeat(mean_wdot, block, axis=0))
    jac = jacobian(at, motion, effects=_fit_effects(with_tilt, with_delay), sensors=("accel",))
    predicted = accel_readings(_ZERO, accel_inputs(_ZERO, motion))
    arms, bias = param_index("lever_arm"), param_index("accel_bias")
    shared = [j for effect in _fit_effects(with_tilt, with_delay)[2:] for j in param_index(effect)]  # tilt, delay
    if delay_s:
        w, wd, f = motion.omega_ib_b, motion.omegadot_ib_b, motion.f_b
        predicted = predicted + 0.5 * delay_s**2 * (-np.cross(wd, f) + np.cross(w, np.cross(w, f)))
    rows = []
    for i in range(3):
        H, y = jac.block(3 + i, [*arms[3 * i : 3 * i + 3], bias[i], *shared]), rec.accel[sl, i] - predicted[:, i]
        if block > 1:
            H, y = H.reshape(m, block, -1).mean(axis=1), y.reshape(m, block).mean(axis=1)
        rows.append((H, y))
    return rows


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


def _spans(bias_index: np.ndarray, chunk: int, block: int = 1):
    """``(window, slice)`` pieces of at most ``chunk`` samples (rounded to whole blocks), each inside
    one bias window (the windows are contiguous runs of samples, in time order) and a whole number
    of ``block`` samples: the last ``< block`` samples of a window are left out."""
    chunk = max(block, chunk - chunk % block)
    edges = np.flatnonzero(np.diff(bias_index)) + 1
    for s0, s1 in zip(np.r_[0, edges], np.r_[edges, bias_index.size]):
        s1 -= (s1 - s0) % block
        for a in range(s0, s1, chunk):
            yield int(bias_index[s0]), slice(a, min(s1, a + chunk))


def _names(window_labels, with_tilt, with_delay):
    names = list(PARAMS_R) + [f"bias_{a} ({label})" for label in window_labels for a in "xyz"]
    if with_tilt:
        names += ["tilt_north", "tilt_east"]
    if with_delay:
        names += ["accel_delay"]
    return names


def _rows(records, bias_index, with_tilt, with_delay, chunk, interval_s, arms=None, delay_s=0.0, left_out=None):
    """The fit's rows, read once: ``(record, window, [H_i], [y_i])`` per contiguous run of rows in a
    bias window of a record (in time order, :func:`_design`'s columns of channel i).

    ``left_out`` [per record: samples bool] (with the delay: :func:`steps_in_angular_acceleration`):
    a row with any of its samples left out is dropped, and the window's rows split there, so the
    noise model never whitens across the gap."""
    segments = []
    for k, rec in enumerate(records):
        block = interval_samples(rec, interval_s)
        pieces: dict = {}
        for window, sl in _spans(bias_index[k], chunk, block):
            keep = (
                np.ones((sl.stop - sl.start) // block, dtype=bool)
                if left_out is None
                else ~left_out[k][sl].reshape(-1, block).any(axis=1)
            )
            pieces.setdefault(window, []).append((_design(rec, sl, with_tilt, with_delay, block, arms, delay_s), keep))
        for window, parts in pieces.items():
            Hs = [np.concatenate([design[i][0] for design, _ in parts]) for i in range(3)]
            ys = [np.concatenate([design[i][1] for design, _ in parts]) for i in range(3)]
            for a, b in _runs(np.concatenate([keep for _, keep in parts])):
                segments.append((k, window, [H[a:b] for H in Hs], [y[a:b] for y in ys]))
    return segments


def _residual_autocovariance(segments, x, max_lag, n_records, n_bias, with_tilt, with_delay):
    """Autocovariances [record][channel] of the rows' residuals at ``x``, pooled over each record's windows."""
    acov = [[Autocovariance(max_lag) for _ in range(3)] for _ in range(n_records)]
    for k, window, Hs, ys in segments:
        for i in range(3):
            acov[k][i].add(ys[i] - Hs[i] @ x[_columns(i, window, n_bias, with_tilt, with_delay)])
    return acov


def _residual_series(segments, x, n_records, n_bias, with_tilt, with_delay):
    """The rows' residuals at ``x`` [record][channel]: one series per segment (a bias window's run)."""
    out: list = [[[] for _ in range(3)] for _ in range(n_records)]
    for k, window, Hs, ys in segments:
        for i in range(3):
            out[k][i].append(ys[i] - Hs[i] @ x[_columns(i, window, n_bias, with_tilt, with_delay)])
    return out


#: The state model's walk and Gauss-Markov part are kept when they raise the likelihood of the
#: residuals over white noise by this much (twice the log-likelihood ratio): the 1 % point of a
#: chi-square with two degrees of freedom (the two variances; their correlation time comes with
#: them). Kept always, a walk found in white noise by chance made the errors of a short white-noise
#: plan up to 21 % wider than the plan predicts (tests/test_plan.py).
STATE_LR_THRESHOLD = 9.21


def _noise_model(series) -> ChainedNoise:
    """The residuals' noise model: a random walk, a first-order Gauss-Markov process and white noise
    (:func:`sizefx.noise_model.fit_state`), then an AR process (order by BIC up to
    :data:`AR_MAX_ORDER`) of what that model leaves, which also sets the innovations' scale.

    Every accelerometer has a bias random walk, and its power lies below any AR order's reach: an AR
    model alone prewhitened it as white noise, and its drift within a bias window passed into the
    arms with standard errors that did not know it (on validate_calibrate's development range, z RMS
    up to 1.54 and an efficiency of 0.64 against the bound for the true noise); so did choosing
    between the two models by BIC, which took the walk for white noise where it was small against
    the white noise per row and still large against the arms."""
    state = fit_state(series)
    floor = NOISE_FLOOR_MPS2**2
    if not state.r >= floor:  # residuals of rounding size (a simulation without noise)
        return ChainedNoise(StateNoise(0.0, 0.0, 0.0, floor), ARNoise(np.zeros(0), 1.0, 1.0))
    white = StateNoise(0.0, 0.0, 0.0, state.variance())
    ll_white = state_log_likelihood(series, white)
    if 2.0 * (state.log_likelihood - ll_white) < STATE_LR_THRESHOLD:
        state = white  # no walk nor Gauss-Markov part beyond chance
    acov = Autocovariance(AR_MAX_ORDER)
    for e in series:
        if e.size:
            acov.add(state.whiten(e))
    return ChainedNoise(state, _floored(fit_ar(acov)))


def _floored(model: ARNoise) -> ARNoise:
    """The noise model, or white noise at :data:`NOISE_FLOOR_MPS2` when the residuals are below it."""
    floor = NOISE_FLOOR_MPS2**2
    return model if model.innovation_var >= floor else ARNoise(np.zeros(0), floor, floor)


def _normal_equations(segments, noise, p, n_bias, with_tilt, with_delay):
    """``N = sum H~' H~ / s2``, ``b = sum H~' y~ / s2`` with ``~`` the rows whitened by each record's
    and channel's noise model (:class:`~sizefx.noise_model.ARNoise`, innovation variance s2)."""
    N = np.zeros((p, p))
    b = np.zeros(p)
    for k, window, Hs, ys in segments:
        for i in range(3):
            model = noise[k][i]
            H, y = model.whiten(Hs[i]), model.whiten(ys[i])
            cols = _columns(i, window, n_bias, with_tilt, with_delay)
            N[np.ix_(cols, cols)] += H.T @ H / model.innovation_var
            b[cols] += H.T @ y / model.innovation_var
    return N, b


def unobservable(N, names) -> tuple[np.ndarray, list]:
    """``(eigenvalues of the column-scaled N, names of the parameters it leaves unobservable)``:
    those with no information, and those in a direction determined :data:`UNOBSERVABLE_EIG` times
    worse than the best (components above 0.3 of it)."""
    scale = 1.0 / np.sqrt(np.where(np.diag(N) > 0, np.diag(N), 1.0))
    eigval, eigvec = np.linalg.eigh(N * np.outer(scale, scale))
    weak = eigval < UNOBSERVABLE_EIG * eigval.max()
    bad = set(np.flatnonzero(np.diag(N) == 0))
    for v in eigvec[:, weak].T:
        bad |= set(np.flatnonzero(np.abs(v) > 0.3))
    return eigval, [names[j] for j in sorted(bad)]


def _check_observable(N, names, with_delay):
    """Refuse a normal matrix with directions the motion does not reveal, naming the parameters in them.
    Returns the eigenvalues of the column-scaled matrix (for the condition number)."""
    eigval, bad = unobservable(N, names)
    if bad:
        raise CalibrationError(
            f"the rotations in the record(s) leave unobservable: {', '.join(bad)}; "
            "record rotations about at least two body axes (the paper rotates about Y, X "
            "and Z in turn)" + (", and about horizontal axes for the delay" if with_delay else "")
        )
    return eigval


def _solve(N, b):
    scale = 1.0 / np.sqrt(np.diag(N))
    return scale * np.linalg.solve(N * np.outer(scale, scale), scale * b)


def _residual_rms(records, bias_index, x, n_bias, with_tilt, with_delay, chunk, steps):
    """RMS of every sample's residual per channel [3] (the rates domain's design at ``x``): the
    accelerometers' noise as the report states it, whatever the fit's domain. The samples near a
    step in angular acceleration (``steps``, :func:`steps_in_angular_acceleration`) are left out:
    there the gyros' filtered derivative, not the accelerometers, makes the residual (on noiseless
    records of a turntable and two sways switched on at rest, 39 ug with them, 3.6 ug without; the
    rest is the derivative's own error on smooth motion, ~0.1 % of the tangential term)."""
    ss, count = np.zeros(3), np.zeros(3)
    arms, delay_s = (x[:9].reshape(3, 3), float(x[-1])) if with_delay else (None, 0.0)
    for k, rec in enumerate(records):
        for window, sl in _spans(bias_index[k], chunk):
            keep = ~steps[k][sl]
            for i, (H, y) in enumerate(_design(rec, sl, with_tilt, with_delay, 1, arms, delay_s)):
                r = (y - H @ x[_columns(i, window, n_bias, with_tilt, with_delay)])[keep]
                ss[i] += r @ r
                count[i] += r.size
    with np.errstate(invalid="ignore"):  # NaN where every sample was near a step: nothing to state
        return np.sqrt(ss / count)


#: The bound's noise model: an AR process of up to this order (64 intervals, 1.3 s at 20 ms),
#: chosen by AIC: a sieve for the residuals' spectrum, which follows colour that the fit's own
#: model (:data:`AR_MAX_ORDER`, BIC) leaves out. (A fixed order would not do: on white noise its
#: 64 spurious coefficients move the spectrum at the motion's frequencies by ~10 %.)
BOUND_AR_ORDER = 64


def cramer_rao_fisher(segments, x, p, n_bias, with_tilt, with_delay, n_records) -> np.ndarray:
    """The Fisher information [p, p] of the parameters on these rows (:func:`_rows`), the noise of
    each record's channel Gaussian with the spectrum measured on the residuals at ``x`` (an AR
    sieve, :data:`BOUND_AR_ORDER`). Its inverse is the Cramer-Rao bound of any unbiased estimator
    from these rows; on white noise it is ``H'H / s2``. The rows are interval means: what the
    averaging itself gives up is not in it (on the paper's plan the rates domain's standard errors,
    from every sample, are within 1 % of the increment domain's; benchmarks/accuracy_calibrate.py)."""
    acov = _residual_autocovariance(segments, x, BOUND_AR_ORDER, n_records, n_bias, with_tilt, with_delay)
    noise = [[_floored(fit_ar(a, criterion="aic")) for a in per_record] for per_record in acov]
    return _normal_equations(segments, noise, p, n_bias, with_tilt, with_delay)[0]


def _layout(records, bias_window_s, with_tilt, with_delay):
    """The parameter vector's layout: each sample's bias window (numbered across the records), their
    count, and the parameters' names (the arms, the bias windows, the tilt, the delay)."""
    bias_index, labels, first = [], [], 0
    for rec in records:
        idx, n = _windows(rec, bias_window_s)
        bias_index.append(idx + first)
        labels += [f"{Path(rec.name).name} window {j}" for j in range(n)]
        first += n
    return bias_index, first, _names(labels, with_tilt, with_delay)


def information(
    records: list[Record],
    density_mps2_per_sqrt_hz: float,
    *,
    with_tilt: bool = True,
    with_delay: bool = False,
    bias_window_s: float | None = BIAS_WINDOW_S,
    chunk: int = 1 << 16,
    markov_density_mps2_per_sqrt_hz: float = 0.0,
    markov_correlation_s: float = 1.0,
    bias_rw_mps2_per_sqrt_s: float = 0.0,
) -> tuple[list, np.ndarray]:
    """``(names, Fisher information)`` of the joint fit's parameters on these records' motion, the
    accelerometers' noise white with this density (per sample ``density^2 * rate``): what a
    calibration on them can reach, before any is recorded (:mod:`sizefx.plan`). The rows are the
    rates domain's, so the records' ``omegadot`` should be the true one (a plan's motion).

    With a first-order Gauss-Markov part (its density below the corner and its correlation time, as
    :mod:`sizefx.simulate` draws it: stationary variance ``density^2 / (2 T)``) or a bias random walk,
    the information is that of the rows whitened by the exact model of that noise
    (:class:`sizefx.noise_model.StateNoise`, the walk restarting with each bias window)."""
    bias_index, n_bias, names = _layout(records, bias_window_s, with_tilt, with_delay)
    segments = _rows(records, bias_index, with_tilt, with_delay, chunk, None)
    noise: list[list] = []
    for rec in records:
        dt = float(np.median(np.diff(rec.t)))
        var = density_mps2_per_sqrt_hz**2 / dt
        if markov_density_mps2_per_sqrt_hz > 0 or bias_rw_mps2_per_sqrt_s > 0:
            phi = float(np.exp(-dt / markov_correlation_s)) if markov_density_mps2_per_sqrt_hz > 0 else 0.0
            stationary = markov_density_mps2_per_sqrt_hz**2 / (2.0 * markov_correlation_s)
            model = StateNoise(bias_rw_mps2_per_sqrt_s**2 * dt, phi, stationary * (1.0 - phi**2), var)
            noise.append([model] * 3)
        else:
            noise.append([ARNoise(np.zeros(0), var, var)] * 3)
    return names, _normal_equations(segments, noise, len(names), n_bias, with_tilt, with_delay)[0]


def joint_fit(
    records: list[Record],
    *,
    with_tilt: bool = True,
    with_delay: bool = False,
    bias_window_s: float | None = BIAS_WINDOW_S,
    interval_s: float | None = INTERVAL_S,
    chunk: int = 1 << 16,
) -> CalibrationResult:
    """Generalised least squares over the intervals (or samples) of all records, the noise of each
    record and channel an AR process fitted to the residuals; with the Cramer-Rao bound.

    - ``interval_s``: the increment domain's interval (:func:`_design`); None fits every sample with
      the gyros' filtered derivative (the rates domain: kept to compare; it holds every sample's
      rows in memory, about 200 bytes a sample).
    - Biases are piecewise constant over ``bias_window_s`` windows of each record (None: one per record).
    - With the delay, the rows near a step in angular acceleration are left out
      (:func:`steps_in_angular_acceleration`; counted in the result).
    - Three solves: ordinary least squares; then twice the noise model fitted to the residuals
      (order by BIC up to :data:`AR_MAX_ORDER`) and the prewhitened least squares, whose inverse
      normal matrix is the covariance (:mod:`sizefx.noise_model`).
    - The bound (:attr:`CalibrationResult.bound_sigma`): the inverse Fisher information of the same
      parameters on the same rows, the noise's spectrum measured on the residuals
      (:func:`cramer_rao_fisher`).
    """
    n_rec = len(records)
    bias_index, n_bias, names = _layout(records, bias_window_s, with_tilt, with_delay)
    p = len(names)
    # a record (or a segment between gaps) at rest adds to the biases and the tilt; only a fit in
    # which nothing rotates has nothing to say about the arms
    if not any(np.any(np.linalg.norm(rec.omega, axis=1) > ROTATING_RAD_S) for rec in records):
        listed = ", ".join(rec.name for rec in records)
        raise CalibrationError(
            f"{listed}: the record never rotates (|omega| stays under 1 deg/s); "
            "no lever arm is observable: record rotations about at least two body axes"
        )
    steps = [steps_in_angular_acceleration(rec) for rec in records]
    left_out = steps if with_delay else None
    segments = _rows(records, bias_index, with_tilt, with_delay, chunk, interval_s, left_out=left_out)
    noise: list[list] = [[WHITE] * 3 for _ in records]
    for step in range(3):
        N, b = _normal_equations(segments, noise, p, n_bias, with_tilt, with_delay)
        eigval = _check_observable(N, names, with_delay)
        x = _solve(N, b)
        if step == 2:
            break
        if step == 0 and with_delay:  # the delay's column with the lever terms, at the first arms and delay
            segments = _rows(
                records,
                bias_index,
                with_tilt,
                with_delay,
                chunk,
                interval_s,
                x[:9].reshape(3, 3),
                float(x[-1]),
                left_out,
            )
        series = _residual_series(segments, x, n_rec, n_bias, with_tilt, with_delay)
        noise = [[_noise_model(e) for e in series[k]] for k in range(n_rec)]
    cov = np.linalg.inv(N)  # weights are the whitened rows' 1 / s2: the inverse is the covariance
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
        listed = ", ".join(
            f"{names[j]} (sigma {sig[j] * (1e3 if j < 9 else 1):.3g}{' mm' if j < 9 else ''})" for j in loose
        )
        raise CalibrationError(
            f"the rotations in the record(s) leave unobservable: {listed}; record rotations "
            "about at least two body axes (the paper rotates about Y, X and Z in turn)"
            + (", and about horizontal axes for the delay" if with_delay else "")
        )
    bound = np.sqrt(np.diag(np.linalg.inv(cramer_rao_fisher(segments, x, p, n_bias, with_tilt, with_delay, n_rec))))
    residual_rms = _residual_rms(records, bias_index, x, n_bias, with_tilt, with_delay, chunk, steps)
    c = 9 + 3 * n_bias
    windows = x[9:c].reshape(n_bias, 3)
    per_record = np.array([windows[np.unique(bias_index[k])].mean(axis=0) for k in range(n_rec)])
    return CalibrationResult(
        arms=x[:9].reshape(3, 3),
        sigma_arms=sig[:9].reshape(3, 3),
        biases=per_record,
        tilt_rad=x[c : c + 2] if with_tilt else None,
        sigma_tilt_rad=sig[c : c + 2] if with_tilt else None,
        delay_s=float(x[-1]) if with_delay else None,
        sigma_delay_s=float(sig[-1]) if with_delay else None,
        condition=float(eigval.max() / eigval.min()),
        residual_rms=residual_rms,
        samples=int(sum(r.t.size for r in records)),
        names=names,
        covariance=cov,
        bound_sigma=bound,
        interval_s=interval_s or None,
        left_out_steps=sum(sum(1 for _ in _runs(mask)) for mask in left_out) if left_out else 0,
        left_out_s=float(sum(mask.sum() * np.median(np.diff(rec.t)) for mask, rec in zip(left_out, records)))
        if left_out
        else 0.0,
        noise=[
            {"record": rec.name, "channels": [_noise_summary(noise[k][i]) for i in range(3)]}
            for k, rec in enumerate(records)
        ],
    )


def _noise_summary(model) -> dict:
    """What the fit took the noise of one record's channel to be (at the rows' rate), for the report
    and the JSON: the state model's walk, Gauss-Markov part and white noise (per row, SI), the AR
    model of what they leave (its order and coefficients), and how much the colour changes the
    variance of a long mean (1: as white; the walk, which grows without bound, apart)."""
    out = {"ar_order": model.order, "ar_coefficients": [], "long_run_variance_ratio": float(model.variance_ratio())}
    if isinstance(model, ChainedNoise):
        state = model.state
        out.update(
            ar_coefficients=model.ar.a.tolist(),
            random_walk_var_per_row=state.q_rw,
            markov_phi=state.phi,
            markov_var=state.s_gm / (1.0 - state.phi**2) if state.phi < 1.0 else 0.0,
            white_var=state.r,
        )
    elif isinstance(model, ARNoise):
        out["ar_coefficients"] = model.a.tolist()
    return out
