"""``sizefx import csv`` with a reference: attitude (quaternion or Euler), velocity, position, frames, time.

The record is built in closed form: a body whose roll, pitch and heading follow sinusoids, at rest
on a site, so its accelerometers read gravity only (``f_b = mat_nb^T (0, 0, -g)``). The expected
``/reference/quaternion`` is scipy's quaternion of that ``mat_nb`` (an independent implementation of
the convention), and every variant of the CSV (quaternion or Euler, NED or ENU, same file or separate,
s or ms) must import to it.
"""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.spatial.transform import Rotation

from sizefx.errors import SourceError
from sizefx.importers import run_import
from sizefx.io.telemetry import read_telemetry
from sizefx_cli.main import main

RATE_HZ = 100.0
N_IMU = 401  #: 4 s at 100 Hz
DECIMATION = 4  #: reference at 25 Hz
G_MPS2 = 9.81
SITE_DEG = (52.5, 13.3, 40.0)
V_N_MPS = np.array([1.5, -0.5, 0.25])  #: a constant NED velocity (the reference is copied, not checked, here)
#: The CSV holds 10 significant digits: the imported attitude is exact to about 1e-9 rad.
ATTITUDE_TOL_RAD = 1e-8
#: East-North-Up from North-East-Down, and forward-left-up from forward-right-down, written out
#: here rather than taken from sizefx.frames, so the test checks those constants too.
MAT_ENU_NED = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
MAT_FLU_FRD = np.diag([1.0, -1.0, -1.0])

IMU_HEADER = ["t", "gx", "gy", "gz", "ax", "ay", "az"]


def _motion():
    t = np.arange(N_IMU) / RATE_HZ
    roll = 0.4 * np.sin(2 * np.pi * 0.5 * t)
    pitch = 0.3 * np.sin(2 * np.pi * 0.3 * t + 1.0)
    heading = 2.0 + 1.0 * np.sin(2 * np.pi * 0.2 * t)
    rot_nb = Rotation.from_euler("ZYX", np.column_stack([heading, pitch, roll]))  # intrinsic z-y-x
    return t, roll, pitch, heading, rot_nb


T_S, ROLL, PITCH, HEADING, ROT_NB = _motion()
MAT_NB = ROT_NB.as_matrix()
F_B = -G_MPS2 * MAT_NB[:, 2, :]  # mat_nb^T (0, 0, -g): gravity's specific force in body axes
GYRO_B = np.tile([0.01, -0.02, 0.03], (N_IMU, 1))  # any plausible rate: not used by the reference
REF_ROWS = np.arange(0, N_IMU, DECIMATION)


def _cell(v):
    return "" if v is None else f"{v:.10g}"


def _write(path, header, rows):
    path.write_text(",".join(header) + "\n" + "".join(",".join(_cell(v) for v in row) + "\n" for row in rows))
    return path


def _imu_rows(sensor="frd"):
    m = MAT_FLU_FRD if sensor == "flu" else np.eye(3)
    return np.column_stack([T_S, GYRO_B @ m.T, F_B @ m.T]).tolist()


def _reference_columns(kind: str, frame: str = "ned", sensor: str = "frd"):
    """Reference values at REF_ROWS: ``quaternion`` [w, x, y, z] of the sensor axes in ``frame``,
    or roll, pitch, heading [deg]; then velocity in ``frame`` and lat [deg], lon [deg], h [m]."""
    mat_s_b = MAT_FLU_FRD if sensor == "flu" else np.eye(3)
    mat_frame_n = MAT_ENU_NED if frame == "enu" else np.eye(3)
    k = REF_ROWS
    if kind == "quaternion":
        mat = mat_frame_n @ MAT_NB[k] @ mat_s_b.T
        att = Rotation.from_matrix(mat).as_quat(scalar_first=True)
    else:
        att = np.degrees(np.column_stack([ROLL[k], PITCH[k], HEADING[k]]))
    vel = np.tile(mat_frame_n @ V_N_MPS, (k.size, 1))
    pos = np.tile(SITE_DEG, (k.size, 1))
    return np.column_stack([att, vel, pos])


QUAT_COLS = ("qw", "qx", "qy", "qz")
EULER_COLS = ("roll_deg", "pitch_deg", "heading_deg")
VEL_COLS = ("v1", "v2", "v3")
POS_COLS = ("lat", "lon", "h")
IMU_OPTS = dict(time="t", gyro=("gx", "gy", "gz"), accel=("ax", "ay", "az"))


