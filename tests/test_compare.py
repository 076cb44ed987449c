"""sizefx compare: hand-made trajectories with known distances, both file kinds, the CLI, bad input.

Closed forms used:
* on the equator (a circle of radius a) the chord between longitudes dlon apart is
  ``2 a sin(dlon / 2)`` and the surface distance ``a dlon``;
* along a meridian the surface distance is the integral of the meridian radius
  ``R_M`` (:func:`sizefx.earth.radii_m`) over latitude, and a chord of a curve with
  radius of curvature R is short of its arc ``s`` by ``s^3 / (24 R^2)``.
"""

from __future__ import annotations

import dataclasses
import json
import sys

import h5py
import numpy as np
import pytest
from click.testing import CliRunner
from scipy.integrate import quad
from scipy.spatial.transform import Rotation
from support import write_raw

from sizefx import compare as C
from sizefx import earth
from sizefx.compare import report as R
from sizefx.compare.plots import PLOT_NAMES
from sizefx.constants import METRES_PER_NMI, WGS84_A_M
from sizefx.effects import IDEAL, load_effects
from sizefx.errors import ConfigError, OutputError, SizefxError, TelemetryError
from sizefx.frames import geodetic_from_local_ned
from sizefx.io.navigation import write_navigation
from sizefx.io.telemetry import Provenance, write_telemetry
from sizefx.motion import (
    ConstantProfile,
    FlightPath,
    ProfileBuilder,
    RotationChain,
    Trajectory,
)
from sizefx.navigate import NavConfig, navigate
from sizefx.rotation import (
    axis_angle_mat,
    euler_to_mat,
    mat_to_euler,
    mat_to_quat,
    quat_to_mat,
)
from sizefx.simulate import simulate_in_memory
from sizefx_cli.compare import compare as compare_command
from sizefx_cli.main import SizefxGroup

#: Tolerances, per quantity, with their reasons.
#: Chord against its closed form: float64 ECEF coordinates (6.4e6 m) resolve 1e-9 m; the
#: quadrature of the meridian arc is good to 1e-10 m.
CHORD_TOL_M = 1e-7
#: Offsets placed with the first-order geodetic_from_local_ned: second-order terms
#: d^2 tan(lat) / R are 3e-4 m for the 40 m offsets at 50 deg used here.
OFFSET_TOL_M = 1e-3
#: Velocities and angles built exactly (constant values, exact quaternions): float64 rounding.
VELOCITY_TOL_MPS = 1e-9
ANGLE_TOL_DEG = 1e-9
#: Velocity from positions by central differences of first-order offsets: the offsets use the
#: radii at the start, the derivation the radii at each point (relative 1e-6 over 1 km).
DERIVED_VELOCITY_TOL_MPS = 1e-3
#: Drift rate: divergence of km placed with first-order offsets on the equator, where the
#: meridian radius is stationary; the chord is short by 5e-5 m (1e-8 relative).
DRIFT_REL_TOL = 1e-6
#: An ideal-sensor navigation against its own reference (the navigator reaches 1e-9 m; the
#: reference is interpolated between its 400 Hz samples along a straight line).
NAV_VS_REFERENCE_M = 1e-4

LAT0, LON0 = np.radians(50.0), np.radians(30.0)
SPEED_MPS = 100.0


def straight_track(psi_deg, *, t=None, lat0=LAT0, lon0=LON0, speed=SPEED_MPS, velocity=True, name="B"):
    """B moving at ``speed`` along the horizontal direction ``psi_deg`` (0 north, 90 east), h = 0."""
    t = np.arange(0.0, 11.0) if t is None else t
    psi = np.radians(psi_deg)
    ned = np.column_stack([speed * t * np.cos(psi), speed * t * np.sin(psi), np.zeros_like(t)])
    lat, lon, h = geodetic_from_local_ned(ned, lat0, lon0, 0.0)
    vel = np.tile([speed * np.cos(psi), speed * np.sin(psi), 0.0], (t.size, 1)) if velocity else None
    return C.Track(t, lat, lon, h, vel, None, name=name)


def offset_track(b: C.Track, north_m, east_m, name="A", velocity=None, quat=None):
    """A at fixed (or per-sample) north/east offsets from B's points, B's velocity unless given."""
    ned = np.column_stack(np.broadcast_arrays(north_m, east_m, np.zeros(b.time_s.size)))
    lat, lon, h = geodetic_from_local_ned(ned, b.lat_rad, b.lon_rad, 0.0)
    vel = b.vel_n_mps if velocity is None else velocity
    return C.Track(b.time_s, lat, lon, h, vel, quat, name=name)


