"""One declaration per option (:mod:`sizefx.options`): the check of every value, its one wording, and
the commands made from the stages' configs (``cli/options.py``'s ``stage_command``)."""

from __future__ import annotations

import dataclasses
import math

import click
import pytest
from click.testing import CliRunner

from sizefx.errors import ConfigError
from sizefx.options import (
    check_options,
    choice,
    config_from,
    declared,
    group,
    integer,
    interval,
    number,
    numbers,
    one_of,
    path,
    refusal,
    switch,
    words,
)
from sizefx_cli.main import main
from sizefx_cli.options import DeclaredSpan, declared_params

# ------------------------------------------------------------------------------ the mechanism


@dataclasses.dataclass(frozen=True)
class _Inner:
    rate_hz: float = number(10.0, unit="Hz", low=0.0, high=100.0, low_open=True, help="A rate [Hz].")

    def __post_init__(self):
        check_options(self)


@dataclasses.dataclass(frozen=True)
class _Outer:
    record: str = path(argument="FILE")
    delay_s: float | None = number(unit="us", low=-10.0, high=10.0, scale=1e-6, flags=("--delay-us",), help="[us]")
    count: int = integer(3, low=1, high=5, help="How many.")
    how: str = choice("a", ("a", "b"), help="Which.")
    on: bool = switch(help="Whether.")
    inner: _Inner = group(_Inner)

    def __post_init__(self):
        check_options(self)


def test_a_refusal_names_the_option_the_value_and_what_is_valid():
    with pytest.raises(ConfigError) as bad:
        _Outer("x.h5", count=0)
    assert str(bad.value) == "--count: 0 is outside [1, 5]"
    with pytest.raises(ConfigError) as bad:
        _Inner(rate_hz=0.0)
    assert str(bad.value) == "--rate-hz: 0 is outside (0, 100] Hz"
    with pytest.raises(ConfigError) as bad:
        _Inner(rate_hz=math.nan)
    assert str(bad.value) == "--rate-hz: nan is not a finite number; give a value in (0, 100] Hz"
    with pytest.raises(ConfigError) as bad:
        _Outer("x.h5", how="c")
    assert str(bad.value) == "--how: 'c' is not one of a, b"
    with pytest.raises(ConfigError) as bad:
        _Outer("x.h5", count=2.5)
    assert str(bad.value) == "--count: 2.5 is not an integer"
    with pytest.raises(ConfigError) as bad:
        _Outer("x.h5", on="yes")
    assert str(bad.value) == "--on: 'yes' is not true or false"
    with pytest.raises(ConfigError) as bad:
        _Outer(None)
    assert str(bad.value) == "FILE: give a value (None is not one)"
    with pytest.raises(ConfigError, match="inner: .* is not a _Inner"):
        _Outer("x.h5", inner={"rate_hz": 5.0})
    assert _Outer("x.h5", delay_s=None, count=5, how="b", on=True).count == 5  # the edges and None are valid


def test_a_scaled_option_is_judged_and_named_in_the_command_lines_unit():
    """The field holds seconds; the user wrote microseconds, and reads microseconds back."""
    option = dict(declared(_Outer))["delay_s"]
    assert refusal(option, 10e-6) is None and refusal(option, -10e-6) is None
    assert refusal(option, 20e-6) == "--delay-us: 20 is outside [-10, 10] us"
    assert interval(option) == "[-10, 10] us"


def test_a_config_is_made_from_the_values_by_name_groups_too():
    made = config_from(_Outer, {"record": "x.h5", "count": 4, "rate_hz": 50.0})
    assert made == _Outer("x.h5", count=4, inner=_Inner(rate_hz=50.0))
    with pytest.raises(TypeError, match="declares no option colour"):
        config_from(_Outer, {"record": "x.h5", "colour": "red"})


