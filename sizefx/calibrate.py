"""Lever-arm calibration on a turntable (or any record with reference attitude): ``sizefx calibrate``.

Measurement model of accelerometer channel i at time t:

    a_i = u_i . [ f_grav + omegadot x r_i + omega x (omega x r_i) ] + b_i
          + tilt_i(phi_N, phi_E) + tau (omega x f_grav)_i + noise

- ``f_grav = C_bn (-g_n)``: normal gravity, projected with the reference attitude.
- ``tilt``: the true attitude is R(phi) C_ref. To first order this adds
  ``C_bn (g phi_E, -g phi_N, 0)``.
- ``tau``: the accelerometers read the specific force tau seconds late; to first order
  ``-tau d/dt f_grav = tau omega x f_grav``.

Unknowns: the nine components of r_x, r_y, r_z; a bias per channel and record; the tilt;
optionally tau. Two estimators:

* :func:`per_rotation_fit`: the paper's per-rotation least squares,
  ``H = [1, omega^2, omegadot]`` for each rotation block and horizontal channel
  (Morozov & Bogdanov 2024, section "Calibration"). It ignores the tilt, which
  therefore biases it.
* :func:`joint_fit`: one weighted least squares over every sample of every record,
  with standard errors, the condition number, residual RMS per channel, and an
  explicit observability check: parameters the motion cannot reveal are named
  instead of inverting a singular matrix.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import earth
from .compensate import sync_accelerometers
from .constants import ARCSEC, DEG
from .errors import SizefxError
from .geometry import triad_point
from .io.files import atomic_output, check_outputs
from .levers import Levers, levers_from_preset, read_levers, write_levers
from .omegadot import SAVGOL_WINDOW, savgol
from .rotation import quat_interp, quat_spline, quat_to_mat
from .io.telemetry import Telemetry, read_telemetry

__all__ = ["CalibrationError", "Record", "prepare", "per_rotation_fit", "joint_fit",
           "detect_rotations", "CalibrationResult", "Excitation", "excitation", "preflight", "run"]

#: Fewest samples a record may have: the Savitzky-Golay angular-acceleration window, with room.
MIN_SAMPLES = 4 * 41
#: A sample rotates when |omega| exceeds this [rad/s] (1 deg/s: far above Earth rate and noise).
ROTATING_RAD_S = 1.0 * DEG
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


class CalibrationError(SizefxError):
    """The records cannot give what was asked (no rotation, unobservable components)."""


@dataclass
class Record:
    """What the fits need from one file, per IMU sample (rates domain)."""

    name: str
    t: np.ndarray  #: [N] s
    accel: np.ndarray  #: [N, 3] m/s^2
    omega: np.ndarray  #: [N, 3] rad/s (gyros)
    omegadot: np.ndarray  #: [N, 3] rad/s^2 (Savitzky-Golay, centred)
    mat_nb: np.ndarray  #: [N, 3, 3] reference attitude
    g_down: float  #: normal gravity at the site [m/s^2]

    @property
    def f_grav(self):
        """C_bn (-g_n) [N, 3]: gravity's specific force in body axes."""
        return -self.g_down * self.mat_nb[:, 2, :]


def _require_reference_site_samples(path, reference, site, n_samples: int):
    """What a record must hold to be calibrated: /reference attitude, a site (or reference
    position) for normal gravity, and enough samples; a one-line refusal otherwise."""
    if reference is None:
        raise CalibrationError(f"{path}: calibration needs /reference attitude (what the table reports); "
                               "this record has none (sizefx inspect shows what it holds)")
    if site is None and not reference.has_position:
        raise CalibrationError(f"{path}: no site: normal gravity needs latitude and height; add the root "
                               "attributes latitude_deg, longitude_deg, height_m (sizefx import --site-deg)")
    if n_samples < MIN_SAMPLES:
        raise CalibrationError(f"{path}: {n_samples} samples; calibration needs at least {MIN_SAMPLES}")


