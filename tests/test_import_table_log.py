"""``sizefx import table-log``: a turntable controller's log of encoder angles into ``/reference``.

The logs are written here the way a controller writes them (a time column in ms, then an angle
and a rate column per axis, in deg or encoder counts) from the simulator's own gimbal angles: the
profiles of the :class:`sizefx.motion.RotationChain` that ``sizefx.scenarios`` builds the
simulated table from. The imported attitude is compared with the simulator's truth (that chain's
``mat_nb``); the convention itself with scipy's rotations, an independent implementation.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.spatial.transform import Rotation

from sizefx import scenarios
from sizefx.constants import DEG
from sizefx.frames import gimbal_axes, table_attitude
from sizefx.importers import ImportConfig, run
from sizefx.io.telemetry import Telemetry, read_telemetry, write_telemetry
from sizefx.rotation import mat_to_euler, mat_to_quat, quat_angle_between
from sizefx.simulate import SimulateConfig
from sizefx.simulate import run as simulate
from sizefx_cli.main import main

ROOT = Path(__file__).resolve().parents[1]
IMU_RATE_HZ = 50.0
SITE_DEG = (57.9825, 55.7089, 120.0)  #: the simulator's default site (the paper's airfield)
#: The log prints angles to 1e-12 deg (2e-14 rad): the imported attitude is the truth to rounding.
ATTITUDE_TOL_RAD = 1e-9
#: Encoder counts are whole: each axis is off by at most half a count, pi / counts_per_rev rad.
CPR = 36_000  #: 0.01 deg per count
COUNTS_TOL_RAD = 3 * np.pi / CPR + 1e-12  # three axes' half counts add up at most
#: A short plan of the paper's kind (each body axis vertical in turn): 89 s, 4451 rows at 50 Hz.
PLAN = scenarios.TurntablePlan(
    axes="YXZ",
    static_s=5.0,
    seconds_per_axis=24.0,
    cycles=2,
    peak_rate_dps=60.0,
    accel_dps2=60.0,
    ramp_s=0.25,
    reposition_s=3.0,
    settle_s=2.0,
)
#: The simulated table's gimbals (sizefx.scenarios): turntable outer down, middle north, inner east;
#: tumble heading (down), pitch (east), roll (north), in that order.
TURNTABLE_AXES = ("z", "x", "y")
TUMBLE_AXES = ("z", "y", "x")


def _imu_only(sim: Path, out: Path, *, site: bool = True) -> Path:
    """The IMU of a simulated record alone, as an IMU logger's import gives it (no reference)."""
    tel = read_telemetry(sim)
    write_telemetry(
        out,
        Telemetry(
            time_s=tel.time_s,
            form="rates",
            gyro_rad_s=tel.gyro_rad_s,
            accel_mps2=tel.accel_mps2,
            site=tel.site if site else None,
        ),
    )
    return out


@pytest.fixture(scope="module")
def records(tmp_path_factory):
    """Simulated records (IMU at 50 Hz): the short turntable plan (IMU only, and IMU only without a
    site), and 20 s tumbles about z, about z and y, and about z, y and x (that one in increments too)."""
    d = tmp_path_factory.mktemp("table_log")
    out = {}
    simulate(SimulateConfig("turntable", d / "turntable_sim.h5", plan=PLAN, rate_hz=IMU_RATE_HZ))
    out["turntable"] = _imu_only(d / "turntable_sim.h5", d / "turntable_imu.h5")
    out["no_site"] = _imu_only(d / "turntable_sim.h5", d / "no_site.h5", site=False)
    for axes in ("z", "zy", "zyx"):
        plan = scenarios.TumblePlan(duration_s=20.0, axes=axes)
        simulate(SimulateConfig("tumble", d / f"tumble_{axes}.h5", plan=plan, rate_hz=IMU_RATE_HZ))
        out[axes] = d / f"tumble_{axes}.h5"
    plan = scenarios.TumblePlan(duration_s=20.0, axes="zyx")
    simulate(SimulateConfig("tumble", d / "increments.h5", plan=plan, rate_hz=IMU_RATE_HZ, form="increments"))
    out["increments"] = d / "increments.h5"
    return out


def _trajectory(kind: str):
    if kind == "turntable":
        return scenarios.turntable(PLAN)[0], TURNTABLE_AXES
    return scenarios.tumble(20.0, axes=kind), TUMBLE_AXES[: len(kind)]