def _reference_file(
    tmp_path, kind="quaternion", frame="ned", sensor="frd", time_scale=1.0, time_offset=0.0, name="ref.csv"
):
    att = QUAT_COLS if kind == "quaternion" else EULER_COLS
    rows = np.column_stack(
        [(T_S[REF_ROWS] + time_offset) * time_scale, _reference_columns(kind, frame, sensor)]
    ).tolist()
    return _write(tmp_path / name, ["t", *att, *VEL_COLS, *POS_COLS], rows)  # "t": --reference-time defaults to --time


def _imu_file(tmp_path, sensor="frd"):
    return _write(tmp_path / "imu.csv", IMU_HEADER, _imu_rows(sensor))


def _ref_opts(kind="quaternion", **extra):
    att = {"reference_quaternion": QUAT_COLS} if kind == "quaternion" else {"reference_euler": EULER_COLS}
    return att | {"reference_velocity": VEL_COLS, "reference_position": POS_COLS} | extra


def _import(tmp_path, source, name="out.h5", **options):
    out = tmp_path / name
    summary = run_import("csv", source, out, **(IMU_OPTS | options))
    return read_telemetry(out), summary


def _assert_truth(ref, rows=REF_ROWS):
    """The imported reference is the closed-form motion: attitude, NED velocity, position."""
    want = ROT_NB[rows]
    got = Rotation.from_quat(ref.quat_nb, scalar_first=True)
    assert np.max((got * want.inv()).magnitude()) < ATTITUDE_TOL_RAD
    np.testing.assert_allclose(ref.time_s, T_S[rows], rtol=0, atol=1e-12)
    np.testing.assert_allclose(ref.velocity_n_mps, np.tile(V_N_MPS, (rows.size, 1)), rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.degrees(ref.lat_rad), SITE_DEG[0], rtol=0, atol=1e-10)
    np.testing.assert_allclose(ref.height_m, SITE_DEG[2], rtol=0, atol=1e-12)


# --------------------------------------------------------------------------- what is imported


@pytest.mark.parametrize("kind", ["quaternion", "euler"])
def test_quaternion_and_euler_give_the_closed_form_attitude(tmp_path, kind):
    tel, summary = _import(
        tmp_path, _imu_file(tmp_path), reference_file=_reference_file(tmp_path, kind), **_ref_opts(kind)
    )
    _assert_truth(tel.reference)
    assert summary["reference_rows"] == REF_ROWS.size and summary["reference_gaps"] == 0


def test_euler_in_radians(tmp_path):
    rows = np.column_stack([T_S[REF_ROWS], np.radians(_reference_columns("euler")[:, :3])]).tolist()
    ref = _write(tmp_path / "ref.csv", ["t", *EULER_COLS], rows)
    tel, _ = _import(
        tmp_path, _imu_file(tmp_path), reference_file=ref, reference_euler=EULER_COLS, reference_euler_units="rad"
    )
    got = Rotation.from_quat(tel.reference.quat_nb, scalar_first=True)
    assert np.max((got * ROT_NB[REF_ROWS].inv()).magnitude()) < ATTITUDE_TOL_RAD
    assert tel.reference.velocity_n_mps is None and not tel.reference.has_position


def test_enu_reference_of_a_flu_sensor_is_the_ned_reference_of_the_body(tmp_path):
    # a ROS-style recording: sensor axes forward-left-up, reference in East-North-Up
    imu = _imu_file(tmp_path, sensor="flu")
    ref = _reference_file(tmp_path, "quaternion", frame="enu", sensor="flu")
    tel, _ = _import(tmp_path, imu, reference_file=ref, axes=("x", "-y", "-z"), reference_frame="enu", **_ref_opts())
    _assert_truth(tel.reference)
    np.testing.assert_allclose(tel.accel_mps2, F_B, rtol=0, atol=1e-8)  # and the IMU is in body FRD
    # the same numbers read as NED are a different attitude: the frame option is not a no-op
    with pytest.raises(SourceError, match="puts 'up' .* from the specific force"):
        _import(tmp_path, imu, name="wrong.h5", reference_file=ref, axes=("x", "-y", "-z"), **_ref_opts())