def prepare(tel: Telemetry, name: str = "") -> Record:
    """Rates, angular acceleration and reference attitude on the IMU samples of a record."""
    _require_reference_site_samples(tel.path, tel.reference, tel.site, tel.n_samples)
    tel = sync_accelerometers(tel)  # on the gyro time base before any conversion
    dt = tel.sample_period_s
    if tel.form == "rates":
        t, omega, accel = tel.time_s, tel.gyro_rad_s, tel.accel_mps2
    else:  # increments -> mean rates over each interval, stamped at its midpoint
        t, omega, accel = tel.time_s - 0.5 * dt, tel.dtheta_rad / dt, tel.dvel_mps / dt
    mat_nb = quat_to_mat(reference_attitude(tel.reference.time_s, tel.reference.quat_nb, t))
    lat, h = (tel.site.lat_rad, tel.site.height_m) if tel.site is not None else (
        tel.reference.lat_rad[0], tel.reference.height_m[0])
    return Record(name or str(tel.path), t, accel, omega, savgol(omega, dt), mat_nb,
                  float(earth.gravity_n(lat, h)[2]))


#: A reference whose median step exceeds this many IMU steps is interpolated by a C2 rotation
#: spline instead of slerp (:func:`sizefx.rotation.quat_spline`): gravity's direction between
#: two reference samples must be known to the accelerometer noise, and slerp's error grows with
#: the square of the reference step (0.08 mm of arm bias with a 100 Hz reference on a 1 Hz sway).
#: At the IMU rate slerp is exact at the samples and costs a tenth of the spline.
SPLINE_REFERENCE_STEPS = 1.5


def reference_attitude(t_ref, quat_ref, t):
    """Reference attitude ``q_nb`` at the IMU times ``t`` [N, 4]: a rotation spline when the
    reference is slower than the IMU (:data:`SPLINE_REFERENCE_STEPS`), slerp otherwise."""
    step_ref = float(np.median(np.diff(t_ref)))
    step_imu = float(np.median(np.diff(t))) if len(t) > 1 else step_ref
    if len(t_ref) >= 4 and step_ref > SPLINE_REFERENCE_STEPS * step_imu:
        return quat_spline(t_ref, quat_ref, t)
    return quat_interp(t_ref, quat_ref, t)


# --------------------------------------------------------------------------- the paper's per-rotation fit


#: A body axis counts as vertical within this angle of the down direction in the reported
#: attitude (36 arcsec: the table reports the axis vertical during a block; within 1 deg,
#: gravity would already leak 17 000 ug into a "horizontal" channel at the block's edge).
VERTICAL_WITHIN_RAD = 0.01 * DEG


def detect_rotations(rec: Record, min_s: float = 5.0):
    """Blocks ``[(axis, i0, i1)]`` in which body axis ``axis`` stays vertical and the table turns about it.

    Segmenting by the reference attitude, not by the gyros, keeps repositioning
    (where gravity sweeps through every channel) out of the blocks.
    """
    down = np.abs(rec.mat_nb[:, 2, :])  # |cosine| between each body axis and the vertical
    axis = np.argmax(down, axis=1)
    vertical = down[np.arange(axis.size), axis] > np.cos(VERTICAL_WITHIN_RAD)
    label = np.where(vertical, axis, -1)
    dt = float(np.median(np.diff(rec.t)))
    blocks = []
    edges = np.flatnonzero(np.diff(label) != 0) + 1
    for i0, i1 in zip(np.r_[0, edges], np.r_[edges, label.size]):
        a = label[i0]
        if a < 0:
            continue
        turning = np.abs(rec.omega[i0:i1, a]) > ROTATING_RAD_S
        if turning.sum() * dt >= min_s:
            blocks.append((int(a), int(i0), int(i1)))
    return blocks


