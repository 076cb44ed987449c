"""Where the reference stops being trustworthy: the band diagnose fits without ``--bandwidth-hz``.

diagnose predicts the IMU from the record's ``/reference``: the rates from the attitude
spline's derivative, the specific force from the position twice differentiated. Whatever noise
the reference carries comes out of a derivative, so it grows with frequency (power ~f^2 for
the rates, up to ~f^4 for the specific force). An exact reference (a turntable's, a
simulation's) has none, and the whole band is usable. A motion-capture reference is fine where
the motion lives, and above some frequency the prediction is mostly noise: there the residual
is the reference's noise, and the regressors built from the reference (scale factors,
misalignments, g-sensitivity, the tilt) carry that noise too, which biases them towards -1
(errors in variables: 600 000 ppm scale factors on BROAD fitted in the full band).

:func:`choose_bandwidth` measures that frequency from the record itself, channel by channel,
with the cross-spectrum of the measured and the predicted readings (see its docstring).

An exact reference has a second limit: its samples. The predicted rates and accelerations are the
derivatives of cubic splines through the reference rows (attitude, velocity), which read a motion
at frequency ``f`` short by the relative error :func:`spline_derivative_error` of ``2 pi f h`` (``h``
the reference's row spacing): 1e-3 at 12 rows a period, the 32 Hz rotor harmonic of a helicopter
logged at 400 Hz. That error is the motion's own, coherent with it, so the noise test above cannot
see it; it is computed instead (:func:`interpolation_chi2`), and the band is set where what is left
of it after the fit's low-pass can bias no estimate by more than :data:`INTERPOLATION_BIAS_SIGMA`
of its standard error. It cuts into the motion's band (which the fit otherwise keeps, as for the
noise) only when keeping it would leave an error able to bias an estimate by
:data:`GROSS_BIAS_SIGMA`; short of that the reason says how much of the error stays in the fit.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .theta import CHANNELS

__all__ = [
    "BandChoice",
    "choose_bandwidth",
    "RESOLUTION_HZ",
    "MIN_SEGMENTS",
    "BANDS_PER_OCTAVE",
    "NOISE_TO_MOTION",
    "PERSIST_BANDS",
    "MOTION_SHARE",
    "NUMERICAL_FLOOR",
    "MAX_FRACTION_OF_NYQUIST",
    "READABLE",
    "INTERPOLATION_BIAS_SIGMA",
    "GROSS_BIAS_SIGMA",
    "interpolation_chi2",
    "spline_derivative_error",
]

#: Frequency resolution of the spectra [Hz]: 4 s segments, fine enough for 1/3-octave bands
#: from 0.5 Hz up (a hand-held motion, 1-10 Hz, spans many bands); a slower motion (a table
#: tumbling at 0.1 Hz) sits in the first bins, below every band examined, which is right: its
#: reference noise is looked for above it.
RESOLUTION_HZ = 0.25
#: Fewest Welch segments (50 % overlap, each wholly inside the usable samples): with fewer the
#: cross-spectrum of two independent noises keeps a bias of ~1/sqrt(K) of their powers and the
#: split below cannot be trusted. Short records halve the segment until they have this many.
MIN_SEGMENTS = 8
#: Shortest segment [samples] before giving up on a short record: 64 bins to form bands from.
MIN_NPERSEG = 128
#: Width of the bands the spectra are averaged over: 1/3 octave, the acoustician's band, wide
#: enough (>= 4 bins from 4 Hz at :data:`RESOLUTION_HZ`) to average out the bin-to-bin scatter,
#: narrow enough that the noise's rise (a factor 1.6-2.5 in power per band) is resolved.
BANDS_PER_OCTAVE = 3
#: A band is untrustworthy when the reference's noise power there exceeds this share of the
#: motion's: the regressors derived from the reference would be more than ~9 % noise in it, and
#: a scale factor fitted there biased by as much (errors in variables, -N/(S+N)). Measured on
#: BROAD trials 07, 09, 16, 21 (start model "none"): 10, 10, 12, 6 Hz, around the hand-chosen
#: 10 Hz; at 0.3: 12, 10, 12, 10 Hz; at 1.0 (noise equal to motion): 12, 12, 15, 12 Hz, on the
#: way to 20 Hz, where the trials' lever arms disagree by 3.2 mm (tests/test_diagnose.py).
NOISE_TO_MOTION = 0.1
#: A channel's reference stops being trustworthy at the first band from which this many
#: consecutive bands (one octave) are untrustworthy: noise from a derivative keeps rising, while
#: a single band can fail by chance or by an unmodelled line (BROAD 07 accel_y at 6-8 Hz).
PERSIST_BANDS = 3
#: The motion's band, per channel: the frequency below which this share of the motion's power
#: lies (the power the measured and the predicted readings share, in the bands where that share
#: dominates). A channel's limit is looked for above it: below, in the gaps between the motion's
#: lines, a band with little motion fails the test without saying anything about the reference
#: (a simulated hand-held tumble at 1-2.3 Hz: accel_x "fails" at 0.5 Hz). The fit band is never
#: set below the median of the channels' motion bands: the fit must keep the motion it learns from.
MOTION_SHARE = 0.9
#: The reference's noise in a band is ignored below this fraction of the channel's largest band
#: power: numerical noise of the splines (1e-8 relative in amplitude on the simulator's exact
#: reference, tests/test_diagnose.py) is 1e-16 in power; motion capture's, 1e-3 and more.
NUMERICAL_FLOOR = 1e-9
#: diagnose fits low-passed rows up to 0.8 times the Nyquist frequency (selection.Rows); a limit
#: above this fraction leaves the whole band to the fit.
MAX_FRACTION_OF_NYQUIST = 0.5
#: The band is rounded down to one of these mantissas (times a power of ten): readable values
#: that never exceed the measured limit.
READABLE = (1.0, 1.2, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0)
#: The largest bias, in units of its standard error, that the reference's interpolation error may
#: put into any estimate. For a least-squares estimate the bias from an error ``e`` in the data is
#: at most ``sqrt(e' W e)`` of its standard error (Cauchy-Schwarz in the weights' metric), so the
#: band keeps that chi-square of the error at most this squared: 0.2, the validation protocol's
#: target for a mean z-score (derived, not tuned).
INTERPOLATION_BIAS_SIGMA = 0.2
#: Where keeping the motion's band would leave an interpolation error able to bias an estimate by
#: this many standard errors (its chi-square this squared), the band is cut inside the motion: an
#: error beyond the 3-sigma line of chance makes every finding it touches meaningless, and the
#: slower motion is kept. Below it the band keeps the motion and its reason says how much error stays.
GROSS_BIAS_SIGMA = 3.0


@dataclass
class BandChoice:
    """The fit band chosen from the record, and why.

    ``bandwidth_hz``: the low-pass for the fit [Hz], or None when the full band is trustworthy.
    ``reason``: one sentence for the report (what was measured, where it crossed).
    ``per_channel``: channel name (:data:`sizefx.diagnose.theta.CHANNELS`) -> the frequency [Hz]
    at which that channel's reference stops being trustworthy, or None where it stays so.
    ``motion_hz``: the motion's band [Hz] (:data:`MOTION_SHARE` of its power below), or None
    when the record is too short to measure spectra.
    """

    bandwidth_hz: float | None
    reason: str
    per_channel: dict = field(default_factory=dict)
    motion_hz: float | None = None
    #: the chi-square the reference's interpolation error leaves in the fit at the chosen band, when
    #: it exceeds :data:`INTERPOLATION_BIAS_SIGMA` squared (the band kept the motion it lies in, and
    #: ``reason`` says so); else 0
    interpolation_chi2: float = 0.0


def readable_floor(f_hz: float) -> float:
    """The largest value of :data:`READABLE` times a power of ten not above ``f_hz`` (> 0) [Hz]."""
    decade = 10.0 ** math.floor(math.log10(f_hz))
    mantissa = max(m for m in READABLE if m * decade <= f_hz * (1.0 + 1e-9))  # 1e-9: 10.0 stays 10
    return mantissa * decade


def readable_ceil(f_hz: float) -> float:
    """The smallest value of :data:`READABLE` times a power of ten not below ``f_hz`` (> 0) [Hz]."""
    decade = 10.0 ** math.floor(math.log10(f_hz))
    for m in READABLE + (10.0,):
        if m * decade >= f_hz * (1.0 - 1e-9):
            return m * decade
    return 10.0 * decade  # unreachable: 10 * decade > f_hz


def spline_derivative_error(theta):
    """``|1 - H(theta)|``: the relative error of an interpolating cubic spline's first derivative at
    its knots on a sinusoid of ``theta = 2 pi f h`` radians per row (``h`` the row spacing).

    The knot slopes ``m`` of a cubic spline solve ``m[k-1] + 4 m[k] + m[k+1] = 3 (y[k+1] - y[k-1]) / h``;
    for ``y = exp(i omega t)`` that gives ``m = H i omega y`` with ``H = 3 sin(theta) / (theta (2 +
    cos(theta)))``, so ``1 - H ~ theta^4 / 180`` (de Boor, A Practical Guide to Splines, ch. IV). Between
    the knots the rates are a cubic spline through the knot rates
    (:class:`sizefx.diagnose.reference.ReferenceMotion`), off by ``theta^4 / 384`` more at most.
    scipy's ``RotationSpline`` (attitude) and ``CubicSpline`` (velocity) are such splines; their end
    conditions matter only within a few rows of an end.
    """
    theta = np.asarray(theta, dtype=float)
    safe = np.where(theta > 1e-3, theta, 1.0)
    exact = 1.0 - 3.0 * np.sin(safe) / (safe * (2.0 + np.cos(safe)))
    return np.abs(np.where(theta > 1e-3, exact, theta**4 / 180.0))


def _no_interpolation_error(cut_hz: float | None) -> float:
    """The interpolation chi-square when the row spacing is not known: none."""
    return 0.0


def _low_pass_power(f_hz, cut_hz):
    """Power response of the fit's zero-phase 4th-order Butterworth low-pass (``sosfiltfilt``: the
    filter's power response squared); 1 without a cut-off (the full band)."""
    if cut_hz is None:
        return np.ones_like(f_hz)
    return 1.0 / (1.0 + (f_hz / cut_hz) ** 8) ** 2


