"""``sizefx import rosbag``: ROS 1, ROS 2 (MCAP, sqlite3) bags written by rosbags' own writers from
a simulated record (tests/bags.py), compared with the simulator's truth; the frame conversion of
REP 103; and the bad bags, each refused in one line with exit code 2."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from bags import FRD_FLU, LATENCY_NS, START_NS, Bag, simulated, write_bag
from click.testing import CliRunner

from sizefx.importers import ImportConfig, run
from sizefx.io.telemetry import read_telemetry
from sizefx.rotation import quat_angle_between, quat_to_mat
from sizefx_cli.main import main

pytest.importorskip("rosbags")

# Tolerances, each with its reason.
#: Rates and specific force: the FLU <-> FRD flips are exact in float64 (a sign), so the import gives
#: back the simulated samples bit for bit; 0 would be the claim, 1e-15 of the largest value leaves
#: room for nothing but an exact copy.
SAMPLE_REL_TOL = 1e-15
#: Time [s]: the bag's stamps are the simulated times rounded to the nanosecond.
TIME_TOL_S = 0.5e-9
#: Attitude [rad]: the quaternion goes through scipy's matrix <-> quaternion (the test's own
#: conversion) and sizefx's; both are exact to a few float64 roundings.
ATTITUDE_TOL_RAD = 1e-12
#: Velocity [m/s]: a 1 m/s twist rotated by that attitude.
VELOCITY_TOL_MPS = 1e-12
SITE = "57.9825,55.7089,120"


@pytest.fixture(scope="module")
def truth():
    """Four seconds of a tumble at 100 Hz (401 samples; bags of about 450 kB with the reference)."""
    return simulated(duration_s=4.0)


def _invoke(*args):
    return CliRunner().invoke(main, ["import", "rosbag", *map(str, args)])


def _refused(result, *words):
    """Exit code 2, one line on stderr, no traceback, every word in it; the line."""
    lines = result.stderr.strip().splitlines()
    assert result.exit_code == 2 and len(lines) == 1, result.output
    assert "Traceback" not in result.output
    for word in words:
        assert word in lines[0], (word, lines[0])
    return lines[0]


def _twist(truth):
    """A twist in the child frame (FLU) that changes along the record: 1 m/s forward, a little left and up."""
    t = truth.reference.time_s
    return np.column_stack([1.0 + 0.1 * t, 0.5 * np.sin(t), -0.2 * np.ones_like(t)])


# --------------------------------------------------------------------------- the conversion


def test_rep103_conversion_of_vectors_and_attitudes():
    """Closed-form cases of sizefx.frames' ROS conventions: FLU (1, 2, 3) is FRD (1, -2, -3); a body
    whose forward axis points east in ENU (ROS yaw 0, identity) heads 90 deg in NED with z down;
    ROS yaw +90 deg (x north, counter-clockwise seen from above) is heading 0; and the two
    functions invert each other."""
    from sizefx.frames import body_from_ros, quat_nb_from_ros, ros_from_body, ros_quat_from_nb

    assert body_from_ros([1.0, 2.0, 3.0], "flu").tolist() == [1.0, -2.0, -3.0]
    assert ros_from_body([1.0, -2.0, -3.0], "flu").tolist() == [1.0, 2.0, 3.0]
    assert body_from_ros([1.0, 2.0, 3.0], "frd").tolist() == [1.0, 2.0, 3.0]
    mat_nb = quat_to_mat(quat_nb_from_ros([0.0, 0.0, 0.0, 1.0], "flu"))  # x, y, z, w: identity
    np.testing.assert_allclose(mat_nb @ [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], atol=1e-15)  # forward -> east
    np.testing.assert_allclose(mat_nb @ [0.0, 0.0, 1.0], [0.0, 0.0, 1.0], atol=1e-15)  # body down -> down
    half = np.sqrt(0.5)
    mat_nb = quat_to_mat(quat_nb_from_ros([0.0, 0.0, half, half], "flu"))  # yaw +90 deg about up
    np.testing.assert_allclose(mat_nb @ [1.0, 0.0, 0.0], [1.0, 0.0, 0.0], atol=1e-15)  # forward -> north
    rng = np.random.default_rng(7)
    q = rng.normal(size=(50, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    for convention in ("flu", "frd"):
        back = quat_nb_from_ros(ros_quat_from_nb(q, convention), convention)
        assert quat_angle_between(back, q).max() < ATTITUDE_TOL_RAD


@pytest.mark.parametrize("kind", ["mcap", "ros1", "sqlite3"])
def test_import_gives_the_simulated_truth(truth, tmp_path, kind):
    """A bag in ROS convention (FLU, ENU, x-y-z-w; converted by the test with scipy) imports to the
    simulator's rates, specific force, attitude and velocity, and keeps the first stamp to the ns."""
    bag = tmp_path / ("rec.bag" if kind == "ros1" else "rec")
    twist = _twist(truth)
    write_bag(bag, truth, Bag(twist_flu=twist), kind=kind)
    out = tmp_path / "rec.h5"
    result = run(ImportConfig("rosbag", bag, out, options=dict(reference="/odom", site_deg=(57.9825, 55.7089, 120.0))))
    assert result.units_check["gyro"]["verdict"] == "ok", result.report()
    assert "body forward-left-up -> FRD (x, -y, -z)" in result.report()
    assert "velocity: the twist in the child frame 'imu_link'" in result.report()
    tel = read_telemetry(out)
    np.testing.assert_allclose(tel.time_s, truth.time_s, rtol=0, atol=TIME_TOL_S)
    for got, want in ((tel.gyro_rad_s, truth.gyro_rad_s), (tel.accel_mps2, truth.accel_mps2)):
        np.testing.assert_allclose(got, want, rtol=0, atol=SAMPLE_REL_TOL * np.abs(want).max())
    ref = tel.reference
    np.testing.assert_allclose(ref.time_s, truth.reference.time_s, rtol=0, atol=TIME_TOL_S)
    assert quat_angle_between(ref.quat_nb, truth.reference.quat_nb).max() < ATTITUDE_TOL_RAD
    # the twist is in the child frame (FLU): NED velocity = mat_nb @ (x, -y, -z)
    want_v = np.einsum("kij,kj->ki", quat_to_mat(truth.reference.quat_nb), twist @ FRD_FLU.T)
    np.testing.assert_allclose(ref.velocity_n_mps, want_v, rtol=0, atol=VELOCITY_TOL_MPS)
    src = tel.source.extra
    assert tel.source.format == "rosbag" and src["stamp_origin_ns"] == START_NS
    assert src["imu_topic"] == "/imu/data" and src["imu_frame_id"] == "imu_link"
    assert src["axes"] == "flu" and src["stamps"] == "header"
    if kind != "ros1":
        assert src["bag_files"] == ("metadata.yaml", f"rec.{'mcap' if kind == 'mcap' else 'db3'}")


