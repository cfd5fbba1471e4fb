"""Pinhole and CAHV cameras: conversion, projection, back-projection and Jacobians."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aida_kb.errors import GeometryError
from aida_kb.geometry.camera import Cahv, PinholeCamera, Rt_from_pose, pose_from_Rt
from aida_kb.geometry.rotation import (
    rotation_from_rvec,
    rotation_from_rvec_jacobian,
    rvec_from_rotation,
)


@st.composite
def cameras(draw: st.DrawFn, skew: bool = False) -> PinholeCamera:
    fx = draw(st.floats(50.0, 8000.0))
    fy = fx * draw(st.floats(0.5, 2.0))
    cx = draw(st.floats(-500.0, 3000.0))
    cy = draw(st.floats(-500.0, 3000.0))
    s = draw(st.one_of(st.just(0.0), st.floats(-50.0, 50.0))) if skew else 0.0
    axis = np.array([draw(st.floats(-1, 1)) for _ in range(3)])
    angle = draw(st.floats(0.0, 3.14))
    rvec = (
        angle * axis / max(np.linalg.norm(axis), 1e-9) if np.linalg.norm(axis) > 1e-3 else 0 * axis
    )
    C = np.array([draw(st.floats(-200.0, 200.0)) for _ in range(3)])
    K = np.array([[fx, s, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
    return PinholeCamera.from_pose(K, np.concatenate([rvec, C]), 1920, 1080)


def _camera(
    rvec: tuple[float, float, float] = (0.1, -0.2, 0.05), skew: float = 0.0
) -> PinholeCamera:
    K = np.array([[1200.0, skew, 640.5], [0.0, 1180.0, 479.5], [0.0, 0.0, 1.0]])
    return PinholeCamera.from_pose(K, np.array([*rvec, 1.0, -2.0, -15.0]), 1280, 960)


def _points_in_front(cam: PinholeCamera, n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    _, rays = cam.unproject(rng.uniform([0, 0], [cam.width, cam.height], size=(n, 2)))
    return cam.centre + rays * rng.uniform(2.0, 40.0, size=(n, 1))


def _close(a: np.ndarray, b: np.ndarray, rel: float = 1e-12) -> None:
    scale = max(float(np.max(np.abs(b))), 1.0)
    np.testing.assert_allclose(a, b, rtol=0, atol=rel * scale)


# ---- conversion --------------------------------------------------------------------------


@settings(max_examples=120, deadline=None)
@given(cameras(skew=True))
def test_pinhole_cahv_pinhole_round_trip(cam: PinholeCamera) -> None:
    back = PinholeCamera.from_cahv(cam.to_cahv(), cam.width, cam.height)
    _close(back.K, cam.K)  # includes the skew: exactly 0 in half of the cameras
    assert back.K[0, 1] == pytest.approx(cam.K[0, 1], abs=1e-12 * cam.K[0, 0])
    _close(back.R_cam_world, cam.R_cam_world)
    _close(back.t_cam_world, cam.t_cam_world)
    _close(back.centre, cam.centre)


@settings(max_examples=60, deadline=None)
@given(cameras(skew=True))
def test_cahv_pinhole_cahv_round_trip(cam: PinholeCamera) -> None:
    cahv = cam.to_cahv()
    again = PinholeCamera.from_cahv(cahv, 10, 10).to_cahv()
    for a, b in zip(again.as_tuple(), cahv.as_tuple(), strict=True):
        _close(a, b)


@settings(max_examples=60, deadline=None)
@given(cameras(skew=True))
def test_cahv_projection_equals_pinhole(cam: PinholeCamera) -> None:
    P = _points_in_front(cam, 20)
    _close(cam.to_cahv().project(P), cam.project(P), rel=1e-10)


def test_cahv_definition() -> None:
    cam = _camera()
    c = cam.to_cahv()
    R = cam.R_cam_world
    np.testing.assert_allclose(c.C, -R.T @ cam.t_cam_world, atol=1e-14)
    np.testing.assert_allclose(c.A, R[2], atol=0)
    np.testing.assert_allclose(c.H, 1200.0 * R[0] + 640.5 * R[2], atol=1e-12)
    np.testing.assert_allclose(c.V, 1180.0 * R[1] + 479.5 * R[2], atol=1e-12)


def test_from_cahv_rejects_bad_models() -> None:
    c = _camera().to_cahv()
    with pytest.raises(GeometryError, match="unit"):
        Cahv(c.C, 2 * c.A, c.H, c.V)
    with pytest.raises(GeometryError, match="left-handed"):
        PinholeCamera.from_cahv(Cahv(c.C, c.A, -c.H + 2 * (c.H @ c.A) * c.A, c.V), 10, 10)
    with pytest.raises(GeometryError, match="parallel"):
        PinholeCamera.from_cahv(Cahv(c.C, c.A, c.H, 3 * c.A), 10, 10)
    with pytest.raises(GeometryError, match="shape"):
        Cahv(c.C[:2], c.A, c.H, c.V)


def test_pinhole_validation() -> None:
    K = np.diag([1000.0, 1000.0, 1.0])
    with pytest.raises(GeometryError, match="K must be"):
        PinholeCamera(K * 2, np.eye(3), np.zeros(3), 10, 10)
    with pytest.raises(GeometryError, match="positive focal"):
        PinholeCamera(np.diag([-1.0, 1.0, 1.0]), np.eye(3), np.zeros(3), 10, 10)
    with pytest.raises(GeometryError, match="reflection"):
        PinholeCamera(K, np.diag([1.0, 1.0, -1.0]), np.zeros(3), 10, 10)
    with pytest.raises(GeometryError, match="image size"):
        PinholeCamera(K, np.eye(3), np.zeros(3), 0, 10)
    with pytest.raises(GeometryError, match="non-finite"):
        PinholeCamera(K, np.eye(3), np.array([0.0, np.inf, 0.0]), 10, 10)


def test_camera_is_immutable() -> None:
    K = np.diag([1000.0, 1000.0, 1.0])
    cam = PinholeCamera(K, np.eye(3), np.zeros(3), 10, 10)
    K[0, 0] = 5.0  # the camera holds its own copy
    assert cam.K[0, 0] == 1000.0
    with pytest.raises(ValueError, match="read-only"):
        cam.K[0, 0] = 1.0
    with pytest.raises(AttributeError):
        cam.width = 3  # type: ignore[misc]


@settings(max_examples=40, deadline=None)
@given(cameras())
def test_cached_pose_and_rotation_derivative_are_those_of_the_rotation(cam: PinholeCamera) -> None:
    """The pose and rotation derivative a camera keeps equal, bit for bit, what the rotation
    functions give for its rotation; the pose handed out is the caller's own copy."""
    rvec = rvec_from_rotation(cam.R_cam_world)
    np.testing.assert_array_equal(cam.pose, pose_from_Rt(cam.R_cam_world, cam.t_cam_world))
    R, dR = rotation_from_rvec_jacobian(rvec)
    np.testing.assert_array_equal(cam.rotation_jacobian[0], R)
    np.testing.assert_array_equal(cam.rotation_jacobian[1], dR)
    pose = cam.pose
    pose[:] = 0.0  # the caller's copy: the camera's own pose is unchanged
    np.testing.assert_array_equal(cam.pose[:3], rvec)
    with pytest.raises(ValueError, match="read-only"):
        cam.rotation_jacobian[1][0, 0, 0] = 1.0


