"""``sizefx plan``: turntable plans designed from the Fisher information.

- The prediction is what a calibration on the plan states (a simulated record's fit, within 5 %).
- The budget search beats the paper's plan in the paper's time; the least-time search is minimal.
- The plan file runs in ``sizefx simulate turntable --plan``; plans the table cannot run, and bad
  requests, are one line and exit code 2.
- With a wanted delay sigma the plan gains a sway, which ``sizefx simulate sway --plan`` runs; the
  delay's prediction is what the fit states, and the sway is the shortest that reaches it.

That the predicted sigmas are the seeds' scatter (within 15 %) is benchmarks/plan_calibrate.py's.
"""

from __future__ import annotations

import tomllib

import numpy as np
import pytest
from click.testing import CliRunner

from sizefx import plan as plan_stage
from sizefx import scenarios
from sizefx.calibrate import joint_fit, prepare
from sizefx.effects import load_effects
from sizefx.io.telemetry import read_telemetry
from sizefx.plan import PlanError, PlanRequest, TableLimits, design_plan, predict, sway_shape
from sizefx.simulate import simulate_in_memory
from sizefx_cli.main import main

SHORT_PLAN = scenarios.TurntablePlan(static_s=20.0, seconds_per_axis=48.0, cycles=2)
NOISE_UG = 2.96


def test_prediction_is_what_the_fit_states():
    """Same plan, white noise of the same density: the fit's sigmas within 5 % of the prediction
    (the fit estimates the noise level from its residuals: ~1 % on 200 s). At 400 Hz: the sigmas
    are set by the density, not the rate (seeds 2, 3, 4 put the arms' sigmas at most 1.6 % from the
    prediction at 400 Hz, as at 1600 Hz), in a quarter of the samples."""
    fx = load_effects(overrides={"accel_noise": {"density_ug_per_sqrt_hz": NOISE_UG, "bias_rw_ug_per_sqrt_h": 0.0}})
    tel = simulate_in_memory(scenarios.turntable(SHORT_PLAN)[0], fx, form="rates", seed=2, rate_hz=400.0)
    res = joint_fit([prepare(tel)])
    pred = predict(SHORT_PLAN, NOISE_UG)
    np.testing.assert_allclose(res.sigma_arms, pred.sigma_arms_m, rtol=0.05)
    np.testing.assert_allclose(res.sigma_tilt_rad, pred.sigma_tilt_rad, rtol=0.05)
    assert pred.duration_s == pytest.approx(scenarios.turntable(SHORT_PLAN)[0].duration_s)


# long tier: a budget search (4 s); fast twin: test_least_time_search_is_minimal
@pytest.mark.slow
def test_budget_search_beats_the_paper_in_its_time():
    paper = scenarios.TurntablePlan()
    design = design_plan(PlanRequest(NOISE_UG, TableLimits(), budget_s=paper.duration_s))
    assert design.prediction.duration_s <= paper.duration_s + 1e-6
    assert design.prediction.max_sigma_mm <= design.paper.max_sigma_mm * (1 + 1e-9)
    assert design.plan.peak_rate_dps <= 20.0 and design.plan.accel_dps2 <= 10.0


# long tier: a plan search (1.3 s), beside test_least_time_search_is_minimal; fast twin:
# test_prediction_is_what_the_fit_states
@pytest.mark.slow
def test_least_time_search_meets_its_target():
    target = 0.06
    design = design_plan(PlanRequest(NOISE_UG, TableLimits(), target_sigma_mm=target, static_s=10.0))
    assert design.prediction.max_sigma_mm <= target


# long tier: a search that needs two cycles (7 s of CPU); fast twin: test_least_time_search_meets_its_target
@pytest.mark.slow
def test_least_time_search_is_minimal():
    # a target that one cycle cannot meet (0.06 mm was met by one, and then there is no fewer to try)
    target = 0.05
    design = design_plan(PlanRequest(NOISE_UG, TableLimits(), target_sigma_mm=target, static_s=10.0))
    p = design.plan
    assert design.prediction.max_sigma_mm <= target
    assert p.cycles > 1, "the target must need more than one cycle for the check below to mean anything"
    fewer = scenarios.TurntablePlan(
        **{**p.__dict__, "cycles": p.cycles - 1, "seconds_per_axis": p.seconds_per_axis * (p.cycles - 1) / p.cycles}
    )
    assert predict(fewer, NOISE_UG).max_sigma_mm > target


def test_two_axes_leave_arms_unobservable():
    with pytest.raises(PlanError, match="unobservable"):
        design_plan(PlanRequest(NOISE_UG, TableLimits(axes="Z"), budget_s=300.0))


