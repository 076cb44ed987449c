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

from collections.abc import Callable

from .. import scenarios
from ..configs.simulate import NAVIGATION_REFERENCE_RATE_HZ, SimulateConfig
from ..effects import IDEAL, load_effects
from ..errors import ConfigError
from ..motion import Trajectory
from ..stage import preflight
from .record import CHUNK_SAMPLES, SimulateResult, simulate_in_memory, simulate_to_file
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
    "NAVIGATION_REFERENCE_RATE_HZ",
]


#: scenario -> (its builder, taking a plan and a site; its plan class, whose defaults make the plan):
#: the motions ``sizefx simulate`` knows
SCENARIOS: dict[str, tuple[Callable[..., tuple[Trajectory, dict]], type]] = {
    "turntable": (scenarios.turntable, scenarios.TurntablePlan),
    "sway": (scenarios.sway, scenarios.SwayPlan),
    "flight": (scenarios.flight, scenarios.FlightPlan),
    "tumble": (scenarios.tumble_scenario, scenarios.TumblePlan),
}


def run(config: SimulateConfig, *, progress=None) -> SimulateResult:
    """The ``simulate`` stage: build the scenario and the effect model, write ``config.output``.

    The options were checked when the config was made; the files first
    (:func:`sizefx.stage.preflight`), then the work. ``progress(done, total)`` is called after each chunk.
    """
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
    traj, info = build(plan or plan_cls(), config.site)
    fx = load_effects(config.effects_path, overrides=config.effect_overrides(), base=IDEAL if config.ideal else None)
    inputs = [p for p in (config.effects_path, config.plan_path) if p]
    return simulate_to_file(
        traj,
        info,
        fx,
        config.output,
        rate_hz=config.rate_hz,
        form=config.form,
        seed=config.seed,
        reference_rate_hz=config.scenario_reference_rate_hz(),
        force=config.force,
        chunk_samples=config.chunk_samples,
        inputs=inputs,
        progress=progress,
        check_units=config.check_units,
    )