@settings(max_examples=60, deadline=None)
@given(cameras())
def test_pose_round_trip(cam: PinholeCamera) -> None:
    R, t = Rt_from_pose(pose_from_Rt(cam.R_cam_world, cam.t_cam_world))
    _close(R, cam.R_cam_world)
    _close(t, cam.t_cam_world)
    again = cam.with_pose(cam.pose)
    _close(again.R_cam_world, cam.R_cam_world)
    np.testing.assert_array_equal(again.K, cam.K)


# ---- projection --------------------------------------------------------------------------


def test_project_known_point() -> None:
    K = np.array([[1000.0, 0.0, 320.0], [0.0, 900.0, 240.0], [0.0, 0.0, 1.0]])
    cam = PinholeCamera(K, np.eye(3), np.array([0.0, 0.0, 2.0]), 640, 480)
    np.testing.assert_allclose(cam.project([[1.0, -1.0, 8.0]]), [[420.0, 150.0]])
    np.testing.assert_allclose(cam.centre, [0.0, 0.0, -2.0])
    np.testing.assert_array_equal(
        cam.in_image([[0.0, 0.0], [639.6, 3.0], [-0.5, 479.5]]), [True, False, True]
    )


def test_project_agrees_with_projection_matrix() -> None:
    cam = _camera(skew=2.0)
    P = _points_in_front(cam, 50)
    q = np.hstack([P, np.ones((50, 1))]) @ cam.P.T
    np.testing.assert_allclose(cam.project(P), q[:, :2] / q[:, 2:], rtol=1e-13)


def test_points_behind_raise_and_are_masked() -> None:
    cam = _camera()
    P = _points_in_front(cam, 5)
    behind = cam.centre - (P[0] - cam.centre)
    P = np.vstack([P, behind, cam.centre])
    np.testing.assert_array_equal(cam.in_front(P), [True] * 5 + [False, False])
    with pytest.raises(GeometryError, match=r"2 of 7 points .* point 5"):
        cam.project(P)
    with pytest.raises(GeometryError, match="behind"):
        cam.project_with_jacobians(P)
    with pytest.raises(GeometryError, match="behind"):
        cam.to_cahv().project(P)
    assert cam.project(P[cam.in_front(P)]).shape == (5, 2)


def test_bad_shapes() -> None:
    cam = _camera()
    with pytest.raises(GeometryError, match=r"\(N, 3\)"):
        cam.project(np.zeros(3))
    with pytest.raises(GeometryError, match=r"\(N, 2\)"):
        cam.unproject(np.zeros((2, 3)))
    with pytest.raises(GeometryError, match="non-finite"):
        cam.project([[0.0, np.nan, 1.0]])


