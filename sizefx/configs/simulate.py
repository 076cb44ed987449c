"""What ``sizefx simulate SCENARIO -o OUTPUT`` is asked (:class:`SimulateConfig`); the stage is
:mod:`sizefx.simulate`, the scenarios' plans :mod:`sizefx.configs.scenarios`."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from ..errors import ConfigError
from ..options import (
    check_options,
    choice,
    declared,
    force,
    group,
    integer,
    number,
    numbers,
    one_of,
    path,
    switch,
    text,
)
from .scenarios import SCENARIO_PLANS, FlightPlan, SiteSpec, SwayPlan, TumblePlan, TurntablePlan

__all__ = ["SimulateConfig", "CHUNK_SAMPLES", "NAVIGATION_REFERENCE_RATE_HZ", "reference_rate"]

#: Default IMU samples per chunk: 2^16 samples keeps the working set of the
#: vectorised kinematics (about 40 arrays of [3 * 65536, 3]) near 100 MB.
CHUNK_SAMPLES = 1 << 16
#: Reference rate of the navigation-length records (sway, flight) when none is
#: given: the 1.8 h flight at 1600 Hz would add 900 MB of reference, and 100 Hz
#: resolves their 1 Hz sway and manoeuvres. The turntable keeps the IMU rate,
#: which calibration and diagnosis use sample by sample.
NAVIGATION_REFERENCE_RATE_HZ = 100.0
#: The scenarios whose plan a plan file (``sizefx plan``) holds: the turntable, and its delay's sway.
PLAN_FILE_SCENARIOS = ("turntable", "sway")

#: Help of simulate's --no-units-check: what it writes, and which readers then refuse the record
#: (inspect by the whole check unless told; the others by the reader's median magnitudes, always).
NO_UNITS_CHECK_HELP = (
    "Write the record even if the physics check of sizefx inspect would refuse it (median specific force "
    "or rate outside what an IMU on Earth reads, specific force at rest far from gravity, gyros that "
    "disagree with the reference): for records that test the checkers. sizefx inspect then needs "
    "--no-units-check too; navigate, calibrate, compensate, diagnose and compare refuse such a record "
    "when its median specific force or rate is implausible (they have no such option), and read it otherwise."
)


def reference_rate(rate_hz: float, reference_rate_hz: float | None) -> float:
    """The reference rate, checked: it must divide the IMU rate (default: the IMU rate)."""
    ref_rate = rate_hz if reference_rate_hz is None else float(reference_rate_hz)
    stride = rate_hz / ref_rate
    if abs(stride - round(stride)) > 1e-9 or stride < 1:
        raise ConfigError(
            f"--reference-rate-hz {ref_rate:g} must divide the IMU rate {rate_hz:g} Hz "
            "(e.g. 100, 200, 400, 800 for 1600 Hz)"
        )
    return ref_rate


def _parse_sets(items) -> dict:
    """``("accel_delay.tau_s=0.0005", ...)`` -> ``{"accel_delay": {"tau_s": 0.0005}}`` (values in TOML syntax)."""
    from ..io.documents import parse_toml  # the TOML reader: when a config is made, not for --help

    out: dict = {}
    for item in items:
        key, sep, value = item.partition("=")
        section, dot, name = key.strip().partition(".")
        if not sep or not dot:
            raise ConfigError(f"--set '{item}': write SECTION.KEY=VALUE, e.g. accel_delay.tau_s=0.0005")
        try:
            parsed = parse_toml(f"v = {value.strip()}", f"--set {key.strip()}")["v"]
        except ConfigError:
            shown = value if len(value) <= 60 else value[:60] + "..."
            raise ConfigError(
                f"--set '{key.strip()}={shown}': not a TOML value (numbers, true/false, "
                '"text", [1, 2, 3]) of reasonable size'
            ) from None
        out.setdefault(section, {})[name] = parsed
    return out


@dataclass(frozen=True)
class SimulateConfig:
    """``sizefx simulate SCENARIO -o OUTPUT``: the motion, the effects, the sampling, the output.

    ``plan``: the scenario's plan (:class:`~sizefx.configs.scenarios.TurntablePlan`, ``SwayPlan``,
    ``FlightPlan``, ``TumblePlan``; None: its defaults), its options checked here. ``effects_path``:
    an effects TOML (``--effects``); ``overrides``: effect parameters in the TOML's layout
    (``{"accel_delay": {"enabled": True}}``), to which ``sets`` (``--set SECTION.KEY=VALUE``),
    ``geometry`` and ``offset_mm`` add (:meth:`effect_overrides`); ``ideal`` switches every effect off
    before both, so ``ideal`` plus ``overrides`` gives a record with exactly the named effects.
    ``reference_rate_hz`` None: the IMU rate for turntable and tumble,
    :data:`NAVIGATION_REFERENCE_RATE_HZ` for sway and flight. ``plan_path``: a sizefx/plan/1 file
    (``sizefx plan``): its turntable plan (or, for the sway scenario, its delay sway), instead of
    ``plan``. ``check_units``: refuse a record ``sizefx inspect`` would refuse by its physics check.
    """

    scenario: str = choice(None, tuple(SCENARIO_PLANS), argument="SCENARIO", help="The motion simulated.")
    output: str | Path = path(
        required=True, flags=("-o", "--output"), help="Telemetry file to write (HDF5, sizefx/telemetry/1)."
    )
    rate_hz: float = number(1600.0, unit="Hz", low=1.0, high=1e5, help="IMU sample rate [Hz].")
    form: str = choice(
        "rates",
        ("rates", "increments"),
        help="Output rates (gyro [rad/s], accel [m/s^2]) or increments (dtheta [rad], dvel [m/s]).",
    )
    seed: int = integer(0, low=0, high=2**63 - 1, help="Seed of every noise stream.")  # numpy's seeds
    effects_path: str | None = path(
        flags=("--effects",), help="Effect model (TOML, sizefx/effects/1); see 'sizefx simulate --print-effects'."
    )
    ideal: bool = switch(help="Start from a point IMU with perfect, noiseless sensors (then --effects, --set).")
    sets: tuple = text(
        many=True,
        flags=("--set",),
        metavar="SECTION.KEY=VALUE",
        help="Override one effect parameter, e.g. --set accel_delay.enabled=true "
        "--set accel_delay.tau_s=0.0005 (repeatable; units as in the key name).",
    )
    geometry: str | None = choice(
        None,
        ("high-precision", "compact", "none"),
        help="Accelerometer arms d_i: a preset of the paper [default: from the effects, high-precision].",
    )
    offset_mm: tuple | None = numbers(
        unit="mm",
        count=3,
        metavar="X,Y,Z",
        help="Offset r from the rotation centre to the triad point, body axes [mm] (sets lever_arm.r_vehicle_m).",
    )
    reference_rate_hz: float | None = number(
        unit="Hz",
        low=1.0,
        high=1e5,
        help="Rate of /reference [Hz]; must divide the IMU rate [default: turntable and tumble the IMU rate; "
        "sway, flight 100].",
    )
    site: SiteSpec = group(SiteSpec)
    check_units: bool = switch(True, flags=("--no-units-check",), sets=False, help=NO_UNITS_CHECK_HELP)
    force: bool = force()
    plan: TurntablePlan | SwayPlan | FlightPlan | TumblePlan | None = one_of("scenario", SCENARIO_PLANS)
    plan_path: str | None = path(
        flags=("--plan",),
        help="Run the plan in this file (sizefx/plan/1, written by sizefx plan; the sway scenario runs its "
        "delay's sway, sizefx plan --delay-sigma-us) instead of the options above.",
    )
    overrides: Mapping | None = None  #: effect parameters in the TOML's layout (Python; ``--set`` adds to them)
    chunk_samples: int = CHUNK_SAMPLES  #: IMU rows per chunk (memory; the output does not depend on it)

    def __post_init__(self):
        if self.site is None:  # the paper's airfield, as a site left out
            object.__setattr__(self, "site", SiteSpec())
        check_options(self)
        if self.plan_path and self.scenario not in PLAN_FILE_SCENARIOS:
            raise ConfigError(
                f"--plan {self.plan_path}: a plan file holds a turntable plan and a sway; the "
                f"{self.scenario} scenario takes its own options"
            )
        if self.plan_path and self.plan is not None:
            raise ConfigError(
                f"--plan {self.plan_path} holds the plan; leave out {', '.join(self._plan_options())} "
                "(or edit the plan file)"
            )
        reference_rate(self.rate_hz, self.scenario_reference_rate_hz())
        if self.plan is not None:
            self.plan.check()
        self.effect_overrides()  # a bad --set is refused now, not after the motion is built

    def scenario_reference_rate_hz(self) -> float | None:
        """``reference_rate_hz``, or the scenario's when it is None (sway and flight:
        :data:`NAVIGATION_REFERENCE_RATE_HZ`; None, the IMU rate, for the others)."""
        if self.reference_rate_hz is None and self.scenario in ("sway", "flight"):
            return NAVIGATION_REFERENCE_RATE_HZ
        return self.reference_rate_hz

    def _plan_options(self) -> list:
        """The scenario's options that ``plan`` sets away from their defaults (all of them when it
        sets none: the user repeated a default)."""
        plan_class = SCENARIO_PLANS[self.scenario]
        default = plan_class()
        options = declared(plan_class)
        named = [o.name for name, o in options if getattr(self.plan, name) != getattr(default, name)]
        return named or [o.name for _, o in options]

    def effect_overrides(self) -> dict:
        """The effect parameters to set over the effects file (or the defaults): ``overrides``,
        then ``--set``, then ``--geometry`` and ``--offset-mm`` (each switching the lever arms on)."""
        out = dict(self.overrides or {})

        def section(name: str) -> dict:  # a copy of one section, to add to (the caller's stays as it is)
            out[name] = dict(out[name]) if isinstance(out.get(name), Mapping) else {}
            return out[name]

        for name, values in _parse_sets(self.sets).items():
            section(name).update(values)
        if self.geometry:
            lever = section("lever_arm")
            lever["preset"] = self.geometry
            lever.setdefault("enabled", True)
        if self.offset_mm:
            lever = section("lever_arm")
            lever["r_vehicle_m"] = [v / 1000.0 for v in self.offset_mm]
            lever.setdefault("enabled", True)
        return out

    def inputs(self) -> dict:
        return {"--effects": self.effects_path, "--plan": self.plan_path}

    def outputs(self) -> dict:
        return {"-o": self.output}
