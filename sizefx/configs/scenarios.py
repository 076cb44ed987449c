"""What a simulated motion is asked: the site (:class:`SiteSpec`) and each scenario's plan
(:class:`TurntablePlan`, :class:`SwayPlan`, :class:`FlightPlan`, :class:`TumblePlan`), their options
declared once (:mod:`sizefx.options`); the motions themselves are :mod:`sizefx.scenarios`, which
re-exports these.

A plan is plain data: the plan search (:mod:`sizefx.plan`) and the tests build plans the command
line never would (a sway of zero amplitude, candidates the search then checks). So a plan does not
refuse its own values when it is made; the ``simulate`` stage does, by the declarations, when its
config is made (:class:`~sizefx.configs.simulate.SimulateConfig`, whose ``plan`` is a
:func:`~sizefx.options.one_of`). A plan's rules across its options are its :meth:`check`, which the
stage's config and the motion's builder both call. Fields without a declaration are for Python
callers only (the table's ramps and dwells, the flight's vibration).
"""

from __future__ import annotations

from dataclasses import dataclass

from ..constants import DEG, PAPER_AIRFIELD_DEG, SECONDS_PER_HOUR
from ..errors import ConfigError
from ..options import check_options, choice, integer, number, numbers, text

__all__ = [
    "SiteSpec",
    "PAPER_AIRFIELD",
    "TurntablePlan",
    "SwayPlan",
    "FlightPlan",
    "TumblePlan",
    "SCENARIO_PLANS",
    "TABLE_ORIENTATIONS_DEG",
]

#: Gimbal angles (middle about north, inner about east), in degrees, that put
#: body axis X, Y or Z along the table's vertical (down) axis.
TABLE_ORIENTATIONS_DEG = {"X": (0.0, -90.0), "Y": (90.0, 0.0), "Z": (0.0, 0.0)}


@dataclass(frozen=True)
class SiteSpec:
    """Site or start position in degrees and metres (the command line's units)."""

    latitude_deg: float = number(
        PAPER_AIRFIELD_DEG[0], unit="deg", low=-89.5, high=89.5, help="Site or start latitude [deg]."
    )
    longitude_deg: float = number(
        PAPER_AIRFIELD_DEG[1], unit="deg", low=-180.0, high=360.0, help="Site or start longitude [deg]."
    )
    height_m: float = number(
        PAPER_AIRFIELD_DEG[2],
        unit="m",
        low=-12000.0,
        high=100000.0,
        help="Site or start height above the WGS-84 ellipsoid [m].",
    )

    def __post_init__(self):
        check_options(self)

    def radians(self):
        return self.latitude_deg * DEG, self.longitude_deg * DEG, self.height_m


#: The paper's airfield "Lugovskoe" (start of the flight test); see
#: :data:`sizefx.constants.PAPER_AIRFIELD_DEG`.
PAPER_AIRFIELD = SiteSpec()