def test_the_command_lines_parameters_are_the_declarations():
    params = {p.name: p for p in declared_params(_Outer)}
    assert list(params) == ["record", "delay_s", "count", "how", "on", "rate_hz"]
    assert isinstance(params["record"], click.Argument) and params["record"].metavar == "FILE"
    assert params["delay_s"].opts == ["--delay-us"] and isinstance(params["delay_s"].type, DeclaredSpan)
    assert params["count"].default == 3 and params["count"].show_default
    assert params["on"].is_flag and not params["on"].default


def test_the_command_line_refuses_in_the_declarations_words_and_converts_the_unit():
    @click.command()
    def probe(**values):
        click.echo(repr(config_from(_Outer, values)))

    probe.params = declared_params(_Outer)
    ok = CliRunner().invoke(probe, ["x.h5", "--delay-us", "5"])
    assert ok.exit_code == 0 and f"delay_s={5 * 1e-6!r}" in ok.output, ok.output  # us times 1e-6, as before
    bad = CliRunner().invoke(probe, ["x.h5", "--rate-hz", "0"])
    assert bad.exit_code == 2 and "--rate-hz: 0 is outside (0, 100] Hz" in bad.output, bad.output


@dataclasses.dataclass(frozen=True)
class _Lists:
    offset_mm: tuple | None = numbers(unit="mm", count=3, metavar="X,Y,Z", help="An offset [mm].")
    amplitudes_dps: tuple = numbers((10.0, 20.0), unit="deg/s", low=0.0, low_open=True, high=50.0, help="[deg/s]")
    columns: tuple = words(("a", "b"), help="Column names.")

    def __post_init__(self):
        check_options(self)


def test_a_list_is_judged_value_by_value_and_counted():
    assert _Lists(offset_mm=(1.0, 0.0, -2.0)).offset_mm == (1.0, 0.0, -2.0)
    for kwargs, words_ in (
        ({"offset_mm": (1.0, 2.0)}, "--offset-mm: 2 values; give 3 (X,Y,Z)"),
        ({"offset_mm": "1,2,3"}, "--offset-mm: '1,2,3' is not a tuple of values"),
        ({"amplitudes_dps": (10.0, 0.0)}, "--amplitudes-dps: 0 is outside (0, 50] deg/s"),
        ({"amplitudes_dps": (10.0, math.inf)}, "--amplitudes-dps: inf is not a finite number; give a value in"),
        ({"amplitudes_dps": ()}, "--amplitudes-dps: 0 values; give at least one"),
        ({"columns": ("a", 3)}, "--columns: 3 is not text"),
    ):
        with pytest.raises(ConfigError) as bad:
            _Lists(**kwargs)
        assert str(bad.value).startswith(words_), (kwargs, str(bad.value))


def test_a_list_is_written_comma_separated_on_the_command_line():
    @click.command()
    def probe(**values):
        click.echo(repr(config_from(_Lists, values)))

    probe.params = declared_params(_Lists)
    assert probe.params[1].default == "10,20" and probe.params[2].default == "a,b"  # as the user writes them
    ok = CliRunner().invoke(probe, ["--offset-mm", "1,0,-2", "--columns", "x,y"])
    assert ok.exit_code == 0 and "offset_mm=(1.0, 0.0, -2.0)" in ok.output and "('x', 'y')" in ok.output, ok.output
    for args, words_ in (
        (["--offset-mm", "1,2"], "--offset-mm: 2 values; give 3 (X,Y,Z)"),
        (["--offset-mm", "1,a,2"], "--offset-mm: '1,a,2' is not 3 comma-separated numbers"),
        (["--amplitudes-dps", "10,x"], "--amplitudes-dps: '10,x' is not a list of numbers"),
    ):
        bad = CliRunner().invoke(probe, args)
        assert bad.exit_code == 2 and words_ in bad.output, bad.output


@dataclasses.dataclass
class _Fast:
    speed: float = number(1.0, unit="m/s", low=0.5, high=2.0, help="[m/s]")