def quat_of(roll_deg, pitch_deg, heading_deg, n):
    mat = euler_to_mat(np.radians(roll_deg), np.radians(pitch_deg), np.radians(heading_deg))
    return np.tile(mat_to_quat(mat), (n, 1))


# --------------------------------------------------------------------------- distances


@pytest.mark.parametrize("distance_m", [1e3, 1e4, 1e5])
def test_equator_chord_is_exact_and_within_the_cubic_bound(distance_m):
    dlon = distance_m / WGS84_A_M  # the surface distance along the equator is a * dlon
    t = np.array([0.0, 1.0])
    b = C.Track(t, 0.0, 0.0, 0.0, np.zeros((2, 3)), None, name="B")
    a = C.Track(t, 0.0, dlon, 0.0, np.zeros((2, 3)), None, name="A")
    res = C.compare(a, b)
    chord = res.horizontal_m
    np.testing.assert_allclose(chord, 2.0 * WGS84_A_M * np.sin(dlon / 2.0), rtol=0, atol=CHORD_TOL_M)
    shortfall = distance_m - chord
    bound = distance_m**3 / (24.0 * WGS84_A_M**2)  # 1.02 mm at 10 km
    assert np.all(shortfall > 0.0) and np.all(shortfall <= bound * (1.0 + 1e-6))
    np.testing.assert_allclose(shortfall, bound, rtol=1e-4)  # the next term is s^5 / (1920 R^4)
    assert res.summary["horizontal_m"]["final"] == pytest.approx(chord[-1])


@pytest.mark.parametrize("lat_deg", [0.0, 45.0, 80.0])
def test_meridian_chord_against_the_integrated_meridian_arc(lat_deg):
    lat1, lat2 = np.radians(lat_deg), np.radians(lat_deg + 0.1)
    arc, _ = quad(lambda x: earth.radii_m(x)[0], lat1, lat2, epsabs=1e-9, epsrel=1e-13)
    t = np.array([0.0, 1.0])
    b = C.Track(t, lat1, 0.3, 0.0, np.zeros((2, 3)), None, name="B")
    a = C.Track(t, lat2, 0.3, 25.0, np.zeros((2, 3)), None, name="A")  # a height difference must not count
    res = C.compare(a, b)
    r_mid = earth.radii_m(0.5 * (lat1 + lat2))[0]
    expected = arc - arc**3 / (24.0 * r_mid**2)  # about 11.1 km: 1.40 mm short of the arc
    np.testing.assert_allclose(res.horizontal_m, expected, rtol=0, atol=CHORD_TOL_M)
    assert 1.3e-3 < arc - res.horizontal_m[-1] < 1.5e-3
    np.testing.assert_allclose(res.north_m, arc, rtol=0, atol=0.01)  # due north: the chord's north part
    np.testing.assert_allclose(res.east_m, 0.0, atol=CHORD_TOL_M)
    assert res.summary["height_m"]["final"] == pytest.approx(25.0)


# --------------------------------------------------------------------------- along / cross track


def test_eastbound_ahead_and_right_are_positive():
    b = straight_track(90.0)
    # flying east, right of the track is south: 20 m south, 30 m east (ahead)
    a = offset_track(b, north_m=-20.0, east_m=30.0)
    res = C.compare(a, b)
    np.testing.assert_allclose(res.along_track_m, 30.0, atol=OFFSET_TOL_M)
    np.testing.assert_allclose(res.cross_track_m, 20.0, atol=OFFSET_TOL_M)
    np.testing.assert_allclose(res.horizontal_m, np.hypot(20.0, 30.0), atol=OFFSET_TOL_M)


def test_northbound_left_and_behind_are_negative():
    b = straight_track(0.0)
    a = offset_track(b, north_m=-15.0, east_m=-40.0)  # behind, and west = left of a northbound track
    res = C.compare(a, b)
    np.testing.assert_allclose(res.along_track_m, -15.0, atol=OFFSET_TOL_M)
    np.testing.assert_allclose(res.cross_track_m, -40.0, atol=OFFSET_TOL_M)
    s = res.summary
    assert s["along_track_m"]["final"] == pytest.approx(-15.0, abs=OFFSET_TOL_M)
    assert s["cross_track_m"]["max_abs"] == pytest.approx(40.0, abs=OFFSET_TOL_M)


