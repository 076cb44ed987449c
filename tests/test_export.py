"""``sizefx export csv|rosbag``: bag -> import -> export -> import gives the same record; a compensated
record goes back to ROS as the corrected stream on the source's clock; the CSV re-imports with the
command the report prints; outputs never replace an input."""

from __future__ import annotations

import shlex
import sys
from pathlib import Path

import numpy as np
import pytest
from bags import Bag, flu, simulated, write_bag
from click.testing import CliRunner

from sizefx.exporters import ExportConfig, run
from sizefx.io.telemetry import read_telemetry, write_telemetry
from sizefx_cli.main import main

pytest.importorskip("rosbags")

SITE = (57.9825, 55.7089, 120.0)


def _cli(*args):
    return CliRunner().invoke(main, [*map(str, args)])


def _refused(result, *words):
    lines = result.stderr.strip().splitlines()
    assert result.exit_code == 2 and len(lines) == 1, result.output
    for word in words:
        assert word in lines[0], (word, lines[0])
    return lines[0]


def _bag_messages(bag: Path):
    """``(topic, frame_id, header ns, receive ns, angular velocity, linear acceleration, orientation
    covariance)`` of every sensor_msgs/Imu message of a bag, read back with rosbags itself."""
    from rosbags.highlevel import AnyReader

    out = []
    with AnyReader([bag]) as reader:
        imus = [c for c in reader.connections if c.msgtype == "sensor_msgs/msg/Imu"]
        for conn, receive_ns, raw in reader.messages(connections=imus):
            m = reader.deserialize(raw, conn.msgtype)
            w, a = m.angular_velocity, m.linear_acceleration
            stamp = m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec
            out.append(
                (
                    conn.topic,
                    m.header.frame_id,
                    stamp,
                    receive_ns,
                    (w.x, w.y, w.z),
                    (a.x, a.y, a.z),
                    m.orientation_covariance,
                )
            )
    return out


@pytest.fixture(scope="module")
def imported(tmp_path_factory):
    """A simulated record written as an MCAP bag (with an odometry reference) and imported."""
    folder = tmp_path_factory.mktemp("export")
    truth = simulated(duration_s=4.0)
    bag = write_bag(folder / "source", truth)
    record = folder / "record.h5"
    result = _cli(
        "import", "rosbag", bag, "-o", record, "--reference-topic", "/odom", "--site-deg", ",".join(map(str, SITE))
    )
    assert result.exit_code == 0, result.output
    return truth, bag, record


def _same_imu(a, b):
    np.testing.assert_array_equal(a.time_s, b.time_s)
    np.testing.assert_array_equal(a.gyro_rad_s, b.gyro_rad_s)
    np.testing.assert_array_equal(a.accel_mps2, b.accel_mps2)


@pytest.mark.parametrize("source,storage", [("mcap", "mcap"), ("ros1", "sqlite3")])
def test_bag_import_export_import_gives_the_same_record(imported, tmp_path, source, storage):
    """The round trip is exact: the stamps come back to the nanosecond (the import kept the first),
    the FLU <-> FRD flips are signs; topic and frame_id are the source's. From an MCAP bag into MCAP,
    from a ROS 1 bag into sqlite3."""
    truth, bag, record = imported
    if source == "ros1":
        # ROS 1 style frame names: the leading slash of the IMU's is ignored against the odometry's child
        spec = Bag(imu_topic="/imu", imu_frame="/imu_frame", child_frame="imu_frame")
        bag = write_bag(tmp_path / "source.bag", truth, spec, kind="ros1")
        record = tmp_path / "record.h5"
        assert _cli("import", "rosbag", bag, "-o", record, "--reference-topic", "/odom").exit_code == 0
    out = tmp_path / "again"
    result = _cli("export", "rosbag", record, "-o", out, "--storage", storage)
    assert result.exit_code == 0, result.output
    topic, frame = ("/imu", "/imu_frame") if source == "ros1" else ("/imu/data", "imu_link")
    assert f"topic {topic} (sensor_msgs/Imu), frame_id '{frame}'" in result.output
    assert "header.stamp: 1700000000.123456789 s + the record's time" in result.output
    command = result.output.strip().splitlines()[-1].removeprefix("import it back: ")
    back = _cli(*shlex.split(command)[1:])
    assert back.exit_code == 0, back.output
    first, second = read_telemetry(record), read_telemetry(out.with_name(out.name + ".h5"))
    _same_imu(first, second)
    assert second.site == first.site  # None for the ROS 1 bag: imported without a site
    for key in ("stamp_origin_ns", "imu_topic", "imu_frame_id", "axes", "stamps"):
        assert second.source.extra[key] == first.source.extra[key], key
    # the messages themselves: the source bag's stamps, no orientation (REP 145)
    sent = [m for m in _bag_messages(bag) if m[0] == topic]
    exported = _bag_messages(out)
    assert [m[2] for m in exported] == [m[2] for m in sent] and [m[3] for m in exported] == [m[2] for m in sent]
    assert {m[0] for m in exported} == {topic} and {m[1] for m in exported} == {frame}
    assert [list(m[6]) for m in exported[:2]] == [[-1.0] + [0.0] * 8] * 2
    np.testing.assert_array_equal([m[4] for m in exported], [m[4] for m in sent])
    np.testing.assert_array_equal([m[5] for m in exported], [m[5] for m in sent])