@dataclasses.dataclass
class _Slow:
    steps: int = integer(2, low=1, high=3, help="How many.")


@dataclasses.dataclass(frozen=True)
class _Variant:
    kind: str = choice(None, ("fast", "slow"), argument="KIND", help="Which.")
    plan: _Fast | _Slow | None = one_of("kind", {"fast": _Fast, "slow": _Slow})
    record: str | None = path(help="A record.")

    def __post_init__(self):
        check_options(self)


def test_one_of_shows_and_checks_the_class_its_key_chooses():
    assert [name for name, _ in declared(_Variant, {"kind": "slow"})] == ["steps", "record"]
    assert [name for name, _ in declared(_Variant, {"kind": "fast", "record": None})] == ["speed"]
    assert config_from(_Variant, {"steps": 3}, {"kind": "slow"}) == _Variant("slow", _Slow(3))
    assert config_from(_Variant, {}, {"kind": "slow"}).plan is None  # none given: the class's defaults
    with pytest.raises(ConfigError) as bad:  # the plan does not check itself; the config that holds it does
        _Variant("fast", _Fast(speed=3.0))
    assert str(bad.value) == "--speed: 3 is outside [0.5, 2] m/s"
    with pytest.raises(ConfigError, match="plan: .* is not a _Slow"):
        _Variant("slow", _Fast())
    with pytest.raises(ConfigError) as bad:
        _Variant("medium")
    assert str(bad.value) == "KIND: 'medium' is not one of fast, slow"


# ------------------------------------------------------------------------------- the stages


def _stages():
    """(command path, config class, the command's own options, in order) of every stage made from its
    config; a command per scenario or format (simulate, import, export) fixes one value of it."""
    from sizefx.configs.calibrate import CalibrateConfig
    from sizefx.configs.compare import CompareConfig
    from sizefx.configs.compensate import CompensateConfig
    from sizefx.configs.diagnose import DiagnoseConfig
    from sizefx.configs.export import EXPORT_OPTIONS, ExportConfig
    from sizefx.configs.import_ import IMPORT_OPTIONS, ImportConfig
    from sizefx.configs.inspect import InspectConfig
    from sizefx.configs.navigate import NavigateConfig
    from sizefx.configs.plan import PlanConfig
    from sizefx.configs.scenarios import SCENARIO_PLANS
    from sizefx.configs.simulate import SimulateConfig

    return [
        (("inspect",), InspectConfig, ()),
        (("calibrate",), CalibrateConfig, ()),
        (("compare",), CompareConfig, ()),
        (("compensate",), CompensateConfig, ()),
        (("diagnose",), DiagnoseConfig, ()),
        (("navigate",), NavigateConfig, ("quiet",)),
        (("plan",), PlanConfig, ()),
        *[(("simulate", scenario), SimulateConfig, ("quiet",)) for scenario in SCENARIO_PLANS],
        *[(("import", fmt), ImportConfig, ()) for fmt in IMPORT_OPTIONS],
        *[(("export", fmt), ExportConfig, ()) for fmt in EXPORT_OPTIONS],
    ]


STAGES = _stages()
#: Fields a config has for Python callers only, with no option on the command line.
LIBRARY_ONLY = {
    "CompensateConfig": {"centripetal"},
    "NavConfig": {"model"},
    "SimulateConfig": {"overrides", "chunk_samples"},
    # what a plan holds beyond the scenario's options: the table's ramps and dwells, the flight's
    # manoeuvres and vibration, the tumble's amplitudes (the plan search and the tests set them)
    "TurntablePlan": {"ramp_s", "dwell_s", "reposition_s", "settle_s"},
    "SwayPlan": {"heading_deg"},
    "FlightPlan": {"turn_rate_dps", "vib_rate_dps", "vib_accel_mps2", "cruise_pitch_deg", "weave_deg", "climb_step_m"},
    "TumblePlan": {"amplitudes_deg", "freqs_hz"},
}