def test_pose_and_tf_references_and_ned_frames(truth, tmp_path):
    """A PoseStamped, a PoseWithCovarianceStamped and the /tf transform odom -> imu_link give the
    same attitude; a bag in REP 103's *_ned frames (--frame frd) imports as it is."""
    for name, spec, reference, extra in (
        ("pose", Bag(reference="pose", reference_topic="/pose"), "/pose", {}),
        ("posecov", Bag(reference="posecov", reference_topic="/amcl_pose", world_frame="map"), "/amcl_pose", {}),
        ("tf", Bag(reference="tf"), "tf:odom/imu_link", {}),
        ("frd", Bag(reference="pose", reference_topic="/pose", body="frd"), "/pose", {"frame": "frd"}),
    ):
        bag = write_bag(tmp_path / name, truth, spec)
        result = run(ImportConfig("rosbag", bag, tmp_path / f"{name}.h5", options=dict(reference=reference, **extra)))
        tel = read_telemetry(result.path)
        assert quat_angle_between(tel.reference.quat_nb, truth.reference.quat_nb).max() < ATTITUDE_TOL_RAD, name
        np.testing.assert_allclose(tel.gyro_rad_s, truth.gyro_rad_s, rtol=0, atol=1e-14)
        assert tel.reference.velocity_n_mps is None
    assert (
        "a pose names no body frame: taken as 'imu_link'"
        in run(
            ImportConfig("rosbag", tmp_path / "pose", tmp_path / "again.h5", options=dict(reference="/pose"))
        ).report()
    )