def interpolation_chi2(f_hz, width_hz, motion, noise_density, duration_s, reference_dt_s, cut_hz=None) -> float:
    """The chi-square the reference's interpolation error leaves in the fit's rows, all channels.

    Per band of centre ``f_hz`` [nb] and width ``width_hz`` [nb]: the motion's power density
    ``motion`` [nb, c] read short by :func:`spline_derivative_error` of ``2 pi f h`` (at the band's
    upper edge, the larger error) is an error of density ``err^2 * motion``; against white noise of
    one-sided density ``noise_density`` [c] over ``duration_s`` its chi-square is ``2 T width err^2
    motion / noise`` (``n`` samples of variance ``noise fs / 2``), times what the low-pass at
    ``cut_hz`` lets through.
    """
    upper = np.asarray(f_hz) + 0.5 * np.asarray(width_hz)
    err2 = spline_derivative_error(2.0 * np.pi * upper * reference_dt_s) ** 2
    keep = _low_pass_power(np.asarray(f_hz, dtype=float), cut_hz)
    per_band = 2.0 * duration_s * (width_hz * err2 * keep)[:, None] * np.maximum(motion, 0.0) / noise_density[None, :]
    return float(per_band.sum())


def _segments(mask: np.ndarray, nperseg: int) -> np.ndarray:
    """Starts of the half-overlapping segments of ``nperseg`` samples that lie wholly in ``mask``."""
    bad = np.concatenate([[0], np.cumsum(~mask)])
    starts = np.arange(0, mask.size - nperseg + 1, nperseg // 2)
    return starts[bad[starts + nperseg] == bad[starts]]


def _spectra(measured, predicted, mask, fs_hz):
    """Welch auto- and cross-spectra of measured and predicted over usable segments: each a function
    ``(lo, hi) ->`` the samples ``lo:hi`` [hi - lo, 6], asked for one batch of segments at a time.

    Returns ``f`` [nf] (Hz), ``p_mm``, ``p_pp`` [nf, 6] ((unit)^2/Hz) and ``p_mp`` [nf, 6]
    (complex), and the same three of the first differences (``(d_mm, d_pp, d_mp)``, scaled back by
    the difference's response ``|2 sin(pi f / fs)|^2``: the spectra without the leakage of a slow,
    large motion into the high bins, which the Hann window's sidelobes spread over all of them), or
    None when the record has fewer than :data:`MIN_SEGMENTS` segments of :data:`MIN_NPERSEG`
    samples. Each segment: linear trend removed, Hann window.
    """
    nperseg = 1 << max(int(math.ceil(math.log2(fs_hz / RESOLUTION_HZ))), 0)
    while True:
        starts = _segments(mask, nperseg)
        if starts.size >= MIN_SEGMENTS:
            break
        if nperseg // 2 < MIN_NPERSEG:
            return None
        nperseg //= 2
    window = np.hanning(nperseg)
    scale = 2.0 / (fs_hz * float(window @ window))  # one-sided density
    k = np.arange(nperseg) - 0.5 * (nperseg - 1)  # centred index: the linear trend's regressor
    nf = nperseg // 2 + 1
    p_mm = np.zeros((nf, 6))
    p_pp = np.zeros((nf, 6))
    p_mp = np.zeros((nf, 6), dtype=complex)
    d_mm, d_pp = np.zeros((nf, 6)), np.zeros((nf, 6))
    d_mp = np.zeros((nf, 6), dtype=complex)
    chunk = max(1, (1 << 22) // (nperseg * 6))  # segments per batch: ~32 MB of float64 at a time
    for i in range(0, starts.size, chunk):
        first = int(starts[i])
        idx = starts[i : i + chunk, None] - first + np.arange(nperseg)
        stop = first + int(idx[-1, -1]) + 1
        spec, diff = [], []
        for x in (measured, predicted):
            raw = x(first, stop)[idx]  # [s, nperseg, 6]
            seg = raw - raw.mean(axis=1, keepdims=True)
            seg = seg - np.einsum("snc,n->sc", seg, k)[:, None, :] / float(k @ k) * k[None, :, None]
            spec.append(np.fft.rfft(seg * window[None, :, None], axis=1))
            d = np.diff(raw, axis=1, prepend=raw[:, :1])
            d = d - d.mean(axis=1, keepdims=True)
            diff.append(np.fft.rfft(d * window[None, :, None], axis=1))
        xm, xp = spec
        p_mm += (np.abs(xm) ** 2).sum(axis=0)
        p_pp += (np.abs(xp) ** 2).sum(axis=0)
        p_mp += (xm * np.conj(xp)).sum(axis=0)
        dm, dp = diff
        d_mm += (np.abs(dm) ** 2).sum(axis=0)
        d_pp += (np.abs(dp) ** 2).sum(axis=0)
        d_mp += (dm * np.conj(dp)).sum(axis=0)
    norm = scale / starts.size
    f = np.fft.rfftfreq(nperseg, 1.0 / fs_hz)
    response = np.maximum((2.0 * np.sin(np.pi * f / fs_hz)) ** 2, 1e-300)[:, None]
    differenced = (d_mm * norm / response, d_pp * norm / response, d_mp * norm / response)
    return f, p_mm * norm, p_pp * norm, p_mp * norm, differenced


def _between(x, lo, hi):
    return x[lo:hi]


def choose_bandwidth(t_s, measured, predicted, mask, dt_s, reference_dt_s=None) -> BandChoice:
    """The band below which the record's reference can be trusted, measured from the record.

    Method. Welch spectra (Hann segments of at least 4 s, a power of two in samples, half-
    overlapping, each wholly inside ``mask``, halved for short records;
    linear trend removed) of the measured readings ``m``, the predicted ``p`` and their
    cross-spectrum, averaged over 1/3-octave bands. Model: ``m = s + n_imu``, ``p = s + n_ref``
    with the motion ``s`` seen by both and the two noises independent of it and of each other
    (the start model's errors, scale factors of a few 1e-3 at most, are small against ``s``).
    Then per band ``S = |P_mp|`` is the motion's power, ``N_ref = P_pp - S`` the power of what
    the prediction holds and the IMU does not see (the reference's noise), and ``N_imu = P_mm - S``
    what the IMU holds and the prediction does not (its noise, unmodelled effects). A band is
    untrustworthy when ``N_ref > NOISE_TO_MOTION * S`` (the reference-derived regressors are
    more than ~9 % noise there), ``N_ref > N_imu`` (the residual there is the reference's noise,
    not the sensor's) and ``N_ref`` is above the numerical floor. A channel's limit is the lower
    edge of the first band from which :data:`PERSIST_BANDS` consecutive bands are untrustworthy.

    Each channel's limit is looked for above its motion's band (:data:`MOTION_SHARE` of the shared
    power below it). The band is the lowest channel limit, but never below the median of the
    channels' motion bands: the fit must keep the motion it learns from. It is rounded down to a readable value
    (:data:`READABLE`); None when no channel has a limit below :data:`MAX_FRACTION_OF_NYQUIST`
    times the Nyquist frequency, or when the record is too short for spectra (the reason says so).

    Parameters
    ----------
    t_s : [n] sample times (s), used only for the record's span in the reason.
    measured, predicted : [n, 6] gyro x, y, z (rad/s), accelerometer x, y, z (m/s^2), body axes
        (:data:`sizefx.diagnose.theta.CHANNELS`); ``predicted`` from the start model. Or each a
        function ``(lo, hi) ->`` the samples ``lo:hi``, asked for a batch of segments at a time
        (bounded memory); then ``mask`` must already leave out samples that are not finite.
    mask : [n] bool, the usable samples (:class:`sizefx.diagnose.Predictor` ``.mask``); samples where
        ``measured`` or ``predicted`` (arrays) are not finite are left out too.
    dt_s : the sample period (s).
    reference_dt_s : the reference's row spacing (s): with it, the band is also kept where the
        splines through the rows read the motion exactly enough (:func:`interpolation_chi2` at
        most :data:`INTERPOLATION_BIAS_SIGMA` squared, the noise density each channel's residual's
        median over the bands); None leaves that test out.

    Assumptions: uniform sampling at ``dt_s`` (diagnose's records are); the reference's noise is
    independent of the IMU's; the start model is close (a prediction that is wrong by a fraction
    ``a`` of the motion looks like reference noise of ``a^2`` of it, far below the threshold).
    """
    mask = np.asarray(mask, dtype=bool)
    if not callable(measured):
        measured = np.asarray(measured, dtype=float)
        mask = mask & np.isfinite(measured).all(axis=1)
        measured = functools.partial(_between, measured)
    if not callable(predicted):
        predicted = np.asarray(predicted, dtype=float)
        mask = mask & np.isfinite(predicted).all(axis=1)
        predicted = functools.partial(_between, predicted)
    fs_hz = 1.0 / float(dt_s)
    nyquist_hz = 0.5 * fs_hz
    names = list(CHANNELS)
    spectra = _spectra(measured, predicted, mask, fs_hz)
    if spectra is None:
        return BandChoice(
            None,
            f"the full band: the {int(mask.sum())} usable samples hold fewer than "
            f"{MIN_SEGMENTS} segments of {MIN_NPERSEG} samples to measure the reference's noise "
            "from",
            {c: None for c in names},
        )
    f, p_mm, p_pp, p_mp, differenced = spectra
    df = f[1] - f[0]
    # 1/3-octave bands from two bins up (the lowest bins hold the trend the segments lost) to
    # MAX_FRACTION_OF_NYQUIST of Nyquist, edges on the base-2 series through 1 Hz (8, 10.1, 12.7, 16 Hz)
    lo_k = math.ceil(BANDS_PER_OCTAVE * math.log2(2.0 * df))
    hi_k = math.floor(BANDS_PER_OCTAVE * math.log2(MAX_FRACTION_OF_NYQUIST * nyquist_hz))
    edges = 2.0 ** (np.arange(lo_k, hi_k + 1) / BANDS_PER_OCTAVE)
    bands = [(a, b, (f >= a) & (f < b)) for a, b in zip(edges[:-1], edges[1:])]
    bands = [(a, b, sel) for a, b, sel in bands if sel.any()]
    if len(bands) < PERSIST_BANDS:
        return BandChoice(
            None,
            f"the full band: the {fs_hz:g} Hz record leaves too few frequency bands to "
            "measure the reference's noise in",
            {c: None for c in names},
        )
    interp_cut: float | None = None
    interp_chi2: Callable[[float | None], float] = _no_interpolation_error
    if reference_dt_s is not None:
        d_mm, d_pp, d_mp = differenced
        interp_cut, interp_chi2 = _interpolation_cut(f, d_mm, d_pp, d_mp, lo_k, nyquist_hz, mask, dt_s, reference_dt_s)
    S = np.array([np.abs(p_mp[sel]).mean(axis=0) for _, _, sel in bands])  # [nb, 6]
    n_ref = np.array([p_pp[sel].mean(axis=0) for _, _, sel in bands]) - S
    n_imu = np.array([p_mm[sel].mean(axis=0) for _, _, sel in bands]) - S
    lower = np.array([a for a, _, _ in bands])
    upper = np.array([b for _, b, _ in bands])
    floor = NUMERICAL_FLOOR * np.maximum(S, 0.0).max(axis=0)
    bad = (n_ref > NOISE_TO_MOTION * S) & (n_ref > n_imu) & (n_ref > floor)

    per_channel: dict[str, float | None] = {}  #: channel -> the lowest band of persistent reference noise
    motion: list[float] = []
    for c, name in enumerate(names):
        shared = np.where(S[:, c] > n_ref[:, c] + n_imu[:, c], S[:, c] * (upper - lower), 0.0)  # power per band
        start = 0
        if shared.sum() > 0.0:
            start = int(np.searchsorted(np.cumsum(shared), MOTION_SHARE * shared.sum()))
            motion.append(float(upper[min(start, len(bands) - 1)]))
            start += 1  # the first band wholly above the motion's
        per_channel[name] = None
        for b in range(start, len(bands) - PERSIST_BANDS + 1):
            if bad[b : b + PERSIST_BANDS, c].all():
                per_channel[name] = float(lower[b])
                break
    motion_hz = float(np.median(motion)) if motion else None
    limits = {n: v for n, v in per_channel.items() if v is not None}
    choice = _noise_choice(t_s, limits, per_channel, motion_hz, upper, nyquist_hz)
    left = interp_chi2(choice.bandwidth_hz)
    if interp_cut is not None and (choice.bandwidth_hz is None or interp_cut < choice.bandwidth_hz):
        # the rows' limit is below the noise's: it sets the band, also inside the motion's band when
        # what the motion's band would leave could bias an estimate by GROSS_BIAS_SIGMA or more
        if motion_hz is None or interp_cut >= motion_hz or left >= GROSS_BIAS_SIGMA**2:
            band, why = _interpolation_choice(interp_cut, interp_chi2(None), reference_dt_s)
            if motion_hz is not None and interp_cut < motion_hz:
                why += f"; the motion reaches {motion_hz:.1f} Hz, and what lies above the cut-off is left out"
            return BandChoice(band, why, per_channel, motion_hz)
    if left > INTERPOLATION_BIAS_SIGMA**2:
        # the splines' error lies inside the motion's band, which the fit must keep: said, not cut
        choice.interpolation_chi2 = left
        choice.reason += (
            f"; the reference's rows resolve the motion too coarsely inside its band (interpolation "
            f"chi-square {left:.3g}, up to {math.sqrt(left):.2g} sigma of bias, most on the gyros' terms)"
        )
    return choice


def _noise_choice(t_s, limits, per_channel, motion_hz, upper, nyquist_hz) -> BandChoice:
    """The band the reference's noise sets (the rule of :func:`choose_bandwidth`)."""
    span = f"{float(t_s[-1] - t_s[0]):.0f} s" if len(t_s) > 1 else "the record"
    if not limits:
        return BandChoice(
            None,
            f"the full band: in {span} the reference's noise stays below "
            f"{NOISE_TO_MOTION:g} of the motion's power or below the IMU's own noise up to "
            f"{upper[-1]:.0f} Hz on every channel",
            per_channel,
            motion_hz,
        )
    first = min(limits, key=limits.__getitem__)
    band = readable_floor(limits[first])
    why = (
        f"below {band:g} Hz: the reference's noise (the prediction's power the IMU does not see) exceeds "
        f"{NOISE_TO_MOTION:g} of the motion's power and the IMU's own noise from {limits[first]:.1f} Hz on "
        f"{first}"
        + (
            f"; the motion lies below {motion_hz:.1f} Hz"
            if motion_hz is not None
            else "; no band where the motion dominates both noises"
        )
    )
    if motion_hz is not None and band < motion_hz:
        band = readable_ceil(motion_hz)
        why = (
            f"below {band:g} Hz, the motion's band: the reference's noise exceeds {NOISE_TO_MOTION:g} of the "
            f"motion's power from {limits[first]:.1f} Hz on {first}, inside the motion (below {motion_hz:.1f} Hz), "
            "so the fit keeps the motion and that noise with it"
        )
    if band >= MAX_FRACTION_OF_NYQUIST * nyquist_hz:
        return BandChoice(
            None,
            f"the full band: the reference stays trustworthy up to {limits[first]:.1f} Hz, "
            f"beyond {MAX_FRACTION_OF_NYQUIST:g} of the Nyquist frequency",
            per_channel,
            motion_hz,
        )
    return BandChoice(band, why, per_channel, motion_hz)


def _interpolation_cut(f, p_mm, p_pp, p_mp, lo_k, nyquist_hz, mask, dt_s, reference_dt_s):
    """``(cut-off or None, chi2_at)``: the largest readable cut-off at which the reference's
    interpolation error (:func:`interpolation_chi2`) stays within :data:`INTERPOLATION_BIAS_SIGMA`
    squared, or None when the full band does; ``chi2_at(cut_hz)`` gives that chi-square at any
    cut-off (None: the full band). 1/3-octave bands up to
    the Nyquist frequency; the spectra those of the first differences (:func:`_spectra`), the
    motion's power per band the cross-spectrum's where the motion dominates the band, the noise
    density each channel's residual's median over the bands."""
    hi_k = math.floor(BANDS_PER_OCTAVE * math.log2(nyquist_hz))
    edges = 2.0 ** (np.arange(lo_k, hi_k + 1) / BANDS_PER_OCTAVE)
    sel = [(f >= a) & (f < b) for a, b in zip(edges[:-1], edges[1:])]
    keep = [i for i, m in enumerate(sel) if m.any()]
    if len(keep) < PERSIST_BANDS:
        return None, _no_interpolation_error
    lower, upper = edges[:-1][keep], edges[1:][keep]
    shared = np.array([np.abs(p_mp[sel[i]]).mean(axis=0) for i in keep])
    own = np.array([(p_mm[sel[i]] + p_pp[sel[i]]).mean(axis=0) for i in keep])
    # the motion counts where it dominates both noises (S > N_ref + N_imu, as for the motion's band):
    # elsewhere |P_mp| is the small bias of two independent noises' cross-spectrum, which near the
    # Nyquist frequency, where the splines' error nears 1, would pass for motion read wrong
    motion = np.where(3.0 * shared > own, shared, 0.0)
    residual = np.array([(p_mm[sel[i]] + p_pp[sel[i]] - 2.0 * p_mp[sel[i]].real).mean(axis=0) for i in keep])
    noise = np.maximum(np.median(residual, axis=0), 1e-300)
    centre, width = np.sqrt(lower * upper), upper - lower
    duration_s = float(np.count_nonzero(mask)) * dt_s

    def chi2_at(cut_hz):
        return interpolation_chi2(centre, width, motion, noise, duration_s, reference_dt_s, cut_hz)

    bound = INTERPOLATION_BIAS_SIGMA**2
    if chi2_at(None) <= bound:
        return None, chi2_at
    cut = readable_floor(MAX_FRACTION_OF_NYQUIST * nyquist_hz)
    while cut > lower[0] and chi2_at(cut) > bound:
        cut = readable_floor(cut * (1.0 - 1e-6))  # the next readable value down
    return cut, chi2_at


def _interpolation_choice(cut_hz, chi2_full, reference_dt_s) -> tuple:
    """``(band, reason)`` the reference's sampling sets (:func:`_interpolation_cut`)."""
    why = (
        f"below {cut_hz:g} Hz: the reference's {1.0 / reference_dt_s:g} Hz rows resolve the motion above it too "
        f"coarsely (its splines' interpolation error would add chi-square {chi2_full:.3g} to a full-band fit, "
        f"enough to bias an estimate by up to {math.sqrt(chi2_full):.2g} sigma; below the cut-off at most "
        f"{INTERPOLATION_BIAS_SIGMA:g} sigma)"
    )
    return cut_hz, why