@dataclass
class TurntablePlan:
    """The paper's calibration plan (Fig. 4, 5): rotations about Y, then X, then Z.

    Each axis in turn is vertical; the outer (azimuth) axis swings it through
    ``cycles`` positive and negative rotations in ``seconds_per_axis``: dwell,
    jerk-limited acceleration to ``peak_rate_dps`` at ``accel_dps2``, cruise,
    deceleration, dwell, then the same negative. ``axes`` is read in capitals.
    """

    axes: str = text(
        "YXZ",
        flags=("--vertical-axes",),
        help="The body axes turned vertical, in the order the table turns about them (letters X, Y, Z).",
    )
    static_s: float = number(60.0, unit="s", low=1.0, high=86400.0, help="Static lead-in [s].")
    seconds_per_axis: float = number(
        120.0, unit="s", low=1.0, high=86400.0, help="Duration of the rotations about each axis [s]."
    )
    cycles: int = integer(5, low=1, high=10000, help="Positive-and-negative rotation cycles per axis.")
    peak_rate_dps: float = number(20.0, unit="deg/s", low=0.01, high=5000.0, help="Peak table rate [deg/s].")
    accel_dps2: float = number(
        10.0, unit="deg/s^2", low=0.01, high=1e5, help="Angular acceleration of the table [deg/s^2] (jerk-limited)."
    )
    ramp_s: float = 0.5  #: duration of each jerk-limited acceleration transition
    dwell_s: float = 0.5  #: rest at each end of a rotation
    reposition_s: float = 10.0
    settle_s: float = 10.0

    def __post_init__(self):
        if isinstance(self.axes, str):
            self.axes = self.axes.upper()

    @property
    def overhead_s(self) -> float:
        """Seconds not spent rotating: the lead-in, the turns to each next axis, the last settling."""
        return self.static_s + (len(self.axes) - 1) * (self.reposition_s + self.settle_s) + self.settle_s

    @property
    def duration_s(self) -> float:
        """Seconds the plan takes (:func:`~sizefx.scenarios.turntable`'s trajectory is this long)."""
        return self.overhead_s + len(self.axes) * self.seconds_per_axis

    def check(self):
        if not self.axes or any(a not in TABLE_ORIENTATIONS_DEG for a in self.axes):
            raise ConfigError(f"--vertical-axes '{self.axes}': use letters X, Y, Z (e.g. YXZ)")
        for name in (
            "static_s",
            "seconds_per_axis",
            "peak_rate_dps",
            "accel_dps2",
            "ramp_s",
            "reposition_s",
            "settle_s",
        ):
            if not getattr(self, name) > 0:
                raise ConfigError(f"turntable: {name} = {getattr(self, name)} must be positive")
        if self.dwell_s < 0:
            raise ConfigError(f"turntable: dwell_s = {self.dwell_s} must not be negative")
        half = self.seconds_per_axis / (2 * self.cycles)
        # ProfileBuilder.change_rate: ramp, hold, ramp; with no room for a hold it takes two ramps
        spin = max(self.peak_rate_dps / self.accel_dps2, self.ramp_s) + self.ramp_s
        cruise = half - 2 * spin - 2 * self.dwell_s
        if cruise <= 0:
            raise ConfigError(
                f"turntable: {self.cycles} cycles (--cycles) in {self.seconds_per_axis} s "
                f"(--seconds-per-axis) leave no time at {self.peak_rate_dps} deg/s (--peak-rate-dps) "
                f"reached at {self.accel_dps2} deg/s^2 (--accel-dps2); allow more seconds per axis, "
                "fewer cycles, a lower rate or a higher acceleration"
            )
        return half, cruise


@dataclass
class SwayPlan:
    """The paper's sway test: static, then rate = A sin(2 pi f t) for each amplitude in turn."""

    axis: str = choice(
        "heading",
        ("heading", "roll", "pitch"),
        help="Sway axis: heading (about the vertical), roll (body x) or pitch (body y).",
    )
    amplitudes_dps: tuple = numbers(
        (10.0, 20.0, 30.0),
        unit="deg/s",
        low=0.0,
        low_open=True,
        high=5000.0,
        help="Rate amplitude A of each segment [deg/s]; rate = A sin(2 pi f t).",
    )
    frequency_hz: float = number(1.0, unit="Hz", low=0.01, high=100.0, help="Sway frequency f [Hz].")
    static_s: float = number(600.0, unit="s", low=1.0, high=86400.0, help="Static lead-in [s].")
    segment_s: float = number(600.0, unit="s", low=1.0, high=86400.0, help="Duration of each amplitude [s].")
    heading_deg: float = 0.0

    @property
    def duration_s(self) -> float:
        """Seconds the plan takes (:func:`~sizefx.scenarios.sway`'s trajectory is this long)."""
        return self.static_s + len(self.amplitudes_dps) * self.segment_s

    def check(self):
        if not (self.frequency_hz > 0 and self.static_s > 0 and self.segment_s > 0):
            raise ConfigError("sway: --frequency-hz, --static-s and --segment-s must be positive")
        if self.axis not in ("heading", "roll", "pitch"):
            raise ConfigError(f"sway axis '{self.axis}': use heading, roll or pitch")
        cycles = self.segment_s * self.frequency_hz
        if abs(cycles - round(cycles)) > 1e-9 or round(cycles) < 1:
            raise ConfigError(
                f"sway: {self.segment_s} s (--segment-s) at {self.frequency_hz} Hz (--frequency-hz) "
                "is not a whole number of periods; choose a segment that is"
            )