def test_a_compensated_record_goes_back_as_the_corrected_stream(imported, tmp_path):
    """bag -> import -> compensate -> export: the bag holds the compensated specific force in FLU, on
    the source bag's stamps, and the report says it is compensated."""
    from sizefx.levers import levers_from_preset, write_levers

    truth, bag, record = imported
    write_levers(tmp_path / "levers.json", levers_from_preset("compact"))
    assert _cli("compensate", record, "--levers", tmp_path / "levers.json", "-o", tmp_path / "comp.h5").exit_code == 0
    result = _cli("export", "rosbag", tmp_path / "comp.h5", "-o", tmp_path / "corrected")
    assert result.exit_code == 0 and "size effect compensated (sizefx compensate)" in result.output, result.output
    comp, plain = read_telemetry(tmp_path / "comp.h5"), read_telemetry(record)
    assert np.abs(comp.accel_mps2 - plain.accel_mps2).max() > 1e-3  # the compensation changed something
    exported = _bag_messages(tmp_path / "corrected")
    np.testing.assert_array_equal([m[5] for m in exported], flu(comp.accel_mps2))
    source = [m for m in _bag_messages(bag) if m[0] == "/imu/data"]
    assert [m[2] for m in exported] == [m[2] for m in source]


def test_csv_reimports_with_the_printed_command(imported, tmp_path):
    """Rates and increments: 17 significant digits give back the very float64 values."""
    from sizefx.simulate import simulate_in_memory

    _, _, record = imported
    result = _cli("export", "csv", record, "-o", tmp_path / "imu.csv")
    assert result.exit_code == 0, result.output
    assert (tmp_path / "imu.csv").read_text().splitlines()[0] == "time_s,gyro_x,gyro_y,gyro_z,accel_x,accel_y,accel_z"
    command = result.output.strip().splitlines()[-1].removeprefix("import it back: ")
    assert command.startswith("sizefx import csv ")
    assert _cli(*shlex.split(command)[1:]).exit_code == 0
    first, back = read_telemetry(record), read_telemetry(tmp_path / "imu.h5")
    _same_imu(first, back)
    np.testing.assert_allclose(
        [back.site.lat_rad, back.site.lon_rad], [first.site.lat_rad, first.site.lon_rad], rtol=1e-15
    )
    # increments
    from sizefx import scenarios

    tel = simulate_in_memory(scenarios.tumble(2.0), rate_hz=100.0, form="increments")
    write_telemetry(tmp_path / "inc.h5", tel)
    result = _cli("export", "csv", tmp_path / "inc.h5", "-o", tmp_path / "inc.csv")
    assert result.exit_code == 0, result.output
    command = result.output.strip().splitlines()[-1].removeprefix("import it back: ")
    assert "--form increments --gyro-units rad --accel-units m/s" in command
    assert _cli(*shlex.split(command)[1:]).exit_code == 0
    back = read_telemetry(tmp_path / "inc-imported.h5")  # inc.h5 is the record: not over it
    np.testing.assert_array_equal(back.dtheta_rad, tel.dtheta_rad)
    np.testing.assert_array_equal(back.dvel_mps, tel.dvel_mps)
    # sensor_msgs/Imu carries rates: increments are refused there, in one line
    _refused(_cli("export", "rosbag", tmp_path / "inc.h5", "-o", tmp_path / "b"), "holds increments", "export csv")