@settings(max_examples=60, deadline=None)
@given(cameras(skew=True))
def test_unproject_inverts_project(cam: PinholeCamera) -> None:
    rng = np.random.default_rng(1)
    q = rng.uniform([0, 0], [cam.width, cam.height], size=(30, 2))
    C, rays = cam.unproject(q)
    np.testing.assert_allclose(np.linalg.norm(rays, axis=1), 1.0, atol=1e-14)
    depth = rng.uniform(0.5, 100.0, size=(30, 1))
    P = C + depth * rays
    assert np.all(cam.in_front(P))
    np.testing.assert_allclose(cam.project(P), q, atol=1e-8)


# ---- Jacobians -----------------------------------------------------------------------------


def _fd_points(cam: PinholeCamera, P: np.ndarray, h: float = 1e-6) -> np.ndarray:
    out = np.zeros((P.shape[0], 2, 3))
    for i in range(3):
        e = np.zeros(3)
        e[i] = h
        out[:, :, i] = (cam.project(P + e) - cam.project(P - e)) / (2 * h)
    return out


def _fd_pose(cam: PinholeCamera, P: np.ndarray, h: float = 1e-7) -> np.ndarray:
    pose = cam.pose
    out = np.zeros((P.shape[0], 2, 6))
    for i in range(6):
        e = np.zeros(6)
        e[i] = h
        out[:, :, i] = (cam.with_pose(pose + e).project(P) - cam.with_pose(pose - e).project(P)) / (
            2 * h
        )
    return out


@pytest.mark.parametrize(
    "rvec",
    [(0.0, 0.0, 0.0), (1e-5, 0.0, -2e-5), (0.1, -0.2, 0.05), (1.2, 2.0, -0.4), (0.0, 3.0, 0.0)],
)
@pytest.mark.parametrize("skew", [0.0, 3.0])
def test_projection_jacobians_match_finite_differences(
    rvec: tuple[float, float, float], skew: float
) -> None:
    cam = _camera(rvec, skew)
    P = _points_in_front(cam, 25, seed=3)
    proj = cam.project_with_jacobians(P)
    np.testing.assert_allclose(proj.pixels, cam.project(P), rtol=0, atol=1e-9)
    fd_p = _fd_points(cam, P)
    fd_pose = _fd_pose(cam, P)
    assert np.max(np.abs(proj.d_pixels_d_points - fd_p)) < 1e-6 * np.max(np.abs(fd_p))
    assert np.max(np.abs(proj.d_pixels_d_pose - fd_pose)) < 1e-6 * np.max(np.abs(fd_pose))


def test_pose_jacobian_of_centre_is_minus_point_jacobian() -> None:
    cam = _camera()
    proj = cam.project_with_jacobians(_points_in_front(cam, 4))
    np.testing.assert_array_equal(proj.d_pixels_d_pose[:, :, 3:], -proj.d_pixels_d_points)


@pytest.mark.parametrize("rvec", [(0.0, 0.0, 0.0), (0.3, -1.0, 0.2), (2.5, 0.5, 1.0)])
def test_ray_jacobians_match_finite_differences(rvec: tuple[float, float, float]) -> None:
    cam = _camera(rvec, skew=1.5)
    rng = np.random.default_rng(5)
    q = rng.uniform([0, 0], [cam.width, cam.height], size=(10, 2))
    jac = cam.unproject_with_jacobians(q)
    C, rays = cam.unproject(q)
    np.testing.assert_allclose(jac.rays, rays, atol=1e-15)
    np.testing.assert_allclose(jac.centre, C, atol=0)
    h = 1e-7
    pose = cam.pose
    for i in range(3):
        e = np.zeros(6)
        e[i] = h
        fd = (cam.with_pose(pose + e).unproject(q)[1] - cam.with_pose(pose - e).unproject(q)[1]) / (
            2 * h
        )
        np.testing.assert_allclose(jac.d_rays_d_rvec[:, :, i], fd, atol=1e-8)
    for p in range(2):
        e2 = np.zeros(2)
        e2[p] = 1e-3
        fd = (cam.unproject(q + e2)[1] - cam.unproject(q - e2)[1]) / 2e-3
        np.testing.assert_allclose(jac.d_rays_d_pixels[:, :, p], fd, atol=1e-10)


def test_optical_axis_and_pose_of_identity() -> None:
    cam = PinholeCamera(
        np.diag([500.0, 500.0, 1.0]), rotation_from_rvec([0, 0, 0]), np.zeros(3), 8, 8
    )
    np.testing.assert_array_equal(cam.optical_axis, [0.0, 0.0, 1.0])
    np.testing.assert_array_equal(cam.pose, np.zeros(6))
    assert math.isclose(cam.depth([[0.0, 0.0, 3.0]])[0], 3.0)