def _write_log(path: Path, kind: str, *, rate_hz=25.0, units="deg", senses=None, modulus=None, rates=True, edit=None):
    """The controller's log of the simulated table ``kind`` at ``rate_hz``: ``time_ms``, then per axis
    ``pos{k}`` (deg to 1e-12, or whole counts of :data:`CPR` rolling over at ``modulus``) and
    ``rate{k}`` [deg/s or counts/s]; ``senses`` (+-1 per axis) the sign the encoder counts with.
    Returns the log's times [s] and the truth ``mat_nb`` there."""
    traj, axes = _trajectory(kind)
    n_axes = len(axes)
    senses = senses or [1.0] * n_axes
    t = np.arange(0.0, traj.duration_s + 1e-9, 1.0 / rate_hz)
    header, columns, formats = ["time_ms"], [t * 1e3], ["%.3f"]
    for k, profile in enumerate(traj.attitude.profiles[:n_axes]):
        theta, rate, _ = profile.evaluate(t)
        theta, rate = senses[k] * theta, senses[k] * rate
        if units == "counts":
            count = np.round(theta / (2 * np.pi) * CPR)
            columns += [np.mod(count, modulus or CPR), rate / (2 * np.pi) * CPR]
            formats += ["%.0f", "%.6f"]
        else:
            columns += [np.degrees(theta), np.degrees(rate)]
            formats += ["%.12f", "%.12f"]
        header += [f"pos{k + 1}", f"rate{k + 1}"]
    rows = [",".join(f % v for f, v in zip(formats, row)) for row in np.column_stack(columns)]
    if edit:
        edit(rows)
    path.write_text(",".join(header) + "\n" + "\n".join(rows) + "\n")
    return t, traj.evaluate(t).mat_nb


def _args(log, imu, out, n_axes, *extra, axes=None, rates=True):
    args = [
        log,
        "--imu",
        imu,
        "-o",
        out,
        "--time",
        "time_ms",
        "--time-units",
        "ms",
        "--site-deg",
        ",".join(map(str, SITE_DEG)),
    ]
    args += [
        "--axes",
        axes or ",".join(TUMBLE_AXES[:n_axes]),
        "--angles",
        ",".join(f"pos{k + 1}" for k in range(n_axes)),
    ]
    if rates:
        args += ["--rates", ",".join(f"rate{k + 1}" for k in range(n_axes))]
    return [str(a) for a in [*args, *extra]]


def _cli(args):
    return CliRunner().invoke(main, ["import", "table-log", *args])


def _attitude_error_rad(out: Path, mat_nb_truth) -> float:
    ref = read_telemetry(out).reference
    return float(np.max(quat_angle_between(ref.quat_nb, mat_to_quat(mat_nb_truth))))


def _one_line_refusal(result, *words):
    lines = result.stderr.strip().splitlines()
    assert result.exit_code == 2 and len(lines) == 1 and "Traceback" not in result.output, result.output
    for word in words:
        assert word in lines[0], lines[0]
    return lines[0]


# --------------------------------------------------------------------------- the convention


def test_a_positive_turn_about_a_down_axis_increases_heading():
    t = np.array([0.0, 1.0])
    theta = np.array([[0.0], [30.0 * DEG]])
    rate = np.full((2, 1), 30.0 * DEG)
    for spec, sign in (("z", 1.0), ("-z", -1.0)):
        mat_nb, omega_nb_b = table_attitude(gimbal_axes([spec]), theta, rate, t)
        _, _, heading = mat_to_euler(mat_nb)
        assert heading[1] == pytest.approx(sign * 30.0 * DEG, abs=1e-15)
        assert omega_nb_b[1] == pytest.approx([0.0, 0.0, sign * 30.0 * DEG], abs=1e-15)  # about body z, down
    mat_nb, _ = table_attitude(gimbal_axes(["z"]), theta, rate, t, heading_rad=20.0 * DEG)  # the table's zero
    assert mat_to_euler(mat_nb)[2] == pytest.approx([20.0 * DEG, 50.0 * DEG], abs=1e-15)


