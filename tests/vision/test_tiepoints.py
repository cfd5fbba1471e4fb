"""Tie points between two views (aida_kb.vision.tiepoints): SIFT pairs of a rendered pair of
textured planes seen from two poses, the Sampson distance against OpenCV's optimal
correction, the relative pose from RANSAC and its refinement from a prior."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt
import pytest

from aida_kb.errors import VisionError
from aida_kb.geometry.rotation import rotation_from_rvec
from aida_kb.vision import tiepoints as tp

FloatArray = npt.NDArray[np.float64]
W, H = 640, 480
K = np.array([[700.0, 0.0, 319.5], [0.0, 700.0, 239.5], [0.0, 0.0, 1.0]])
D = np.array([0.06, 0.0, 0.0, 0.0, 0.0])  # as the random scenes' lenses (k1 up to 0.06)
R_BA = rotation_from_rvec(np.radians([1.0, 6.0, 0.5]))
T_BA = np.array([-2.0, 0.1, 0.3])  # metres: view b 2 m to the right of view a
PLANES = ((np.array([0.0, 0.0, 1.0]), 20.0), (np.array([0.3, 0.0, 1.0]) / np.hypot(0.3, 1), 9.0))
"""(unit normal, distance) in view a's camera frame, n.X = d: a far wall and a nearer one,
turned 17 deg (two planes at different depths: not a degenerate scene for E)."""


def _texture(rng: np.random.Generator) -> npt.NDArray[np.float32]:
    noise = rng.uniform(0.0, 255.0, (H, W)).astype(np.float32)
    return cv2.GaussianBlur(noise, (0, 0), 2.0) * 3.0 - 255.0


def _distorted(image: npt.NDArray[np.uint8]) -> npt.NDArray[np.uint8]:
    """The pinhole image as the lens D sees it: each distorted pixel samples the pinhole image
    at its undistorted position."""
    grid = np.mgrid[0:H, 0:W][::-1].reshape(2, -1).T.astype(np.float64)
    ideal = cv2.undistortPoints(grid.reshape(-1, 1, 2), K, D, P=K).reshape(H, W, 2)
    out = cv2.remap(
        image, ideal[..., 0].astype(np.float32), ideal[..., 1].astype(np.float32), cv2.INTER_LINEAR
    )
    return np.asarray(out, np.uint8)


@dataclass(frozen=True)
class Pair:
    """Two views' features (distorted images, lens D) and the true relative pose."""

    a: tp.Features
    b: tp.Features


