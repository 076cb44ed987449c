"""The joint fit's rows: the parameter layout, the increment domain, and each channel's design.

- the layout (:func:`_layout`): the arms, a bias per window of each record, the tilt, the delay
  (:data:`FIT_EFFECTS`), and the columns of each channel's rows in it (:func:`_columns`);
- the increment domain: rows are means over :data:`INTERVAL_S` intervals, the tangential term's
  angular acceleration the interval's exact mean (:func:`mean_angular_acceleration`), and with the
  delay the rows near a step in angular acceleration left out (:func:`steps_in_angular_acceleration`);
- the design (:func:`_design`, :func:`_rows`): the sensor model's Jacobian at the linearisation
  point, read once, in pieces inside the bias windows.

:mod:`sizefx.calibrate.joint` fits them.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from ..omegadot import SAVGOL_WINDOW
from ..sensor_model import SensorParams, accel_inputs, accel_readings, jacobian, param_index
from .records import Record, motion_of

__all__ = [
    "FIT_EFFECTS",
    "INTERVAL_S",
    "PARAMS_R",
    "STEP_FLOOR_RAD_S2",
    "STEP_SIGMAS",
    "interval_samples",
    "mean_angular_acceleration",
    "steps_in_angular_acceleration",
]

#: The increment domain's interval [s] (32 samples at 1600 Hz). Within 20 ms the design moves
#: little (0.4 deg of table rotation at 20 deg/s), so the interval means keep the information of
#: the samples (the efficiency against the bound is printed), while the tangential term's angular
#: acceleration is the interval's exact mean, not a filtered derivative.
INTERVAL_S = 0.02
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
PARAMS_R = [f"r_{a}[{c}]" for a in "xyz" for c in "xyz"]
#: The linearisation point: no arms, biases, tilt or delay (the fit's model is linear in them).
_ZERO = SensorParams()


def _fit_effects(with_tilt: bool, with_delay: bool) -> list:
    """The sensor model's effects the joint fit estimates, in the order of :func:`_design`'s columns."""
    return ["lever_arm", "accel_bias"] + (["level_tilt"] if with_tilt else []) + (["accel_delay"] if with_delay else [])


#: The effects the fit can estimate (the others of :data:`sizefx.sensor_model.EFFECTS` are taken as absent).
FIT_EFFECTS = tuple(_fit_effects(True, True))


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
