"""Gaps an importer found are a declared property of the record.

One definition and one count of a gap for every reader; ``/imu/gaps`` declares them; a declaration
that contradicts the data is refused naming both; ``--segment K`` processes one continuous piece;
and the real PX4 log goes import -> inspect -> navigate end to end.
"""

from __future__ import annotations

import h5py
import numpy as np
import pytest
from click.testing import CliRunner
from support import RATE_HZ, real_data, write_raw

from sizefx.errors import ConfigError, TelemetryError
from sizefx.io.telemetry import TelemetryStream, find_imu_gaps, read_telemetry, write_telemetry
from sizefx.levers import levers_from_preset, write_levers
from sizefx_cli.main import main

GAP_ROW = 600  #: write_raw's record (1000 rows at 100 Hz) loses 0.5 s before this row
GAP_S = 0.5 + 1.0 / RATE_HZ  #: the step across the gap [s]
GAP_AT_S = (GAP_ROW - 1) / RATE_HZ  #: time of the last sample before it [s]


def _with_gap(accel_time=False, declared=None):
    """write_raw's mutation: a gap at GAP_ROW (in /imu/accel_time too), and ``declared`` as /imu/gaps."""

    def mutate(h5):
        t = h5["imu/time"][()]
        t[GAP_ROW:] += 0.5
        h5["imu/time"][...] = t
        if accel_time:
            h5["imu"].create_dataset("accel_time", data=t + 1e-4).attrs["units"] = "s"
        if declared is not None:
            h5["imu"].create_dataset("gaps", data=np.asarray(declared, dtype=float).reshape(-1, 2)).attrs["units"] = "s"

    return mutate


def _file(tmp_path, name="gap.h5", **kw):
    return write_raw(tmp_path / name, mutate=_with_gap(**kw))


def test_declared_gaps_are_read_without_allow_gaps_and_counted_once(tmp_path):
    path = _file(tmp_path, accel_time=True, declared=[[GAP_AT_S, GAP_S]])
    tel = read_telemetry(path)
    # /imu/time and /imu/accel_time both show the dropout: one gap, as the importer counts it
    assert len(tel.gaps) == 1 == len(find_imu_gaps(tel.time_s, tel.accel_time_s))
    gap = tel.gaps[0]
    assert gap.declared and gap.dataset == "/imu/time" and gap.index == GAP_ROW
    assert gap.duration_s == pytest.approx(GAP_S)
    undeclared = _file(tmp_path, "undeclared.h5", accel_time=True)
    with pytest.raises(TelemetryError, match=r"/imu/time: has 1 undeclared gap longer .* pass --allow-gaps"):
        read_telemetry(undeclared)
    assert not read_telemetry(undeclared, allow_gaps=True).gaps[0].declared


@pytest.mark.parametrize(
    "declared,words",
    [
        (
            [[GAP_AT_S + 0.1, GAP_S]],
            "row 0 declares a gap after t = 6.090000 s lasting 510 ms, but /imu/time has no gap there",
        ),
        (
            [[GAP_AT_S, 0.2]],
            "row 0 declares a gap after t = 5.990000 s lasting 200 ms, but the gap of /imu/time there "
            "(row 600) lasts 510 ms",
        ),
        (
            [[GAP_AT_S, GAP_S], [8.0, 0.1]],
            "row 1 declares a gap after t = 8.000000 s lasting 100 ms, but /imu/time has no gap there",
        ),
        (
            np.zeros((0, 2)),
            "declares 0 gaps but /imu/time has 1: the gap at row 600 (t = 5.990000 s, 510 ms) is not declared",
        ),
        ([[GAP_AT_S, -0.5]], "gap lengths are positive"),
    ],
)
def test_a_declaration_that_contradicts_the_data_is_refused_naming_both(tmp_path, declared, words):
    path = _file(tmp_path, declared=declared)
    for allow_gaps in (False, True):  # the file contradicts itself: --allow-gaps does not make it right
        with pytest.raises(TelemetryError) as info:
            read_telemetry(path, allow_gaps=allow_gaps)
        msg = str(info.value)
        assert msg.startswith(f"{path}: /imu/gaps: ") and words in msg and "\n" not in msg, msg
    with pytest.raises(TelemetryError, match="/imu/gaps"):
        TelemetryStream(path).close()  # the streamed reader settles gaps the same way


def test_writer_declares_the_gaps_and_a_segment_holds_only_its_rows(tmp_path):
    whole = read_telemetry(_file(tmp_path, declared=[[GAP_AT_S, GAP_S]]))
    copy = write_telemetry(tmp_path / "copy.h5", whole)
    with h5py.File(copy) as h5:
        t = whole.time_s  # the writer declares what the data show (not what the source declared)
        np.testing.assert_array_equal(h5["imu/gaps"][()], [[t[GAP_ROW - 1], t[GAP_ROW] - t[GAP_ROW - 1]]])
        assert h5["imu/gaps"].attrs["units"] == "s"
    second = read_telemetry(copy, segment=2)
    np.testing.assert_array_equal(second.time_s, whole.time_s[GAP_ROW:])
    np.testing.assert_array_equal(second.gyro_rad_s, whole.gyro_rad_s[GAP_ROW:])
    assert second.gaps == [] and (second.segment.number, second.segment.of) == (2, 2)
    with TelemetryStream(copy, segment=2) as st:
        assert st.n_samples == 1000 - GAP_ROW and st.first_row == GAP_ROW and st.gaps == []
        t, g, _, _ = st.read(0, st.n_samples)
        np.testing.assert_array_equal(t, second.time_s)
        np.testing.assert_array_equal(g, second.gyro_rad_s)
    with pytest.raises(ConfigError, match=r"--segment 3: .*copy.h5: its 2 continuous segments are numbered 1..2"):
        read_telemetry(copy, segment=3)
    with pytest.raises(ConfigError, match="it has no gaps: one segment"):
        read_telemetry(write_raw(tmp_path / "plain.h5"), segment=2)