def _command(path: tuple) -> click.Command:
    command = main
    for name in path:
        command = command.commands[name]
    return command


@pytest.mark.parametrize("path,config,own", STAGES, ids=[" ".join(p) for p, _, _ in STAGES])
def test_every_field_of_a_stage_config_is_a_declared_option(path, config, own):
    """Each field says how the command line writes it, what it holds and, for a physical quantity,
    its unit (which the help shows as [unit])."""
    configs = [config]
    while configs:
        current = configs.pop()
        for f in dataclasses.fields(current):
            if f.name in LIBRARY_ONLY.get(current.__name__, set()):
                continue
            kinds = {"option", "group", "one_of"} & set(f.metadata)
            assert kinds, f"{current.__name__}.{f.name} is not declared"
            configs += [f.metadata["group"]] if "group" in f.metadata else []
            configs += list(f.metadata["one_of"][1].values()) if "one_of" in f.metadata else []
    for name, option in declared(config, _command(path).fixed):
        assert option.argument or option.help, f"{config.__name__}.{name} has no help"
        if option.kind == "number" and option.unit is not None:
            assert f"[{option.unit}" in option.help, f"{option.name}: help does not show [{option.unit}]"


@pytest.mark.parametrize("path,config,own", STAGES, ids=[" ".join(p) for p, _, _ in STAGES])
def test_the_stage_command_is_made_from_its_config(path, config, own):
    command = _command(path)
    assert command.config_class is config
    options = declared(config, command.fixed)
    names = [name for name, _ in options]
    assert [p.name for p in command.params] == [*names, *own], "the declared options, in order, then the command's"
    assert not set(command.fixed) & {p.name for p in command.params}, "what the command fixes is no option of it"
    for param, (_, option) in zip(command.params, options, strict=False):
        if option.argument is None:
            assert option.name in (*param.opts, *param.secondary_opts)


#: The required options of import table-log and csv, on the command line and from Python.
TABLE_LOG = ["--imu", "r.h5", "--axes", "z", "--time", "t", "--angles", "a"]
CSV = ["--time", "t", "--gyro", "gx,gy,gz", "--accel", "ax,ay,az"]
CSV_OPTIONS = dict(time="t", gyro=("gx", "gy", "gz"), accel=("ax", "ay", "az"))