@pytest.mark.parametrize("psi_deg, along, cross", [(225.0, 12.0, -7.0), (180.0, 5.0, 25.0), (300.0, -8.0, 3.0)])
@pytest.mark.parametrize("velocity", [True, False])
def test_along_cross_for_any_direction_with_and_without_velocity(psi_deg, along, cross, velocity):
    b = straight_track(psi_deg, velocity=velocity)
    psi = np.radians(psi_deg)
    north = along * np.cos(psi) - cross * np.sin(psi)  # right of direction psi is direction psi + 90 deg
    east = along * np.sin(psi) + cross * np.cos(psi)
    a = offset_track(
        b, north, east, velocity=np.tile([SPEED_MPS * np.cos(psi), SPEED_MPS * np.sin(psi), 0.0], (b.time_s.size, 1))
    )
    res = C.compare(a, b)
    np.testing.assert_allclose(res.along_track_m, along, atol=OFFSET_TOL_M)
    np.testing.assert_allclose(res.cross_track_m, cross, atol=OFFSET_TOL_M)
    assert res.velocity_derived == {"a": False, "b": not velocity}
    assert any("central differences" in n for n in res.notes) is (not velocity)


def test_track_direction_undefined_below_the_speed_threshold():
    t = np.arange(0.0, 21.0)
    speed = np.where(t < 10.0, 0.2, 20.0)  # B creeps at 0.2 m/s, then flies east at 20 m/s
    east = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]))])
    lat, lon, _ = geodetic_from_local_ned(np.column_stack([0 * t, east, 0 * t]), LAT0, LON0, 0.0)
    b = C.Track(t, lat, lon, 0.0, np.column_stack([0 * t, speed, 0 * t]), None, name="B")
    a = offset_track(b, north_m=-5.0, east_m=0.0)
    res = C.compare(a, b)
    slow = t < 10.0
    assert np.all(np.isnan(res.along_track_m[slow])) and np.all(np.isnan(res.cross_track_m[slow]))
    np.testing.assert_allclose(res.cross_track_m[~slow], 5.0, atol=OFFSET_TOL_M)
    assert res.summary["track_defined_samples"] == int((~slow).sum())
    assert any("undefined at 10 of 21" in n for n in res.notes)
    # all slow: the figures are null in JSON, "n/a" in the text
    res = C.compare(
        C.Track(t[:5], lat[:5], lon[:5], 0.0, b.vel_n_mps[:5], None, name="A2"),
        C.Track(t[:5], lat[:5], lon[:5], 0.0, b.vel_n_mps[:5], None, name="B2"),
    )
    assert res.summary["along_track_m"] == {"final": None, "rms": None, "max_abs": None}
    assert "along track (A ahead +): final n/a m" in C.format_comparison(res)
    doc = C.to_json([res], {"a": "A2", "b": "B2"})
    assert json.loads(json.dumps(doc, allow_nan=False))["comparisons"][0]["cross_track_m"]["rms"] is None


# --------------------------------------------------------------------------- drift, velocity, attitude


def test_drift_rate_of_a_known_divergence():
    """B flies east along the equator; A drifts to its right (south) at 1 nmi/h for 40 min, then back."""
    t = np.arange(0.0, 3601.0, 10.0)
    b = straight_track(90.0, t=t, lat0=0.0, lon0=0.0, speed=50.0)
    rate = 2.0 * METRES_PER_NMI / 3600.0  # 2 nmi/h out ...
    cross = np.where(t <= 2400.0, rate * t, rate * 2400.0 - rate * (t - 2400.0))  # ... and 2 nmi/h back
    a = offset_track(b, north_m=-cross, east_m=0.0)
    res = C.compare(a, b)
    s = res.summary
    assert s["elapsed_s"] == 3600.0
    # final: 2 nmi/h * (40 - 20) min = 2/3 nmi after 1 h; max: 2 nmi/h * 40 min = 4/3 nmi
    assert s["drift_nmi_per_h"]["final"] == pytest.approx(2.0 * 1200.0 / 3600.0, rel=DRIFT_REL_TOL)
    assert s["drift_nmi_per_h"]["max"] == pytest.approx(2.0 * 2400.0 / 3600.0, rel=DRIFT_REL_TOL)
    assert s["horizontal_m"]["time_of_max_s"] == 2400.0
    np.testing.assert_allclose(res.cross_track_m, cross, rtol=DRIFT_REL_TOL, atol=1e-6)
    np.testing.assert_allclose(res.along_track_m, 0.0, atol=1e-3)
    assert s["horizontal_m"]["rms"] == pytest.approx(np.sqrt(np.mean(cross**2)), rel=DRIFT_REL_TOL)


