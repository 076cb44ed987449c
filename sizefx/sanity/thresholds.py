"""The named thresholds of the units checks (:mod:`sizefx.sanity`), each beside the evidence that set it.

They are kept together because they are weighed against each other: the windows and their rest
detection serve (a) and (c), and :data:`GYRO_BAND` bounds both (b) and (c) (it spans
:data:`TILT_SCALE_GRID`). The rates quoted were measured on the real recordings.
"""

from __future__ import annotations

import math

import numpy as np

from ..constants import DEG

__all__ = [
    "WINDOW_S",
    "MIN_WINDOW_SAMPLES",
    "MAX_WINDOWS",
    "REST_STEADINESS",
    "REST_GYRO_FACTOR",
    "REST_GYRO_PERCENTILE",
    "REST_MIN_WINDOWS",
    "ACCEL_BAND",
    "ACCEL_MOVING_BAND",
    "REF_MAX_STARTS",
    "REF_MAX_INTERVAL_S",
    "REF_CONSECUTIVE",
    "REF_END_OFFSETS",
    "REF_COARSE_ROWS",
    "REF_MIN_ANGLE_RAD",
    "REF_MAX_PATH_RAD",
    "REF_MIN_INTERVALS",
    "GYRO_BAND",
    "QUASI_STATIC_TOL",
    "TILT_MIN_RAD",
    "TILT_PAIR_MAX_S",
    "TILT_MAX_PAIRS",
    "TILT_BLOCKS",
    "TILT_MATCH",
    "TILT_REJECT",
    "TILT_MIN_PAIRS",
    "TILT_SCALE_GRID",
]


# --------------------------------------------------------------------------- windows and rest

#: Window length [s] over which "steady" and "quiet" are judged, and the gravity direction
#: is measured: short enough that a tumbling record (0.7 rad/s) turns only 10 deg within one,
#: long enough to average MEMS noise over 25 samples at 100 Hz.
WINDOW_S = 0.25
#: Fewest samples per window (a slow record gets longer windows).
MIN_WINDOW_SAMPLES = 8
#: Most windows examined; a longer record is sampled evenly (bounded time and memory).
MAX_WINDOWS = 3000
#: A window is steady when every accelerometer axis varies (standard deviation) by less than this
#: fraction of ``|mean f|``. Unit-free, so that a unit mistake cannot hide rest. Measured at rest:
#: BROAD MEMS 0.007, PX4 0.002, the parked ring-laser log 0.018 (quantisation and disturbance);
#: in motion: BROAD 0.1-1, a tumbling table 0.05-0.09, helicopter vibration 0.05-0.07.
REST_STEADINESS = 0.03
#: Quiet gyros: ``|mean omega|`` of a steady window within this factor of the quietest steady
#: windows' (their :data:`REST_GYRO_PERCENTILE`-th percentile). Relative, because the gyro units
#: are under test: rest reads bias plus Earth rate in whatever unit the data are in. A steady
#: window that turns about the vertical (heading sway, a turntable) reads far more.
REST_GYRO_FACTOR = 4.0
REST_GYRO_PERCENTILE = 5.0
#: Rest lasts at least this many windows in a row (1 s): a table or a hand holds a position for
#: seconds, while a tumbling motion passes through a steady, slow moment in a fraction of one.
REST_MIN_WINDOWS = 4

# --------------------------------------------------------------------------- (a) accelerometers

#: ``|f|`` at rest within this factor of normal gravity passes. Uncalibrated MEMS read a few
#: per cent off (imucal raw: 1.054, the PSINS car MEMS: 0.97, PX4: 0.99); a unit mistake is 9.8.
ACCEL_BAND = 1.25
#: The same for a record that never rests (median ``|f|`` of all windows: vehicle accelerations,
#: vibration and centripetal terms add to gravity, by tens of per cent at most).
ACCEL_MOVING_BAND = 1.5

# --------------------------------------------------------------------------- (b) gyros, reference

#: Reference intervals examined at most (evenly spread start rows).
REF_MAX_STARTS = 2000
#: Longest interval [s] (a MEMS bias times the span stays small against the rotation; a
#: 10 Hz reference of a car turning at 10 deg/s reaches the minimum angle).
REF_MAX_INTERVAL_S = 2.0
#: Interval ends tried per start: the next :data:`REF_CONSECUTIVE` rows, then rows spaced
#: geometrically out to :data:`REF_MAX_INTERVAL_S` (a 1600 Hz reference spans 3200 rows).
REF_CONSECUTIVE = 16
REF_END_OFFSETS = 64
#: Most rows of the coarse grid on which the turning stretches of a reference are found.
REF_COARSE_ROWS = 100_000
#: An interval "really rotates" when the reference turns by at least this net angle [rad]:
#: 20 times motion-capture noise (~0.3 deg), and 10 times a 0.5 deg/s MEMS bias over 2 s.
REF_MIN_ANGLE_RAD = 0.1
#: The reference's path (sum of its row-to-row angles) over an interval stays below this [rad],
#: so the net angle is unambiguous (far from pi) and the length of the integrated gyro vector
#: equals it to second order (coning).
REF_MAX_PATH_RAD = 1.0
#: Fewest rotating intervals for a verdict.
REF_MIN_INTERVALS = 10
#: The median ratio (integrated gyro / reference angle) passes within this factor of 1;
#: uncalibrated MEMS scale factors are off by a few per cent, deg/s for rad/s by 57.3.
GYRO_BAND = 1.25

# --------------------------------------------------------------------------- (c) gyros, tilt

#: A window is quasi-static when its ``|mean f|`` is within this fraction of the record's median:
#: then ``f`` is ``-g`` in body axes to within the same angle (3 % ~ 2 deg).
QUASI_STATIC_TOL = 0.03
#: A tilt change counts when the gravity direction moves by at least this [rad] (20 deg):
#: far above the direction's noise (< 1 deg) and a MEMS bias over the pair (removed where the
#: record rests), and large enough that a hypothesis that scales the rotation by 57.3 either way
#: misses it by far.
TILT_MIN_RAD = 20.0 * DEG
#: Longest time between the two moments of a pair [s] (bounds the bias drift and the work).
TILT_PAIR_MAX_S = 10.0
#: Most pairs integrated (evenly chosen among those found).
TILT_MAX_PAIRS = 60
#: Each pair is integrated in this many blocks of summed increments (the rotation per block
#: stays below 0.1 rad for 1 rad/s over 10 s: coning error well below the verdict's tolerance).
TILT_BLOCKS = 128
#: The hypothesis that explains the tilt changes leaves a median residual below this fraction of
#: the tilt change: the raw imucal MEMS leave 4 % (its gyro scale factors are a few per cent off,
#: and a 177 deg flip magnifies them); direction noise, bias and block coning add less...
TILT_MATCH = 0.15
#: ...and every other hypothesis a median residual above this fraction, else no verdict (reading
#: the rotation 57.3 times too small leaves the whole tilt change, 1.0; too large, a random one).
TILT_REJECT = 0.5
#: Fewest tilt changes for a verdict.
TILT_MIN_PAIRS = 3
#: Scale factors tried around the winning hypothesis for the reported ratio (within GYRO_BAND).
TILT_SCALE_GRID = np.exp(np.linspace(-math.log(GYRO_BAND), math.log(GYRO_BAND), 41))