#: A bad value per stage: the command line's arguments, and the config that Python makes with it.
BAD_VALUES = [
    (["navigate", "f.h5", "--align-s", "0"], lambda: _navigate(align_s=0.0)),
    (["navigate", "f.h5", "--subsamples", "5"], lambda: _navigate(subsamples=5)),
    (["navigate", "f.h5", "--output-rate-hz", "0.0005"], lambda: _navigate(output_rate_hz=0.0005)),
    (["navigate", "f.h5", "--vertical", "sideways"], lambda: _navigate(vertical="sideways")),
    (["compensate", "f.h5", "-o", "o.h5", "--levers", "l.json", "--accel-delay-us", "2e5"], lambda: _compensate()),
    (["calibrate", "t.h5", "--triad-point", "middle"], lambda: _stage("calibrate", "CalibrateConfig", triad="middle")),
    (["diagnose", "m.h5", "--bandwidth-hz", "0"], lambda: _stage("diagnose", "DiagnoseConfig", bandwidth_hz=0.0)),
    (["diagnose", "m.h5", "--grade", "consumer"], lambda: _stage("diagnose", "DiagnoseConfig", grade="consumer")),
    (["simulate", "turntable", "-o", "o.h5", "--cycles", "0"], lambda: _simulate("turntable", cycles=0)),
    (
        ["simulate", "sway", "-o", "o.h5", "--amplitudes-dps", "10,0"],
        lambda: _simulate("sway", amplitudes_dps=(10.0, 0.0)),
    ),
    (["simulate", "flight", "-o", "o.h5", "--duration-h", "30"], lambda: _simulate("flight", duration_s=30 * 3600.0)),
    (["simulate", "tumble", "-o", "o.h5", "--latitude-deg", "90"], lambda: _simulate("tumble", latitude_deg=90.0)),
    (["simulate", "tumble", "-o", "o.h5", "--offset-mm", "1,2"], lambda: _simulate("tumble", offset_mm=(1.0, 2.0))),
    (["import", "rosbag", "b", "-o", "o.h5", "--stamps", "sideways"], lambda: _import("rosbag", stamps="sideways")),
    (
        ["import", "table-log", "l.csv", "-o", "o.h5", *TABLE_LOG, "--mount-deg", "1,2"],
        lambda: _import("table-log", imu_record="r.h5", axes=("z",), time="t", angles=("a",), mount_deg=(1.0, 2.0)),
    ),
    (
        ["import", "csv", "s.csv", "-o", "o.h5", *CSV, "--rate-hz", "0"],
        lambda: _import("csv", **CSV_OPTIONS, rate_hz=0.0),
    ),
    (["export", "rosbag", "r.h5", "-o", "bag", "--storage", "zip"], lambda: _export(storage="zip")),
    (["export", "rosbag", "r.h5", "-o", "bag", "--frame", "enu"], lambda: _export(axes="enu")),
    (["plan", "--budget-s", "300", "--noise-ug", "0"], lambda: _plan(0.0, budget_s=300.0)),
    (
        ["plan", "--noise-ug", "3", "--budget-s", "300", "--max-rate-dps", "0"],
        lambda: _plan(3.0, 300.0, max_rate_dps=0.0),
    ),
]


def _stage(module: str, name: str, **options):
    """A stage's config made in Python with one file (as its first field) and ``options``."""
    import importlib

    config = getattr(importlib.import_module(f"sizefx.configs.{module}"), name)
    return config(("t.h5",) if name == "CalibrateConfig" else "m.h5", **options)


def _simulate(scenario: str, **options):
    """``sizefx simulate SCENARIO -o o.h5`` made in Python: ``options`` of the plan, the site or the config."""
    from sizefx.configs.scenarios import SCENARIO_PLANS, SiteSpec
    from sizefx.configs.simulate import SimulateConfig

    plan_class = SCENARIO_PLANS[scenario]
    plan = {k: options.pop(k) for k in list(options) if k in {f.name for f in dataclasses.fields(plan_class)}}
    site = {k: options.pop(k) for k in list(options) if k in {f.name for f in dataclasses.fields(SiteSpec)}}
    return SimulateConfig(
        scenario,
        "o.h5",
        plan=plan_class(**plan) if plan else None,
        site=SiteSpec(**site) if site else None,
        **options,
    )


def _import(fmt: str, **options):
    from sizefx.configs.import_ import ImportConfig

    return ImportConfig(fmt, "s", "o.h5", options=options)


def _export(**options):
    from sizefx.configs.export import ExportConfig

    return ExportConfig("rosbag", "r.h5", "bag", options=options)


def _plan(noise_ug: float, budget_s: float, **table):
    from sizefx.configs.plan import PlanConfig, PlanRequest, TableLimits

    return PlanConfig(PlanRequest(noise_ug, TableLimits(**table), budget_s=budget_s))


def _navigate(**options):
    from sizefx.configs.navigate import NavConfig, NavigateConfig

    return NavigateConfig("f.h5", options=NavConfig(**options))


def _compensate():
    from sizefx.configs.compensate import CompensateConfig

    return CompensateConfig("f.h5", "o.h5", levers="l.json", accel_delay_s=0.2)