def test_velocity_and_ground_speed_differences():
    b = straight_track(0.0)
    n = b.time_s.size
    v_a = np.tile([100.0, 5.0, 1.0], (n, 1))
    v_a[-1] = [98.0, -3.0, 0.0]  # a different final row, to tell "final" from RMS
    a = offset_track(b, 0.0, 0.0, velocity=v_a)
    res = C.compare(a, b)
    v = res.summary["velocity_mps"]
    assert v["north"]["final"] == pytest.approx(-2.0, abs=VELOCITY_TOL_MPS)
    assert v["east"]["final"] == pytest.approx(-3.0, abs=VELOCITY_TOL_MPS)
    assert v["down"]["final"] == pytest.approx(0.0, abs=VELOCITY_TOL_MPS)
    assert v["east"]["rms"] == pytest.approx(np.sqrt((10 * 25.0 + 9.0) / 11), abs=VELOCITY_TOL_MPS)
    assert v["down"]["rms"] == pytest.approx(np.sqrt(10 / 11), abs=VELOCITY_TOL_MPS)
    gs = np.hypot(v_a[:, 0], v_a[:, 1]) - 100.0  # sqrt(100^2 + 5^2) - 100 = 0.1249 m/s
    assert v["ground_speed"]["final"] == pytest.approx(gs[-1], abs=VELOCITY_TOL_MPS)
    assert v["ground_speed"]["rms"] == pytest.approx(np.sqrt(np.mean(gs**2)), abs=VELOCITY_TOL_MPS)
    assert gs[0] == pytest.approx(0.12492197, abs=1e-8)


def test_velocity_derived_from_position_when_missing():
    b = straight_track(90.0, velocity=False)
    a = offset_track(b, 3.0, 0.0, velocity=np.tile([0.0, SPEED_MPS, 0.0], (b.time_s.size, 1)))
    res = C.compare(a, b)
    np.testing.assert_allclose(res.velocity_n_mps, 0.0, atol=DERIVED_VELOCITY_TOL_MPS)
    assert res.summary["velocity_derived"] == {"a": False, "b": True}
    assert "B has no velocity: derived from its positions by central differences" in C.format_comparison(res)


def test_northbound_with_a_90_deg_heading_difference():
    b = straight_track(0.0)
    n = b.time_s.size
    b.quat_nb = quat_of(0.0, 0.0, 0.0, n)
    a = offset_track(b, 0.0, 0.0, quat=quat_of(0.0, 0.0, 90.0, n))
    att = C.compare(a, b).summary["attitude_deg"]
    assert att["heading"]["final"] == pytest.approx(90.0, abs=ANGLE_TOL_DEG)
    assert att["roll"]["max_abs"] == pytest.approx(0.0, abs=ANGLE_TOL_DEG)
    assert att["pitch"]["rms"] == pytest.approx(0.0, abs=ANGLE_TOL_DEG)
    assert att["total"]["max"] == pytest.approx(90.0, abs=ANGLE_TOL_DEG)


@pytest.mark.parametrize("heading_a, heading_b", [(350.0, 10.0), (170.0, 190.0)])  # both ways across the cut
def test_heading_wraps_and_total_angle_matches_scipy(heading_a, heading_b):
    b = straight_track(0.0)
    n = b.time_s.size
    b.quat_nb = quat_of(2.0, -1.0, heading_b, n)
    a = offset_track(b, 0.0, 0.0, quat=quat_of(-3.0, 4.0, heading_a, n))
    res = C.compare(a, b)
    att = res.summary["attitude_deg"]
    assert att["heading"]["final"] == pytest.approx(-20.0, abs=ANGLE_TOL_DEG)  # not 340 or -340
    assert att["roll"]["final"] == pytest.approx(-5.0, abs=ANGLE_TOL_DEG)
    assert att["pitch"]["final"] == pytest.approx(5.0, abs=ANGLE_TOL_DEG)
    rel = Rotation.from_quat(a.quat_nb, scalar_first=True) * Rotation.from_quat(b.quat_nb, scalar_first=True).inv()
    np.testing.assert_allclose(np.degrees(res.attitude_rad[:, 3]), np.degrees(rel.magnitude()), atol=ANGLE_TOL_DEG)