def test_ned_reference_of_a_flu_sensor_takes_the_axis_map(tmp_path):
    imu = _imu_file(tmp_path, sensor="flu")
    ref = _reference_file(tmp_path, "quaternion", frame="ned", sensor="flu")
    tel, _ = _import(tmp_path, imu, reference_file=ref, axes=("x", "-y", "-z"), **_ref_opts())
    _assert_truth(tel.reference)


def test_same_file_reference_with_its_own_time_column(tmp_path):
    # reference cells filled on every 4th row (stamped 3 ms after the IMU row), empty elsewhere
    values = _reference_columns("quaternion")
    rows = []
    for k, imu in enumerate(_imu_rows()):
        j = k // DECIMATION
        own = k % DECIMATION == 0
        rows.append(imu + ([T_S[k] + 0.003, *values[j]] if own else [None] * (1 + values.shape[1])))
    src = _write(tmp_path / "both.csv", IMU_HEADER + ["t_ref", *QUAT_COLS, *VEL_COLS, *POS_COLS], rows)
    tel, _ = _import(tmp_path, src, reference_time="t_ref", **_ref_opts())
    np.testing.assert_allclose(tel.reference.time_s, T_S[REF_ROWS] + 0.003, rtol=0, atol=1e-12)
    tel.reference.time_s = tel.reference.time_s - 0.003
    _assert_truth(tel.reference)
    assert tel.source.extra["reference_time_column"] == "t_ref" and "reference_file" not in tel.source.extra