@pytest.fixture
def gapped(tmp_path):
    path = _file(tmp_path, declared=[[GAP_AT_S, GAP_S]])
    write_levers(tmp_path / "levers.json", levers_from_preset("high-precision"))
    return path, tmp_path / "levers.json"


def _run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def test_compensate_refuses_a_gap_offers_segments_and_bridges_with_allow_gaps(gapped, tmp_path):
    path, levers = gapped
    refused = _run("compensate", path, "--levers", levers, "-o", tmp_path / "out.h5")
    assert refused.exit_code == 2 and refused.output.count("\n") == 1, refused.output
    assert refused.output.startswith(f"sizefx: error: {path}: /imu/time: has 1 gap (declared in /imu/gaps")
    assert (
        "compensate estimates angular acceleration and increment edges from neighbouring samples, which a gap "
        "separates: process one continuous segment with --segment K (1..2, as sizefx inspect numbers them), "
        "or pass --allow-gaps to bridge the gaps"
    ) in refused.output
    seg = _run("compensate", path, "--levers", levers, "-o", tmp_path / "seg.h5", "--segment", "1")
    assert seg.exit_code == 0, seg.output
    out = read_telemetry(tmp_path / "seg.h5")
    assert out.n_samples == GAP_ROW and out.gaps == [] and out.source.compensation["segment"] == 1
    bridged = _run("compensate", path, "--levers", levers, "-o", tmp_path / "all.h5", "--allow-gaps")
    assert bridged.exit_code == 0, bridged.output
    assert [g.declared for g in read_telemetry(tmp_path / "all.h5").gaps] == [True]  # still declared
    wrong = _run("compensate", path, "--levers", levers, "-o", tmp_path / "x.h5", "--segment", "0")
    assert wrong.exit_code == 2 and "--segment" in wrong.output


def test_diagnose_segment_and_a_time_span_conflict(gapped):
    path, _ = gapped
    result = _run("diagnose", path, "--segment", "2", "--from-s", "1")
    assert result.exit_code == 2 and result.output.count("\n") == 1
    assert "--segment 2 and --from-s/--to-s both choose the span; give one" in result.output


# --------------------------------------------------------------------------- the real PX4 log, end to end


@pytest.fixture(scope="module")
def px4(tmp_path_factory):
    src = real_data("px4/sample.ulg")
    out = tmp_path_factory.mktemp("px4") / "px4.h5"
    result = _run("import", "ulog", src, "-o", out, "--site-deg", "47.4,8.5,500")
    assert result.exit_code == 0, result.output
    return out, result.output


def test_px4_import_and_inspect_count_the_same_gaps_and_inspect_accepts_them(px4):
    path, imported = px4
    assert "gaps: 8 in the IMU time stamps, 8 declared in /imu/gaps" in imported
    assert "9 continuous segments" in imported
    shown = _run("inspect", path)
    assert shown.exit_code == 0, shown.output
    assert (
        "gaps      8 in the IMU time stamps (declared in /imu/gaps); the first at row 1 (t = 112.614307 s, "
        "36 ms), the longest at row 10242 (t = 153.851108 s, 64.79 ms)" in shown.output
    )
    assert "segments  9 continuous" in shown.output
    assert (
        "   2  rows         1..10241         10241 samples  t = 112.650307 .. 153.851108 s (41.201 s)" in shown.output
    )
    assert "checked   specific force at rest" in shown.output


def test_px4_navigate_refuses_across_gaps_and_runs_one_segment(px4):
    path, _ = px4
    for extra in ([], ["--allow-gaps"]):  # navigation cannot bridge a gap, allowed or not
        refused = _run("navigate", path, *extra)
        assert refused.exit_code == 2 and refused.output.count("\n") == 1, refused.output
        assert (
            "navigate integrates every sample and cannot bridge a gap (--allow-gaps does not help here): "
            "process one continuous segment with --segment K (1..9"
        ) in refused.output
    one = _run("navigate", path, "--segment", "1")
    assert one.exit_code == 2 and "segment 1 of" in one.output and "holds 1 sample" in one.output
    beyond = _run("navigate", path, "--segment", "10")
    assert beyond.exit_code == 2 and "its 9 continuous segments are numbered 1..9" in beyond.output
    ran = _run("navigate", path, "--segment", "2", "--align-s", "20")
    assert ran.exit_code == 0, ran.output
    assert "segment 2 of 9: rows 1..10241, t = 112.650307 .. 153.851108 s" in ran.output
    assert "alignment over 20.0 s" in ran.output
    whole = _run("navigate", path, "--segment", "2", "--align-s", "20", "--chunk-samples", "0")
    assert whole.exit_code == 0 and whole.output.splitlines()[1:] == ran.output.splitlines()[1:]