def test_plan_file_runs_in_simulate(plan_file, tmp_path):
    record = tmp_path / "turntable.h5"
    doc = tomllib.loads(plan_file.read_text())
    assert doc["schema"] == "sizefx/plan/1" and doc["designed_for"]["objective"] == "min-sigma"
    result = CliRunner().invoke(
        main, ["simulate", "turntable", "--plan", str(plan_file), "-o", str(record), "--rate-hz", "400", "-q"]
    )
    assert result.exit_code == 0, result.output
    tel = read_telemetry(record)
    assert tel.time_s[-1] == pytest.approx(doc["prediction"]["duration_s"], abs=0.01)


def _one_line_refusal(args, *, needle):
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.output, result.output
    assert needle in lines[0], lines[0]


@pytest.mark.parametrize("noise", ["0", "-1", "nan", "inf"])
def test_noise_must_be_positive_and_finite(noise):
    _one_line_refusal(["plan", "--noise-ug", noise, "--budget-s", "300"], needle="--noise-ug")


@pytest.mark.parametrize(
    "args, needle",
    [
        (["--budget-s", "300", "--target-sigma-mm", "0.05"], "either"),
        ([], "either"),
        (["--budget-s", "300", "--vertical-axes", "XQ"], "table axes"),
        (["--budget-s", "300", "--vertical-axes", "XX"], "table axes"),
        (["--budget-s", "40"], "--budget-s 40"),
        # long tier: the search runs to its limit before it refuses (4 s); fast twin: budget-too-short
        pytest.param(["--target-sigma-mm", "1e-7"], "--target-sigma-mm", marks=pytest.mark.slow),
    ],
    ids=["both", "neither", "bad-axis", "axis-twice", "budget-too-short", "unreachable-sigma"],
)
def test_requests_no_plan_can_meet_are_one_line(args, needle):
    _one_line_refusal(["plan", "--noise-ug", "2.96", *args], needle=needle)


@pytest.fixture(scope="module")
def plan_text(tmp_path_factory):
    """A plan as ``sizefx plan`` writes it (200 s budget): designed once for this module."""
    path = tmp_path_factory.mktemp("plan") / "plan.toml"
    result = CliRunner().invoke(
        main, ["plan", "--noise-ug", str(NOISE_UG), "--budget-s", "200", "--static-s", "10", "-o", str(path)]
    )
    assert result.exit_code == 0, result.output
    return path.read_text()


@pytest.fixture
def plan_file(plan_text, tmp_path):
    """A copy of the plan each test may edit."""
    path = tmp_path / "plan.toml"
    path.write_text(plan_text)
    return path


@pytest.mark.parametrize(
    "key, value, needle",
    [
        ("peak_rate_dps", "40.0", "above the table's max_rate_dps"),
        ("accel_dps2", "25.0", "above the table's max_accel_dps2"),
        ("axes", '"XYZ"', None),
    ],
    ids=["rate", "acceleration", "axes-ok"],
)
def test_a_plan_the_table_cannot_run_is_refused(plan_file, tmp_path, key, value, needle):
    text = plan_file.read_text()
    edited = "\n".join(f"{key} = {value}" if line.startswith(f"{key} =") else line for line in text.splitlines())
    if needle is None:  # the same axes: runs; a table that reaches fewer refuses it
        edited = edited.replace('axes = "XYZ"\nreposition_s', 'axes = "XY"\nreposition_s')
        needle = "cannot reach"
    plan_file.write_text(edited)
    _one_line_refusal(["simulate", "turntable", "--plan", str(plan_file), "-o", str(tmp_path / "t.h5")], needle=needle)
    assert not (tmp_path / "t.h5").exists()


def test_plan_with_plan_options_is_refused(plan_file, tmp_path):
    _one_line_refusal(
        ["simulate", "turntable", "--plan", str(plan_file), "--cycles", "3", "-o", str(tmp_path / "t.h5")],
        needle="--cycles",
    )


def test_plan_never_overwrites_its_input(plan_file):
    _one_line_refusal(
        ["simulate", "turntable", "--plan", str(plan_file), "-o", str(plan_file), "--force"], needle=str(plan_file)
    )