def per_rotation_fit(rec: Record):
    """The paper's fit: per block and horizontal channel, ``a_i = b + c2 omega_a^2 + c3 omegadot_a``.

    A block is a stretch in which body axis ``a`` is vertical (static lead-in and
    dwell included) and the table turns about it.

    Returns a list of dicts with the block, channel, the coefficients and the lever-arm
    components they stand for: ``c2 = -r_i[i]`` (centripetal), ``c3 = eps(i, a, j) r_i[j]``
    (tangential, j the third axis), as rigid-body kinematics gives them.
    """
    out = []
    for a, i0, i1 in detect_rotations(rec):
        wa = rec.omega[i0:i1, a]
        H = np.column_stack([np.ones(i1 - i0), wa**2, rec.omegadot[i0:i1, a]])
        for i in range(3):
            if i == a:
                continue
            j = 3 - a - i
            eps = np.sign(np.linalg.det(np.eye(3)[[i, a, j]]))  # Levi-Civita symbol eps(i, a, j)
            coef, *_ = np.linalg.lstsq(H, rec.accel[i0:i1, i], rcond=None)
            resid = rec.accel[i0:i1, i] - H @ coef
            cov = np.linalg.inv(H.T @ H) * resid.var()
            out.append({"axis": "xyz"[a], "channel": "xyz"[i], "t0": float(rec.t[i0]), "t1": float(rec.t[i1 - 1]),
                        "bias": float(coef[0]), "r_own": float(-coef[1]), "r_other": float(eps * coef[2]),
                        "other_component": "xyz"[j],
                        "sigma_r_own": float(np.sqrt(cov[1, 1])), "sigma_r_other": float(np.sqrt(cov[2, 2]))})
    return out


# --------------------------------------------------------------------------- the joint fit


@dataclass
class CalibrationResult:
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


def _arm_regressors(omega, omegadot, i: int):
    """``[n, 3]``: accelerometer i's reading per metre of each component of r_i,
    ``u_i . (omegadot x r_i + omega x (omega x r_i))`` = ``(e_i x omegadot + omega omega_i - |omega|^2 e_i) . r_i``."""
    e = np.zeros(3)
    e[i] = 1.0
    return np.cross(e, omegadot) + omega * omega[:, i:i + 1] - np.sum(omega * omega, axis=1, keepdims=True) * e


def _rows(rec: Record, i: int, sl: slice, with_tilt: bool, with_delay: bool):
    """Design rows of channel i for samples ``sl`` in their active columns only:
    ``[r_i (3) | bias_i (1) | tilt (2) | delay (1)]``, and the target.

    Every other column of the full design (the other channels' arms, the other bias windows)
    is zero on these rows, so the normal equations are accumulated from these few columns
    (see :func:`_columns`): 7 columns a row instead of 9 + 3 * windows + 3.
    """
    w, wd, mat = rec.omega[sl], rec.omegadot[sl], rec.mat_nb[sl]
    n = w.shape[0]
    H = np.zeros((n, 4 + (2 if with_tilt else 0) + (1 if with_delay else 0)))
    H[:, 0:3] = _arm_regressors(w, wd, i)
    H[:, 3] = 1.0
    c = 4
    if with_tilt:
        H[:, c] = -rec.g_down * mat[:, 1, i]  # phi_N
        H[:, c + 1] = rec.g_down * mat[:, 0, i]  # phi_E
        c += 2
    if with_delay:
        fg = -rec.g_down * mat[:, 2, :]
        H[:, c] = np.cross(w, fg)[:, i]
    y = rec.accel[sl, i] + rec.g_down * mat[:, 2, i]  # minus the known gravity term
    return H, y


def _columns(i: int, window: int, n_bias: int, with_tilt: bool, with_delay: bool) -> np.ndarray:
    """Indices in the full parameter vector of :func:`_rows`' columns for channel i, bias window ``window``."""
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
                for i in range(3):
                    H, y = _rows(rec, i, sl, with_tilt, with_delay)
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
                for i in range(3):
                    H, y = _rows(rec, i, sl, with_tilt, with_delay)
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