@dataclass
class FlightPlan:
    """A helicopter-like flight: align, take off, out, turn, back to the start, land.

    Rotor-induced vibration: angular (roll, pitch, yaw) and linear (N, E, D) at
    the first, second and fourth harmonics of ``rotor_hz``, fading in 120 s
    before take-off and out after landing. ``duration_s`` in seconds (the command line's
    ``--duration-h`` in hours).
    """

    duration_s: float = number(
        1.8 * SECONDS_PER_HOUR,
        unit="h",
        low=0.05,
        high=24.0,
        scale=SECONDS_PER_HOUR,
        flags=("--duration-h",),
        help="Flight record length [h].",
    )
    align_s: float = number(600.0, unit="s", low=1.0, high=86400.0, help="Static alignment before take-off [s].")
    speed_mps: float = number(40.0, unit="m/s", low=1.0, high=1000.0, help="Cruise ground speed [m/s].")
    altitude_m: float = number(300.0, unit="m", low=0.0, high=20000.0, help="Cruise height above the start [m].")
    heading_deg: float = number(45.0, unit="deg", low=-360.0, high=360.0, help="Outbound track [deg].")
    turn_rate_dps: float = 3.0
    rotor_hz: float = number(
        8.0, unit="Hz", low=1.0, high=200.0, help="Main rotor rate [Hz]; vibration at 1, 2 and 4 times it."
    )
    vib_rate_dps: tuple = (1.5, 1.0, 0.5)  #: roll, pitch, yaw rate amplitude at 1x rotor; halved at 2x, quartered at 4x
    vib_accel_mps2: tuple = (0.3, 0.3, 1.0)  #: N, E, D acceleration amplitude at 2x rotor
    cruise_pitch_deg: float = -3.0  #: nose-down attitude at cruise speed
    weave_deg: float = 10.0  #: S-turn manoeuvre on the way out (0: none)
    climb_step_m: float = 150.0  #: climb and descent manoeuvre on the way back (0: none)

    def check(self):
        """Nothing across the options: whether the record is long enough for the route is known when
        :func:`~sizefx.scenarios.flight` solves it."""


@dataclass
class TumblePlan:
    """A diagnosis record: the table tumbles about ``axes`` (see :func:`sizefx.scenarios.tumble`);
    ``axes`` is read in small letters."""

    duration_s: float = number(120.0, unit="s", low=1.0, high=86400.0, help="Record length [s].")
    axes: str = text(
        "zyx",
        flags=("--gimbals",),
        help="Gimbals that move: z heading, y pitch, x roll (z alone: rotation about the vertical only).",
    )
    amplitudes_deg: tuple = (120.0, 70.0, 80.0)
    freqs_hz: tuple = (0.05, 0.083, 0.117)

    def __post_init__(self):
        if isinstance(self.axes, str):
            self.axes = self.axes.lower()

    def check(self):
        if not self.axes or set(self.axes) - set("xyz"):
            raise ConfigError(
                f"--gimbals '{self.axes}': use a subset of x, y, z (e.g. zyx, or z for the vertical only)"
            )


#: scenario -> its plan's class, whose defaults make the plan (``sizefx simulate SCENARIO``)
SCENARIO_PLANS = {"turntable": TurntablePlan, "sway": SwayPlan, "flight": FlightPlan, "tumble": TumblePlan}
