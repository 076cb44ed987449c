"""Physical and numerical constants, each with its source or reason."""

from __future__ import annotations

import math

# WGS-84 (NIMA TR8350.2, 3rd ed., Table 3.1).
WGS84_A_M = 6378137.0  #: semi-major axis [m]
WGS84_F = 1.0 / 298.257223563  #: flattening [-]
WGS84_E2 = WGS84_F * (2.0 - WGS84_F)  #: first eccentricity squared [-]
WGS84_B_M = WGS84_A_M * (1.0 - WGS84_F)  #: semi-minor axis [m]
WGS84_GM_M3_S2 = 3.986004418e14  #: geocentric gravitational constant [m^3/s^2]
OMEGA_EARTH_RAD_S = 7.292115e-5  #: Earth rotation rate [rad/s]

# Somigliana normal gravity on the WGS-84 ellipsoid (NIMA TR8350.2 eq. 4-1;
# Groves 2013, eq. 2.134).
GAMMA_EQUATOR_MPS2 = 9.7803253359  #: normal gravity at the equator [m/s^2]
SOMIGLIANA_K = 0.00193185265241  #: Somigliana constant [-]

#: Standard gravity, used only to convert "g" units and ug figures [m/s^2].
STANDARD_GRAVITY_MPS2 = 9.80665

#: Seconds in an hour [s/h]: a rate per second times it is the rate per hour.
SECONDS_PER_HOUR = 3600.0
#: Its square root [sqrt(s/h)]: a random walk per sqrt(s) times it is the walk per sqrt(h).
SQRT_SECONDS_PER_HOUR = 60.0

DEG = math.pi / 180.0  #: one degree [rad]
ARCSEC = DEG / 3600.0  #: one arc second [rad]
DEG_PER_H = DEG / SECONDS_PER_HOUR  #: one degree per hour [rad/s]
DEG_PER_SQRT_H = DEG / SQRT_SECONDS_PER_HOUR  #: one deg/sqrt(h) [rad/sqrt(s)], angle random walk
MICRO_G = 1e-6 * STANDARD_GRAVITY_MPS2  #: one ug [m/s^2]
PPM = 1e-6  #: one part per million [-]

#: Tolerance on |q| - 1 when reading quaternions from a file. float32 storage
#: resolves about 6e-8; a recorder that normalises in float32 and rounds on
#: output stays well inside 1e-5, while a quaternion that was never normalised
#: (or is in another convention padded with zeros) misses it by far.
QUATERNION_NORM_TOLERANCE = 1e-5

#: The paper's airfield "Lugovskoe" (start of the flight test): latitude [deg], longitude [deg],
#: height [m]. The height is not given in the paper; 120 m is an assumption (the region's
#: airfields lie at 100-170 m). Kept here, free of numpy, so that the command line can show
#: it as a default without importing the simulator (``sizefx --help`` stays fast).
PAPER_AIRFIELD_DEG = (57.9825, 55.7089, 120.0)

#: TU Berlin (approximate), where BROAD was recorded: latitude, longitude [deg], height [m].
BROAD_SITE_DEG = (52.5125, 13.3269, 40.0)

#: A time step larger than this many nominal sample periods is a gap (the telemetry contract's
#: definition, ``data-schemas/telemetry-1.json``: "a step over 1.5 nominal periods").
GAP_FACTOR = 1.5

#: One international nautical mile [m] (drift is quoted in nmi/h).
METRES_PER_NMI = 1852.0

#: Most IMU (and reference) rows a whole read loads: 12 M rows hold the paper's 1.8 h flight at
#: 1600 Hz (10.4 M) and take about 0.8 GB as SI arrays; a file declaring more (or a decompression
#: bomb of that size) is refused before anything is read (docs/reliability.md has the memory this
#: takes). Streamed commands (navigate, simulate) read in chunks and have no such limit.
MAX_WHOLE_READ_ROWS = 12_000_000
#: The longest calibration plan ``sizefx plan`` designs [s]: the plan is for one turntable record,
#: which calibrate reads whole, at most :data:`MAX_WHOLE_READ_ROWS` rows: 7500 s at 1600 Hz, the
#: rate sizefx simulate writes by default and the paper's (tests/test_consistent_inputs.py checks
#: the two agree). A longer calibration is several records, each planned on its own.
MAX_PLAN_S = 7500.0

# Words the command line offers as choices, kept here free of numpy so that ``sizefx --help`` can
# show them without importing the code that uses them.
#: Where a correction brings the accelerometers (``--mode``): to the triad point (arms d_i) or to the
#: rotation centre (arms r_i).
CORRECTION_MODES = ("triad", "center")
#: Angular-acceleration estimators (``--estimator``, :mod:`sizefx.omegadot`).
ESTIMATORS = ("central", "savgol", "increments")
#: The axes of a ROS message's frames (``--frame`` of import and export rosbag): REP 103's
#: forward-left-up, or its ``*_ned`` frames' forward-right-down; the names of
#: :data:`sizefx.frames.ROS_AXES`, which holds their matrices.
ROS_AXES_NAMES = ("flu", "frd")
#: Storage plug-ins of a ROS 2 bag (``export rosbag --storage``): MCAP (the default since ROS 2 Iron) or sqlite3.
ROS_STORAGES = ("mcap", "sqlite3")

#: Sensor grades whose plausible ranges a diagnosis judges by (``--grade``,
#: :mod:`sizefx.diagnose.plausibility`).
GRADES = ("navigation", "tactical", "industrial")
