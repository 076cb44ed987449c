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
"""

from __future__ import annotations

import functools
import math
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


def _segments(mask: np.ndarray, nperseg: int) -> np.ndarray:
    """Starts of the half-overlapping segments of ``nperseg`` samples that lie wholly in ``mask``."""
    bad = np.concatenate([[0], np.cumsum(~mask)])
    starts = np.arange(0, mask.size - nperseg + 1, nperseg // 2)
    return starts[bad[starts + nperseg] == bad[starts]]


def _spectra(measured, predicted, mask, fs_hz):
    """Welch auto- and cross-spectra of measured and predicted over usable segments: each a function
    ``(lo, hi) ->`` the samples ``lo:hi`` [hi - lo, 6], asked for one batch of segments at a time.

    Returns ``f`` [nf] (Hz), ``p_mm``, ``p_pp`` [nf, 6] ((unit)^2/Hz) and ``p_mp`` [nf, 6]
    (complex), or None when the record has fewer than :data:`MIN_SEGMENTS` segments of
    :data:`MIN_NPERSEG` samples. Each segment: linear trend removed, Hann window.
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
    chunk = max(1, (1 << 22) // (nperseg * 6))  # segments per batch: ~32 MB of float64 at a time
    for i in range(0, starts.size, chunk):
        first = int(starts[i])
        idx = starts[i : i + chunk, None] - first + np.arange(nperseg)
        stop = first + int(idx[-1, -1]) + 1
        spec = []
        for x in (measured, predicted):
            seg = x(first, stop)[idx]  # [s, nperseg, 6]
            seg = seg - seg.mean(axis=1, keepdims=True)
            seg = seg - np.einsum("snc,n->sc", seg, k)[:, None, :] / float(k @ k) * k[None, :, None]
            spec.append(np.fft.rfft(seg * window[None, :, None], axis=1))
        xm, xp = spec
        p_mm += (np.abs(xm) ** 2).sum(axis=0)
        p_pp += (np.abs(xp) ** 2).sum(axis=0)
        p_mp += (xm * np.conj(xp)).sum(axis=0)
    norm = scale / starts.size
    f = np.fft.rfftfreq(nperseg, 1.0 / fs_hz)
    return f, p_mm * norm, p_pp * norm, p_mp * norm


def _between(x, lo, hi):
    return x[lo:hi]


def choose_bandwidth(t_s, measured, predicted, mask, dt_s) -> BandChoice:
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
    f, p_mm, p_pp, p_mp = spectra
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