# --------------------------------------------------------------------------- pre-flight

#: IMU rows the pre-flight pass reads at a time (plus the Savitzky-Golay half window each side).
PREFLIGHT_ROWS = 1 << 18


@dataclass
class Excitation:
    """What the motion of one record can reveal about the lever arms: one streamed pass over its
    IMU rows, before any fit (:func:`excitation`)."""

    path: str
    samples: int
    duration_s: float
    rms_rate_rad_s: np.ndarray  #: [3] per body axis
    rms_angular_acceleration_rad_s2: np.ndarray  #: [3] per body axis
    rotating_s: float  #: time with |omega| above ROTATING_RAD_S
    #: [3, 3, 3] per accelerometer channel i: sum over samples of h h^T, h = d(reading_i)/d(r_i)
    #: [1/s^2], each bias window's mean removed (the biases absorb it); [1/s^4]
    arm_information: np.ndarray
    noise_mps2: np.ndarray  #: [3] per-sample accelerometer noise of the quietest chunk (white-noise estimate)


def _noise_floor(accel: np.ndarray) -> np.ndarray:
    """Per-sample white noise [3] of a chunk from its second differences (robust: MAD):
    smooth motion contributes the signal's second derivative times dt^2, far below the noise."""
    d2 = accel[2:] - 2.0 * accel[1:-1] + accel[:-2]
    mad = np.median(np.abs(d2 - np.median(d2, axis=0)), axis=0)
    return 1.4826 * mad / np.sqrt(6.0)  # var(d2) = 6 sigma^2 for white noise


def excitation(path, *, allow_gaps: bool = False, bias_window_s: float = BIAS_WINDOW_S,
               n_segments: int | None = None) -> Excitation:
    """One streamed pass over the IMU rows of ``path``: rates and angular accelerations per body
    axis, and the information the motion carries about each lever arm.

    The information is that of :func:`joint_fit`'s arm columns with the bias windows projected
    out, but not the tilt and the delay: an optimistic bound. A record with IMU gaps is read one
    continuous segment at a time, as the fit takes it. A component that even this bound
    cannot determine is certainly not determined by the fit, so :func:`preflight` can refuse it
    in seconds instead of after the fit (issue 13: 526 s on a flight record).
    """
    from .io.telemetry import TelemetryStream

    half = SAVGOL_WINDOW // 2
    if n_segments is None:  # preflight passes it from the open it checks the record with
        with TelemetryStream(path, allow_gaps=allow_gaps) as st:
            n_segments = st.n_segments
    sum_w2, sum_wd2 = np.zeros(3), np.zeros(3)
    rotating = n_total = 0
    noise = np.full(3, np.inf)
    info = np.zeros((3, 3, 3))
    win_sum, win_outer, win_n, window = np.zeros((3, 3)), np.zeros((3, 3, 3)), 0, 0
    t_first = t_last = None
    dt = None

    def close_window():
        nonlocal win_sum, win_outer, win_n
        if win_n:
            info[:] += win_outer - np.einsum("ia,ib->iab", win_sum, win_sum) / win_n
        win_sum, win_outer, win_n = np.zeros((3, 3)), np.zeros((3, 3, 3)), 0

    # each continuous segment on its own: the angular acceleration is not estimated across a gap
    for number in (range(1, n_segments + 1) if n_segments > 1 else [None]):
        with TelemetryStream(path, allow_gaps=allow_gaps, segment=number) as st:
            n, dt = st.n_samples, st.sample_period_s
            if n < MIN_SAMPLES:
                continue  # as the fit: too short for its angular acceleration
            for k0 in range(0, n, PREFLIGHT_ROWS):
                k1 = min(n, k0 + PREFLIGHT_ROWS)
                a0, a1 = max(0, k0 - half), min(n, k1 + half)
                t, g, a, _ = st.read(a0, a1)
                if st.form == "increments":
                    t, g, a = t - 0.5 * dt, g / dt, a / dt
                wd = savgol(g, dt)
                inner = slice(k0 - a0, k0 - a0 + (k1 - k0))
                t, w, wd, acc = t[inner], g[inner], wd[inner], a[inner]
                if t_first is None:
                    t_first = float(t[0])
                t_last = float(t[-1])
                n_total += t.size
                sum_w2 += np.sum(w * w, axis=0)
                sum_wd2 += np.sum(wd * wd, axis=0)
                rotating += int(np.count_nonzero(np.linalg.norm(w, axis=1) > ROTATING_RAD_S))
                if acc.shape[0] > 16:
                    noise = np.minimum(noise, _noise_floor(acc))
                h = np.stack([_arm_regressors(w, wd, i) for i in range(3)])  # [3, n, 3]
                wid = (np.floor((t - t_first) / bias_window_s).astype(int) if bias_window_s
                       else np.zeros(t.size, int))
                for w_id in np.unique(wid):
                    if w_id != window:
                        close_window()
                        window = int(w_id)
                    sel = wid == w_id
                    hs = h[:, sel, :]
                    win_sum += hs.sum(axis=1)
                    win_outer += np.einsum("ina,inb->iab", hs, hs)
                    win_n += int(sel.sum())
    close_window()
    if n_total == 0:
        raise CalibrationError(f"{path}: no continuous segment holds {MIN_SAMPLES} samples; calibration needs "
                               "that many between gaps")
    n = n_total
    return Excitation(str(path), n, t_last - t_first, np.sqrt(sum_w2 / n), np.sqrt(sum_wd2 / n),
                      rotating * dt, info, noise)