@pytest.mark.parametrize("args,make", BAD_VALUES, ids=[f"{a[0]} {a[-2]} {a[-1]}" for a, _ in BAD_VALUES])
def test_a_bad_value_is_refused_in_the_same_words_from_python_and_the_command_line(tmp_path, args, make):
    with pytest.raises(ConfigError) as from_python:
        make()
    words = str(from_python.value)
    assert words.startswith(args[-2])  # names the option as the command line writes it
    result = CliRunner().invoke(main, args)
    lines = result.stderr.strip().splitlines()
    assert result.exit_code == 2 and len(lines) == 1 and words in lines[0], (words, result.stderr)


def test_the_scenarios_and_formats_declared_are_those_the_stages_know():
    """The configs name the scenarios and formats without numpy; the stages' tables of builders,
    readers and writers (with numpy) must know the same ones."""
    from sizefx import constants, exporters, frames, importers, simulate
    from sizefx.configs.export import EXPORT_OPTIONS
    from sizefx.configs.import_ import IMPORT_OPTIONS
    from sizefx.configs.scenarios import SCENARIO_PLANS

    assert list(IMPORT_OPTIONS) == list(importers.FORMATS)
    assert list(EXPORT_OPTIONS) == list(exporters.FORMATS)
    assert {name: plan for name, (_, plan) in simulate.SCENARIOS.items()} == SCENARIO_PLANS
    assert constants.ROS_AXES_NAMES == tuple(frames.ROS_AXES)


def test_a_format_option_a_reader_does_not_take_is_refused_when_the_config_is_made():
    """Each declared option of a format is a keyword of its reader or writer, and a name neither
    declares is refused before any file is read."""
    import importlib
    import inspect

    from sizefx import exporters, importers
    from sizefx.configs.export import EXPORT_OPTIONS
    from sizefx.configs.import_ import IMPORT_OPTIONS, ImportConfig

    for fmt, (module, function) in importers.FORMATS.items():
        reader = inspect.signature(getattr(importlib.import_module(f"sizefx.importers.{module}"), function))
        assert {name for name, _ in declared(IMPORT_OPTIONS[fmt])} <= set(reader.parameters), fmt
    for fmt, module in exporters.FORMATS.items():
        writer = inspect.signature(importlib.import_module(f"sizefx.exporters.{module}").write)
        assert {name for name, _ in declared(EXPORT_OPTIONS[fmt])} <= set(writer.parameters), fmt
    with pytest.raises(ConfigError) as bad:
        ImportConfig("rosbag", "b", "o.h5", options={"topic": "/imu"})
    assert str(bad.value) == (
        "import rosbag: no option topic; its options: imu, reference, body_frame, stamps, frame, site_deg, navsat"
    )


def test_a_plan_file_beside_the_scenarios_own_options_is_refused_from_python_and_the_command_line():
    """The command passes a plan only when the user gave one of its options (so --plan alone is
    no conflict); the config names the options that set it, or all of them when one repeats a default."""
    from sizefx.configs.scenarios import TurntablePlan
    from sizefx.configs.simulate import SimulateConfig

    words = "--plan p.toml holds the plan; leave out --cycles (or edit the plan file)"
    with pytest.raises(ConfigError) as from_python:
        SimulateConfig("turntable", "o.h5", plan=TurntablePlan(cycles=3), plan_path="p.toml")
    assert str(from_python.value) == words
    args = ["simulate", "turntable", "-o", "o.h5", "--plan", "p.toml"]
    result = CliRunner().invoke(main, [*args, "--cycles", "3"])
    assert result.exit_code == 2 and result.stderr.strip() == f"sizefx: error: {words}", result.stderr
    repeated = CliRunner().invoke(main, [*args, "--cycles", "5"])
    assert "leave out --vertical-axes, --static-s, --seconds-per-axis, --cycles," in repeated.stderr
    alone = CliRunner().invoke(main, args)  # refused for the missing file, by the pre-flight
    assert alone.exit_code == 2 and "holds the plan" not in alone.stderr and "p.toml" in alone.stderr