def test_attitude_of_b_is_slerped_between_its_samples():
    t_b = np.array([0.0, 2.0, 4.0])
    b = C.Track(
        t_b, LAT0, LON0, 0.0, np.zeros((3, 3)), np.vstack([quat_of(0, 0, h, 1) for h in (0.0, 20.0, 30.0)]), name="B"
    )
    t_a = np.array([1.0, 3.0])
    a = C.Track(
        t_a, LAT0, LON0, 0.0, np.zeros((2, 3)), np.vstack([quat_of(0, 0, h, 1) for h in (10.0, 25.0)]), name="A"
    )
    res = C.compare(a, b)
    np.testing.assert_allclose(res.attitude_rad, 0.0, atol=np.radians(ANGLE_TOL_DEG))
    assert any("no attitude" in n for n in C.compare(a, C.Track(t_b, LAT0, LON0, 0.0, None, None, name="B")).notes)


# --------------------------------------------------------------------------- overlap


def test_only_a_samples_inside_the_overlap_are_compared():
    a = straight_track(90.0, t=np.arange(0.0, 101.0), name="A")
    b = straight_track(90.0, t=np.arange(49.5, 200.0, 0.5))
    res = C.compare(a, b)
    assert res.summary["samples"] == 51 and res.time_s[0] == 50.0 and res.time_s[-1] == 100.0
    np.testing.assert_allclose(res.horizontal_m, 0.0, atol=OFFSET_TOL_M)


@pytest.mark.parametrize(
    "t_b, words",
    [(np.arange(200.0, 300.0), "no time overlap"), (np.arange(100.0, 120.0), "only 1 sample inside the time overlap")],
)
def test_empty_or_single_sample_overlap_is_an_error(t_b, words):
    a = straight_track(90.0, t=np.arange(0.0, 101.0), name="A")
    b = straight_track(90.0, t=t_b)
    with pytest.raises(TelemetryError, match=words) as info:
        C.compare(a, b)
    assert "\n" not in str(info.value) and str(info.value).startswith("A: /time: ")


def test_document_check_catches_a_missing_key():
    res = C.compare(straight_track(90.0, name="A"), straight_track(90.0))
    doc = C.to_json([res], {"a": "A", "b": "B"})
    assert doc["schema"] == "sizefx/comparison/1"
    del doc["comparisons"][0]["velocity_mps"]["ground_speed"]["rms"]
    with pytest.raises(AssertionError, match=r"comparisons\[0\]\.velocity_mps\.ground_speed\.rms"):
        R._check_document(doc)


# --------------------------------------------------------------------------- files


def write_navigation_by_hand(path, t, lat_rad, lon_rad, h_m, v_n, quat_nb):
    """A sizefx/navigation/1 file written with h5py from the contract, not with sizefx's writer."""
    roll, pitch, heading = (np.degrees(x) for x in mat_to_euler(quat_to_mat(quat_nb)))
    with h5py.File(path, "w") as h5:
        h5.attrs["schema"] = "sizefx/navigation/1"
        h5.create_dataset("time", data=t).attrs["units"] = "s"
        h5.create_dataset("position", data=np.column_stack([np.degrees(lat_rad), np.degrees(lon_rad), h_m])).attrs[
            "units"
        ] = "deg,deg,m"
        h5.create_dataset("velocity", data=v_n).attrs["units"] = "m/s"
        h5.create_dataset("quaternion", data=quat_nb).attrs["units"] = "1"
        h5.create_dataset("euler", data=np.column_stack([roll, pitch, heading % 360.0])).attrs["units"] = "deg"
    return path


@pytest.fixture(scope="module")
def flight_files(tmp_path_factory):
    """An eastbound 30 s flight at 50 m/s: ideal telemetry (REF), its navigation (A), and B.

    B is A moved to the right of the track (south) by 0.5 m/s * t and turned by +2 deg
    in heading, written by hand following data-schemas/navigation-1.json.
    """
    d = tmp_path_factory.mktemp("compare")
    duration = 30.0
    lat0, lon0, h0 = np.radians(57.9825), np.radians(55.7089), 300.0
    speed = ProfileBuilder().hold(duration).build(50.0)
    track = ProfileBuilder().hold(duration).build(np.pi / 2)
    height = ProfileBuilder().hold(duration).build(h0)
    traj = Trajectory(
        FlightPath(speed, track, height, lat0, lon0, duration),
        RotationChain([np.array([0.0, 0.0, 1.0])], [ConstantProfile(np.pi / 2)]),
        duration,
    )
    tel = simulate_in_memory(traj, load_effects(base=IDEAL), rate_hz=400.0)
    ref = write_telemetry(d / "ref.h5", tel)
    res = navigate(tel, NavConfig(subsamples=4, output_rate_hz=10.0))
    nav = d / "a_nav.h5"
    write_navigation(nav, res, input_file=ref)
    a = C.read_track(nav)
    cross = 0.5 * (a.time_s - a.time_s[0])
    lat_b, lon_b, h_b = geodetic_from_local_ned(
        np.column_stack([-cross, 0 * cross, 0 * cross]), a.lat_rad, a.lon_rad, a.height_m
    )
    q_b = mat_to_quat(axis_angle_mat([0.0, 0.0, 1.0], np.radians(2.0)) @ quat_to_mat(a.quat_nb))
    b = write_navigation_by_hand(d / "b_nav.h5", a.time_s, lat_b, lon_b, h_b, a.vel_n_mps, q_b)
    return {"dir": d, "tel": tel, "res": res, "ref": ref, "a": nav, "b": b, "cross_final_m": float(cross[-1])}


