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

The rows, their layout and the increment domain are :mod:`.design`'s; the noise model, the
whitened normal equations and the bound :mod:`.noise`'s; here the fit, its observability checks
and :func:`information`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..constants import ARCSEC
from ..noise_model import WHITE, ARNoise, StateNoise
from .design import (
    FIT_EFFECTS,
    INTERVAL_S,
    PARAMS_R,
    STEP_FLOOR_RAD_S2,
    STEP_SIGMAS,
    _columns,
    _design,
    _layout,
    _rows,
    _runs,
    _spans,
    interval_samples,
    mean_angular_acceleration,
    steps_in_angular_acceleration,
)

# the noise model's settings stay importable from here (BOUND_AR_ORDER, NOISE_FLOOR_MPS2, STATE_LR_THRESHOLD)
from .noise import (  # noqa: F401
    AR_MAX_ORDER,
    BOUND_AR_ORDER,
    NOISE_FLOOR_MPS2,
    STATE_LR_THRESHOLD,
    _noise_model,
    _noise_summary,
    _normal_equations,
    _residual_series,
    cramer_rao_fisher,
)
from .records import ROTATING_RAD_S, CalibrationError, Record

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
#: The accelerometer biases are modelled piecewise constant over windows of this length [s].
#: A bias random walk (2 ug/sqrt(h) by default) drifts ~0.7 ug over the paper's plan; one
#: constant per channel would pass that drift into the centripetal estimate (~0.1 mm, 4 sigma).
BIAS_WINDOW_S = 120.0
#: Standard errors beyond which a parameter counts as not determined. Column scaling makes a
#: parameter seen only through Earth rate look well conditioned, so the check is in physical
#: units: arms are known to ~0.02-0.05 mm from a proper plan; 1 mm is no calibration.
UNDETERMINED_SIGMA = {"arm_m": 1e-3, "tilt_rad": 60 * ARCSEC, "delay_s": 1e-3}


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