def test_the_chain_is_heading_gimbals_then_mount_and_its_rate_the_attitudes_derivative():
    """``mat_nb = Rz(psi) R(a1, s1 th1) R(a2, s2 th2) R(a3, s3 th3) mat_pb``, by scipy's rotations
    (intrinsic products), and ``omega_nb_b`` against ``mat_nb^T d(mat_nb)/dt`` by central differences."""
    rng = np.random.default_rng(7)
    t = np.linspace(0.0, 2.0, 2001)
    coeffs = rng.normal(size=(3, 3))
    theta = np.column_stack([c[0] * t + c[1] * np.sin(3 * t + c[2]) for c in coeffs])
    rate = np.column_stack([c[0] + 3 * c[1] * np.cos(3 * t + c[2]) for c in coeffs])
    mount_deg = (5.0, -10.0, 100.0)
    axes = gimbal_axes(["z", "-x", "y"])
    mat_pb = Rotation.from_euler("ZYX", mount_deg[::-1], degrees=True).as_matrix()
    mat_nb, omega_nb_b = table_attitude(axes, theta, rate, t, heading_rad=0.3, mat_pb=mat_pb)
    unit = {"x": [1, 0, 0], "y": [0, 1, 0], "z": [0, 0, 1]}
    expected = Rotation.from_rotvec([0.0, 0.0, 0.3])
    for k, (axis, sign) in enumerate(axes):
        expected = expected * Rotation.from_rotvec(np.outer(sign * theta[:, k], unit[axis]))
    expected = (expected * Rotation.from_matrix(mat_pb)).as_matrix()
    assert np.max(np.abs(mat_nb - expected)) < 1e-13
    h = t[1] - t[0]
    skew = np.swapaxes(mat_nb[1:-1], 1, 2) @ (mat_nb[2:] - mat_nb[:-2]) / (2 * h)
    omega_fd = np.column_stack([skew[:, 2, 1], skew[:, 0, 2], skew[:, 1, 0]])
    assert np.max(np.abs(omega_fd - omega_nb_b[1:-1])) < 1e-4  # central differences: O(h^2 * rate^3)


@pytest.mark.parametrize("spec", [["z", "z"], ["w"], [], ["z", "x", "y", "z"], ["--z"]])
def test_axes_that_are_no_table_are_refused(spec):
    with pytest.raises(ValueError):
        gimbal_axes(spec)


# --------------------------------------------------------------------------- against the simulator's truth


def test_a_three_axis_turntable_log_gives_the_simulators_attitude(records, tmp_path):
    """The simulated turntable (outer z, middle x, inner y), its outer axis counted anticlockwise seen from
    above and reported within 0..360 deg as many controllers do: the record's attitude is the truth."""

    def wrap_outer(rows):  # the outer angle within 0..360: the log wraps where the turn crosses zero
        for k, row in enumerate(rows):
            cells = row.split(",")
            cells[1] = f"{float(cells[1]) % 360.0:.12f}"
            rows[k] = ",".join(cells)

    log, out = tmp_path / "log.csv", tmp_path / "out.h5"
    t, truth = _write_log(log, "turntable", senses=[-1.0, 1.0, 1.0], edit=wrap_outer)
    result = _cli(_args(log, records["turntable"], out, 3, axes="-z,x,y"))
    assert result.exit_code == 0, result.output
    assert _attitude_error_rad(out, truth) < ATTITUDE_TOL_RAD
    back = read_telemetry(out)
    assert back.source.extra["angle_wraps"][0] > 0 and back.source.format == "table-log"
    assert back.reference.time_s == pytest.approx(t, abs=1e-12) and back.site is not None
    assert back.source.extra["imu_record"] == "turntable_imu.h5" and "undone" in result.output
    sim = read_telemetry(records["turntable"].with_name("turntable_sim.h5"))  # the simulator's own /reference
    rows = np.rint(t * IMU_RATE_HZ).astype(int)  # the simulated reference is at the IMU's rate
    assert np.max(quat_angle_between(sim.reference.quat_nb[rows], back.reference.quat_nb)) < ATTITUDE_TOL_RAD


@pytest.mark.parametrize("kind", ["z", "zy", "zyx"])
def test_one_two_and_three_axis_tables(records, tmp_path, kind):
    log, out = tmp_path / "log.csv", tmp_path / "out.h5"
    _, truth = _write_log(log, kind)
    result = _cli(_args(log, records[kind], out, len(kind)))
    assert result.exit_code == 0, result.output
    assert _attitude_error_rad(out, truth) < ATTITUDE_TOL_RAD
    assert "/reference of tumble" in result.output  # the simulated record's own reference is replaced, and said so


def test_an_increment_record_takes_a_log_too(records, tmp_path):
    """The checks against the IMU read increments as mean rates over their intervals."""
    log, out = tmp_path / "log.csv", tmp_path / "out.h5"
    _, truth = _write_log(log, "zyx")
    result = _cli(_args(log, records["increments"], out, 3))
    assert result.exit_code == 0, result.output
    assert _attitude_error_rad(out, truth) < ATTITUDE_TOL_RAD and read_telemetry(out).form == "increments"
    assert re.search(r"which turn 1\.0\d\d\d times as fast|which turn 0\.99\d\d times as fast", result.output)


