"""Consistent inputs or a refusal (issue 28, item 7).

- A levers file describes one geometry: ``r_i = offset + d_i`` (within
  ``LEVER_CHAIN_TOLERANCE_M``) and, when it gives ``axes``, three unit, independent sensitive axes,
  row i along body axis +i. Anything else, and NaN, is one line naming the file and the field, exit
  code 2, in the single command and up front in a batch or a chain.
- Every value ``simulate --set`` accepts writes finite readings: a quantisation step of 0 is no
  quantisation; NaN, inf and values beyond a key's range are refused before anything is simulated.
- ``sizefx plan`` refuses a budget longer than the longest plan calibrate can use before it
  searches; above ``BLOCK_MAX_S`` per axis its screening rests on the information being additive
  over repeated cycles, which is checked here.
"""

from __future__ import annotations

import json
from dataclasses import replace
from importlib import resources

import numpy as np
import pytest
from click.testing import CliRunner
from support import write_raw

from sizefx import scenarios
from sizefx.constants import MAX_PLAN_S, MAX_WHOLE_READ_ROWS
from sizefx.effects import IDEAL, load_effects
from sizefx.errors import ConfigError
from sizefx.levers import AXIS_LENGTH_TOLERANCE, LEVER_CHAIN_TOLERANCE_M, levers_from_preset, read_levers, write_levers
from sizefx.plan import PlanError, PlanRequest, _fisher, _one_bias_per_channel
from sizefx.simulate import ImuSynthesizer, SimulateConfig, simulate_to_file
from sizefx_cli.main import main

NOISE_UG = 2.96


def _levers(tmp_path, change=None, name="lev.json"):
    """A good levers file (the high-precision preset 10 mm off centre), changed by ``change(doc)``."""
    path = tmp_path / name
    write_levers(path, levers_from_preset("high-precision", offset_m=(0.01, 0.0, 0.0)))
    if change is not None:
        doc = json.loads(path.read_text())
        change(doc)
        path.write_text(json.dumps(doc))
    return path


def _set(key, value):
    def change(doc):
        doc[key] = value

    return change


def _refused(result, *words):
    """Exit code 2, one line ``sizefx: error: ...`` holding ``words``, no traceback."""
    lines = result.output.strip().splitlines()
    assert result.exit_code == 2, result.output
    assert len(lines) == 1 and lines[0].startswith("sizefx: error:"), result.output
    assert "Traceback" not in result.output
    for w in words:
        assert w in lines[0], lines[0]


# --------------------------------------------------------------------------- levers: the arms


def test_arms_that_disagree_with_offset_plus_d_are_refused_naming_the_field(tmp_path):
    path = _levers(tmp_path, _set("r_y", [0.01, 10.0249, 0.0]))  # d_y = (0, 0.0249, 0): 10 m off
    with pytest.raises(ConfigError) as info:
        read_levers(path)
    message = str(info.value)
    assert message.startswith(f"{path}: $.r_y[1] = 10.0249 m disagrees with $.offset[1] + $.d_y[1]")
    assert "r_i = offset + d_i" in message and "\n" not in message


@pytest.mark.parametrize("fraction, accepted", [(0.5, True), (2.0, False)])
def test_the_arm_tolerance_is_the_stated_one(tmp_path, fraction, accepted):
    """Half the tolerance (a hand-typed file's rounding is below it) is read; twice it is not."""
    miss = fraction * LEVER_CHAIN_TOLERANCE_M
    path = _levers(tmp_path, _set("r_z", [0.01, 0.0, 0.0249 + miss]))
    if accepted:
        np.testing.assert_allclose(read_levers(path).arms_total[2], [0.01, 0.0, 0.0249 + miss])
    else:
        with pytest.raises(ConfigError, match=r"\$\.r_z\[2\]"):
            read_levers(path)


# --------------------------------------------------------------------------- levers: the axes