@pytest.mark.parametrize(
    "text, needle",
    [
        ('schema = "sizefx/plan/1"\n[turntable]\naxes = "YXZ"\n', "seconds_per_axis"),
        (
            'schema = "sizefx/plan/1"\n[turntable]\naxes = "YXZ"\nseconds_per_axis = 120.0\ncycles = "five"\n'
            "peak_rate_dps = 20.0\naccel_dps2 = 10.0\n",
            "cycles",
        ),
        (
            'schema = "sizefx/plan/1"\n[turntable]\naxes = "YXZ"\nseconds_per_axis = 120.0\ncycles = 5\n'
            "peak_rate_dps = 1e9\naccel_dps2 = 10.0\n",
            "peak_rate_dps",
        ),
        (
            'schema = "sizefx/plan/1"\n[turntable]\naxes = "YXZ"\nseconds_per_axis = 2.0\ncycles = 5\n'
            "peak_rate_dps = 20.0\naccel_dps2 = 10.0\n",
            "leave no time",
        ),
        ('schema = "sizefx/levers/1"\n', "schema"),
        ("[turntable\n", "plan file"),
    ],
    ids=["missing-keys", "wrong-type", "absurd-rate", "no-time", "other-schema", "not-toml"],
)
def test_malformed_plan_files_are_one_line(tmp_path, text, needle):
    path = tmp_path / "plan.toml"
    path.write_text(text)
    _one_line_refusal(["simulate", "turntable", "--plan", str(path), "-o", str(tmp_path / "t.h5")], needle=needle)
    assert not (tmp_path / "t.h5").exists()


#: A request with the delay's sway: the turntable's budget and the delay sigma small enough to
#: run in a test (the sway 43 s, the whole plan 200 s). The sway is the same with a 400 s budget;
#: 200 s leave less turntable plan to search (twice, before and after the sway), a fifth of the time.
DELAY_REQUEST = PlanRequest(
    NOISE_UG, TableLimits(sway_axes="XY"), budget_s=200.0, static_s=10.0, target_delay_sigma_us=2.0
)


@pytest.fixture(scope="module")
def delay_plan(tmp_path_factory):
    """The delay plan as ``sizefx plan`` writes it, and the design the command computed for it (the
    search, 1.8 s, runs once for this module): ``(text, design)``. The command's request is
    :data:`DELAY_REQUEST`."""
    path = tmp_path_factory.mktemp("delay-plan") / "plan.toml"
    results, run = [], plan_stage.run

    def recording_run(config, **kwargs):
        results.append(run(config, **kwargs))
        return results[-1]

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(plan_stage, "run", recording_run)  # the command imports run from sizefx.plan when it runs
        result = CliRunner().invoke(
            main,
            [
                "plan",
                "--noise-ug",
                "2.96",
                "--budget-s",
                "200",
                "--static-s",
                "10",
                "--delay-sigma-us",
                "2",
                "--sway-axes",
                "XY",
                "-o",
                str(path),
            ],
        )
    assert result.exit_code == 0, result.output
    assert "delay sway" in result.output and "simulate sway --plan" in path.read_text()
    assert len(results) == 1 and results[0].design.request == DELAY_REQUEST.check()
    return path.read_text(), results[0].design


@pytest.fixture(scope="module")
def delay_design(delay_plan):
    return delay_plan[1]


def test_sway_stays_within_the_table(delay_design):
    """The sway's rate amplitude, its acceleration amplitude and its swing within the table's limits
    and SWAY_MAX_ANGLE_DEG; the whole plan within the budget."""
    w, table = delay_design.sway, DELAY_REQUEST.table
    amplitude, period = sway_shape(table)
    assert w is not None and w.amplitudes_dps == (amplitude,) and w.frequency_hz == pytest.approx(1 / period)
    assert amplitude <= table.max_rate_dps and 2 * np.pi * amplitude / period <= table.max_accel_dps2
    assert amplitude * period / (2 * np.pi) <= 30.0 + 1e-9
    assert delay_design.prediction.duration_s == pytest.approx(delay_design.plan.duration_s + w.duration_s)
    assert delay_design.prediction.duration_s <= DELAY_REQUEST.budget_s + 1e-6


# long tier: simulates and fits a sway (5 s); fast twin: test_prediction_is_what_the_fit_states
@pytest.mark.slow
def test_delay_prediction_is_what_the_fit_states(delay_design):
    """The designed turntable plan and sway simulated with white noise of the request's density:
    the fit's delay sigma (and arms) within 5 % of the prediction, and the delay found within 4 sigma."""
    fx = load_effects(
        overrides={
            "accel_noise": {"density_ug_per_sqrt_hz": NOISE_UG, "bias_rw_ug_per_sqrt_h": 0.0},
            "accel_delay": {"enabled": True, "tau_s": 0.3e-3},
        }
    )
    records = [
        prepare(simulate_in_memory(scenarios.turntable(delay_design.plan)[0], fx, form="rates", seed=4), "turntable"),
        prepare(simulate_in_memory(scenarios.sway(delay_design.sway)[0], fx, form="rates", seed=5), "sway"),
    ]
    res = joint_fit(records, with_delay=True)
    pred = delay_design.prediction
    assert res.sigma_delay_s == pytest.approx(pred.sigma_delay_s, rel=0.05)
    assert pred.sigma_delay_s <= DELAY_REQUEST.target_delay_sigma_us * 1e-6
    np.testing.assert_allclose(res.sigma_arms, pred.sigma_arms_m, rtol=0.05)
    assert abs(res.delay_s - 0.3e-3) < 4 * res.sigma_delay_s