@pytest.mark.parametrize("modulus", [None, 65536])
def test_counts_that_roll_over_are_unwrapped(records, tmp_path, modulus):
    """Whole counts of a single-turn encoder (0..CPR-1), and of a 16-bit counter rolling over at 65536."""
    log, out = tmp_path / "log.csv", tmp_path / "out.h5"
    _, truth = _write_log(log, "zyx", units="counts", modulus=modulus)
    extra = ["--angle-units", "counts", "--counts-per-rev", CPR] + (["--counter-modulus", modulus] if modulus else [])
    result = _cli(_args(log, records["zyx"], out, 3, *extra))
    assert result.exit_code == 0, result.output
    assert _attitude_error_rad(out, truth) < COUNTS_TOL_RAD
    wraps = read_telemetry(out).source.extra["angle_wraps"]
    assert wraps[0] > 0, wraps  # the heading swings through +-120 deg: the counter rolls over below zero


def test_a_flipped_sense_is_read_with_a_minus_and_refused_without(records, tmp_path):
    log, out = tmp_path / "log.csv", tmp_path / "out.h5"
    _, truth = _write_log(log, "zyx", senses=[-1.0, 1.0, -1.0])
    assert _cli(_args(log, records["zyx"], out, 3, axes="-z,y,-x")).exit_code == 0
    assert _attitude_error_rad(out, truth) < ATTITUDE_TOL_RAD
    line = _one_line_refusal(_cli(_args(log, records["zyx"], tmp_path / "no.h5", 3, axes="z,y,-x")), "--axes", "gyros")
    assert "rows where the table turns" in line
    assert not (tmp_path / "no.h5").exists()


def test_heading_and_mount_enter_as_the_formula_says(records, tmp_path):
    """``mat_nb = Rz(heading) @ chain @ mat_pb``, with a heading and a mount of a few degrees (which the
    checks against the IMU let through: they cannot see a heading, and a few degrees are within them)."""
    log, out = tmp_path / "log.csv", tmp_path / "out.h5"
    _, truth = _write_log(log, "zyx", rates=False)
    mount = Rotation.from_euler("ZYX", [3.0, 2.0, 1.0], degrees=True).as_matrix()  # yaw, pitch, roll
    args = _args(log, records["zyx"], out, 3, "--table-heading-deg", "30", "--mount-deg", "1,2,3", rates=False)
    assert _cli(args).exit_code == 0
    expected = Rotation.from_rotvec([0.0, 0.0, 30.0 * DEG]).as_matrix() @ truth @ mount
    assert _attitude_error_rad(out, expected) < ATTITUDE_TOL_RAD


def test_the_stage_reads_the_log_with_a_time_offset(records, tmp_path):
    """From Python: the log on a clock 1000 s ahead of the IMU's, put back with ``time_offset_s``; the
    IMU rows beyond the log's span are cut and counted."""
    log, out = tmp_path / "log.csv", tmp_path / "out.h5"

    def shift(rows):  # the controller's clock: 1000 s ahead; its log ends 2 s before the IMU's
        rows[:] = [f"{float(r.split(',', 1)[0]) + 1e6:.3f},{r.split(',', 1)[1]}" for r in rows[:-50]]

    _, truth = _write_log(log, "zyx", edit=shift)
    options = dict(
        imu_record=records["zyx"],
        axes=("z", "y", "x"),
        time="time_ms",
        time_units="ms",
        time_offset_s=-1000.0,
        angles=("pos1", "pos2", "pos3"),
        site_deg=SITE_DEG,
    )
    result = run(ImportConfig("table-log", log, out, options=options))
    assert _attitude_error_rad(out, truth[:-50]) < ATTITUDE_TOL_RAD
    assert result.samples == read_telemetry(records["zyx"]).n_samples - 100  # 2 s at 50 Hz cut
    assert any("cut: 0 before, 100 after" in line for line in result.conversion)


# --------------------------------------------------------------------------- refusals


def _set_cell(line: int, col: int, text: str):
    def edit(rows):
        cells = rows[line - 2].split(",")
        cells[col] = text
        rows[line - 2] = ",".join(cells)

    return edit