def _describe_motion(exc: list[Excitation]) -> str:
    """'it turns about body z (RMS 8.1 deg/s; x 0.02, y 0.03)' for the records together."""
    n = sum(e.samples for e in exc)
    rms = np.sqrt(sum(e.rms_rate_rad_s**2 * e.samples for e in exc) / max(n, 1)) / DEG
    order = np.argsort(rms)[::-1]
    return "RMS rate about body " + ", ".join(f"{'xyz'[j]} {rms[j]:.3g}" for j in order) + " deg/s"


def preflight(paths, *, with_delay: bool = False, allow_gaps: bool = False) -> list[Excitation]:
    """Everything that can refuse a calibration before the fit, cheapest first.

    1. Each record has ``/reference`` (the attitude the table reports) and a site (normal
       gravity): read from the file's structure, no IMU rows.
    2. The motion excites the lever arms: one streamed pass (:func:`excitation`); a record that
       never rotates, or a component that even the optimistic information bound leaves
       undetermined (weak direction, or sigma above :data:`UNDETERMINED_SIGMA`), is named with
       the rotation each axis saw.
    """
    from .io.telemetry import TelemetryStream

    segments = []
    for path in paths:  # every record's structure first: the cheapest refusals before any pass
        with TelemetryStream(path, allow_gaps=allow_gaps) as st:
            _require_reference_site_samples(path, st.reference, st.site, st.n_samples)
            segments.append(st.n_segments)
    exc = [excitation(p, allow_gaps=allow_gaps, n_segments=k) for p, k in zip(paths, segments)]
    if all(e.rotating_s == 0.0 for e in exc):
        names = ", ".join(e.path for e in exc)
        raise CalibrationError(f"{names}: the record never rotates (|omega| stays under 1 deg/s; "
                               f"{_describe_motion(exc)}); no lever arm is observable: record rotations about "
                               "at least two body axes")
    weak, loose = [], []
    for i in range(3):
        info = np.zeros((3, 3))
        for e in exc:
            if np.all(e.noise_mps2 > 0):
                info += e.arm_information[i] / e.noise_mps2[i] ** 2
            else:  # noiseless (simulated ideal) data: only the structure can be judged
                info += e.arm_information[i]
        diag = np.diag(info)
        scale = 1.0 / np.sqrt(np.where(diag > 0, diag, 1.0))
        eigval, eigvec = np.linalg.eigh(info * np.outer(scale, scale))
        bad = {j for j in range(3) if diag[j] == 0}
        for v in eigvec[:, eigval < UNOBSERVABLE_EIG * max(eigval.max(), 1e-300)].T:
            bad |= {j for j in range(3) if abs(v[j]) > 0.3}
        weak += [3 * i + j for j in sorted(bad)]
        if not bad and all(np.all(e.noise_mps2 > 0) for e in exc):
            sigma = np.sqrt(np.diag(np.linalg.inv(info)))
            loose += [(3 * i + j, sigma[j]) for j in range(3) if sigma[j] > UNDETERMINED_SIGMA["arm_m"]]
    if weak or loose:
        listed = ", ".join([PARAMS_R[j] for j in weak]
                           + [f"{PARAMS_R[j]} (sigma at least {s * 1e3:.3g} mm)" for j, s in loose])
        names = ", ".join(Path(e.path).name for e in exc)
        advice = ("record rotations about at least two body axes (the paper rotates about Y, X and Z in turn)"
                  if weak else "the rotations are too small: record larger or longer rotations (an arm's sigma "
                               "falls with the square of the rate and the square root of the time)")
        raise CalibrationError(f"the rotations in {names} leave unobservable: {listed} ({_describe_motion(exc)}); "
                               f"{advice}" + (", and rotations about horizontal axes for the delay" if with_delay else "")
                               + "; found before fitting, from one pass over the gyros")
    return exc


