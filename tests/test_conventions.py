"""The conventions stated once in sizefx/__init__.py, each checked here.

scipy's Rotation is the independent reference: with ``scalar_first=True`` it
uses scalar-first Hamilton quaternions whose ``apply`` rotates vectors
actively, i.e. body vectors into the navigation frame for q_nb.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import sizefx
from sizefx import rotation as rot
from sizefx.constants import OMEGA_EARTH_RAD_S, STANDARD_GRAVITY_MPS2
from sizefx.io.schema import load_schema

unit_quats = (
    st.lists(st.floats(-1, 1, allow_nan=False), min_size=4, max_size=4)
    .filter(lambda q: np.linalg.norm(q) > 0.1)
    .map(lambda q: np.asarray(q) / np.linalg.norm(q))
)


#: The package docstring, whitespace collapsed: where the conventions are stated, once.
DOC = " ".join(sizefx.__doc__.split())


def _stated(pattern: str) -> str:
    """What the package docstring states where ``pattern`` (one group) matches it."""
    found = re.search(pattern, DOC)
    assert found, f"sizefx/__init__.py no longer states {pattern!r}; restate it or change this test"
    return found.group(1)


def _rx(a):
    return np.array([[1.0, 0.0, 0.0], [0.0, math.cos(a), -math.sin(a)], [0.0, math.sin(a), math.cos(a)]])


def _ry(a):
    return np.array([[math.cos(a), 0.0, math.sin(a)], [0.0, 1.0, 0.0], [-math.sin(a), 0.0, math.cos(a)]])


def _rz(a):
    return np.array([[math.cos(a), -math.sin(a), 0.0], [math.sin(a), math.cos(a), 0.0], [0.0, 0.0, 1.0]])


class _Quat:
    """A quaternion whose ``*`` is sizefx's Hamilton product, to evaluate the docstring's formula as written."""

    def __init__(self, q):
        self.q = np.asarray(q, dtype=float)

    def __mul__(self, other):
        return _Quat(rot.quat_multiply(self.q, other.q))


def test_the_constants_the_package_docstring_states_are_the_ones_the_code_uses():
    assert float(_stated(r"Earth rate ([0-9.eE+-]+) rad/s")) == OMEGA_EARTH_RAD_S
    assert float(_stated(r"g \(([0-9.]+) m/s\^2\)")) == STANDARD_GRAVITY_MPS2


def test_the_formulas_of_the_package_docstring_hold_for_the_code():
    """Each formula evaluated as the docstring writes it, against the functions that implement it."""
    rng = np.random.default_rng(14)
    euler = _stated(r"``mat_nb = ([^`]+)``")  # Rz(heading) @ Ry(pitch) @ Rx(roll)
    sandwich = _stated(r"``v_n = ([^`]+)``")  # q * v_b * conj(q)
    assert _stated(r"``(mat_nb @ v_b) = v_n``")  # the naming rule: adjacent letters cancel
    for roll, pitch, heading in rng.uniform(-3.0, 3.0, (20, 3)):
        mat_nb = rot.euler_to_mat(roll, pitch, heading)
        written = eval(euler, {"Rz": _rz, "Ry": _ry, "Rx": _rx, "roll": roll, "pitch": pitch, "heading": heading})
        np.testing.assert_allclose(mat_nb, written, atol=1e-15)
        q = rot.mat_to_quat(mat_nb)
        v_b = rng.standard_normal(3)
        v_n = eval(
            sandwich, {"q": _Quat(q), "v_b": _Quat(np.r_[0.0, v_b]), "conj": lambda p: _Quat(rot.quat_conjugate(p.q))}
        ).q
        assert abs(v_n[0]) < 1e-15  # a pure quaternion stays pure
        np.testing.assert_allclose(v_n[1:], mat_nb @ v_b, atol=1e-14)  # mat_nb @ v_b = v_n, with q_nb of mat_nb


@settings(max_examples=200, deadline=None)
@given(unit_quats)
def test_quaternion_rotates_body_vectors_into_ned_like_scipy(q):
    v_b = np.array([0.3, -1.2, 2.0])
    ref = Rotation.from_quat(q, scalar_first=True)
    np.testing.assert_allclose(rot.quat_to_mat(q) @ v_b, ref.apply(v_b), atol=1e-14)
    # and as the quaternion sandwich q * v * conj(q)
    sandwich = rot.quat_multiply(rot.quat_multiply(q, np.r_[0.0, v_b]), rot.quat_conjugate(q))
    np.testing.assert_allclose(sandwich[1:], ref.apply(v_b), atol=1e-14)


@settings(max_examples=200, deadline=None)
@given(unit_quats, unit_quats)
def test_hamilton_product_composes_like_matrices(p, q):
    np.testing.assert_allclose(
        rot.quat_to_mat(rot.quat_multiply(p, q)), rot.quat_to_mat(p) @ rot.quat_to_mat(q), atol=1e-14
    )


@settings(max_examples=200, deadline=None)
@given(unit_quats)
def test_matrix_quaternion_round_trip(q):
    back = rot.mat_to_quat(rot.quat_to_mat(q))
    assert back[0] >= 0.0  # mat_to_quat returns the q0 >= 0 one of q and -q (the same rotation)
    # at q0 = 0 (180 deg) both signs qualify, so compare up to sign
    assert min(np.abs(back - q).max(), np.abs(back + q).max()) < 1e-14


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(-1.8, 1.8, allow_nan=False), min_size=3, max_size=3))
def test_rotation_vector_round_trip_and_scipy(v):
    # |v| <= 1.8 * sqrt(3) = 3.118 < pi: the range where a rotation vector is unique
    v = np.asarray(v)
    mat = rot.rotvec_to_mat(v)
    np.testing.assert_allclose(mat, Rotation.from_rotvec(v).as_matrix(), atol=1e-14)
    np.testing.assert_allclose(rot.mat_to_rotvec(mat), v, atol=1e-12)


def test_small_rotation_vectors_keep_full_precision():
    v = np.array([1e-9, -2e-9, 3e-10])
    np.testing.assert_allclose(rot.rotvec_to_mat(v), Rotation.from_rotvec(v).as_matrix(), atol=1e-22, rtol=0)


def test_heading_90_deg_points_body_x_east_and_z_stays_down():
    mat_nb = rot.euler_to_mat(0.0, 0.0, math.pi / 2)
    np.testing.assert_allclose(mat_nb @ [1, 0, 0], [0, 1, 0], atol=1e-15)  # x forward -> East
    np.testing.assert_allclose(mat_nb @ [0, 1, 0], [-1, 0, 0], atol=1e-15)  # y right -> South
    np.testing.assert_allclose(mat_nb @ [0, 0, 1], [0, 0, 1], atol=1e-15)  # z down stays down


def test_positive_roll_lowers_the_right_wing_and_positive_pitch_raises_the_nose():
    right_wing = rot.euler_to_mat(0.1, 0.0, 0.0) @ [0, 1, 0]
    assert right_wing[2] > 0  # NED: positive down
    nose = rot.euler_to_mat(0.0, 0.1, 0.0) @ [1, 0, 0]
    assert nose[2] < 0


def test_euler_angles_round_trip_and_match_scipy_zyx():
    r, p, h = 0.3, -0.4, 2.5
    mat = rot.euler_to_mat(r, p, h)
    np.testing.assert_allclose(mat, Rotation.from_euler("ZYX", [h, p, r]).as_matrix(), atol=1e-15)
    np.testing.assert_allclose(rot.mat_to_euler(mat), (r, p, h), atol=1e-14)


def test_skew_is_the_cross_product():
    a, b = np.array([1.0, -2.0, 0.5]), np.array([0.3, 0.7, -1.1])
    np.testing.assert_allclose(rot.skew(a) @ b, np.cross(a, b), atol=1e-15)


def test_skew_matches_the_papers_omega_matrix():
    # Morozov & Bogdanov: Omega = [[0, -wz, wy], [wz, 0, -wx], [-wy, wx, 0]]
    wx, wy, wz = 0.1, 0.2, 0.3
    assert rot.skew([wx, wy, wz]).tolist() == [[0, -wz, wy], [wz, 0, -wx], [-wy, wx, 0]]


def test_effect_unit_table_is_consistent():
    units = load_schema("sizefx/effects/1")["units"]
    assert units["arcsec"] == pytest.approx(math.pi / 180 / 3600, rel=1e-13)
    assert units["deg_per_sqrt_h"] == pytest.approx(math.pi / 180 / 60, rel=1e-13)
    assert units["deg_per_h_per_g"] == pytest.approx(math.pi / 180 / 3600 / 9.80665, rel=1e-9)
    assert units["ug_per_g2"] == pytest.approx(1e-6 / 9.80665, rel=1e-13)
    assert units["deg_per_h_per_sqrt_h"] == pytest.approx(math.pi / 180 / 3600 / 60, rel=1e-9)
    assert units["ug_per_sqrt_h"] == pytest.approx(9.80665e-6 / 60, rel=1e-13)