BAD_AXES = {
    "two identical": ([[1, 0, 0], [1, 0, 0], [0, 0, 1]], "not three independent directions"),
    "nearly parallel": ([[1, 0, 0], [0.9998, 0.02, 0], [0, 0, 1]], "$.axes[0] and $.axes[1] are 1.15 deg from"),
    "zero length": ([[1, 0, 0], [0, 0, 0], [0, 0, 1]], "$.axes[1] has length 0, not 1"),
    "not unit": ([[2, 0, 0], [0, 1, 0], [0, 0, 1]], "$.axes[0] has length 2, not 1"),
    "swapped": ([[0, 1, 0], [1, 0, 0], [0, 0, 1]], "$.axes[0] = [0.0, 1.0, 0.0] is not nearest body axis +x"),
    "reversed": ([[1, 0, 0], [0, 1, 0], [0, 0, -1]], "$.axes[2] = [0.0, 0.0, -1.0] is not nearest body axis +z"),
}


@pytest.mark.parametrize("case", list(BAD_AXES))
def test_degenerate_axes_are_refused(tmp_path, case):
    axes, words = BAD_AXES[case]
    path = _levers(tmp_path, _set("axes", axes))
    with pytest.raises(ConfigError) as info:
        read_levers(path)
    assert str(info.value).startswith(f"{path}: ") and words in str(info.value), str(info.value)


def test_axes_typed_to_three_decimals_are_read_as_unit_vectors(tmp_path):
    row = [0.999, 0.044, 0.0]  # 2.5 deg off x, length 1 - 6.3e-5
    assert abs(np.linalg.norm(row) - 1.0) < AXIS_LENGTH_TOLERANCE
    back = read_levers(_levers(tmp_path, _set("axes", [row, [0, 1, 0], [0, 0, 1]])))
    np.testing.assert_allclose(back.axes[0], np.asarray(row) / np.linalg.norm(row), rtol=0, atol=1e-15)


# --------------------------------------------------------------------------- levers and models on the command line


def _nan_arms(tmp_path):
    path = _levers(tmp_path, name="nan.json")
    doc = json.loads(path.read_text())
    doc["r_x"][0] = float("nan")
    path.write_text(json.dumps(doc))  # Python writes NaN, which JSON does not have
    return path


def test_nan_arms_are_one_line_in_navigate(tmp_path):
    out = tmp_path / "nav.h5"
    result = CliRunner().invoke(
        main, ["navigate", str(write_raw(tmp_path / "rec.h5")), "--levers", str(_nan_arms(tmp_path)), "-o", str(out)]
    )
    _refused(result, "nan.json", "NaN is not a JSON number")
    assert not out.exists()


@pytest.mark.parametrize(
    "bad, words",
    [
        (_nan_arms, ("nan.json", "NaN is not a JSON number")),
        (lambda p: _levers(p, _set("r_x", [10.0349, 0, 0]), name="off.json"), ("off.json", "$.r_x[0]")),
    ],
    ids=["nan-arms", "arms-off"],
)
def test_a_bad_levers_file_stops_a_batch_before_any_record(tmp_path, bad, words):
    """The file is every record's: refused once, exit 2, no --out made (not one refusal per record, exit 1)."""
    (tmp_path / "flights").mkdir()
    write_raw(tmp_path / "flights" / "a.h5")
    out = tmp_path / "out"
    result = CliRunner().invoke(
        main,
        ["batch", "navigate", str(tmp_path / "flights"), "--out", str(out), "--levers", str(bad(tmp_path)), "-q"],
    )
    _refused(result, *words)
    assert not out.exists()


def test_a_bad_levers_file_stops_a_chain_before_the_plain_run(tmp_path):
    out = tmp_path / "run"
    lev = _levers(tmp_path, _set("axes", [[1, 0, 0], [1, 0, 0], [0, 0, 1]]))
    rec = write_raw(tmp_path / "rec.h5")
    result = CliRunner().invoke(main, ["run", "--out", str(out), "navigate", "--levers", str(lev), str(rec), "compare"])
    _refused(result, "lev.json", "not three independent directions")
    assert not out.exists()