def test_same_file_reference_at_the_imu_time(tmp_path):
    values = _reference_columns("euler")
    rows = [
        imu + (list(values[k // DECIMATION]) if k % DECIMATION == 0 else [None] * values.shape[1])
        for k, imu in enumerate(_imu_rows())
    ]
    src = _write(tmp_path / "both.csv", IMU_HEADER + [*EULER_COLS, *VEL_COLS, *POS_COLS], rows)
    tel, _ = _import(tmp_path, src, **_ref_opts("euler"))
    _assert_truth(tel.reference)
    assert tel.source.extra["reference_time_column"] == "(IMU time)"


def test_separate_file_equals_same_file(tmp_path):
    a, _ = _import(tmp_path, _imu_file(tmp_path), name="a.h5", reference_file=_reference_file(tmp_path), **_ref_opts())
    rows = [
        imu + (list(_reference_columns("quaternion")[k // DECIMATION]) if k % DECIMATION == 0 else [None] * 10)
        for k, imu in enumerate(_imu_rows())
    ]
    src = _write(tmp_path / "both.csv", IMU_HEADER + [*QUAT_COLS, *VEL_COLS, *POS_COLS], rows)
    b, _ = _import(tmp_path, src, name="b.h5", **_ref_opts())
    for name in ("time_s", "quat_nb", "velocity_n_mps", "lat_rad", "lon_rad", "height_m"):
        np.testing.assert_array_equal(getattr(a.reference, name), getattr(b.reference, name), err_msg=name)


@pytest.mark.parametrize("units,scale", [("ms", 1e3), ("us", 1e6), ("s", 1.0)])
def test_reference_time_units(tmp_path, units, scale):
    ref = _reference_file(tmp_path, time_scale=scale)
    tel, _ = _import(
        tmp_path, _imu_file(tmp_path), reference_file=ref, reference_time="t", reference_time_units=units, **_ref_opts()
    )
    _assert_truth(tel.reference)


def test_reference_time_units_default_to_the_imu_s(tmp_path):
    imu_ms = _write(tmp_path / "imu_ms.csv", IMU_HEADER, np.column_stack([T_S * 1e3, GYRO_B, F_B]).tolist())
    ref_ms = _reference_file(tmp_path, time_scale=1e3)
    tel, _ = _import(tmp_path, imu_ms, time_units="ms", reference_file=ref_ms, reference_time="t", **_ref_opts())
    _assert_truth(tel.reference)
    assert tel.source.extra["reference_time_units"] == "ms"


def test_dropouts_are_left_out_and_reported(tmp_path):
    values = _reference_columns("quaternion")
    rows = np.column_stack([T_S[REF_ROWS], values]).tolist()
    rows[10][1:] = [None] * 10  # an occlusion: every cell empty
    rows[11][5] = float("nan")  # one NaN velocity
    rows[30][2] = None  # one empty quaternion cell
    ref = _write(tmp_path / "ref.csv", ["t", *QUAT_COLS, *VEL_COLS, *POS_COLS], rows)
    tel, summary = _import(tmp_path, _imu_file(tmp_path), reference_file=ref, **_ref_opts())
    kept = np.delete(REF_ROWS, [10, 11, 30])
    _assert_truth(tel.reference, kept)
    assert tel.source.extra["reference_dropout_rows"] == 3 and tel.source.extra["reference_rows"] == kept.size
    assert summary["reference_gaps"] == 2  # rows 10-11 one gap, row 30 another
    assert "3 rows with empty or NaN cells left out" in tel.description


def test_provenance_records_the_column_map(tmp_path):
    ref = _reference_file(tmp_path, "euler")
    tel, _ = _import(tmp_path, _imu_file(tmp_path), reference_file=ref, **_ref_opts("euler"))
    src = tel.source.extra
    assert src["reference_file"] == "ref.csv" and len(src["reference_sha256"]) == 64
    assert src["reference_euler_columns"] == tuple(EULER_COLS) and src["reference_euler_units"] == "deg"
    assert src["reference_velocity_columns"] == tuple(VEL_COLS)
    assert src["reference_position_columns"] == tuple(POS_COLS) and src["reference_frame"] == "ned"
    assert "reference from reference file ref.csv" in tel.description and "roll_deg" in tel.description


# --------------------------------------------------------------------------- bad input


def _cli(args):
    return CliRunner().invoke(main, ["import", "csv", *map(str, args)])


def _bad_setup(tmp_path):
    """A good IMU file, a good reference file, and the CLI arguments that import them."""
    imu, ref = _imu_file(tmp_path), _reference_file(tmp_path)
    args = [
        imu,
        "-o",
        tmp_path / "out.h5",
        "--time",
        "t",
        "--gyro",
        "gx,gy,gz",
        "--accel",
        "ax,ay,az",
        "--reference-file",
        ref,
        "--reference-quaternion",
        ",".join(QUAT_COLS),
        "--reference-velocity",
        ",".join(VEL_COLS),
        "--reference-position",
        ",".join(POS_COLS),
    ]
    return imu, ref, args


def _replace(args, option, value):
    out = list(args)
    if option in out:
        out[out.index(option) + 1] = value
    else:
        out += [option, value]
    return out


def _drop(args, option):
    out = list(args)
    k = out.index(option)
    return out[:k] + out[k + 2 :]


def _edit_ref(ref, row, col, text):
    """Put ``text`` into data row ``row`` (0-based), column ``col`` of the reference file."""
    lines = ref.read_text().splitlines()
    cells = lines[row + 1].split(",")
    cells[col] = text
    lines[row + 1] = ",".join(cells)
    ref.write_text("\n".join(lines) + "\n")


BAD = {
    # name: (change the setup, the file the message names, words it must hold)
    "misnamed reference column": (
        lambda a, ref: _replace(a, "--reference-quaternion", "qw,qx,qy,q_z"),
        "ref",
        ["column 'q_z' is not in the header (--reference-quaternion)", "columns are: t, qw, qx, qy, qz"],
    ),
    "missing reference time column": (
        lambda a, ref: _replace(a, "--reference-time", "stamp"),
        "ref",
        ["column 'stamp' is not in the header (--reference-time)"],
    ),
    "reference column in the IMU file": (
        lambda a, ref: _drop(a, "--reference-file"),
        "imu",
        ["column 'qw' is not in the header (--reference-quaternion)", "columns are: t, gx"],
    ),
    "unknown euler units": (
        lambda a, ref: _replace(
            _replace(_drop(a, "--reference-quaternion"), "--reference-euler", "qw,qx,qy"),
            "--reference-euler-units",
            "grad",
        ),
        "ref",
        ["--reference-euler-units 'grad' are not known; use deg or rad"],
    ),
    "unknown position units": (
        lambda a, ref: _replace(a, "--reference-position-units", "gon"),
        "ref",
        ["--reference-position-units 'gon' are not known"],
    ),
    "unknown time units": (
        lambda a, ref: _replace(a, "--reference-time-units", "min"),
        "ref",
        ["--reference-time-units 'min' are not known; use s, ms, us, ns"],
    ),
    "unknown frame": (
        lambda a, ref: _replace(a, "--reference-frame", "nwu"),
        "ref",
        ["--reference-frame 'nwu' is not known; use ned or enu"],
    ),
    "three quaternion columns": (
        lambda a, ref: _replace(a, "--reference-quaternion", "qw,qx,qy"),
        "ref",
        ["--reference-quaternion names 3 columns (qw, qx, qy); give exactly four"],
    ),
    "two euler columns": (
        lambda a, ref: _replace(_drop(a, "--reference-quaternion"), "--reference-euler", "qx,qy"),
        "ref",
        ["--reference-euler names 2 columns", "give exactly three"],
    ),
    "four velocity columns": (
        lambda a, ref: _replace(a, "--reference-velocity", "v1,v2,v3,lat"),
        "ref",
        ["--reference-velocity names 4 columns"],
    ),
    "two position columns": (
        lambda a, ref: _replace(a, "--reference-position", "lat,lon"),
        "ref",
        ["--reference-position names 2 columns"],
    ),
    "both attitudes": (
        lambda a, ref: _replace(a, "--reference-euler", "qx,qy,qz"),
        "ref",
        ["give the reference attitude once"],
    ),
    "euler in enu": (
        lambda a, ref: _replace(
            _replace(_drop(a, "--reference-quaternion"), "--reference-euler", "qx,qy,qz"), "--reference-frame", "enu"
        ),
        "ref",
        ["--reference-euler: roll, pitch and heading are defined in NED only"],
    ),
    "velocity without attitude": (
        lambda a, ref: _drop(a, "--reference-quaternion"),
        "imu",
        ["--reference-file needs a reference attitude"],
    ),
    "non-numeric cell": (
        lambda a, ref: (_edit_ref(ref, 7, 3, "0.5x"), a)[1],
        "ref",
        ["column 'qy' (--reference-quaternion) on line 9 holds '0.5x', which is not numeric"],
    ),
    "no overlap": (
        lambda a, ref: (_reference_file(ref.parent, time_offset=1000.0), a)[1],
        "ref",
        [
            "reference time 't' [s] spans 1000 .. 1004 s and the IMU time 't' in imu.csv spans 0 .. 4 s",
            "do not overlap",
        ],
    ),
    "one row": (
        lambda a, ref: (ref.write_text("\n".join(ref.read_text().splitlines()[:2]) + "\n"), a)[1],
        "ref",
        ["the reference has 1 row(s) with every column filled", "at least 2 are needed"],
    ),
    "time going back": (
        lambda a, ref: (_edit_ref(ref, 20, 0, "0.01"), a)[1],
        "ref",
        ["reference time column 't' (--reference-time) goes back on line 22"],
    ),
    "non-unit quaternion": (
        lambda a, ref: (_edit_ref(ref, 5, 1, "2"), a)[1],
        "ref",
        [
            "columns qw,qx,qy,qz (--reference-quaternion) on line 7 have |q| =",
            "check the columns are named in scalar-first order W,X,Y,Z",
        ],
    ),
    "scalar-last order": (
        lambda a, ref: _replace(a, "--reference-quaternion", "qx,qy,qz,qw"),
        "ref",
        ["the reference attitude puts 'up'", "--reference-quaternion (order W,X,Y,Z)"],
    ),
    "latitude out of range": (
        lambda a, ref: (_edit_ref(ref, 3, 8, "91"), a)[1],
        "ref",
        ["column 'lat' (--reference-position) on line 5 holds latitude 91 deg, outside +-90"],
    ),
    "latitude at the pole": (
        lambda a, ref: (_edit_ref(ref, 3, 8, "90"), a)[1],
        "ref",
        [
            "column 'lat' (--reference-position) on line 5 holds latitude 90 deg, outside [-89.5, 89.5] deg",
            "within 0.5 deg of a pole",
        ],
    ),
    "latitude in degrees said radians": (
        lambda a, ref: _replace(a, "--reference-position-units", "rad"),
        "ref",
        ["holds latitude 52.5 rad, outside +-90 deg"],
    ),
    # refused by the pre-flight every stage shares (sizefx.stage.preflight), before any conversion
    "missing reference file": (lambda a, ref: (ref.unlink(), a)[1], "ref", ["--reference-file: no such file"]),
    "output over the reference": (
        lambda a, ref: _replace(_replace(a, "-o", ref), "--force", None),
        "ref",
        ["output would overwrite the input"],
    ),
}


@pytest.mark.parametrize("case", list(BAD))
def test_bad_reference_input_is_one_line_exit_2(tmp_path, case):
    change, names, words = BAD[case]
    imu, ref, args = _bad_setup(tmp_path)
    args = [a for a in change(args, ref) if a is not None]
    before = ref.read_bytes() if ref.exists() else None
    result = _cli(args)
    assert result.exit_code == 2, result.output
    text = result.output.strip()
    assert "\n" not in text and "Traceback" not in text, text
    assert text.startswith("sizefx: error: ") and str(imu if names == "imu" else ref) in text, text
    for w in words:
        assert w in text, (w, text)
    assert not (tmp_path / "out.h5").exists()
    if before is not None:
        assert ref.read_bytes() == before  # the reference file is never touched


@pytest.mark.parametrize("site", ["90,13.3,40", "-89.6,13.3,40"])
def test_a_site_at_a_pole_names_the_option_and_the_range(tmp_path, site):
    """``--site-deg`` at a pole is the option's fault: refused before the CSV is read, naming the
    option, the valid range and why (not an HDF5 root attribute the user never wrote)."""
    _, _, args = _bad_setup(tmp_path)
    result = _cli(args + ["--site-deg", site])
    assert result.exit_code == 2, result.output
    text = result.output.strip()
    assert "\n" not in text and "Traceback" not in text, text
    assert text.startswith(f"sizefx: error: import csv: --site-deg {site}: latitude "), text
    assert "outside [-89.5, 89.5] deg (within 0.5 deg of a pole" in text, text
    assert not (tmp_path / "out.h5").exists()


@pytest.mark.parametrize(
    "scale,units,words",
    [
        (
            1e3,
            "s",
            "the time column 't' (--time) implies 0.1 Hz in s, outside the 5..35000 Hz of an IMU; in ms it "
            "would be 100 Hz: give --time-units ms",
        ),
        (
            1e6,
            "s",
            "implies 0.0001 Hz in s, outside the 5..35000 Hz of an IMU; in us it would be 100 Hz: give --time-units us",
        ),
        (
            1.0,
            "ms",
            "implies 1e+05 Hz in ms, outside the 5..35000 Hz of an IMU; in s it would be 100 Hz: give --time-units s",
        ),
    ],
)
def test_a_time_column_in_the_wrong_unit_is_refused_with_the_unit_that_fits(tmp_path, scale, units, words):
    """The time unit is checked against the rate it implies (``IMU_RATE_HZ``): a column in milliseconds
    read as seconds is not a 0.1 Hz record; the message names the column and the option, and the unit
    that gives a plausible rate."""
    src = _write(tmp_path / "imu.csv", IMU_HEADER, np.column_stack([T_S * scale, GYRO_B, F_B]).tolist())
    args = [src, "-o", tmp_path / "out.h5", "--time", "t", "--gyro", "gx,gy,gz", "--accel", "ax,ay,az"]
    result = _cli(args + ["--time-units", units])
    assert result.exit_code == 2, result.output
    text = result.output.strip()
    assert "\n" not in text and "Traceback" not in text, text
    assert text.startswith(f"sizefx: error: {src}: "), text
    assert words in text, text
    assert not (tmp_path / "out.h5").exists()


def test_a_reference_time_column_in_the_wrong_unit_is_refused_with_the_unit_that_fits(tmp_path):
    """The reference file's own time column gets the same check, against ``REFERENCE_RATE_HZ`` (a
    reference may be sparser than the IMU), naming its column and --reference-time-units."""
    ref = _reference_file(tmp_path, time_scale=1e3)  # 25 Hz in ms; --reference-time-units defaults to s
    with pytest.raises(SourceError) as info:
        _import(tmp_path, _imu_file(tmp_path), reference_file=ref, reference_time="t", **_ref_opts())
    assert str(info.value) == (
        f"{ref}: the time column 't' (--reference-time) implies 0.025 Hz in s, outside the 0.7..35000 Hz of a "
        "reference; in ms it would be 25 Hz: give --reference-time-units ms"
    )


def test_a_sample_counter_at_an_implausible_rate_names_rate_hz(tmp_path):
    src = _write(tmp_path / "imu.csv", IMU_HEADER, np.column_stack([np.arange(N_IMU), GYRO_B, F_B]).tolist())
    with pytest.raises(
        SourceError,
        match=r"implies 1 Hz as a sample counter, outside the 5\.\.35000 Hz of an IMU; "
        r"check --rate-hz",
    ):
        run_import("csv", src, tmp_path / "o.h5", time_units="samples", rate_hz=1.0, **IMU_OPTS)


def test_the_readme_example_imports_at_its_100_hz(tmp_path):
    """examples/tumble_imu.csv (100 Hz, time in s) and its 50 Hz reference pass the rate check."""
    from pathlib import Path

    examples = Path(__file__).resolve().parents[1] / "examples"
    summary = run_import(
        "csv",
        examples / "tumble_imu.csv",
        tmp_path / "own.h5",
        time="time_s",
        gyro=("gyro_x_dps", "gyro_y_dps", "gyro_z_dps"),
        gyro_units="deg/s",
        accel=("accel_x_mps2", "accel_y_mps2", "accel_z_mps2"),
        axes=("x", "-y", "-z"),
        reference_file=examples / "tumble_reference.csv",
        reference_frame="enu",
        reference_time="time_s",
        reference_quaternion=("qw", "qx", "qy", "qz"),
        reference_velocity=("v_east_mps", "v_north_mps", "v_up_mps"),
        reference_position=("lat_deg", "lon_deg", "height_m"),
    )
    assert summary["rate_hz"] == pytest.approx(100.0) and summary["reference_rows"] == 5998


def test_empty_imu_cell_names_the_column_and_line(tmp_path):
    rows = _imu_rows()
    rows[4][2] = None
    src = _write(tmp_path / "imu.csv", IMU_HEADER, rows)
    with pytest.raises(SourceError, match=r"column 'gy' \(--gyro\) is empty on line 6; IMU cells must all be filled"):
        run_import("csv", src, tmp_path / "o.h5", **IMU_OPTS)


def test_nan_imu_cell_names_the_column_and_line(tmp_path):
    rows = _imu_rows()
    rows[7][6] = float("nan")
    src = _write(tmp_path / "imu.csv", IMU_HEADER, rows)
    with pytest.raises(SourceError, match=r"column 'az' \(--accel\) holds NaN/Inf on line 9"):
        run_import("csv", src, tmp_path / "o.h5", **IMU_OPTS)


def test_samples_time_needs_explicit_reference_time_units(tmp_path):
    src = _write(tmp_path / "imu.csv", IMU_HEADER, np.column_stack([np.arange(N_IMU), GYRO_B, F_B]).tolist())
    ref = _reference_file(tmp_path)
    with pytest.raises(SourceError, match="give the reference's time units"):
        run_import(
            "csv",
            src,
            tmp_path / "o.h5",
            time_units="samples",
            rate_hz=RATE_HZ,
            reference_file=ref,
            **(IMU_OPTS | _ref_opts()),
        )
    tel, _ = _import(
        tmp_path,
        src,
        time_units="samples",
        rate_hz=RATE_HZ,
        reference_file=ref,
        reference_time_units="s",
        **_ref_opts(),
    )
    _assert_truth(tel.reference)


def test_a_contract_violation_found_after_conversion_names_the_csv_not_a_temporary_file(tmp_path):
    """The importer validates what it wrote to a temporary file; the message must
    name the user's CSV, never the temporary file that is gone by the time it is read."""
    src = tmp_path / "backwards.csv"
    rows = ["t,gx,gy,gz,ax,ay,az"] + [f"{t},0,0,0,0,0,-9.81" for t in (0.00, 0.01, 0.02, 0.015, 0.03)]
    src.write_text("\n".join(rows) + "\n")
    result = CliRunner().invoke(
        main,
        [
            "import",
            "csv",
            str(src),
            "-o",
            str(tmp_path / "out.h5"),
            "--time",
            "t",
            "--gyro",
            "gx,gy,gz",
            "--accel",
            "ax,ay,az",
        ],
    )
    assert result.exit_code == 2, result.output
    line = result.output.strip()
    assert line.count("\n") == 0 and str(src) in line and ".tmp" not in line, line
    assert "not strictly increasing" in line
    assert not (tmp_path / "out.h5").exists() and not list(tmp_path.glob(".out.h5.*"))


def test_a_source_named_in_latin1_is_carried_with_escapes(tmp_path):
    """The source's file name goes into /source and the description: one that is not UTF-8 is written
    with backslash escapes (h5py cannot write the lone surrogates the file system hands over)."""
    import os

    src = _write(tmp_path / os.fsdecode(b"caf\xe9.csv"), IMU_HEADER, _imu_rows())
    tel, _ = _import(tmp_path, src)
    assert tel.source.file == "caf\\xe9.csv"
    assert tel.description.startswith("imported from CSV caf\\xe9.csv: ")
