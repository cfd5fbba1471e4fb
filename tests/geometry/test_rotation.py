"""Rotation vectors: exponential and logarithm maps and the analytic Jacobian."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aida_kb.errors import GeometryError
from aida_kb.geometry.rotation import (
    check_rotation,
    rotation_from_rvec,
    rotation_from_rvec_jacobian,
    rvec_from_rotation,
    skew,
)

unit = st.tuples(st.floats(-1, 1, allow_nan=False), st.floats(-1, 1), st.floats(-1, 1)).filter(
    lambda v: math.hypot(*v) > 1e-3
)


def _rvec(axis: tuple[float, float, float], angle: float) -> np.ndarray:
    a = np.asarray(axis)
    return angle * a / np.linalg.norm(a)


def test_skew_is_cross_product() -> None:
    rng = np.random.default_rng(0)
    v, w = rng.normal(size=(2, 5, 3))
    np.testing.assert_allclose(np.einsum("nij,nj->ni", skew(v), w), np.cross(v, w), atol=1e-15)


def test_known_rotation() -> None:
    R = rotation_from_rvec([0.0, 0.0, math.pi / 2])
    np.testing.assert_allclose(R @ [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], atol=1e-15)
    np.testing.assert_array_equal(rotation_from_rvec([0.0, 0.0, 0.0]), np.eye(3))
    np.testing.assert_array_equal(rvec_from_rotation(np.eye(3)), np.zeros(3))


@settings(max_examples=120, deadline=None)
@given(unit, st.floats(0.0, math.pi * (1 - 1e-9)))
def test_log_inverts_exp(axis: tuple[float, float, float], angle: float) -> None:
    v = _rvec(axis, angle)
    R = rotation_from_rvec(v)
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-15)
    assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-14)
    np.testing.assert_allclose(
        rvec_from_rotation(R), v, rtol=1e-12, atol=2e-15 / max(1e-3, math.pi - angle)
    )


@pytest.mark.parametrize("angle", [1e-12, 1e-8, 1e-4, 0.049, 0.051, 1.0, 2.1, 3.0, math.pi - 1e-7])
def test_log_inverts_exp_at_difficult_angles(angle: float) -> None:
    v = _rvec((0.3, -0.5, 0.8), angle)
    got = rvec_from_rotation(rotation_from_rvec(v))
    tol = 1e-15 / (math.pi - angle) if angle > 3 else 1e-12 * angle
    np.testing.assert_allclose(got, v, atol=max(tol, 1e-20))


def test_angle_pi_gives_either_vector() -> None:
    v = _rvec((1.0, 2.0, -2.0), math.pi)
    got = rvec_from_rotation(rotation_from_rvec(v))
    assert min(np.linalg.norm(got - v), np.linalg.norm(got + v)) < 1e-7
    np.testing.assert_allclose(rotation_from_rvec(got), rotation_from_rvec(v), atol=1e-14)


def _numeric_jacobian(v: np.ndarray, h: float = 1e-6) -> np.ndarray:
    out = np.zeros((3, 3, 3))
    for i in range(3):
        e = np.zeros(3)
        e[i] = h
        out[:, :, i] = (rotation_from_rvec(v + e) - rotation_from_rvec(v - e)) / (2 * h)
    return out


@pytest.mark.parametrize(
    "v",
    [
        [0.0, 0.0, 0.0],
        [1e-9, -2e-9, 3e-9],
        [0.01, 0.02, -0.03],
        [0.03, 0.0, 0.03],  # just under the series threshold
        [0.3, -1.2, 0.7],
        [2.0, 1.0, -1.5],
    ],
)
def test_jacobian_matches_finite_differences(v: list[float]) -> None:
    vv = np.asarray(v)
    R, dR = rotation_from_rvec_jacobian(vv)
    np.testing.assert_allclose(R, rotation_from_rvec(vv), atol=1e-15)
    np.testing.assert_allclose(dR, _numeric_jacobian(vv), atol=1e-9)


def test_jacobian_continuous_across_series_threshold() -> None:
    axis = np.array([0.6, 0.0, 0.8])
    _, below = rotation_from_rvec_jacobian(axis * (0.05 - 1e-12))
    _, above = rotation_from_rvec_jacobian(axis * (0.05 + 1e-12))
    np.testing.assert_allclose(below, above, atol=1e-12)


def test_check_rotation_rejects() -> None:
    with pytest.raises(GeometryError, match="reflection"):
        check_rotation(np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(GeometryError, match="orthonormal"):
        check_rotation(np.diag([1.0, 1.0, 1.1]))
    with pytest.raises(GeometryError, match="shape"):
        check_rotation(np.eye(2))
    with pytest.raises(GeometryError, match="non-finite"):
        rotation_from_rvec([np.nan, 0.0, 0.0])