def test_receive_stamps_and_a_site_from_navsatfix(truth, tmp_path):
    """--stamps receive takes the recorder's times (2 ms late here, the same origin shift for the
    reference); --navsat-topic takes the first message that holds a fix."""
    bag = write_bag(tmp_path / "rec", truth, Bag(navsat=(47.4, 8.5, 500.0)))
    result = _invoke(
        bag, "-o", tmp_path / "rec.h5", "--stamps", "receive", "--reference-topic", "/odom", "--navsat-topic", "/fix"
    )
    assert result.exit_code == 0, result.output
    assert "site: the first fix of /fix (message 1): 48.4000000 deg" in result.output
    tel = read_telemetry(tmp_path / "rec.h5")
    assert tel.source.extra["stamp_origin_ns"] == START_NS + LATENCY_NS and tel.source.extra["stamps"] == "receive"
    np.testing.assert_allclose(np.degrees([tel.site.lat_rad, tel.site.lon_rad]), [48.4, 8.5], rtol=0, atol=1e-9)
    assert tel.site.height_m == 500.0
    np.testing.assert_allclose(tel.reference.time_s, truth.reference.time_s, rtol=0, atol=TIME_TOL_S)


def test_dropped_messages_are_declared_gaps(truth, tmp_path):
    from dataclasses import replace

    keep = np.r_[0:150, 160 : truth.n_samples]
    holed = replace(
        truth, time_s=truth.time_s[keep], gyro_rad_s=truth.gyro_rad_s[keep], accel_mps2=truth.accel_mps2[keep]
    )
    bag = write_bag(tmp_path / "rec", holed, Bag(reference=None))
    result = run(ImportConfig("rosbag", bag, tmp_path / "rec.h5"))
    assert result.imu_gaps == 1 and result.declared_gaps == 1 and result.segments == 2


def test_only_the_chosen_topics_are_read(truth, tmp_path, monkeypatch):
    """The fast twin of test_a_bag_of_images_imports_in_bounded_memory: a bag with camera images
    beside the IMU; the reader is asked for the IMU's connections alone and deserialises nothing else."""
    from rosbags.highlevel import AnyReader

    bag = write_bag(tmp_path / "rec", truth, Bag(reference=None, images=20, image_bytes=20_000))
    asked, deserialised = [], set()
    messages, deserialize = AnyReader.messages, AnyReader.deserialize

    def spy_messages(self, connections=(), **kw):
        asked.extend(c.topic for c in connections)
        return messages(self, connections=connections, **kw)

    def spy_deserialize(self, raw, typ):
        deserialised.add(typ)
        return deserialize(self, raw, typ)

    monkeypatch.setattr(AnyReader, "messages", spy_messages)
    monkeypatch.setattr(AnyReader, "deserialize", spy_deserialize)
    run(ImportConfig("rosbag", bag, tmp_path / "rec.h5"))
    assert set(asked) == {"/imu/data"} and deserialised == {"sensor_msgs/msg/Imu"}


# --------------------------------------------------------------------------- bad bags


def test_topics_are_listed_when_the_imu_is_absent_or_ambiguous(truth, tmp_path):
    two = write_bag(tmp_path / "two", truth, Bag(reference=None, extra_imu_topics=("/imu/raw",)))
    _refused(
        _invoke(two, "-o", tmp_path / "x.h5"), "holds 2 sensor_msgs/Imu topics (/imu/data, /imu/raw)", "--imu-topic"
    )
    assert _invoke(two, "-o", tmp_path / "x.h5", "--imu-topic", "/imu/raw").exit_code == 0
    _refused(
        _invoke(two, "-o", tmp_path / "y.h5", "--imu-topic", "/imu"),
        "--imu-topic /imu: the bag has no such topic; its sensor_msgs/Imu topics: /imu/data, /imu/raw",
    )
    # a bag without any Imu: its topics listed
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.LATEST)
    empty = tmp_path / "noimu"
    with Writer(empty, version=9) as w:
        c = w.add_connection("/chatter", "std_msgs/msg/String", typestore=ts)
        w.write(c, START_NS, ts.serialize_cdr(ts.types["std_msgs/msg/String"](data="hi"), "std_msgs/msg/String"))
    _refused(
        _invoke(empty, "-o", tmp_path / "z.h5"),
        f"{empty}: holds no sensor_msgs/Imu topic; its topics: /chatter (std_msgs/String)",
    )


