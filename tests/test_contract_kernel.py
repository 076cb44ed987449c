"""The one-pass checks of sizefx.kernels.checks against their NumPy twins: the contract's sample check
(scale_and_check, twin sizefx.io.contract.invalid_rows) with the reader's messages it feeds, and the
navigation's grid check (worst_grid_offset, twin sizefx.navigate.steps.grid_offsets_periods)."""

from __future__ import annotations

import h5py
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from sizefx.errors import TelemetryError
from sizefx.io.contract import invalid_rows
from sizefx.io.schema import TELEMETRY_SCHEMA, load_schema
from sizefx.io.telemetry import read_telemetry
from sizefx.kernels.checks import CHECK_BLOCK_ROWS, scale_and_check, worst_grid_offset
from sizefx.navigate.steps import grid_offsets_periods

SCHEMA = load_schema(TELEMETRY_SCHEMA)
ACCEL_LIMIT = SCHEMA["sample_limits"]["/imu/accel"]  # m/s^2, symmetric or per column

# finite values of every size, and the values a file may hold that are not
_samples = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True, width=64), st.sampled_from([0.0, 1e3, -1e3, 1e6, 1e308, -1e308])
)


def _first(mask: np.ndarray) -> int:
    flat = np.flatnonzero(mask.ravel())
    return int(flat[0]) if flat.size else -1


@settings(max_examples=300, deadline=None)
@given(
    arrays(np.float64, st.tuples(st.integers(1, 40), st.just(3)), elements=_samples),
    st.sampled_from([1.0, 9.80665, 1e-3, 1e3]),
)
def test_kernel_finds_what_the_numpy_twin_finds(raw, factor):
    """The first sample not finite as read, and the first whose SI value the twin calls invalid
    (not finite after scaling, or beyond the limits), at the same flat index; the SI values
    themselves bit for bit (the same one multiplication)."""
    values = raw.copy()
    first_not_finite, first_beyond = scale_and_check(values, np.full(3, factor), *_limits(3))
    assert first_not_finite == _first(~np.isfinite(raw))
    with np.errstate(over="ignore"):  # 1e308 * 9.8: the overflow is one of the cases
        scaled = raw * factor
    finite = np.isfinite(raw)
    assert first_beyond == _first(invalid_rows(SCHEMA, "/imu/accel", scaled) & finite)
    np.testing.assert_array_equal(values[finite], scaled[finite])  # bit for bit: the same multiplication


@settings(max_examples=150, deadline=None)
@given(
    st.integers(1, 3 * CHECK_BLOCK_ROWS + 7),
    st.lists(
        st.tuples(st.floats(0, 1), st.integers(0, 2), st.sampled_from([np.nan, np.inf, -np.inf, 1e6, -1e6, 1e308])),
        max_size=3,
    ),
    st.sampled_from([1.0, 9.80665]),
    st.integers(0, 2**32),
)
def test_kernel_blocks_find_what_the_numpy_twin_finds(n, bad, factor, seed):
    """Records longer than a block, in SI (judged block by block, a bad block scanned again) and not
    (scanned sample by sample): the same first indices and SI values as the twin wherever the bad
    samples fall, before, inside or after a block boundary."""
    raw = np.random.default_rng(seed).normal(0.0, 5.0, (n, 3))
    for where, column, value in bad:
        raw[min(n - 1, int(where * n)), column] = value
    values = raw.copy()
    first_not_finite, first_beyond = scale_and_check(values, np.full(3, factor), *_limits(3))
    with np.errstate(over="ignore"):
        scaled = raw * factor
    finite = np.isfinite(raw)
    assert first_not_finite == _first(~finite)
    assert first_beyond == _first(invalid_rows(SCHEMA, "/imu/accel", scaled) & finite)
    np.testing.assert_array_equal(values[finite], scaled[finite])


def _limits(columns):
    per = ACCEL_LIMIT if isinstance(ACCEL_LIMIT, list) else [ACCEL_LIMIT] * columns
    low = np.array([b[0] if isinstance(b, list) else -b for b in per], dtype=float)
    high = np.array([b[1] if isinstance(b, list) else b for b in per], dtype=float)
    return low, high


def _record(path, accel, units="m/s^2"):
    n = accel.shape[0]
    with h5py.File(path, "w") as f:
        f.attrs["schema"] = "sizefx/telemetry/1"
        g = f.create_group("imu")
        g.create_dataset("time", data=np.arange(n) / 1600.0).attrs["units"] = "s"
        g.create_dataset("gyro", data=np.zeros((n, 3))).attrs["units"] = "rad/s"
        g.create_dataset("accel", data=accel).attrs["units"] = units
    return path


@pytest.mark.parametrize("bad_row", [0, 777, 4999])
def test_reader_names_the_first_nan_row(tmp_path, bad_row):
    accel = np.tile([0.0, 0.0, -9.81], (5000, 1))
    accel[bad_row, 1] = np.nan
    accel[min(bad_row + 3, 4999), 2] = 1e9  # beyond the limits too, later: NaN is named (as before)
    with pytest.raises(TelemetryError, match=f"NaN/Inf values, the first at row {bad_row};"):
        read_telemetry(_record(tmp_path / "r.h5", accel))


def test_reader_names_the_first_row_beyond_the_limits_after_the_units(tmp_path):
    """1e5 g is beyond any accelerometer's range: refused at its row, in SI, with the count of rows."""
    accel = np.tile([0.0, 0.0, -1.0], (3000, 1))  # in g
    accel[1234, 0] = 1e5
    accel[2000, 2] = -2e5
    with pytest.raises(
        TelemetryError,
        match=r"holds 980665 \(SI, after its units\) at row 1234, column 0, outside "
        r".*\(2 rows in this read\)",
    ):
        read_telemetry(_record(tmp_path / "g.h5", accel, units="g"))


def test_reader_returns_si_values(tmp_path):
    """Read in g, returned in m/s^2 (the in-place scaling of the kernel)."""
    accel = np.tile([0.5, -0.25, -1.0], (100, 1))
    tel = read_telemetry(_record(tmp_path / "g.h5", accel, units="g"))
    np.testing.assert_array_equal(tel.accel_mps2, accel * 9.80665)


@settings(max_examples=200, deadline=None)
@given(st.integers(1, 300), st.integers(0, 10**7), st.floats(-0.4, 0.4), st.integers(0, 299), st.integers(0, 2**32))
def test_worst_grid_offset_is_its_twins_largest(n, first_row, jump, at, seed):
    """The worst stamp and its offset as the NumPy twin finds them (argmax of |offset|, its signed
    value), bit for bit: the same formula, evaluated in the same order."""
    dt = 1 / 1600
    t_first = 1234.5
    rng = np.random.default_rng(seed)
    t = t_first + (first_row + np.arange(n)) * dt + rng.normal(0, 1e-3 * dt, n)
    t[min(at, n - 1)] += jump * dt
    offsets = grid_offsets_periods(t, t_first, dt, first_row)
    row, offset = worst_grid_offset(t, t_first, dt, first_row)
    assert row == int(np.argmax(np.abs(offsets))) and offset == offsets[row]