def test_read_both_file_kinds(flight_files):
    nav = C.read_track(flight_files["a"])
    res = flight_files["res"]
    assert nav.time_dataset == "/time" and nav.time_s.size == 300 and nav.time_s[0] == pytest.approx(0.1)
    sel = slice(9, None, 10)  # write_navigation decimates the 100 Hz solution to 10 Hz
    np.testing.assert_allclose(nav.lat_rad, res.lat_rad[sel], rtol=0, atol=1e-15)
    np.testing.assert_allclose(nav.vel_n_mps, res.v_n[sel])
    np.testing.assert_allclose(nav.quat_nb, res.quat_nb[sel], atol=1e-15)
    tel = C.read_track(flight_files["ref"])
    ref = flight_files["tel"].reference
    assert tel.time_dataset == "/reference/time" and tel.time_s.size == ref.time_s.size
    np.testing.assert_allclose(tel.lon_rad, ref.lon_rad, rtol=0, atol=1e-15)  # stored in degrees
    np.testing.assert_allclose(tel.vel_n_mps, ref.velocity_n_mps, rtol=1e-15, atol=1e-13)
    assert tel.quat_nb is not None
    hand = C.read_track(flight_files["b"])
    assert hand.name == str(flight_files["b"]) and hand.quat_nb.shape == (300, 4)


def test_ideal_navigation_against_its_telemetry_reference(flight_files):
    nav, ref = C.read_track(flight_files["a"]), C.read_track(flight_files["ref"])
    res = C.compare(nav, ref, "A vs REF")
    s = res.summary
    assert s["horizontal_m"]["max"] < NAV_VS_REFERENCE_M
    assert s["cross_track_m"]["max_abs"] < NAV_VS_REFERENCE_M and s["track_defined_samples"] == s["samples"]
    assert s["velocity_mps"]["ground_speed"]["max_abs"] < 1e-6
    assert s["attitude_deg"]["total"]["max"] < 1e-6
    # the other way round: 400 Hz against a 10 Hz solution, and the report says B is sparser
    back = C.compare(ref, nav)
    assert back.summary["samples"] == 300 * 40 - 39 and back.summary["horizontal_m"]["max"] < NAV_VS_REFERENCE_M
    assert any("sparser" in n for n in back.notes)


def cli():
    return SizefxGroup("sizefx", commands=[compare_command])


def test_cli_with_reference_and_json(flight_files, tmp_path):
    f = flight_files
    out_json = tmp_path / "cmp.json"
    args = ["compare", str(f["a"]), str(f["b"]), "--reference", str(f["ref"]), "--json", str(out_json)]
    result = CliRunner().invoke(cli(), args)
    assert result.exit_code == 0, result.output
    doc = json.loads(out_json.read_text())
    assert doc["schema"] == "sizefx/comparison/1" and doc["inputs"]["reference"] == str(f["ref"])
    by = {c["label"]: c for c in doc["comparisons"]}
    assert list(by) == ["A vs REF", "B vs REF", "A vs B"]
    assert by["A vs REF"]["horizontal_m"]["final"] < NAV_VS_REFERENCE_M
    # B is right of the track (south of an eastbound flight); A is left of B
    assert by["B vs REF"]["cross_track_m"]["final"] == pytest.approx(f["cross_final_m"], abs=0.01)
    assert by["A vs B"]["cross_track_m"]["final"] == pytest.approx(-f["cross_final_m"], abs=0.01)
    assert by["A vs B"]["attitude_deg"]["heading"]["final"] == pytest.approx(-2.0, abs=1e-6)
    assert by["A vs B"]["attitude_deg"]["total"]["max"] == pytest.approx(2.0, abs=1e-6)
    assert "A and B diverge by" in result.stdout and "nmi/h" in result.stdout
    # outputs exist: refused without --force (one line, exit 2), replaced with it
    again = CliRunner().invoke(cli(), args)
    assert again.exit_code == 2 and len(again.stderr.strip().splitlines()) == 1 and "--force" in again.stderr
    assert CliRunner().invoke(cli(), [*args, "--force"]).exit_code == 0