def test_a_reference_in_another_frame_is_refused_naming_the_frames(truth, tmp_path):
    bag = write_bag(tmp_path / "rec", truth, Bag(child_frame="base_link"))
    line = _refused(
        _invoke(bag, "-o", tmp_path / "x.h5", "--reference-topic", "/odom"),
        "describes frame 'base_link' in 'odom'",
        "the body is 'imu_link'",
        "--body-frame base_link",
    )
    assert "tf:odom/imu_link" in line
    # the user says the two frames have the same axes
    assert (
        _invoke(bag, "-o", tmp_path / "x.h5", "--reference-topic", "/odom", "--body-frame", "base_link").exit_code == 0
    )
    tf = write_bag(tmp_path / "tf", truth, Bag(reference="tf"))
    _refused(
        _invoke(tf, "-o", tmp_path / "y.h5", "--reference-topic", "tf:odom/base_link"),
        "/tf has no transform with parent and child odom/base_link",
        "map/odom, odom/imu_link",
    )
    _refused(_invoke(tf, "-o", tmp_path / "y.h5", "--reference-topic", "tf:base_link"), "tf:PARENT/CHILD")
    _refused(
        _invoke(tf, "-o", tmp_path / "y.h5", "--reference-topic", "/imu/data"),
        "holds sensor_msgs/Imu; a reference is one of",
    )
    # a world frame that is not ENU (a NED world read as REP 103's ENU): up is upside down
    ned = write_bag(tmp_path / "ned", truth, Bag(reference="pose", reference_topic="/pose", body="frd"))
    _refused(
        _invoke(
            ned, "-o", tmp_path / "z.h5", "--reference-topic", "/pose", "--imu-topic", "/imu/data", "--no-units-check"
        ),
        "puts 'up'",
        "--frame flu",
    )


@pytest.mark.parametrize(
    "case,edit,words",
    [
        (
            "back",
            lambda ns: np.r_[ns[:100], ns[101:102], ns[100:101], ns[102:]],
            "header stamps go back at message 101",
        ),
        ("repeat", lambda ns: np.r_[ns[:100], ns[99:100], ns[101:]], "header stamps repeat at message 100"),
        ("zero", lambda ns: np.zeros_like(ns), "every header stamp is zero"),
    ],
)
def test_stamps_that_go_back_or_repeat_are_refused(truth, tmp_path, case, edit, words):
    bag = write_bag(tmp_path / "rec", truth, Bag(reference=None, edit_stamps=edit))
    line = _refused(_invoke(bag, "-o", tmp_path / "x.h5"), f"{bag}: topic /imu/data: {words}", "--stamps receive")
    if case == "back":
        assert "(1700000001.133456789 s -> 1700000001.123456789 s)" in line, line
    # the recorder's own times are in order: --stamps receive imports the bag
    assert _invoke(bag, "-o", tmp_path / "x.h5", "--stamps", "receive").exit_code == 0