# --------------------------------------------------------------------------- the command


def nominal_levers(nominal: str) -> Levers:
    if nominal in ("high-precision", "compact", "none"):
        return levers_from_preset(nominal)
    return read_levers(nominal)


def run(paths, *, nominal: str = "high-precision", with_tilt: bool = True, with_delay: bool = False,
        triad: str = "normals", allow_gaps: bool = False, plot=None, json_path=None, force: bool = False) -> dict:
    """Entry point of ``sizefx calibrate``: pre-flight, fits, decomposition, report figures; writes the
    lever arms (``json_path``, sizefx/levers/1) and the figure (``plot``) when asked.

    Everything that can refuse the run is checked before the first record is read whole: the
    outputs (:func:`sizefx.io.files.check_outputs`), the nominal geometry, each record's
    reference and site, and the motion's excitation of the arms (:func:`preflight`).
    """
    paths = [str(p) for p in paths]
    if len(set(map(lambda p: Path(p).resolve(), paths))) != len(paths):
        raise CalibrationError("a record is given twice; give each record once")
    check_outputs({"--json": json_path, "--plot": plot}, inputs=paths, force=force)
    if triad not in ("normals", "x-accelerometer"):
        raise CalibrationError(f"triad point '{triad}': use normals or x-accelerometer")
    nom = nominal_levers(nominal)
    preflight(paths, with_delay=with_delay, allow_gaps=allow_gaps)
    records, skipped = [], []
    for p in paths:
        pieces = read_telemetry(p, allow_gaps=allow_gaps).continuous_pieces()
        for seg, piece in pieces:
            name = p if len(pieces) == 1 else f"{p} segment {seg.number}/{seg.of}"
            if piece.n_samples < MIN_SAMPLES:
                skipped.append(f"{name} ({piece.n_samples} samples)")
                continue
            records.append(prepare(piece, name))
    per_rotation = {rec.name: per_rotation_fit(rec) for rec in records}
    res = joint_fit(records, with_tilt=with_tilt, with_delay=with_delay)
    point = triad_point(res.arms, how=triad)
    levers = Levers(arms_total=res.arms, offset=point, arms_triad=res.arms - point, sigma=res.sigma_arms,
                    reference_point="rotation-center",
                    tilt_arcsec=None if res.tilt_rad is None else (res.tilt_rad / ARCSEC).tolist(),
                    accel_delay_s=res.delay_s,
                    extra={"triad_point": triad,
                           "sigma_tilt_arcsec": None if res.sigma_tilt_rad is None else (res.sigma_tilt_rad / ARCSEC).tolist(),
                           "sigma_accel_delay_s": res.sigma_delay_s,
                           "accel_bias_mps2": res.biases.tolist(), "condition_number": res.condition,
                           "residual_rms_mps2": res.residual_rms.tolist(), "samples": res.samples,
                           "nominal": nominal, "difference_from_nominal_m": (res.arms - nom.arms_total).tolist(),
                           "per_rotation": per_rotation, "records": [str(p) for p in paths],
                           "segments": [rec.name for rec in records], "segments_too_short": skipped})
    out = {"levers": levers, "result": res, "per_rotation": per_rotation, "nominal": nom, "records": records,
           "skipped": skipped}
    if plot:
        with_blocks = [k for k, rec in enumerate(records) if detect_rotations(rec)]
        if not with_blocks:
            raise CalibrationError("--plot draws rotation blocks about vertical axes, and none of the records has one")
        k = with_blocks[0]
        out["figure_spans"] = compensation_figure(records[k], levers, plot,
                                                  title=f"{Path(records[k].name).name}: size effect before and after")
    if json_path:
        write_levers(json_path, levers, inputs=paths, force=force)
    return out