# long tier: four plots (a second and a half of drawing); fast twins: test_cli_with_reference_and_json,
# and the demo's compare plot that .ci/run checks
@pytest.mark.slow
def test_cli_draws_the_comparison(flight_files, tmp_path):
    f = flight_files
    out_json, plots = tmp_path / "cmp.json", tmp_path / "figs"
    args = ["compare", str(f["a"]), str(f["b"]), "--reference", str(f["ref"]), "--json", str(out_json)]
    result = CliRunner().invoke(cli(), [*args, "--plots", str(plots)])
    assert result.exit_code == 0, result.output
    doc = json.loads(out_json.read_text())
    names = sorted(p.name for p in plots.iterdir())
    assert names == ["attitude.png", "horizontal_error.png", "trajectories.png", "velocity.png"]
    for p in plots.iterdir():
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and p.stat().st_size > 10_000
    assert sorted(doc["plots"]) == sorted(str(p) for p in plots.iterdir())


def test_cli_without_reference_and_no_overwrite_of_inputs(flight_files):
    f = flight_files
    result = CliRunner().invoke(cli(), ["compare", str(f["a"]), str(f["b"])])
    assert result.exit_code == 0, result.output
    assert result.stdout.startswith("A vs B: ") and "REF" not in result.stdout
    clash = CliRunner().invoke(cli(), ["compare", str(f["a"]), str(f["b"]), "--json", str(f["b"]), "--force"])
    assert clash.exit_code == 2 and "would overwrite the input" in clash.stderr


def test_result_reports_what_the_cli_prints_and_holds_what_it_writes(flight_files, tmp_path):
    f = flight_files
    out_json = tmp_path / "cmp.json"
    calls = []
    config = C.CompareConfig(f["a"], f["b"], reference=f["ref"], json_path=out_json)
    result = C.run(config, progress=lambda done, total: calls.append((done, total)))
    assert calls == [(1, 5), (2, 5), (3, 5), (4, 5), (5, 5)]  # A, B, REF, the comparisons, the outputs
    assert result.to_json() == json.loads(out_json.read_text())
    assert [c.label for c in result.comparisons] == ["A vs REF", "B vs REF", "A vs B"]
    assert result.report().splitlines()[-1] == f"comparison -> {out_json}"
    args = ["compare", str(f["a"]), str(f["b"]), "--reference", str(f["ref"]), "--json", str(out_json), "--force"]
    printed = CliRunner().invoke(cli(), args)
    assert printed.exit_code == 0, printed.output
    assert printed.stdout == result.report() + "\n"
    with pytest.raises(dataclasses.FrozenInstanceError):
        config.force = True


def test_preflight_refuses_before_reading_anything(flight_files, tmp_path):
    f = flight_files
    figs = tmp_path / "figs"
    figs.mkdir()
    clash = C.CompareConfig(f["a"], f["b"], json_path=figs / "velocity.png", plots_dir=figs)
    assert set(clash.outputs()) == {"--json", *(f"--plots {n}" for n in PLOT_NAMES)}
    with pytest.raises(OutputError, match="given to both --json and --plots velocity.png"):
        C.run(clash)
    (figs / "attitude.png").write_bytes(b"")  # an earlier run's figure is not replaced without --force
    with pytest.raises(OutputError, match="attitude.png: output exists; pass --force"):
        C.run(C.CompareConfig(f["a"], f["b"], plots_dir=figs))
    with pytest.raises(ConfigError, match="--reference: no such file"):
        C.run(C.CompareConfig(f["a"], f["b"], reference=tmp_path / "missing.h5", json_path=tmp_path / "c.json"))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["figs"]
    assert [p.name for p in figs.iterdir()] == ["attitude.png"] and (figs / "attitude.png").stat().st_size == 0


