"""Importers on the real recordings in ../shared/data/real, frame conversions, and bad sources."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner
from support import IMUCAL, REAL, REAL_FILES, real_data

from sizefx import earth
from sizefx.constants import DEG, OMEGA_EARTH_RAD_S
from sizefx.errors import ConfigError, SourceError, UnitsError
from sizefx.frames import MAT_FRD_FLU, MAT_FRD_RFU, enu_to_ned, mat_nb_from_enu_body, psins_mat_enu_rfu
from sizefx.importers import run_import
from sizefx.importers.table import axis_matrix
from sizefx.io.telemetry import read_telemetry
from sizefx.rotation import mat_to_euler, quat_multiply, quat_to_mat
from sizefx_cli.main import main

#: a test that reads the real recordings: skipped with the reason when they are missing (failed under .ci/run)
needs_real = pytest.mark.usefixtures("real_data_folder")


@pytest.fixture(scope="module")
def imported(tmp_path_factory):
    """Each real file imported once: name -> (summary, Telemetry read back)."""
    real_data()
    out = {}
    folder = tmp_path_factory.mktemp("imported")
    for name, (fmt, rel, opts) in REAL_FILES.items():
        summary = run_import(fmt, REAL / rel, folder / f"{name}.h5", **opts)
        out[name] = (summary, read_telemetry(folder / f"{name}.h5", allow_gaps=True))
    return out


@needs_real
@pytest.mark.parametrize("name", list(REAL_FILES))
def test_every_real_file_imports_and_validates(imported, name):
    summary, tel = imported[name]
    assert tel.n_samples == summary["samples"] > 1000
    assert tel.source.format == REAL_FILES[name][0]
    assert len(tel.source.sha256) == 64
    assert tel.description


# --------------------------------------------------------------------------- physical sanity

#: How the units check judges each real file's gyros: against the motion capture or
#: the FOG-INS attitude, against the tilts between imucal's static faces, or not at all (with the reason
#: given) where nothing rotates against a reference and nothing tilts by 20 deg.
GYRO_CHECK = {
    "broad07": "reference",
    "broad09": "reference",
    "broad16": "reference",
    "broad21": "reference",
    "lasergyro": None,
    "fog_mems": "reference",
    "imucal": "tilt",
    "px4": None,
}
#: Real, partly uncalibrated sensors: imucal's raw accelerometers read 1.054 g at rest, BROAD's gyros
#: 0.98 of the motion capture's rate; a unit mistake is a factor 9.8 or 57.3.
REAL_RATIO_TOL = 0.08


@needs_real
@pytest.mark.parametrize("name", list(REAL_FILES))
def test_units_check_passes_every_real_file(imported, name):
    units = imported[name][0]["units_check"]
    assert units["accel"]["verdict"] == "ok", units["accel"]["detail"]
    assert units["accel"]["ratio"] == pytest.approx(1.0, abs=REAL_RATIO_TOL)
    gyro = units["gyro"]
    if GYRO_CHECK[name] is None:
        assert gyro["verdict"] == "unchecked" and "not checked" in gyro["detail"]
    else:
        assert gyro["verdict"] == "ok" and gyro["method"] == GYRO_CHECK[name], gyro["detail"]
        assert gyro["ratio"] == pytest.approx(1.0, abs=REAL_RATIO_TOL)


@needs_real
def test_ring_laser_log_reads_earth_rate_and_gravity(imported):
    _, tel = imported["lasergyro"]
    dt = tel.sample_period_s
    w = tel.dtheta_rad.mean(axis=0) / dt
    f = tel.dvel_mps.mean(axis=0) / dt
    # 14.85 deg/h measured against 15.04 deg/h expected
    assert np.degrees(np.linalg.norm(w)) * 3600 == pytest.approx(14.85, abs=0.01)
    assert np.linalg.norm(w) == pytest.approx(OMEGA_EARTH_RAD_S, rel=0.02)
    g = earth.gravity_n(tel.site.lat_rad, tel.site.height_m)[2]
    assert np.linalg.norm(f) == pytest.approx(g, rel=1e-4)
    # FRD: z down reads -g, and the vertical Earth rate -Omega sin(lat) (within the 1.3 % the log is low)
    assert f[2] == pytest.approx(-g, rel=1e-3)
    assert w[2] == pytest.approx(-OMEGA_EARTH_RAD_S * np.sin(tel.site.lat_rad), rel=0.03)
    # the header's approximate attitude becomes heading 90.6 deg in NED/FRD
    _, _, heading = mat_to_euler(quat_to_mat(tel.reference.quat_nb[0]))
    assert np.degrees(heading) == pytest.approx(90.6, abs=1e-9)


def _rate_from_quaternions(time_s, quat_nb):
    """Body rate of consecutive reference rows (gaps skipped): 2 vec(conj(q_k) q_k+1) / dt at the midpoints."""
    dt = np.diff(time_s)
    ok = dt < 1.5 * np.median(dt)
    dq = quat_multiply(np.column_stack([quat_nb[:-1, :1], -quat_nb[:-1, 1:]]), quat_nb[1:])
    dq *= np.sign(dq[:, :1])
    rate = 2.0 * dq[:, 1:] / dt[:, None]
    return (0.5 * (time_s[:-1] + time_s[1:]))[ok], rate[ok]


@needs_real
@pytest.mark.parametrize("name", ["broad07", "broad21"])
def test_broad_gyros_agree_with_the_motion_capture_rate(imported, name):
    _, tel = imported[name]
    t_mid, w_ref = _rate_from_quaternions(tel.reference.time_s, tel.reference.quat_nb)
    w_gyro = np.column_stack([np.interp(t_mid, tel.time_s, tel.gyro_rad_s[:, i]) for i in range(3)])
    for axis in range(3):
        corr = np.corrcoef(w_gyro[:, axis], w_ref[:, axis])[0, 1]
        assert corr > 0.95, (name, axis, corr)  # a wrong axis or sign would give ~0 or -1
    # at rest (first second) the FRD accelerometers read -g on z
    rest = tel.time_s < 1.0
    f = tel.accel_mps2[rest].mean(axis=0)
    assert f[2] == pytest.approx(-9.81, abs=0.1) and np.hypot(f[0], f[1]) < 0.3


@needs_real
def test_broad_dropouts_are_left_out_of_the_reference(imported):
    summary, tel = imported["broad07"]
    assert summary["reference_rows"] == tel.n_samples - tel.source.extra["reference_dropout_rows"]
    assert tel.source.extra["reference_dropout_rows"] == 1594
    assert np.all(np.isfinite(tel.reference.quat_nb)) and np.all(np.isfinite(tel.reference.lat_rad))


@needs_real
def test_fog_mems_record_moves_forward_along_body_x(imported):
    _, tel = imported["fog_mems"]
    ref = tel.reference
    mat_nb = quat_to_mat(ref.quat_nb)
    v_b = np.einsum("nji,nj->ni", mat_nb, ref.velocity_n_mps)
    moving = np.linalg.norm(ref.velocity_n_mps, axis=1) > 2.0
    assert moving.sum() > 500
    # a car: forward speed dominates. The data show a steady ~5 deg between the velocity and the
    # FOG-INS x axis (its mounting on the car); a conversion error would be 90 or 180 deg, or vary.
    assert np.all(v_b[moving, 0] > 0)
    sideslip = np.degrees(np.arctan2(np.abs(v_b[moving, 1:]), v_b[moving, :1]))
    assert sideslip.max() < 7.0
    assert np.ptp(sideslip[:, 0]) < 3.0  # steady, not motion-dependent
    # the MEMS gyros follow the rate of the FOG-INS attitude on every axis: compare like with
    # like, the MEMS increments summed over each 0.1 s reference interval
    _, w_ref = _rate_from_quaternions(ref.time_s, ref.quat_nb)
    angle = np.vstack([np.zeros(3), np.cumsum(tel.dtheta_rad, axis=0)])
    t_edges = np.r_[tel.time_s[0] - tel.sample_period_s, tel.time_s]
    angle_at_ref = np.column_stack([np.interp(ref.time_s, t_edges, angle[:, i]) for i in range(3)])
    w_mems = np.diff(angle_at_ref, axis=0) / np.diff(ref.time_s)[:, None]
    for axis in range(3):
        assert np.corrcoef(w_mems[:, axis], w_ref[:, axis])[0, 1] > 0.95, axis
    f_all = tel.dvel_mps / tel.sample_period_s
    # this MEMS reads ~3 % low on average (its scale factor; the importer does not correct data)
    assert np.linalg.norm(f_all.mean(axis=0)) == pytest.approx(9.79, rel=0.05)
    # levelling: roll from the accelerometers (f_y = -g sin(roll) cos(pitch)) matches the FOG-INS roll,
    # which a sign or axis mistake in either conversion would break
    f = f_all[:100].mean(axis=0)
    roll_accel = np.arcsin(-f[1] / np.linalg.norm(f))
    roll_ref, _, _ = mat_to_euler(mat_nb[0])
    assert np.degrees(roll_accel) == pytest.approx(np.degrees(roll_ref), abs=0.3)
    # biases carried over, in FRD: (x, y, z)_FRD = (y, x, -z)_RFU
    rfu = np.asarray(tel.source.extra["psins_eb0_rad_s_rfu"])
    np.testing.assert_array_equal(tel.source.extra["gyro_bias_rad_s_frd"], [rfu[1], rfu[0], -rfu[2]])


@needs_real
def test_imucal_rotations_are_minus_360_deg_and_faces_read_g(imported):
    _, tel = imported["imucal"]
    sections = json.loads((REAL / "imucal/example_ferraris_session_list.json").read_text())
    dt = 1 / 102.4
    for axis, key in enumerate(("x_rot", "y_rot", "z_rot")):
        s = sections[key]
        angle = np.degrees(tel.gyro_rad_s[s["start"] : s["end"], axis].sum() * dt)
        # uncalibrated sensor, hand-turned: "each rotation is about -360 deg"
        assert angle == pytest.approx(-360.0, rel=0.1), (key, angle)
    for key in ("x_p", "x_a", "y_p", "y_a", "z_p", "z_a"):
        s = sections[key]
        f = np.linalg.norm(tel.accel_mps2[s["start"] : s["end"]].mean(axis=0))
        assert f == pytest.approx(9.81, rel=0.08), (key, f)  # raw, uncalibrated accelerometers


@needs_real
def test_px4_dropouts_are_gaps_and_accelerometers_have_their_own_stamps(imported, tmp_path):
    summary, tel = imported["px4"]
    # one count, one per dropout (the gyro and accelerometer stamps show each once)
    assert [g.dataset for g in tel.gaps].count("/imu/time") == 8 == len(tel.gaps) == summary["imu_gaps"]
    assert summary["declared_gaps"] == 8 and all(g.declared for g in tel.gaps)
    assert tel.accel_time_s is not None and np.all(tel.accel_time_s >= tel.time_s)
    assert np.linalg.norm(np.median(tel.accel_mps2, axis=0)) == pytest.approx(9.8, abs=0.3)
    # declared gaps are a property of the record: read without --allow-gaps (tests/test_gaps.py has the rest)
    assert len(read_telemetry(summary["path"]).gaps) == 8


@needs_real
def test_real_imucal_csv_mislabelled_as_rad_s_is_refused(tmp_path):
    """The raw imucal gyros are in deg/s (no reference: the tilts between its static faces decide)."""
    src = REAL / "imucal/example_ferraris_session.csv"
    with pytest.raises(UnitsError) as info:
        run_import("csv", src, tmp_path / "o.h5", **{**IMUCAL, "gyro_units": "rad/s"})
    msg = str(info.value)
    assert msg.startswith(f"{src}: gyro columns gyr_x, gyr_y, gyr_z: explains the 5 tilt changes"), msg
    assert "the data look like deg/s, not rad/s: import with --gyro-units deg/s" in msg
    with pytest.raises(
        UnitsError,
        match="accel columns acc_x, acc_y, acc_z: reads 101.3 m/s.2 at rest .* "
        "the data look like m/s\\^2, not g: import with --accel-units m/s\\^2",
    ):
        run_import("csv", src, tmp_path / "o.h5", **{**IMUCAL, "accel_units": "g"})
    assert not (tmp_path / "o.h5").exists()


# --------------------------------------------------------------------------- conversions in closed form


def test_enu_to_ned_and_rfu_to_frd():
    np.testing.assert_array_equal(enu_to_ned([1.0, 2.0, 3.0]), [2.0, 1.0, -3.0])
    # right, forward, up sensor axes -> forward, right, down
    np.testing.assert_array_equal(MAT_FRD_RFU @ [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    np.testing.assert_array_equal(MAT_FRD_RFU @ [0.0, 1.0, 0.0], [1.0, 0.0, 0.0])
    np.testing.assert_array_equal(MAT_FRD_RFU @ [0.0, 0.0, 1.0], [0.0, 0.0, -1.0])
    np.testing.assert_array_equal(MAT_FRD_FLU @ [0.0, 1.0, 1.0], [0.0, -1.0, -1.0])
    for m in (MAT_FRD_RFU, MAT_FRD_FLU):
        assert np.linalg.det(m) == pytest.approx(1.0)


def test_psins_attitude_converts_to_heading_minus_yaw():
    for yaw_deg in (-90.6, 30.0, 170.0):
        mat_nb = mat_nb_from_enu_body(psins_mat_enu_rfu(0.0, 0.0, yaw_deg * DEG), MAT_FRD_RFU.T)
        roll, pitch, heading = mat_to_euler(mat_nb)
        assert np.degrees(heading) == pytest.approx(-yaw_deg, abs=1e-12)
        assert abs(roll) < 1e-15 and abs(pitch) < 1e-15
    # PSINS pitch (nose up, about the right axis) is sizefx pitch; PSINS roll (about forward) is roll
    roll, pitch, _ = mat_to_euler(mat_nb_from_enu_body(psins_mat_enu_rfu(0.1, 0.0, 0.0), MAT_FRD_RFU.T))
    assert pitch == pytest.approx(0.1) and abs(roll) < 1e-15
    roll, pitch, _ = mat_to_euler(mat_nb_from_enu_body(psins_mat_enu_rfu(0.0, 0.2, 0.0), MAT_FRD_RFU.T))
    assert roll == pytest.approx(0.2) and abs(pitch) < 1e-15
    # PSINS's own meaning of each angle, in ENU/RFU: yaw 90 deg (counter-clockwise) points forward west,
    # pitch raises the nose, roll lowers the right side
    np.testing.assert_allclose(psins_mat_enu_rfu(0.0, 0.0, np.pi / 2) @ [0, 1, 0], [-1, 0, 0], atol=1e-15)
    np.testing.assert_allclose(psins_mat_enu_rfu(0.1, 0.0, 0.0) @ [0, 1, 0], [0, np.cos(0.1), np.sin(0.1)], atol=1e-15)
    np.testing.assert_allclose(psins_mat_enu_rfu(0.0, 0.2, 0.0) @ [1, 0, 0], [np.cos(0.2), 0, -np.sin(0.2)], atol=1e-15)


def test_axis_map():
    np.testing.assert_array_equal(axis_matrix(("y", "x", "-z")), MAT_FRD_RFU)
    with pytest.raises(ValueError, match="not a rotation"):
        axis_matrix(("x", "y", "-z"))
    with pytest.raises(ValueError, match="not an axis"):
        axis_matrix(("x", "y", "w"))


# --------------------------------------------------------------------------- bad sources


def _csv(tmp_path, text):
    p = tmp_path / "log.csv"
    p.write_text(text)
    return p


GOOD_CSV = "t,gx,gy,gz,ax,ay,az\n" + "".join(f"{k / 100},0,0,0,0,0,-9.8\n" for k in range(200))


@pytest.mark.parametrize(
    "text,options,words",
    [
        (GOOD_CSV, {"gyro": ("gx", "gy", "gq")}, "column 'gq' is not in the header"),
        (GOOD_CSV.replace("0,0,-9.8\n", "0,x,-9.8\n", 1), {}, "not numeric"),
        (GOOD_CSV, {"gyro_units": "dps"}, "gyro units 'dps' are not known"),
        (GOOD_CSV, {"time_units": "samples"}, "needs the sample rate"),
        (GOOD_CSV, {"axes": ("x", "x", "z")}, "not a rotation"),
        ("t,gx,gy,gz,ax,ay,az\n", {}, "0 data rows"),
    ],
)
def test_bad_csv_sources(tmp_path, text, options, words):
    opts = dict(time="t", gyro=("gx", "gy", "gz"), accel=("ax", "ay", "az")) | options
    with pytest.raises(SourceError) as info:
        run_import("csv", _csv(tmp_path, text), tmp_path / "out.h5", **opts)
    assert words in str(info.value) and "\n" not in str(info.value)
    assert not (tmp_path / "out.h5").exists()


@needs_real
def test_truncated_psins_log(tmp_path):
    text = (REAL / "psins/lasergyro.imu").read_text()
    cut = tmp_path / "cut.imu"
    cut.write_text(text[: len(text) // 2].rsplit(" ", 2)[0])  # stop in the middle of a line
    with pytest.raises(SourceError, match=r"line \d+ has \d values, expected 6 .* truncated"):
        run_import("psins-imu", cut, tmp_path / "out.h5")


@needs_real
@pytest.mark.parametrize(
    "fmt,rel",
    [("broad", "broad/07_undisturbed_fast_rotation_B.mat"), ("psins-mat", "psins/transfer_align_fog_mems.mat")],
)
def test_truncated_mat(tmp_path, fmt, rel):
    data = (REAL / rel).read_bytes()
    cut = tmp_path / "cut.mat"
    cut.write_bytes(data[: len(data) // 3])
    with pytest.raises(SourceError, match="truncated or not a .mat|is missing"):
        run_import(fmt, cut, tmp_path / "out.h5")


def test_mat_without_the_expected_variables(tmp_path):
    import scipy.io

    p = tmp_path / "other.mat"
    scipy.io.savemat(p, {"imu_gyr": np.zeros((10, 3))})
    with pytest.raises(SourceError, match="variable 'imu_acc' is missing; not a BROAD trial"):
        run_import("broad", p, tmp_path / "out.h5")


def test_not_a_ulog(tmp_path):
    p = tmp_path / "x.ulg"
    p.write_bytes(b"\x00" * 64 + b"definitely not a ULog")
    with pytest.raises(SourceError, match="not a readable PX4 ULog"):
        run_import("ulog", p, tmp_path / "out.h5")


def test_missing_and_empty_source(tmp_path):
    with pytest.raises(ConfigError, match="none.imu: SOURCE: no such file"):  # the shared pre-flight
        run_import("psins-imu", tmp_path / "none.imu", tmp_path / "out.h5")
    (tmp_path / "empty.imu").write_text("")
    with pytest.raises(SourceError, match="empty"):
        run_import("psins-imu", tmp_path / "empty.imu", tmp_path / "out.h5")


def test_cli_import_bad_source_is_one_line_exit_2(tmp_path):
    p = _csv(tmp_path, GOOD_CSV)
    result = CliRunner().invoke(
        main,
        [
            "import",
            "csv",
            str(p),
            "-o",
            str(tmp_path / "o.h5"),
            "--time",
            "t",
            "--gyro",
            "gx,gy,nope",
            "--accel",
            "ax,ay,az",
        ],
    )
    assert result.exit_code == 2
    assert result.output.strip().count("\n") == 0 and "column 'nope'" in result.output


def test_cli_import_csv_round_trip(tmp_path):
    p = _csv(tmp_path, GOOD_CSV)
    out = tmp_path / "o.h5"
    result = CliRunner().invoke(
        main,
        [
            "import",
            "csv",
            str(p),
            "-o",
            str(out),
            "--time",
            "t",
            "--gyro",
            "gx,gy,gz",
            "--accel",
            "ax,ay,az",
            "--axes",
            "y,x,-z",
            "--site-deg",
            "50,10,100",
        ],
    )
    assert result.exit_code == 0, result.output
    tel = read_telemetry(out)
    np.testing.assert_allclose(tel.accel_mps2[0], [0.0, 0.0, 9.8])  # sensor z up -> body z down
    assert tel.site.height_m == 100.0
    again = CliRunner().invoke(
        main,
        ["import", "csv", str(p), "-o", str(p), "--time", "t", "--gyro", "gx,gy,gz", "--accel", "ax,ay,az", "--force"],
    )
    assert again.exit_code == 2 and "overwrite the input" in again.output


# --------------------------------------------------------------------------- the stage

CSV_OPTIONS = dict(time="t", gyro=("gx", "gy", "gz"), accel=("ax", "ay", "az"))


def test_import_is_a_stage_whose_report_the_command_prints(tmp_path):
    from dataclasses import FrozenInstanceError

    from sizefx.importers import ImportConfig, ImportResult, run

    src = _csv(tmp_path, GOOD_CSV)
    cfg = ImportConfig("csv", src, tmp_path / "a.h5", options=CSV_OPTIONS)
    with pytest.raises(FrozenInstanceError):
        cfg.force = True
    with pytest.raises(TypeError):
        cfg.options["time"] = "n"  # the options are frozen too
    res = run(cfg)
    assert isinstance(res, ImportResult) and res.samples == 200 and res.form == "rates"
    assert res.to_json()["samples"] == 200 and res.to_json()["units_check"]["accel"]["verdict"] == "ok"
    json.dumps(res.to_json())  # JSON-ready
    cli = CliRunner().invoke(
        main,
        [
            "import",
            "csv",
            str(src),
            "-o",
            str(tmp_path / "b.h5"),
            "--time",
            "t",
            "--gyro",
            "gx,gy,gz",
            "--accel",
            "ax,ay,az",
        ],
    )
    assert cli.exit_code == 0, cli.output
    assert cli.output == res.report().replace(str(tmp_path / "a.h5"), str(tmp_path / "b.h5")) + "\n"
    assert cli.output.startswith(f"wrote {tmp_path / 'b.h5'}: 200 rates samples at 100 Hz, 1.99 s; reference rows: 0")


def test_import_runs_the_preflight_before_any_conversion(tmp_path):
    from sizefx.errors import OutputError
    from sizefx.importers import ImportConfig, run

    src = _csv(tmp_path, GOOD_CSV)
    out = tmp_path / "out.h5"
    out.write_bytes(b"keep")
    bad = dict(CSV_OPTIONS, gyro=("gx", "gy", "nope"))  # a conversion would fail on this column
    with pytest.raises(OutputError, match="output exists; pass --force"):
        run(ImportConfig("csv", src, out, options=bad))
    assert out.read_bytes() == b"keep"


def test_import_names_the_output_not_the_temporary_file_when_writing_fails(tmp_path, monkeypatch):
    import errno

    import sizefx.importers as importers
    from sizefx.errors import OutputError

    def full_disk(path, *args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    monkeypatch.setattr(importers, "write_telemetry", full_disk)
    out = tmp_path / "out.h5"
    with pytest.raises(OutputError) as info:
        importers.run(importers.ImportConfig("csv", _csv(tmp_path, GOOD_CSV), out, options=CSV_OPTIONS))
    message = str(info.value)
    assert message.startswith(f"{out}: cannot be written (No space left on device)") and ".tmp" not in message
    assert not out.exists() and list(tmp_path.glob(".out.h5.*")) == []  # no temporary file left behind


def test_invalid_rows_are_refused_or_dropped_as_gaps(tmp_path):
    """A CSV with a NaN and an absurd sample: refused in one line by default; with
    --drop-invalid-rows the two rows become declared gaps, counted, the first named."""
    rows = [f"{k / 100},0,0,0,0,0,-9.8\n" for k in range(200)]
    rows[50] = "0.5,0,nan,0,0,0,-9.8\n"
    rows[120] = "1.2,0,0,0,1e300,0,-9.8\n"
    src = _csv(tmp_path, "t,gx,gy,gz,ax,ay,az\n" + "".join(rows))
    out = tmp_path / "o.h5"
    args = ["import", "csv", str(src), "-o", str(out), "--time", "t", "--gyro", "gx,gy,gz", "--accel", "ax,ay,az"]
    refused = CliRunner().invoke(main, args)
    assert refused.exit_code == 2 and refused.stderr.count("\n") == 1 and "'gy' (--gyro) holds NaN" in refused.stderr, (
        refused.stderr
    )
    assert str(src) in refused.stderr and ".tmp" not in refused.stderr and not out.exists()
    kept = CliRunner().invoke(main, args + ["--drop-invalid-rows"])
    assert kept.exit_code == 0, kept.output
    assert "dropped 2 IMU rows" in kept.stdout and "source row 50, after t = 0.490000 s" in kept.stdout
    tel = read_telemetry(out)  # the holes are declared gaps: no --allow-gaps needed
    assert tel.n_samples == 198 and sum(g.declared for g in tel.gaps) == 2


def test_a_fixed_unit_format_whose_stamps_imply_an_implausible_rate_is_refused(tmp_path, monkeypatch):
    """The formats whose time unit is fixed (psins, broad, ulog) get the rate check too: a source whose
    converted stamps imply 0.1 Hz is not what its format promises; refused before anything is written."""
    import sizefx.importers as importers
    from sizefx.io.telemetry import Telemetry

    n = 50
    slow = Telemetry(time_s=np.arange(n) * 10.0, form="rates")  # 0.1 Hz
    slow.gyro_rad_s, slow.accel_mps2 = np.zeros((n, 3)), np.tile([0.0, 0.0, -9.81], (n, 1))
    monkeypatch.setattr(importers, "load_source", lambda *args, **kwargs: slow)
    src = tmp_path / "log.imu"
    src.write_text("a PSINS log\n")
    out = tmp_path / "o.h5"
    with pytest.raises(SourceError) as info:
        importers.run(importers.ImportConfig("psins-imu", src, out))
    assert str(info.value) == (
        f"{src}: its IMU time stamps imply 0.1 Hz (the median step), outside the 5..35000 Hz of an IMU; "
        "check that the source is a genuine psins-imu file"
    )
    assert not out.exists()
