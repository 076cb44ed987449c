"""Simulated IMU telemetry with known truth: the ``simulate`` stage.

The ideal outputs follow exactly from the analytic motion (:mod:`sizefx.motion`):

* gyros read ``omega_ib_b = omega_nb_b + mat_bn (omega_ie_n + omega_en_n)``;
* the reference point feels ``f_b = mat_bn (vdot_n + (2 omega_ie_n + omega_en_n) x v_n - g_n)``
  (the NED velocity equation, Groves eq. 5.54, solved for f);
* ``mat_nb`` is the true attitude of the IMU: the trajectory's, tilted by ``[level_tilt]`` and
  turned by ``[reference_mount]`` (:func:`sizefx.sensor_model.true_attitude`; ``omega_nb_b``
  turns with it, :func:`sizefx.sensor_model.mount_matrix`); ``/reference`` reports the
  trajectory's own (untilted, the reference's body axes), late by ``[reference_delay]``
  (:func:`sizefx.sensor_model.reported_time`);
* what the sensors make of this true motion is the sensor model's forward map
  (:func:`sizefx.sensor_model.sample`: lever arms, accelerometer delay, biases, scale factors,
  misalignments, quadratic term, g-sensitivity), per instant, before integration;
* increments are the integrals of these over each sample interval by
  three-point Gauss-Legendre quadrature (error below 1e-12 of the signal for
  motion content under 100 Hz at 1600 Hz sampling).

Then per sample white noise, bias random walks and quantisation. Noise streams are drawn
from one seed, each stream in sample order, so the output does not depend on the chunk size
and switching one effect on does not change another's noise.

The package, from the bottom up:

- :mod:`.truth`: the true motion and the ideal readings (:func:`true_motion`, :func:`kinematics`);
- :mod:`.synthesizer`: the samples, chunk by chunk, with their noise (:class:`ImuSynthesizer`);
- :mod:`.refusals`: what refuses a record before it is published (the contract's sample limits,
  ``sizefx inspect``'s physics check), naming the effects;
- :mod:`.record`: a record streamed into a file (:func:`simulate_to_file`) or made in memory
  (:func:`simulate_in_memory`);
- here: the scenarios ``sizefx simulate`` knows (:data:`SCENARIOS`) and the stage.

The stage: :class:`SimulateConfig` -> :func:`run` -> :class:`SimulateResult`, as ``sizefx
simulate`` calls it::

    from sizefx.simulate import SimulateConfig, run
    res = run(SimulateConfig("turntable", "tt.h5", plan=scenarios.TurntablePlan(axes="Z"), seed=3))
    print(res.report())
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

from .. import scenarios
from ..effects import IDEAL, load_effects
from ..errors import ConfigError
from ..motion import Trajectory
from ..stage import preflight
from .record import CHUNK_SAMPLES, SimulateResult, _reference_rate, simulate_in_memory, simulate_to_file
from .synthesizer import GAUSS_NODES, GAUSS_WEIGHTS, ImuSynthesizer
from .truth import ImuKinematics, kinematics, true_motion

__all__ = [
    "ImuKinematics",
    "kinematics",
    "true_motion",
    "ImuSynthesizer",
    "simulate_to_file",
    "simulate_in_memory",
    "SimulateConfig",
    "SimulateResult",
    "run",
    "SCENARIOS",
    "GAUSS_NODES",
    "GAUSS_WEIGHTS",
    "CHUNK_SAMPLES",
]


#: Reference rate of the navigation-length records (sway, flight) when none is
#: given: the 1.8 h flight at 1600 Hz would add 900 MB of reference, and 100 Hz
#: resolves their 1 Hz sway and manoeuvres. The turntable keeps the IMU rate,
#: which calibration and diagnosis use sample by sample.
NAVIGATION_REFERENCE_RATE_HZ = 100.0

#: scenario -> (builder, its plan's class): the motions ``sizefx simulate`` knows.
#: scenario -> (its builder, taking a plan and a site; its plan class, whose defaults make the plan)
SCENARIOS: dict[str, tuple[Callable[..., tuple[Trajectory, dict]], type]] = {
    "turntable": (scenarios.turntable, scenarios.TurntablePlan),
    "sway": (scenarios.sway, scenarios.SwayPlan),
    "flight": (scenarios.flight, scenarios.FlightPlan),
    "tumble": (scenarios.tumble_scenario, scenarios.TumblePlan),
}


@dataclass(frozen=True)
class SimulateConfig:
    """``sizefx simulate SCENARIO -o OUTPUT``: the motion, the effects, the sampling, the output.

    ``plan``: the scenario's plan (:class:`sizefx.scenarios.TurntablePlan`, ``SwayPlan``,
    ``FlightPlan``, ``TumblePlan``; None: its defaults). ``effects_path``: an effects TOML
    (``--effects``); ``overrides``: ``--set`` values in the TOML's layout
    (``{"accel_delay": {"enabled": True}}``); ``ideal`` switches every effect off before both,
    so ``ideal`` plus ``overrides`` gives a record with exactly the named effects.
    ``reference_rate_hz`` None: the IMU rate for turntable and tumble,
    :data:`NAVIGATION_REFERENCE_RATE_HZ` for sway and flight.
    """

    scenario: str
    output: str | Path
    plan: object | None = None
    site: scenarios.SiteSpec | None = None
    effects_path: str | None = None
    overrides: Mapping | None = None
    ideal: bool = False
    rate_hz: float = 1600.0
    form: str = "rates"
    seed: int = 0
    reference_rate_hz: float | None = None
    force: bool = False
    chunk_samples: int = CHUNK_SAMPLES  #: IMU rows per chunk (memory; the output does not depend on it)
    #: a sizefx/plan/1 file (``sizefx plan``): its turntable plan (or, for the sway scenario, its
    #: delay sway), instead of ``plan``
    plan_path: str | None = None
    #: refuse a record ``sizefx inspect`` would refuse by its physics check (``--no-units-check``: write it
    #: anyway, to test the checkers)
    check_units: bool = True

    def inputs(self) -> dict:
        return {"--effects": self.effects_path, "--plan": self.plan_path}

    def outputs(self) -> dict:
        return {"-o": self.output}


def run(config: SimulateConfig, *, progress=None) -> SimulateResult:
    """The ``simulate`` stage: build the scenario and the effect model, write ``config.output``.

    Options first (scenario, form, rates), then the files (:func:`sizefx.stage.preflight`),
    then the work. ``progress(done, total)`` is called after each chunk.
    """
    if config.scenario not in SCENARIOS:
        raise ConfigError(f"scenario '{config.scenario}': use one of {', '.join(SCENARIOS)}")
    if config.form not in ("rates", "increments"):
        raise ConfigError(f"--form {config.form}: use rates or increments")
    reference_rate_hz = config.reference_rate_hz
    if reference_rate_hz is None and config.scenario in ("sway", "flight"):
        reference_rate_hz = NAVIGATION_REFERENCE_RATE_HZ
    _reference_rate(config.rate_hz, reference_rate_hz)
    if config.plan_path and config.scenario not in ("turntable", "sway"):
        raise ConfigError(
            f"--plan {config.plan_path}: a plan file holds a turntable plan and a sway; the "
            f"{config.scenario} scenario takes its own options"
        )
    preflight(inputs=config.inputs(), outputs=config.outputs(), force=config.force)
    build, plan_cls = SCENARIOS[config.scenario]
    plan = config.plan
    if config.plan_path:
        from ..io.plan_file import read_plan_document

        doc = read_plan_document(config.plan_path)
        if config.scenario == "turntable":
            plan = scenarios.TurntablePlan(**doc["turntable"])
        elif "sway" not in doc:
            raise ConfigError(
                f"{config.plan_path}: the plan has no [sway] (the accelerometers' delay's); design one "
                "with sizefx plan --delay-sigma-us and --sway-axes"
            )
        else:
            w = doc["sway"]
            plan = scenarios.SwayPlan(
                axis=w["axis"],
                amplitudes_dps=(w["amplitude_dps"],),
                frequency_hz=w["frequency_hz"],
                static_s=w["static_s"],
                segment_s=w["segment_s"],
            )
        try:
            plan.check()
        except ConfigError as exc:
            raise ConfigError(f"{config.plan_path}: {exc}") from None
    traj, info = build(plan or plan_cls(), config.site or scenarios.PAPER_AIRFIELD)
    fx = load_effects(config.effects_path, overrides=dict(config.overrides or {}), base=IDEAL if config.ideal else None)
    inputs = [p for p in (config.effects_path, config.plan_path) if p]
    return simulate_to_file(
        traj,
        info,
        fx,
        config.output,
        rate_hz=config.rate_hz,
        form=config.form,
        seed=config.seed,
        reference_rate_hz=reference_rate_hz,
        force=config.force,
        chunk_samples=config.chunk_samples,
        inputs=inputs,
        progress=progress,
        check_units=config.check_units,
    )