def test_nan_in_a_model_file_is_one_line(tmp_path):
    model = tmp_path / "model.toml"
    model.write_text('schema = "sizefx/effects/1"\n[accel_bias]\nenabled = true\nbias_ug = [nan, 0.0, 0.0]\n')
    result = CliRunner().invoke(main, ["navigate", str(write_raw(tmp_path / "rec.h5")), "--model", str(model)])
    _refused(result, "model.toml", "[accel_bias] bias_ug holds NaN or Inf")


# --------------------------------------------------------------------------- simulate --set

_SCHEMA = json.loads(resources.files("sizefx.schemas").joinpath("effects-1.json").read_text("utf-8"))
NUMERIC_KEYS = [
    (section, key, rule)
    for section, body in _SCHEMA["sections"].items()
    for key, rule in body["keys"].items()
    if rule["type"] in ("number", "vector", "matrix")
]


@pytest.mark.parametrize("section, key, rule", NUMERIC_KEYS, ids=[f"{s}.{k}" for s, k, _ in NUMERIC_KEYS])
def test_every_set_value_beyond_its_range_or_not_finite_is_refused_up_front(section, key, rule):
    low, high = rule["range"]
    for value in (float("nan"), float("inf"), -float("inf"), low - 1.0 - abs(low), high + 1.0 + abs(high)):
        shape = {"number": (), "vector": (3,), "matrix": (3, 3)}[rule["type"]]
        with pytest.raises(ConfigError, match=rf"\[{section}\] {key}"):
            load_effects(overrides={section: {"enabled": True, key: np.full(shape, value).tolist()}})


def _quantised(lsb: dict, form="rates"):
    traj = scenarios.turntable(
        scenarios.TurntablePlan(axes="Z", static_s=1.0, seconds_per_axis=8.0, cycles=1, peak_rate_dps=5.0)
    )[0]
    fx = load_effects(base=IDEAL, overrides={"quantisation": {"enabled": bool(lsb), **lsb}})
    syn = ImuSynthesizer(traj, fx, rate_hz=100.0, form=form)
    return syn.next_chunk(syn.n_samples)[1:]


@pytest.mark.parametrize("form", ["rates", "increments"])
def test_a_quantisation_step_of_zero_is_no_quantisation(form):
    """As a noise density of 0 is no noise. A step below the readings' float spacing (where a
    reading over it overflows) leaves them finite and as they were, to their rounding (2 ulp)."""
    plain = _quantised({}, form)
    zero = _quantised({"gyro_lsb_rad": 0.0, "accel_lsb_m_per_s": 0.0}, form)
    tiny = _quantised({"gyro_lsb_rad": 5e-324, "accel_lsb_m_per_s": 5e-324}, form)
    for k in range(2):
        np.testing.assert_array_equal(zero[k], plain[k])
        np.testing.assert_allclose(tiny[k], plain[k], rtol=4.5e-16, atol=0)


def test_simulate_quantisation_zero_writes_a_record_inspect_accepts(tmp_path):
    out = tmp_path / "q0.h5"
    runner = CliRunner()
    sets = ["--set", "quantisation.enabled=true", "--set", "quantisation.gyro_lsb_rad=0"]
    result = runner.invoke(
        main, ["simulate", "tumble", "--duration-s", "2", "--rate-hz", "200", "-q", "-o", str(out)] + sets
    )
    assert result.exit_code == 0, result.output
    result = runner.invoke(main, ["inspect", str(out)])
    assert result.exit_code == 0, result.output


def test_readings_that_are_not_finite_are_never_written(tmp_path):
    """The last guard: an effect model that makes NaN (here set past the reader) is refused, nothing left."""
    fx = load_effects(base=IDEAL, overrides={"accel_bias": {"enabled": True}})
    fx.sections["accel_bias"]["bias_mps2"] = np.array([np.nan, 0.0, 0.0])
    traj = scenarios.turntable(
        scenarios.TurntablePlan(axes="Z", static_s=1.0, seconds_per_axis=8.0, cycles=1, peak_rate_dps=5.0)
    )[0]
    out = tmp_path / "nan.h5"
    with pytest.raises(ConfigError, match="accel readings that are not finite at t = 0 s; nothing was written"):
        simulate_to_file(traj, {}, fx, out, rate_hz=100.0)
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------- plan