REFUSALS = {
    "time goes back": (dict(edit=_set_cell(10, 0, "100.000")), [], ("'time_ms'", "goes back on line 10", "sort")),
    "NaN": (dict(edit=_set_cell(7, 3, "nan")), [], ("'pos2'", "line 7", "--angles")),
    "empty cell": (dict(edit=_set_cell(7, 4, "")), [], ("'rate2'", "line 7", "--rates")),
    "missing column": ({}, ["--angles", "pos1,pos2,az"], ("'az'", "columns are: time_ms, pos1, rate1")),
    "milliseconds read as seconds": ({}, ["--time-units", "s"], ("'time_ms'", "--time-units ms")),
    "not overlapping": ({}, ["--time-offset-s", "100"], ("do not overlap", "--time-offset-s")),
    "degrees read as radians": ({}, ["--angle-units", "rad"], ("--angle-units",)),
    "counts without a count per turn": ({}, ["--angle-units", "counts"], ("--counts-per-rev", "is missing")),
    "rates in other units": ({}, ["--rate-units", "rad/s"], ("'rate1'", "57.3", "--rate-units")),
    "too few angle columns": ({}, ["--angles", "pos1,pos2"], ("--angles names 2 columns", "--axes names 3")),
    "an axis twice": ({}, ["--axes", "z,z,x"], ("--axes", "both turn about z")),
    "a mount of two angles": ({}, ["--mount-deg", "1,2"], ("--mount-deg",)),
}


@pytest.mark.parametrize("case", REFUSALS, ids=list(REFUSALS))
def test_bad_logs_and_options_are_one_line(records, tmp_path, case):
    log_options, extra, words = REFUSALS[case]
    log, out = tmp_path / "log.csv", tmp_path / "out.h5"
    _write_log(log, "zyx", **log_options)
    _one_line_refusal(_cli(_args(log, records["zyx"], out, 3) + [str(e) for e in extra]), *words)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["log.csv"]


def test_counts_read_as_degrees_are_refused(records, tmp_path):
    log = tmp_path / "log.csv"
    _write_log(log, "zyx", units="counts")
    line = _one_line_refusal(_cli(_args(log, records["zyx"], tmp_path / "o.h5", 3, rates=False)), "--angles")
    assert "beyond any table" in line or "not wraps of deg" in line


def test_degrees_read_as_radians_on_a_vertical_axis_are_refused(records, tmp_path):
    """About a vertical axis alone neither gravity nor the gyros' direction tell the angles' unit; the
    gyros' speed does: they turn 57 times slower than the log says."""
    log = tmp_path / "log.csv"
    _write_log(log, "z")
    result = _cli(_args(log, records["z"], tmp_path / "o.h5", 1, "--angle-units", "rad"))
    _one_line_refusal(result, "gyros of tumble_z.h5 turn 0.01745 times as fast", "--angle-units")


def test_no_site_anywhere_and_an_output_on_the_imu_record_are_refused(records, tmp_path):
    log = tmp_path / "log.csv"
    _write_log(log, "turntable")
    args = _args(log, records["no_site"], tmp_path / "o.h5", 3, axes="z,x,y")
    k = args.index("--site-deg")
    _one_line_refusal(_cli(args[:k] + args[k + 2 :]), "no_site.h5", "--site-deg LAT,LON,H")
    copy = tmp_path / "imu.h5"
    copy.write_bytes(Path(records["turntable"]).read_bytes())
    _one_line_refusal(_cli(_args(log, copy, copy, 3, "--force", axes="z,x,y")), "would overwrite the input")
    assert read_telemetry(copy).reference is None  # the input is untouched


# --------------------------------------------------------------------------- the how-to, end to end


@pytest.mark.slow
def test_the_howto_runs_as_the_page_says(tmp_path):
    """docs/howto/calibrate-a-real-turntable.md, in the page's order: the example's logs, then each
    ``sh`` block's sizefx command (it must succeed), each ``text`` block's lines among what the
    commands before it printed, and each ``console`` block's command refused with the lines it shows."""
    page = (ROOT / "docs" / "howto" / "calibrate-a-real-turntable.md").read_text()
    subprocess.run([sys.executable, ROOT / "examples" / "make_table_log.py", "--out", tmp_path / "run"], check=True)
    sizefx = Path(sys.executable).with_name("sizefx")

    def run_sizefx(command):
        return subprocess.run([sizefx, *command.split()[1:]], cwd=tmp_path, capture_output=True, text=True)

    printed, checked = [], 0
    for kind, body in re.findall(r"```(sh|text|console)\n(.*?)```", page, flags=re.S):
        if kind == "sh" and body.startswith("sizefx "):
            result = run_sizefx(" ".join(body.replace("\\\n", " ").split()))
            assert result.returncode == 0, result.stderr
            printed += result.stdout.splitlines()
        elif kind == "text":
            missing = [line for line in body.splitlines() if line not in printed]
            assert not missing, missing
            checked += 1
        elif kind == "console":
            command, _, shown = body.replace("\\\n", " ").partition("\n")
            result = run_sizefx(" ".join(command.removeprefix("$ ").split()))
            assert result.returncode == 2 and result.stderr.splitlines() == shown.splitlines(), result.stderr
            checked += 1
    assert checked >= 4  # the page's outputs were found and compared