@pytest.fixture(scope="module")
def pair() -> Pair:
    rng = np.random.default_rng(7)
    far, near = _texture(rng), _texture(rng)
    near_mask = np.zeros((H, W), np.float32)
    near_mask[:, : W // 2] = 1.0  # the near wall fills view a's left half
    Kinv = np.linalg.inv(K)
    image_a = np.where(near_mask > 0, near, far)
    image_b = np.zeros((H, W), np.float32)
    covered = np.zeros((H, W), np.float32)
    for (n, d), tex, mask in (
        (PLANES[1], near, near_mask),
        (PLANES[0], far, np.ones((H, W), np.float32)),
    ):
        Hba = K @ (R_BA + np.outer(T_BA, n) / d) @ Kinv  # plane-induced homography a -> b
        warped = cv2.warpPerspective(tex, Hba, (W, H), flags=cv2.INTER_LINEAR)
        seen = cv2.warpPerspective(mask, Hba, (W, H), flags=cv2.INTER_NEAREST) * (1.0 - covered)
        image_b += warped * seen
        covered += seen
    grey = [_distorted(np.clip(im, 0, 255).astype(np.uint8)) for im in (image_a, image_b)]
    return Pair(tp.features(grey[0], K, D), tp.features(grey[1], K, D))


def test_sampson_distance_matches_opencv_optimal_correction() -> None:
    rng = np.random.default_rng(1)
    X = np.c_[rng.uniform(-4, 4, (50, 2)), rng.uniform(8, 25, 50)]
    xa = X / X[:, 2:]
    Xb = X @ R_BA.T + T_BA
    xb = Xb / Xb[:, 2:]
    E = tp.essential(R_BA, T_BA)
    assert np.abs(tp.sampson_px(E, xa, xb, 700.0)).max() < 1e-9  # exact pairs lie on the lines
    pa = xa[:, :2] * 700.0 + 320.0
    pb = xb[:, :2] * 700.0 + 320.0 + rng.normal(0.0, 1.0, (50, 2))
    Kp = np.array([[700.0, 0.0, 320.0], [0.0, 700.0, 320.0], [0.0, 0.0, 1.0]])
    F = np.linalg.inv(Kp).T @ E @ np.linalg.inv(Kp)
    ca, cb = cv2.correctMatches(F, pa[None], pb[None])
    optimal = np.sqrt(((ca[0] - pa) ** 2).sum(1) + ((cb[0] - pb) ** 2).sum(1))
    rays_b = np.c_[(pb - 320.0) / 700.0, np.ones(50)]
    sampson = np.abs(tp.sampson_px(E, xa, rays_b, 700.0))
    assert optimal.mean() > 0.3  # the noise moved the pairs off their lines
    np.testing.assert_allclose(sampson, optimal, rtol=1e-3, atol=1e-4)


def test_relative_pose_composes_world_poses() -> None:
    Ra, ta = rotation_from_rvec([0.1, -0.2, 0.05]), np.array([1.0, 2.0, 3.0])
    Rb, tb = R_BA @ Ra, R_BA @ ta + T_BA
    R, t = tp.relative_pose(Ra, ta, Rb, tb)
    np.testing.assert_allclose(R, R_BA, atol=1e-12)
    np.testing.assert_allclose(t, T_BA, atol=1e-12)
    assert tp.rotation_angle_deg(R_BA) == pytest.approx(
        np.degrees(np.linalg.norm(np.radians([1, 6, 0.5])))
    )


def test_ransac_pose_of_textured_planes_is_within_a_tenth_degree(pair: Pair) -> None:
    ia, ib = tp.match(pair.a, pair.b)
    assert len(ia) > 300
    xa, xb = pair.a.rays[ia], pair.b.rays[ib]
    true_px = np.abs(tp.sampson_px(tp.essential(R_BA, T_BA), xa, xb, 700.0))
    assert np.median(true_px) < 0.05  # 0.024 px; 0.086 px with the lens left in the rays
    pose = tp.ransac_pose(xa, xb, 700.0)
    assert pose.inliers.mean() > 0.9
    assert tp.rotation_angle_deg(pose.R @ R_BA.T) < 0.02  # measured 0.005 deg
    assert np.degrees(np.arccos(pose.t @ T_BA / np.linalg.norm(T_BA))) < 0.1  # 0.02 deg


def test_guided_match_and_refinement_from_an_offset_prior(pair: Pair) -> None:
    R0 = rotation_from_rvec(np.radians([0.0, 0.3, 0.0])) @ R_BA  # a prior 0.3 deg off
    ga, gb = tp.match(pair.a, pair.b, tp.essential(R0, T_BA), band_px=8.0)
    free, _ = tp.match(pair.a, pair.b)
    assert len(ga) >= len(free)
    pose = tp.refined_pose(pair.a.rays[ga], pair.b.rays[gb], 700.0, R0, T_BA)
    err = tp.rotation_angle_deg(pose.R @ R_BA.T)
    assert err < 0.01  # measured 0.004 deg from 0.3 deg off
    assert 0.0 < pose.sigma_px < 0.1  # 0.04 px: the mismatches are cut out
    assert 0.3 < err / pose.rotation_sd_deg() < 5.0  # the sd is of the error's size (2.8)


def test_too_few_pairs_are_refused() -> None:
    rays = np.c_[np.zeros((5, 2)), np.ones(5)]
    with pytest.raises(VisionError, match="at least 8"):
        tp.ransac_pose(rays, rays, 700.0)
    with pytest.raises(VisionError, match="at least 8"):
        tp.refined_pose(rays, rays, 700.0, np.eye(3), np.array([1.0, 0.0, 0.0]))
    empty = tp.features(np.zeros((60, 80), np.uint8), K, D)
    assert empty.rays.shape == (0, 3)
    assert tp.match(empty, empty)[0].shape == (0,)