def test_the_longest_plan_is_what_calibrate_reads_at_the_simulators_rate():
    assert MAX_PLAN_S == MAX_WHOLE_READ_ROWS / SimulateConfig.rate_hz


@pytest.mark.parametrize("budget", ["7501", "1e7"])
def test_a_budget_beyond_the_longest_plan_is_refused_before_the_search(budget):
    result = CliRunner().invoke(main, ["plan", "--noise-ug", "2.96", "--budget-s", budget])
    _refused(result, "--budget-s")
    with pytest.raises(PlanError, match=r"--budget-s 1e\+07: longer than the 7500 s a plan may take"):
        PlanRequest(NOISE_UG, budget_s=1e7).check()


def test_repeated_cycles_add_their_information():
    """What the budget search's screening rests on: with one bias per channel (the fit's windows'
    columns merged per channel), the information of a plan whose rotations are repeated k times is
    ``k I(1) - (k - 1) F``, F the same for every rotation shape with the same lead-in (to rounding:
    1e-10 of the largest element)."""
    a = scenarios.TurntablePlan(axes="XYZ", static_s=10.0, seconds_per_axis=30.0, cycles=1)
    b = replace(a, seconds_per_axis=40.0, peak_rate_dps=14.0, accel_dps2=5.0, dwell_s=3.0)

    def info(plan, k=1):
        names, fisher = _fisher(
            replace(plan, seconds_per_axis=k * plan.seconds_per_axis, cycles=k * plan.cycles), NOISE_UG
        )
        return _one_bias_per_channel(fisher, names)

    scale = np.abs(info(b, 3)).max()
    per_channel = _fisher(b, NOISE_UG, None)[1]  # arms, biases x, y, z, tilt: reordered as the merge
    order = [*range(9), 12, 13, 9, 10, 11]
    np.testing.assert_allclose(info(b), per_channel[np.ix_(order, order)], rtol=0, atol=1e-10 * scale)
    fixed = 2 * info(a) - info(a, 2)
    np.testing.assert_allclose(3 * info(b) - 2 * fixed, info(b, 3), rtol=0, atol=1e-10 * scale)


# every settable key at 0 and at both ends of its range: a 19 s record at 100 Hz each, in memory
# (under 0.1 s a key, about 1.5 s in all)
@pytest.mark.parametrize("section, key, rule", NUMERIC_KEYS, ids=[f"{s}.{k}" for s, k, _ in NUMERIC_KEYS])
def test_every_value_set_accepts_gives_finite_readings(section, key, rule):
    """0 and both ends of the range (those in it), alone on an ideal IMU, in both forms: finite readings (what the
    contract asks of /imu; simulate refuses the others before writing, naming the effects)."""
    shape = {"number": (), "vector": (3,), "matrix": (3, 3)}[rule["type"]]
    traj = scenarios.turntable(
        scenarios.TurntablePlan(axes="Z", static_s=1.0, seconds_per_axis=8.0, cycles=1, peak_rate_dps=5.0)
    )[0]
    low, high = rule["range"]
    # the correlation time shapes the coloured part only when it has a density
    extra = {"markov_density_ug_per_sqrt_hz": 100.0} if key == "markov_correlation_s" else {}
    for value in dict.fromkeys(v for v in (0.0, low, high) if low <= v <= high):
        given = {"enabled": True, **extra, key: np.full(shape, value).tolist()}
        fx = load_effects(base=IDEAL, overrides={section: given})
        for form in ("rates", "increments"):
            syn = ImuSynthesizer(traj, fx, rate_hz=100.0, form=form)
            _, gyro, accel = syn.next_chunk(syn.n_samples)
            assert np.all(np.isfinite(gyro)) and np.all(np.isfinite(accel)), (section, key, value, form)