def test_plots_without_matplotlib_is_a_config_error(flight_files, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib -> ImportError
    with pytest.raises(ConfigError, match=r"plots need matplotlib: pip install 'sizefx\[plots\]'"):
        C.run(C.CompareConfig(flight_files["a"], flight_files["b"], plots_dir=tmp_path / "figs"))
    assert not (tmp_path / "figs").exists()


def _not_hdf5(d, good):
    (d / "notes.h5").write_text("latitude,longitude\n")
    return d / "notes.h5", "/: is not an HDF5 file"


def _telemetry_without_position(d, good):
    return write_raw(d / "static.h5"), "/reference/position: dataset is missing"


def _no_overlap(d, good):
    a = C.read_track(good)
    write_navigation_by_hand(d / "late.h5", a.time_s + 1000.0, a.lat_rad, a.lon_rad, a.height_m, a.vel_n_mps, a.quat_nb)
    return d / "late.h5", "no time overlap"


def _missing_velocity(d, good):
    a = C.read_track(good)
    path = write_navigation_by_hand(d / "novel.h5", a.time_s, a.lat_rad, a.lon_rad, a.height_m, a.vel_n_mps, a.quat_nb)
    with h5py.File(path, "a") as h5:
        del h5["velocity"]
    return path, "/velocity: dataset is missing"


def _wrong_schema(d, good):
    with h5py.File(d / "other.h5", "w") as h5:
        h5.attrs["schema"] = "sizefx/levers/1"
    return d / "other.h5", "/: root attribute schema is 'sizefx/levers/1'"


def _position_in_radians_labelled(d, good):
    a = C.read_track(good)
    path = write_navigation_by_hand(d / "rad.h5", a.time_s, a.lat_rad, a.lon_rad, a.height_m, a.vel_n_mps, a.quat_nb)
    with h5py.File(path, "a") as h5:
        h5["position"].attrs["units"] = "rad,rad,m"
    return path, "/position: has units 'rad,rad,m'"


@pytest.mark.parametrize(
    "make",
    [
        _not_hdf5,
        _telemetry_without_position,
        _no_overlap,
        _missing_velocity,
        _wrong_schema,
        _position_in_radians_labelled,
    ],
)
def test_bad_input_exits_2_with_one_line(flight_files, tmp_path, make):
    bad, words = make(tmp_path, flight_files["a"])
    result = CliRunner().invoke(cli(), ["compare", str(flight_files["a"]), str(bad)])
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.output and result.stdout == ""
    assert lines[0].startswith("sizefx: error: ") and str(bad) in lines[0] and words in lines[0], lines[0]
    with pytest.raises(SizefxError):
        C.run(C.CompareConfig(flight_files["a"], bad))


def test_approximate_reference_attitude_is_left_out(flight_files, tmp_path):
    path = write_telemetry(
        tmp_path / "approx.h5",
        dataclasses.replace(flight_files["tel"], source=Provenance(extra={"reference_is_approximate": True})),
    )
    track = C.read_track(path)
    assert track.quat_nb is None and "approximate" in track.notes[0]
    res = C.compare(C.read_track(flight_files["a"]), track)
    assert res.attitude_rad is None and res.summary["attitude_deg"] is None
    assert any("approximate" in n for n in res.notes)


def test_plot_directory_needs_an_existing_parent(flight_files, tmp_path):
    with pytest.raises(OutputError, match="does not exist; create it first"):
        C.run(C.CompareConfig(flight_files["a"], flight_files["b"], plots_dir=tmp_path / "no" / "figs"))
    (tmp_path / "file").write_text("")
    with pytest.raises(OutputError, match="needs a directory"):
        C.run(C.CompareConfig(flight_files["a"], flight_files["b"], plots_dir=tmp_path / "file"))


def test_a_vs_b_takes_the_track_direction_from_the_reference():
    """Two drifting solutions: along/cross-track of A - B are split along the reference's motion
    (eastbound), not along B's own drift (northbound)."""
    t = np.arange(0.0, 100.0, 1.0)
    r_e = WGS84_A_M
    zeros = np.zeros(t.size)
    ref = C.Track(t, zeros, 20.0 * t / r_e, zeros, np.column_stack([zeros, np.full(t.size, 20.0), zeros]), None, "REF")
    b = C.Track(t, 5.0 * t / r_e, zeros, zeros, np.column_stack([np.full(t.size, 5.0), zeros, zeros]), None, "B")
    a = C.Track(t, b.lat_rad, b.lon_rad + 10.0 / r_e, zeros, b.vel_n_mps, None, "A")  # 10 m east of B
    with_ref = C.compare(a, b, "A vs B", track=ref)
    assert with_ref.summary["along_track_m"]["final"] == pytest.approx(10.0, abs=1e-3)  # ahead along the east track
    assert with_ref.summary["cross_track_m"]["final"] == pytest.approx(0.0, abs=1e-3)
    own = C.compare(a, b, "A vs B")  # B moves north: 10 m east is 10 m to the right of B's own motion
    assert own.summary["cross_track_m"]["final"] == pytest.approx(10.0, abs=1e-3)
