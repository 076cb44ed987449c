"""Streaming navigation equals whole-record navigation, chunk by chunk; bad rows are found mid-stream."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from sizefx import scenarios
from sizefx.errors import TelemetryError
from sizefx.io.telemetry import read_telemetry
from sizefx.levers import levers_from_preset, write_levers
from sizefx.navigate import NavConfig, navigate, navigate_file
from sizefx.simulate import SimulateConfig, run

FIELDS = ("time_s", "quat_nb", "v_n", "lat_rad", "lon_rad", "height_m")


@pytest.fixture(scope="module")
def sway(tmp_path_factory):
    folder = tmp_path_factory.mktemp("stream")
    path = folder / "sway.h5"
    run(
        SimulateConfig(
            "sway",
            path,
            plan=scenarios.SwayPlan(static_s=60.0, segment_s=30.0),
            rate_hz=400.0,
            seed=1,
            overrides={"accel_delay": {"enabled": True}},
        )
    )
    levers = levers_from_preset("high-precision")
    levers.accel_delay_s = 5e-4  # the spline sync runs on every chunk
    write_levers(folder / "levers.json", levers)
    return path, folder / "levers.json"


def assert_same(whole, streamed):
    """Streamed rows equal the whole run's output rows to 1e-12 relative (in practice bit for bit)."""
    stride = streamed.config["output_stride"]
    for name in FIELDS:
        a, b = getattr(whole, name)[stride - 1 :: stride], getattr(streamed, name)
        assert a.shape == b.shape, name
        np.testing.assert_allclose(b, a, rtol=1e-12, atol=1e-12 * np.abs(a).max(), err_msg=name)
    for key, value in whole.summary.items():
        if key not in ("kernel_s", "wall_s") and value is not None:
            assert streamed.summary[key] == pytest.approx(value, rel=1e-12), key


@pytest.mark.parametrize("chunk", [1000, 4096, 1 << 20])
def test_streaming_equals_whole_record_with_alignment(sway, chunk):
    path, _ = sway
    cfg = NavConfig(init="align", align_s=60.0)
    assert_same(navigate(read_telemetry(path), cfg), navigate_file(path, cfg, chunk_samples=chunk))


def test_streaming_equals_whole_record_with_levers_and_sync(sway):
    path, levers = sway
    cfg = NavConfig(levers=str(levers), mode="center", output_rate_hz=None)
    assert_same(navigate(read_telemetry(path), cfg), navigate_file(path, cfg, chunk_samples=3000))
    # without the worker thread too
    assert_same(navigate(read_telemetry(path), cfg), navigate_file(path, cfg, chunk_samples=3000, threads=False))


def test_streaming_equals_whole_record_for_increments_and_vertical_reference(tmp_path):
    path = tmp_path / "flight.h5"
    # 10 min without the S-turns (weave; 571 s is the shortest the plan then allows): 60 chunks
    plan = scenarios.FlightPlan(duration_s=600.0, align_s=60.0, speed_mps=30.0, altitude_m=100.0, weave_deg=0.0)
    run(SimulateConfig("flight", path, plan=plan, rate_hz=200.0, form="increments", seed=2))
    cfg = NavConfig()
    whole = navigate(read_telemetry(path), cfg)
    assert whole.config["vertical"] == "reference"
    assert_same(whole, navigate_file(path, cfg, chunk_samples=2000))


def test_a_bad_row_in_a_later_chunk_names_its_absolute_row(sway, tmp_path):
    path, _ = sway
    bad = tmp_path / "bad.h5"
    bad.write_bytes(path.read_bytes())
    with h5py.File(bad, "r+") as h5:
        h5["imu/accel"][30_000, 1] = np.nan
    with pytest.raises(TelemetryError, match="NaN/Inf values, the first at row 30000"):
        navigate_file(bad, NavConfig(), chunk_samples=5000)


def test_progress_is_reported_to_the_end(sway):
    path, _ = sway
    seen = []
    navigate_file(path, NavConfig(), chunk_samples=5000, progress=lambda done, total: seen.append((done, total)))
    assert seen[-1][0] == seen[-1][1] and len(seen) > 5
    assert all(a[0] < b[0] for a, b in zip(seen, seen[1:]))


def test_stamps_far_from_zero_give_the_same_period_whole_and_streamed(tmp_path):
    """Stamps k/1600 + 2007 s cross 2048 s after 41 s, where their spacing starts rounding the
    other way: the median step of the whole record and of the stream's first 65536 rows differ in
    the 10th digit. Both runs take the span over the count instead, and agree."""
    from sizefx.io.telemetry import TelemetryStream, write_telemetry

    path = tmp_path / "sway.h5"
    run(
        SimulateConfig(
            "sway",
            path,
            plan=scenarios.SwayPlan(static_s=60.0, segment_s=40.0, amplitudes_dps=(20.0,)),
            rate_hz=1600.0,
            reference_rate_hz=100.0,
            seed=4,
        )
    )
    tel = read_telemetry(path)
    tel.time_s = tel.time_s + 2007.0
    tel.reference.time_s = tel.reference.time_s + 2007.0
    shifted = tmp_path / "shifted.h5"
    write_telemetry(shifted, tel)
    whole_tel = read_telemetry(shifted)
    with TelemetryStream(shifted) as st:
        assert whole_tel.sample_period_s != st.sample_period_s  # the premise: the medians differ
    cfg = NavConfig(init="align", align_s=60.0)
    assert_same(navigate(whole_tel, cfg), navigate_file(shifted, cfg, chunk_samples=40_000))


def test_streamed_output_file_is_written_chunk_by_chunk_and_equals_the_whole_one(sway, tmp_path):
    from sizefx.navigate import NavigateConfig, run

    path, levers = sway
    cfg = NavConfig(levers=str(levers), mode="triad")
    run(NavigateConfig(input=path, options=cfg, output=tmp_path / "whole.h5", chunk_samples=0))
    run(NavigateConfig(input=path, options=cfg, output=tmp_path / "streamed.h5", chunk_samples=3000))
    with h5py.File(tmp_path / "whole.h5") as a, h5py.File(tmp_path / "streamed.h5") as b:
        for name in ("time", "position", "velocity", "quaternion", "euler"):
            np.testing.assert_array_equal(b[name][()], a[name][()], err_msg=name)
            assert b[name].attrs["units"] == a[name].attrs["units"]
        assert b.attrs["schema"] == "sizefx/navigation/1" and "summary_json" in b.attrs


def test_a_failing_stream_leaves_no_output(sway, tmp_path):
    from sizefx.navigate import NavigateConfig, run

    path, _ = sway
    bad = tmp_path / "bad.h5"
    bad.write_bytes(path.read_bytes())
    with h5py.File(bad, "r+") as h5:
        h5["imu/gyro"][40_000, 0] = np.inf
    with pytest.raises(TelemetryError, match="row 40000"):
        run(NavigateConfig(input=bad, output=tmp_path / "out.h5", chunk_samples=5000))
    assert not list(tmp_path.glob("out.h5*")) and not list(tmp_path.glob(".out.h5*"))