def format_report(out: dict) -> str:
    res, nom, lev = out["result"], out["nominal"], out["levers"]
    mm = 1e3
    lines = [f"joint weighted least squares over {res.samples} samples "
             f"(condition number {res.condition:.3g}; residual RMS x, y, z = "
             + ", ".join(f"{v / 9.80665e-6:.2f}" for v in res.residual_rms) + " ug)",
             "  arm   r [mm] (from the rotation centre)          sigma [mm]              estimate - nominal [mm]"]
    for i, a in enumerate("xyz"):
        lines.append(f"  r_{a}  " + " ".join(f"{v * mm:8.4f}" for v in res.arms[i]) + "   "
                     + " ".join(f"{v * mm:7.4f}" for v in res.sigma_arms[i]) + "   "
                     + " ".join(f"{v * mm:7.4f}" for v in (res.arms[i] - nom.arms_total[i])))
    lines.append(f"  sigma: mean {res.sigma_arms.mean() * mm:.4f} mm, max {res.sigma_arms.max() * mm:.4f} mm")
    segmented = [rec.name for rec in out["records"] if " segment " in rec.name]
    if segmented or out.get("skipped"):
        lines.append(f"  records cut at their IMU gaps, each continuous segment fitted on its own: {len(segmented)} "
                     "segments used" + (f"; left out, shorter than {MIN_SAMPLES} samples: {', '.join(out['skipped'])}"
                                        if out.get("skipped") else ""))
    lines.append(f"  triad point ({lev.extra['triad_point']}) from the rotation centre [mm]: "
                 + " ".join(f"{v * mm:.4f}" for v in lev.offset))
    for i, a in enumerate("xyz"):
        lines.append(f"  d_{a}  " + " ".join(f"{v * mm:8.4f}" for v in lev.arms_triad[i]))
    if res.tilt_rad is not None:
        lines.append(f"  table tilt: north {res.tilt_rad[0] / ARCSEC:.2f} +- {res.sigma_tilt_rad[0] / ARCSEC:.2f} arcsec, "
                     f"east {res.tilt_rad[1] / ARCSEC:.2f} +- {res.sigma_tilt_rad[1] / ARCSEC:.2f} arcsec")
    if res.delay_s is not None:
        lines.append(f"  accelerometer delay: {res.delay_s * 1e6:.2f} +- {res.sigma_delay_s * 1e6:.2f} us")
    for path, rows in out["per_rotation"].items():
        if not rows:  # no block of rotation about one vertical axis (a tumble, a flight): nothing to show
            continue
        lines.append(f"the paper's per-rotation fit ({Path(path).name}; ignores the tilt) [mm]:")
        for row in rows:
            i, j = "xyz".index(row["channel"]), "xyz".index(row["other_component"])
            d_own = (row["r_own"] - nom.arms_total[i][i]) * mm
            d_other = (row["r_other"] - nom.arms_total[i][j]) * mm
            lines.append(f"  rotation about {row['axis']}, channel {row['channel']}: "
                         f"r_{row['channel']}[{row['channel']}] = {row['r_own'] * mm:8.4f} +- {row['sigma_r_own'] * mm:.4f}, "
                         f"r_{row['channel']}[{row['other_component']}] = {row['r_other'] * mm:8.4f} +- "
                         f"{row['sigma_r_other'] * mm:.4f}, bias (tau) {row['bias'] / 9.80665e-6:8.1f} ug; "
                         f"minus nominal {d_own:+.4f}, {d_other:+.4f}")
    return "\n".join(lines)


