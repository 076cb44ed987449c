"""Shared fixtures: a valid minimal telemetry file written with raw h5py, and small simulated records."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from sizefx import scenarios
from sizefx.simulate import run

RATE_HZ = 100.0
N = 1000


def write_raw(path, *, n=N, rate_hz=RATE_HZ, form="rates", mutate=None, reference=True):
    """A valid static record written with h5py directly (not with sizefx's writer).

    ``mutate(h5)`` may then break it in one way.
    """
    rng = np.random.default_rng(1)
    t = np.arange(n) / rate_hz
    with h5py.File(path, "w") as h5:
        h5.attrs["schema"] = "sizefx/telemetry/1"
        h5.attrs["latitude_deg"] = 57.9825
        h5.attrs["longitude_deg"] = 55.7089
        h5.attrs["height_m"] = 120.0
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


@pytest.fixture
def raw_file(tmp_path):
    return write_raw(tmp_path / "static.h5")


@pytest.fixture(scope="session")
def turntable_file(tmp_path_factory):
    """The full paper turntable plan with default effects (lever arms + noise), seed 0."""
    path = tmp_path_factory.mktemp("sim") / "turntable.h5"
    run("turntable", path, seed=0)
    return path


@pytest.fixture(scope="session")
def short_turntable_plan():
    """One axis (Z), one cycle: a 40 s record for quick checks."""
    return scenarios.TurntablePlan(axes="Z", static_s=5.0, seconds_per_axis=24.0, cycles=1, settle_s=5.0)