def test_truncated_damaged_and_foreign_files_are_one_line(truth, tmp_path):
    ros1 = write_bag(tmp_path / "rec.bag", truth, kind="ros1")
    mcap = write_bag(tmp_path / "rec", truth)
    for name, data in (
        ("half.bag", ros1.read_bytes()[: ros1.stat().st_size // 2]),
        ("half.mcap", (mcap / "rec.mcap").read_bytes()[:200_000]),
        ("text.bag", b"not a bag at all\n"),
    ):
        (tmp_path / name).write_bytes(data)
        _refused(_invoke(tmp_path / name, "-o", tmp_path / "x.h5"), f"{tmp_path / name}: cannot be read as a ROS")
    (tmp_path / "notes.txt").write_text("hello\n")
    _refused(_invoke(tmp_path / "notes.txt", "-o", tmp_path / "x.h5"), "is not a ROS bag by its name")
    (tmp_path / "folder").mkdir()
    _refused(_invoke(tmp_path / "folder", "-o", tmp_path / "x.h5"), "is a folder without metadata.yaml")
    _refused(_invoke(tmp_path / "missing", "-o", tmp_path / "x.h5"), "no such file")
    # the output may not be a file of the bag, even with --force
    _refused(_invoke(mcap, "-o", mcap / "metadata.yaml", "--force"), "would overwrite the input")
    assert not (tmp_path / "x.h5").exists()


def test_too_many_messages_are_refused_before_reading(truth, tmp_path, monkeypatch):
    """The fast twin of the limit: MAX_WHOLE_READ_ROWS lowered to 100 messages."""
    from sizefx.importers import rosbag

    monkeypatch.setattr(rosbag, "MAX_WHOLE_READ_ROWS", 100)
    bag = write_bag(tmp_path / "rec", truth, Bag(reference=None))
    _refused(
        _invoke(bag, "-o", tmp_path / "x.h5"), "topic /imu/data holds 401 messages (its index says)", "at most 100"
    )


def test_without_rosbags_the_command_says_how_to_install_it(truth, tmp_path, monkeypatch):
    bag = write_bag(tmp_path / "rec", truth, Bag(reference=None))
    for name in [m for m in sys.modules if m == "rosbags" or m.startswith("rosbags.")]:
        monkeypatch.setitem(sys.modules, name, None)
    monkeypatch.setitem(sys.modules, "rosbags", None)
    _refused(_invoke(bag, "-o", tmp_path / "x.h5"), "needs the rosbags package: pip install 'sizefx[ros]'")


def test_help_imports_neither_rosbags_nor_numpy(tmp_path):
    probe = (
        "import sys; from click.testing import CliRunner; from sizefx_cli.main import main\n"
        "for args in (['import', 'rosbag', '--help'], ['export', 'rosbag', '--help'], ['export', 'csv', '--help']):\n"
        "    assert CliRunner().invoke(main, args).exit_code == 0, args\n"
        "print(','.join(m for m in ('rosbags', 'numpy', 'h5py') if m in sys.modules))"
    )
    # run outside the checkout: `python -c` puts the working directory first on sys.path, where the
    # source tree's sizefx/ (without sizefx.schemas, which the install maps in) would shadow the install
    proc = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=60, cwd=tmp_path)
    assert proc.returncode == 0 and proc.stdout.strip() == "", proc.stdout + proc.stderr


# --------------------------------------------------------------------------- the long tier


_PEAK = """
import sys
from sizefx.importers import ImportConfig, run
import rosbags.highlevel


def high_water_kib():  # this process's own peak (ru_maxrss would carry the parent's across exec)
    with open("/proc/self/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith("VmHWM:"))


before = high_water_kib()
run(ImportConfig("rosbag", sys.argv[1], sys.argv[2]))
print(high_water_kib() - before)
"""


# long tier: a 300 MB bag of camera images (about 5 s to write); fast twin: test_only_the_chosen_topics_are_read
@pytest.mark.slow
def test_a_bag_of_images_imports_in_bounded_memory(truth, tmp_path):
    """What the import adds to the process's peak resident memory, for a bag holding 300 MB of
    images beside the IMU against the same bag without them: within 32 MiB (the images are
    neither deserialised nor kept; the reader holds one storage chunk at a time)."""
    if not Path("/proc/self/status").is_file():
        pytest.skip("needs Linux's /proc/self/status (VmHWM)")
    small = write_bag(tmp_path / "small", truth, Bag(reference=None))
    big = write_bag(tmp_path / "big", truth, Bag(reference=None, images=300, image_bytes=1_000_000))
    assert sum(f.stat().st_size for f in big.iterdir()) > 300e6
    grew = {}
    for name, bag in (("small", small), ("big", big)):
        proc = subprocess.run(
            [sys.executable, "-c", _PEAK, str(bag), str(tmp_path / f"{name}.h5")],
            capture_output=True,
            text=True,
            timeout=300,
            cwd=tmp_path,  # not the checkout, whose sizefx/ would shadow the installed package
        )
        assert proc.returncode == 0, proc.stderr
        grew[name] = int(proc.stdout.split()[-1]) / 1024  # KiB -> MiB
    assert grew["big"] - grew["small"] < 32, grew
