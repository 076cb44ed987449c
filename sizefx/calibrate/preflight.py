"""What can refuse a calibration before the fit, cheapest first: the records' structure, then one
streamed pass that bounds what the motion can reveal about the arms."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..constants import DEG
from ..io.telemetry import TelemetryStream
from ..omegadot import SAVGOL_WINDOW, savgol
from ..sensor_model import Motion, SensorParams, jacobian, param_index
from .joint import BIAS_WINDOW_S, PARAMS_R, UNDETERMINED_SIGMA, UNOBSERVABLE_EIG
from .records import MIN_SAMPLES, ROTATING_RAD_S, CalibrationError, _require_reference_site_samples

__all__ = ["Excitation", "excitation", "preflight", "PREFLIGHT_ROWS"]


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


def excitation(
    path, *, allow_gaps: bool = False, bias_window_s: float = BIAS_WINDOW_S, n_segments: int | None = None
) -> Excitation:
    """One streamed pass over the IMU rows of ``path``: rates and angular accelerations per body
    axis, and the information the motion carries about each lever arm.

    The information is that of :func:`joint_fit`'s arm columns with the bias windows projected
    out, but not the tilt and the delay: an optimistic bound. A record with IMU gaps is read one
    continuous segment at a time, as the fit takes it. A component that even this bound
    cannot determine is certainly not determined by the fit, so :func:`preflight` can refuse it
    in seconds instead of after the fit.
    """
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
    for number in range(1, n_segments + 1) if n_segments > 1 else [None]:
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
                h = _arm_columns(w, wd)  # [3, n, 3]
                wid = np.floor((t - t_first) / bias_window_s).astype(int) if bias_window_s else np.zeros(t.size, int)
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
        raise CalibrationError(
            f"{path}: no continuous segment holds {MIN_SAMPLES} samples; calibration needs that many between gaps"
        )
    assert t_first is not None and t_last is not None and dt is not None  # set by the first chunk (n_total > 0)
    n = n_total
    return Excitation(
        str(path), n, t_last - t_first, np.sqrt(sum_w2 / n), np.sqrt(sum_wd2 / n), rotating * dt, info, noise
    )


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
    segments = []
    for path in paths:  # every record's structure first: the cheapest refusals before any pass
        with TelemetryStream(path, allow_gaps=allow_gaps) as st:
            _require_reference_site_samples(path, st.reference, st.site, st.n_samples)
            segments.append(st.n_segments)
    exc = [excitation(p, allow_gaps=allow_gaps, n_segments=k) for p, k in zip(paths, segments)]
    if all(e.rotating_s == 0.0 for e in exc):
        names = ", ".join(e.path for e in exc)
        raise CalibrationError(
            f"{names}: the record never rotates (|omega| stays under 1 deg/s; "
            f"{_describe_motion(exc)}); no lever arm is observable: record rotations about "
            "at least two body axes"
        )
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
        listed = ", ".join(
            [PARAMS_R[j] for j in weak] + [f"{PARAMS_R[j]} (sigma at least {s * 1e3:.3g} mm)" for j, s in loose]
        )
        names = ", ".join(Path(e.path).name for e in exc)
        advice = (
            "record rotations about at least two body axes (the paper rotates about Y, X and Z in turn)"
            if weak
            else "the rotations are too small: record larger or longer rotations (an arm's sigma "
            "falls with the square of the rate and the square root of the time)"
        )
        raise CalibrationError(
            f"the rotations in {names} leave unobservable: {listed} ({_describe_motion(exc)}); "
            f"{advice}"
            + (", and rotations about horizontal axes for the delay" if with_delay else "")
            + "; found before fitting, from one pass over the gyros"
        )
    return exc


def _arm_columns(w, wd) -> np.ndarray:
    """``[3, n, 3]``: accelerometer i's reading per metre of each component of r_i (the sensor
    model's lever-arm columns; they depend on the rates alone)."""
    jac = jacobian(SensorParams(), Motion(w, wd, np.zeros_like(w)), effects=["lever_arm"], sensors=("accel",))
    arms = param_index("lever_arm")
    return np.stack([jac.block(3 + i, arms[3 * i : 3 * i + 3]) for i in range(3)])
