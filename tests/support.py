"""Helpers shared by several test modules (fixtures live in conftest.py).

The tests run against the *installed* sizefx (README command 2 installs it without -e),
so this folder, not the repository root, is on ``sys.path``: ``import support``,
``import naive``.
"""

from __future__ import annotations

import os
from pathlib import Path

import h5py
import numpy as np
import pytest

#: The real recordings by others (../shared/data/real beside the checkout; read there, never
#: copied): ``SIZEFX_REAL_DATA`` points elsewhere.
REAL = Path(os.environ.get("SIZEFX_REAL_DATA", Path(__file__).resolve().parents[2] / "shared" / "data" / "real"))
#: Source folder -> the package it is installed as (pyproject.toml's [tool.setuptools] package-dir;
#: tests/test_packaging.py checks the two agree).
INSTALLED_AS = {"sizefx": "sizefx", "cli": "sizefx_cli", "data-schemas": "sizefx.schemas"}
#: Set by .ci/run: a missing real data set fails the test instead of skipping it.
REQUIRE_REAL = os.environ.get("SIZEFX_REQUIRE_REAL_DATA") == "1"

RATE_HZ = 100.0
N = 1000


#: The imucal hand-rotation CSV's import options (its columns, units and rate).
IMUCAL = dict(
    time="n_samples",
    time_units="samples",
    rate_hz=102.4,
    gyro=("gyr_x", "gyr_y", "gyr_z"),
    gyro_units="deg/s",
    accel=("acc_x", "acc_y", "acc_z"),
    accel_units="m/s^2",
)
#: name -> (format, file under REAL, import options): the real recordings sizefx imports, as
#: docs/import.md lists them (tests/test_importers.py, benchmarks/accuracy_import.py).
REAL_FILES = {
    "broad07": ("broad", "broad/07_undisturbed_fast_rotation_B.mat", {}),
    "broad09": ("broad", "broad/09_undisturbed_fast_rotation_with_breaks_B.mat", {}),
    "broad16": ("broad", "broad/16_undisturbed_fast_translation_B.mat", {}),
    "broad21": ("broad", "broad/21_undisturbed_fast_combined.mat", {}),
    "lasergyro": ("psins-imu", "psins/lasergyro.imu", {}),
    "fog_mems": ("psins-mat", "psins/transfer_align_fog_mems.mat", {}),
    "imucal": ("csv", "imucal/example_ferraris_session.csv", IMUCAL),
    "px4": ("ulog", "px4/sample.ulg", {}),
}


def real_data(rel: str = "") -> Path:
    """A real data set (a file or folder under :data:`REAL`). Run by hand, a missing one skips the
    test with the reason; under .ci/run (``SIZEFX_REQUIRE_REAL_DATA=1``) it fails the test."""
    path = REAL / rel
    if not path.exists():
        why = f"real data {path} not found: put shared/ beside the checkout or set SIZEFX_REAL_DATA"
        if REQUIRE_REAL:
            pytest.fail(why)
        pytest.skip(why)
    return path


def long_tier_selected(config) -> bool:
    """Whether this run includes the long tier (``--full``, or any ``-m`` expression such as
    ``-m slow``); a plain ``pytest`` runs the fast tier alone (tests/conftest.py)."""
    return bool(config.getoption("--full") or config.getoption("markexpr"))


def write_root_attributes(h5):
    """The contract's root attributes of a test record: the schema and the paper's airfield."""
    h5.attrs["schema"] = "sizefx/telemetry/1"
    h5.attrs["latitude_deg"] = 57.9825
    h5.attrs["longitude_deg"] = 55.7089
    h5.attrs["height_m"] = 120.0


def write_raw(path, *, n=N, rate_hz=RATE_HZ, form="rates", mutate=None, reference=True):
    """A valid static record written with h5py directly (not with sizefx's writer).

    ``mutate(h5)`` may then break it in one way.
    """
    rng = np.random.default_rng(1)
    t = np.arange(n) / rate_hz
    with h5py.File(path, "w") as h5:
        write_root_attributes(h5)
        imu = h5.create_group("imu")
        imu.create_dataset("time", data=t).attrs["units"] = "s"
        w = np.tile([3.9e-5, 0.0, -6.2e-5], (n, 1)) + 1e-6 * rng.standard_normal((n, 3))
        f = np.tile([0.0, 0.0, -9.817], (n, 1)) + 1e-4 * rng.standard_normal((n, 3))
        if form == "rates":
            imu.create_dataset("gyro", data=w).attrs["units"] = "rad/s"
            imu.create_dataset("accel", data=f).attrs["units"] = "m/s^2"
        else:
            imu.create_dataset("dtheta", data=w / rate_hz).attrs["units"] = "rad"
            imu.create_dataset("dvel", data=f / rate_hz).attrs["units"] = "m/s"
        if reference:
            ref = h5.create_group("reference")
            ref.create_dataset("time", data=t[::10]).attrs["units"] = "s"
            ref.create_dataset("quaternion", data=np.tile([1.0, 0.0, 0.0, 0.0], (n // 10, 1)))
        if mutate is not None:
            mutate(h5)
    return path


def write_tiny_flight(path, n: int):
    """A static record of ``n`` samples (:func:`write_raw`'s rate) with a level ``/reference``, position
    included, at every sample: a flight too short for what is asked of it."""

    def reference(h5):
        t = h5["imu/time"][()]
        ref = h5.create_group("reference")
        ref.create_dataset("time", data=t).attrs["units"] = "s"
        ref.create_dataset("quaternion", data=np.tile([1.0, 0.0, 0.0, 0.0], (t.size, 1)))
        pos = np.tile([57.9825, 55.7089, 120.0], (t.size, 1))
        ref.create_dataset("position", data=pos).attrs["units"] = "deg,deg,m"

    return write_raw(path, n=n, reference=False, mutate=reference)