def compensation_figure(rec: Record, levers: Levers, png, *, mode: str = "center", title: str = ""):
    """The paper's Fig. 6: horizontal accelerometers before and after compensation, per rotation block.

    Offsets of +-100 ug separate the two horizontal channels, as in the paper. Returns
    the peak-to-peak [ug] of each horizontal channel in each block, before and after.
    """
    from .kernels.sizeeffect import compensate_rates

    try:
        import matplotlib
    except ImportError:
        raise CalibrationError("plots need matplotlib: pip install 'sizefx[plots]'") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    after = np.empty_like(rec.accel)
    compensate_rates(np.ascontiguousarray(rec.accel), np.ascontiguousarray(rec.omega),
                     np.ascontiguousarray(rec.omegadot), np.ascontiguousarray(levers.arms_for(mode)),
                     np.ascontiguousarray(levers.axes), True, True, after)
    blocks = detect_rotations(rec)
    dt = float(np.median(np.diff(rec.t)))
    width = max(1, int(round(0.25 / dt)))  # 0.25 s means: the 100 ug sample noise would hide a 60 ug tilt signal

    def smooth(x):
        return np.convolve(x, np.ones(width) / width, mode="valid")

    fig, axes = plt.subplots(len(blocks), 1, figsize=(9, 2.6 * len(blocks)), constrained_layout=True, squeeze=False)
    ug = 9.80665e-6
    spans = []
    for ax, (a, i0, i1) in zip(axes[:, 0], blocks):
        t = smooth(rec.t[i0:i1] - rec.t[i0])
        horiz = [i for i in range(3) if i != a]
        for off, i in zip((100.0, -100.0), horiz):
            before = smooth(rec.accel[i0:i1, i]) / ug
            compensated = smooth(after[i0:i1, i]) / ug
            ax.plot(t, before + off, lw=0.6, alpha=0.6, label=f"{'xyz'[i]} raw {off:+.0f} ug")
            ax.plot(t, compensated + off, lw=0.9, label=f"{'xyz'[i]} compensated {off:+.0f} ug")
            spans.append({"axis": "xyz"[a], "channel": "xyz"[i], "raw_ptp_ug": float(np.ptp(before)),
                          "compensated_ptp_ug": float(np.ptp(compensated))})
        ax.set_title(f"rotation about {'XYZ'[a]}")
        ax.set_ylabel("specific force, 0.25 s means [ug]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, ncol=2, loc="upper right")
    axes[-1, 0].set_xlabel("time in block [s]")
    if title:
        fig.suptitle(title)
    with atomic_output(png, force=True) as tmp:  # the caller checked the path (and --force)
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return spans
