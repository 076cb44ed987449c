"""Consistent inputs or a refusal.

- A levers file describes one geometry: ``r_i = offset + d_i`` (within
  ``LEVER_CHAIN_TOLERANCE_M``) and, when it gives ``axes``, three unit, independent sensitive axes,
  row i along body axis +i. Anything else, and NaN, is one line naming the file and the field, exit
  code 2, in the single command and up front in a batch or a chain.
- Every value ``simulate --set`` accepts writes finite readings: a quantisation step of 0 is no
  quantisation; NaN, inf and values beyond a key's range are refused before anything is simulated.
- Every value ``simulate --set`` accepts makes a record ``sizefx inspect`` accepts, or is refused in
  one line naming the key (exit 2, nothing left): readings beyond the contract's physical limits
  always, records the physics check refuses unless ``--no-units-check``, which writes them (and
  then inspect refuses them: the two agree, also on a long record judged on a sample).
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

from sizefx import sanity, scenarios
from sizefx.constants import MAX_PLAN_S, MAX_WHOLE_READ_ROWS
from sizefx.effects import IDEAL, load_effects
from sizefx.errors import ConfigError, SizefxError
from sizefx.inspect import InspectConfig
from sizefx.inspect import run as inspect
from sizefx.levers import AXIS_LENGTH_TOLERANCE, LEVER_CHAIN_TOLERANCE_M, levers_from_preset, read_levers, write_levers
from sizefx.plan import PlanRequest, _fisher, _one_bias_per_channel
from sizefx.simulate import ImuSynthesizer, SimulateConfig, simulate_to_file
from sizefx.simulate import run as simulate
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
    with pytest.raises(ConfigError, match=r"^--budget-s: 10000000 is outside \[1, 7500\] s$"):
        PlanRequest(NOISE_UG, budget_s=1e7)


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


# --------------------------------------------------------------------------- simulate: records inspect accepts

#: A short tumble (5 s at 100 Hz: it rests for 1.75 s, and its reference turns in ~500 intervals, so
#: both physics checks decide), as every --set value below is simulated on.
TUMBLE = ["simulate", "tumble", "--duration-s", "5", "--rate-hz", "100", "-q"]

#: The extreme but in-range values: the scenario options each comes with, its --set
#: values, the key a refusal must name, and whether it is refused today (every accelerometer extreme;
#: a gyro scale factor of +-50 % reads 1.5 or 0.5 times the reference's rotation, which inspect calls
#: odd, matching no unit, and accepts): pinned, so that a change in either checker is seen.
EXTREMES = {
    "100 m lever arms on a tumble": (TUMBLE, ["lever_arm.r_vehicle_m=[100, 100, 100]"], "lever_arm.r_vehicle_m", True),
    "1 g accelerometer bias": (
        TUMBLE,
        ["accel_bias.enabled=true", "accel_bias.bias_ug=[1e6, 1e6, 1e6]"],
        "accel_bias.bias_ug",
        True,
    ),
    "+50 % accelerometer scale factor": (
        TUMBLE,
        ["accel_scale_factor.enabled=true", "accel_scale_factor.ppm=[5e5, 5e5, 5e5]"],
        "accel_scale_factor.ppm",
        True,
    ),
    "-50 % accelerometer scale factor": (
        TUMBLE,
        ["accel_scale_factor.enabled=true", "accel_scale_factor.ppm=[-5e5, -5e5, -5e5]"],
        "accel_scale_factor.ppm",
        True,
    ),
    "+50 % gyro scale factor": (
        TUMBLE,
        ["gyro_scale_factor.enabled=true", "gyro_scale_factor.ppm=[5e5, 5e5, 5e5]"],
        "gyro_scale_factor.ppm",
        False,
    ),
    "-50 % gyro scale factor": (
        TUMBLE,
        ["gyro_scale_factor.enabled=true", "gyro_scale_factor.ppm=[-5e5, -5e5, -5e5]"],
        "gyro_scale_factor.ppm",
        False,
    ),
    "noise density 1e6 ug/sqrt(Hz)": (
        TUMBLE,
        ["accel_noise.density_ug_per_sqrt_hz=1e6"],
        "accel_noise.density_ug_per_sqrt_hz",
        True,
    ),
    "accelerometer LSB of 1 m/s at 1600 Hz": (
        ["simulate", "tumble", "--duration-s", "2", "--rate-hz", "1600", "-q"],
        ["quantisation.enabled=true", "quantisation.accel_lsb_m_per_s=1"],
        "quantisation.accel_lsb_m_per_s",
        True,
    ),
    "accelerometer LSB of 1 m/s at 1600 Hz, increments": (
        ["simulate", "tumble", "--duration-s", "2", "--rate-hz", "1600", "--form", "increments", "-q"],
        ["quantisation.enabled=true", "quantisation.accel_lsb_m_per_s=1"],
        "quantisation.accel_lsb_m_per_s",
        True,
    ),
}


def _sets(items):
    return [arg for item in items for arg in ("--set", item)]


@pytest.mark.parametrize("case", list(EXTREMES))
def test_an_extreme_set_value_is_refused_in_one_line_or_makes_a_record_inspect_accepts(tmp_path, case):
    """Refused (exit 2, one line naming the key, the check's figures and --no-units-check, nothing left)
    exactly when inspect refuses the record --no-units-check writes; --no-units-check always writes it."""
    command, items, key, expected = EXTREMES[case]
    runner = CliRunner()
    out = tmp_path / "rec.h5"
    result = runner.invoke(main, command + _sets(items) + ["-o", str(out)])
    refused = result.exit_code != 0
    if refused:
        _refused(result, str(out), "sizefx inspect would refuse this record", key, "--no-units-check")
        assert list(tmp_path.iterdir()) == []  # neither the record nor its temporary file
    else:
        assert result.exit_code == 0, result.output
        assert runner.invoke(main, ["inspect", str(out)]).exit_code == 0
        out.unlink()
    result = runner.invoke(main, command + _sets(items) + ["--no-units-check", "-o", str(out)])
    assert result.exit_code == 0 and out.exists(), result.output
    assert runner.invoke(main, ["inspect", str(out), "--no-units-check"]).exit_code == 0
    checked = runner.invoke(main, ["inspect", str(out)])
    assert (checked.exit_code == 2) == refused, checked.output
    assert refused == expected


def test_a_motion_beyond_the_contracts_limits_is_refused_even_without_the_units_check(tmp_path):
    """A 5000 deg/s table with 3 m arms reads 10 586 m/s^2: beyond the telemetry contract, which every
    reader refuses with or without --no-units-check, so simulate never writes it."""
    command = [
        "simulate",
        "turntable",
        "--vertical-axes",
        "Z",
        "--static-s",
        "60",
        "--seconds-per-axis",
        "10",
        "--cycles",
        "1",
    ]
    command += ["--peak-rate-dps", "5000", "--accel-dps2", "1e5", "--rate-hz", "100", "-q"]
    out = tmp_path / "fast.h5"
    for extra in ([], ["--no-units-check"]):
        result = CliRunner().invoke(
            main, command + _sets(["lever_arm.r_vehicle_m=[3, 0, 0]"]) + extra + ["-o", str(out)]
        )
        _refused(
            result, "/imu/accel would read -10586.4 (SI) at t = 61.09 s", "physical limit", "lever_arm.r_vehicle_m"
        )
        assert list(tmp_path.iterdir()) == []


def test_a_record_of_one_sample_is_refused_before_it_is_written(tmp_path):
    """A 1 s tumble at 1 Hz has one increment, and the reader needs two stamps to know the rate."""
    out = tmp_path / "one.h5"
    command = ["simulate", "tumble", "--duration-s", "1", "--rate-hz", "1", "--form", "increments", "-q"]
    _refused(CliRunner().invoke(main, command + ["-o", str(out)]), "make 1 increments sample", "--rate-hz")
    assert list(tmp_path.iterdir()) == []


# every settable key at 0 and both ends of its range, alone on an ideal IMU, on the 5 s tumble: simulate and
# inspect both (about 0.1 s a value)
@pytest.mark.parametrize("section, key, rule", NUMERIC_KEYS, ids=[f"{s}.{k}" for s, k, _ in NUMERIC_KEYS])
def test_every_value_set_accepts_makes_a_record_inspect_accepts(tmp_path, section, key, rule):
    """simulate writes the record exactly when inspect accepts it: a refusal is a ConfigError that leaves
    nothing and names the key, and the record --no-units-check then writes is one inspect refuses."""
    shape = {"number": (), "vector": (3,), "matrix": (3, 3)}[rule["type"]]
    low, high = rule["range"]
    extra = {"markov_density_ug_per_sqrt_hz": 100.0} if key == "markov_correlation_s" else {}
    out = tmp_path / "rec.h5"
    for value in dict.fromkeys(v for v in (0.0, low, high) if low <= v <= high):
        given = {"enabled": True, **extra, key: np.full(shape, value).tolist()}
        config = SimulateConfig(
            "tumble",
            out,
            plan=scenarios.TumblePlan(duration_s=5.0),
            ideal=True,
            rate_hz=100.0,
            overrides={section: given},
        )
        try:
            simulate(config)
        except ConfigError as exc:
            assert f"{section}" in str(exc) and "--no-units-check" in str(exc), str(exc)
            assert list(tmp_path.iterdir()) == [], (section, key, value)
            simulate(replace(config, check_units=False))
            with pytest.raises(SizefxError):
                inspect(InspectConfig(out))
        else:
            inspect(InspectConfig(out))
        out.unlink()


@pytest.mark.parametrize("bias_deg_per_h, refused", [(1e5, False), (3e5, True)])
def test_a_long_record_is_judged_on_its_sample_as_inspect_judges_it_whole(
    tmp_path, monkeypatch, bias_deg_per_h, refused
):
    """Beyond SAMPLE_ROWS simulate judges blocks of the record (here 6 blocks of 10 s of a 1050 s flight
    at 20 Hz), and must find what inspect finds on the whole: a gyro bias of 3e5 deg/h integrates to 49
    times the rotation of the flight's turn, which inspect takes for deg/s read as rad/s; 1e5 deg/h to 17
    times, odd but no unit. The turn fills 9 of the 525 two-second cells: 6 evenly spread blocks miss it
    and leave the gyros unchecked (this test then fails), so half the blocks go where the reference turns."""
    monkeypatch.setattr(sanity, "SAMPLE_ROWS", 1200)
    out = tmp_path / "flight.h5"
    config = SimulateConfig(
        "flight",
        out,
        plan=scenarios.FlightPlan(duration_s=1050.0, align_s=30.0),
        rate_hz=20.0,
        reference_rate_hz=20.0,
        overrides={"gyro_bias": {"enabled": True, "deg_per_h": [bias_deg_per_h] * 3}},
    )
    if refused:
        with pytest.raises(ConfigError, match=r"/imu/gyro integrates to 49\.\d+ times .* gyro_bias\.deg_per_h"):
            simulate(config)
        assert list(tmp_path.iterdir()) == []
        simulate(replace(config, check_units=False))
        with pytest.raises(SizefxError, match="the data look like deg/s"):
            inspect(InspectConfig(out))
    else:
        simulate(config)
        assert inspect(InspectConfig(out)).units_check["gyro"]["method"] == "reference"