def test_a_record_from_elsewhere_goes_out_in_rep103_axes(tmp_path):
    """A simulated record (no ROS source): FRD -> FLU, /imu/data, imu_link, stamps from the record's
    time; --frame frd writes FRD; both import back to the record."""
    truth = simulated(duration_s=2.0)
    write_telemetry(tmp_path / "sim.h5", truth)
    result = run(ExportConfig("rosbag", tmp_path / "sim.h5", tmp_path / "flu"))
    assert "axes: body forward-left-up (REP 103)" in result.report()
    messages = _bag_messages(tmp_path / "flu")
    assert {m[0] for m in messages} == {"/imu/data"} and {m[1] for m in messages} == {"imu_link"}
    assert [m[2] for m in messages] == np.round(truth.time_s * 1e9).astype(np.int64).tolist()
    np.testing.assert_array_equal([m[4] for m in messages], flu(truth.gyro_rad_s))
    run(ExportConfig("rosbag", tmp_path / "sim.h5", tmp_path / "frd", options=dict(axes="frd", topic="/imu")))
    np.testing.assert_array_equal([m[4] for m in _bag_messages(tmp_path / "frd")], truth.gyro_rad_s)
    assert _cli("import", "rosbag", tmp_path / "frd", "-o", tmp_path / "frd.h5", "--frame", "frd").exit_code == 0
    back = read_telemetry(tmp_path / "frd.h5")
    np.testing.assert_allclose(back.time_s, truth.time_s, rtol=0, atol=0.5e-9)
    np.testing.assert_array_equal(back.gyro_rad_s, truth.gyro_rad_s)


def test_outputs_never_replace_an_input(imported, tmp_path):
    _, bag, record = imported
    local = tmp_path / "record.h5"
    local.write_bytes(record.read_bytes())
    _refused(_cli("export", "csv", local, "-o", local, "--force"), "would overwrite the input")
    _refused(_cli("export", "rosbag", local, "-o", local, "--force"), "would overwrite the input")
    _refused(_cli("export", "rosbag", local, "-o", tmp_path, "--force"), "output folder holds the input")
    (tmp_path / "notes").mkdir()
    (tmp_path / "notes" / "keep.txt").write_text("mine")
    _refused(_cli("export", "rosbag", local, "-o", tmp_path / "notes", "--force"), "is not a ROS 2 bag")
    _refused(_cli("export", "rosbag", local, "-o", tmp_path / "run.mcap"), "a ROS 2 bag is a folder", "-o")
    assert (tmp_path / "notes" / "keep.txt").read_text() == "mine"
    assert _cli("export", "rosbag", local, "-o", tmp_path / "bag").exit_code == 0
    _refused(_cli("export", "rosbag", local, "-o", tmp_path / "bag"), "--force")
    before = (tmp_path / "bag" / "metadata.yaml").read_text()
    result = _cli("export", "rosbag", local, "-o", tmp_path / "bag", "--force", "--storage", "sqlite3")
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in (tmp_path / "bag").iterdir()) == ["bag.db3", "metadata.yaml"]
    assert (tmp_path / "bag" / "metadata.yaml").read_text() != before
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")], "a temporary was left behind"


def test_separate_accelerometer_stamps_and_a_missing_rosbags_are_one_line(imported, tmp_path, monkeypatch):
    truth, _, _ = imported
    from dataclasses import replace

    write_telemetry(tmp_path / "split.h5", replace(truth, accel_time_s=truth.time_s + 1e-4))
    _refused(
        _cli("export", "csv", tmp_path / "split.h5", "-o", tmp_path / "x.csv"), "/imu/accel_time", "sizefx compensate"
    )
    write_telemetry(tmp_path / "sim.h5", truth)
    for name in [m for m in sys.modules if m == "rosbags" or m.startswith("rosbags.")]:
        monkeypatch.setitem(sys.modules, name, None)
    monkeypatch.setitem(sys.modules, "rosbags", None)
    _refused(_cli("export", "rosbag", tmp_path / "sim.h5", "-o", tmp_path / "b"), "pip install 'sizefx[ros]'")
    assert not (tmp_path / "b").exists() and not (tmp_path / "x.csv").exists()