def test_least_sway_is_minimal(delay_design):
    """One period fewer misses the wanted delay sigma."""
    w = delay_design.sway
    periods = round(w.segment_s * w.frequency_hz)
    assert periods > 1
    fewer = scenarios.SwayPlan(**{**w.__dict__, "segment_s": (periods - 1) / w.frequency_hz})
    assert predict(delay_design.plan, NOISE_UG, fewer).sigma_delay_s > DELAY_REQUEST.target_delay_sigma_us * 1e-6


@pytest.fixture
def delay_plan_file(delay_plan, tmp_path):
    """A copy of the delay plan each test may edit."""
    path = tmp_path / "plan.toml"
    path.write_text(delay_plan[0])
    return path


def test_plan_sway_runs_in_simulate(delay_plan_file, tmp_path):
    doc = tomllib.loads(delay_plan_file.read_text())
    record = tmp_path / "sway.h5"
    result = CliRunner().invoke(
        main, ["simulate", "sway", "--plan", str(delay_plan_file), "-o", str(record), "--rate-hz", "400", "-q"]
    )
    assert result.exit_code == 0, result.output
    sway = doc["sway"]
    assert read_telemetry(record).time_s[-1] == pytest.approx(sway["static_s"] + sway["segment_s"], abs=0.01)
    assert doc["prediction"]["sigma_delay_us"] <= 2.0


@pytest.mark.parametrize(
    "args, needle",
    [
        (["--delay-sigma-us", "1"], "--sway-axes"),
        (["--delay-sigma-us", "1", "--sway-axes", "Z"], "sway axes"),
        # with the 100 s budget the turntable plan is searched in a quarter of the time 400 s take;
        # no sway reaches 1e-6 us with either
        (["--delay-sigma-us", "1e-6", "--sway-axes", "X", "--budget-s", "100"], "--delay-sigma-us"),
        # 100 s holds a turntable plan alone, not with the 43 s sway
        (["--delay-sigma-us", "2", "--sway-axes", "XY", "--budget-s", "100"], "after the delay's sway"),
    ],
    ids=["no-sway-axes", "bad-sway-axis", "unreachable-delay", "budget-too-short-for-the-sway"],
)
def test_delay_requests_no_plan_can_meet_are_one_line(args, needle):
    extra = [] if "--budget-s" in args else ["--budget-s", "400"]
    _one_line_refusal(["plan", "--noise-ug", "2.96", "--static-s", "10", *extra, *args], needle=needle)


@pytest.mark.parametrize(
    "key, value, needle",
    [
        ("amplitude_dps", "25.0", "above the table's max_rate_dps"),
        ("frequency_hz", "1.0", "above the table's max_accel_dps2"),
        ("axis", '"pitch"', "cannot swing about"),
    ],
    ids=["rate", "acceleration", "axis"],
)
def test_a_sway_the_table_cannot_run_is_refused(delay_plan_file, tmp_path, key, value, needle):
    lines = delay_plan_file.read_text().splitlines()
    start = lines.index("[sway]")
    lines = [f"{key} = {value}" if k > start and line.startswith(f"{key} =") else line for k, line in enumerate(lines)]
    if key == "axis":  # a table that swings about body x only cannot pitch
        lines = ['sway_axes = "X"' if line.startswith("sway_axes =") else line for line in lines]
    delay_plan_file.write_text("\n".join(lines) + "\n")
    _one_line_refusal(["simulate", "sway", "--plan", str(delay_plan_file), "-o", str(tmp_path / "s.h5")], needle=needle)
    assert not (tmp_path / "s.h5").exists()


def test_sway_from_a_plan_without_one_is_refused(plan_file, tmp_path):
    _one_line_refusal(["simulate", "sway", "--plan", str(plan_file), "-o", str(tmp_path / "s.h5")], needle="no [sway]")


def test_sway_plan_with_sway_options_is_refused(delay_plan_file, tmp_path):
    _one_line_refusal(
        ["simulate", "sway", "--plan", str(delay_plan_file), "--axis", "roll", "-o", str(tmp_path / "s.h5")],
        needle="--axis",
    )
