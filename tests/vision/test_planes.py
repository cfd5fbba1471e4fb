"""Disparity-space plane fits: exact recovery, robustness, conversion to 3-D, pixel areas."""

from __future__ import annotations

import numpy as np
import pytest

from aida_kb.errors import VisionError
from aida_kb.vision.planes import (
    DisparityPlane,
    fit_disparity_plane,
    photometric_pair,
    pixel_areas_m2,
    plane_depth,
    refine_plane_photometric,
)

F, CX, CY, B = 500.0, 160.0, 120.0, 0.3


def _plane_disparity(n: np.ndarray, D: float, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Independent: ray-plane depth along each rectified pixel's ray, then d = f·B / z."""
    rays = np.stack([(u - CX) / F, (v - CY) / F, np.ones_like(u)], axis=-1)
    z = D / (rays @ n)
    return F * B / z


def test_exact_plane_and_its_normal() -> None:
    n_true = np.array([0.3, -0.2, -1.0])
    n_true /= np.linalg.norm(n_true)
    D_true = -12.0  # the camera is on the side the normal points to
    rng = np.random.default_rng(0)
    u, v = rng.uniform(0, 320, 2000), rng.uniform(0, 240, 2000)
    d = _plane_disparity(n_true, D_true, u, v)
    fit = fit_disparity_plane(u, v, d, np.ones_like(d))
    n, D = fit.plane(F, CX, CY, B)
    np.testing.assert_allclose(n, n_true, atol=1e-9)
    assert pytest.approx(D_true, rel=1e-9) == D
    assert fit.inliers.all()


def test_outliers_and_noise_are_rejected() -> None:
    rng = np.random.default_rng(1)
    u, v = rng.uniform(0, 320, 4000), rng.uniform(0, 240, 4000)
    d = 0.02 * u - 0.01 * v + 9.0 + rng.normal(0, 0.1, 4000)
    bad = rng.random(4000) < 0.25
    d[bad] += rng.uniform(-6, 6, bad.sum())
    cert = rng.uniform(0.2, 1.0, 4000)
    fit = fit_disparity_plane(u, v, d, cert)
    assert fit.a == pytest.approx(0.02, abs=5e-4)
    assert fit.b == pytest.approx(-0.01, abs=5e-4)
    assert fit.g == pytest.approx(9.0, abs=0.05)
    far = bad & (np.abs(d - (0.02 * u - 0.01 * v + 9.0)) > 1.5)
    assert not fit.inliers[far].any()
    assert fit.scale_px == pytest.approx(0.1, rel=0.25)


def test_too_few_samples_and_bad_values() -> None:
    one = np.ones(2)
    with pytest.raises(VisionError, match="fewer than 3"):
        fit_disparity_plane(one, one, one, one)
    with pytest.raises(VisionError, match="finite"):
        fit_disparity_plane(np.ones(5), np.ones(5), np.array([1, 2, np.nan, 3, 4.0]), np.ones(5))
    with pytest.raises(VisionError, match="differ in length"):
        fit_disparity_plane(np.ones(5), np.ones(4), np.ones(5), np.ones(5))


def test_pixel_areas_sum_to_the_area_of_a_tilted_square() -> None:
    # a 2 m x 2 m square on a plane tilted 40 degrees about the vertical axis, 8 m away
    fx = fy = 400.0
    ang = np.radians(40.0)
    n = np.array([np.sin(ang), 0.0, -np.cos(ang)])
    centre = np.array([0.0, 0.0, 8.0])
    D = float(n @ centre)
    e1 = np.array([np.cos(ang), 0.0, np.sin(ang)])  # in-plane axes
    e2 = np.array([0.0, 1.0, 0.0])
    # pixel grid: a pixel counts when its ray hits the square
    ys, xs = np.mgrid[-200:200, -200:200].astype(float)
    rays = np.stack([xs / fx, ys / fy, np.ones_like(xs)], axis=-1)
    hit = rays * plane_depth(rays, n, D)[..., None] - centre
    inside = (np.abs(hit @ e1) <= 1.0) & (np.abs(hit @ e2) <= 1.0)
    total = pixel_areas_m2(rays[inside], n, D, fx, fy).sum()
    assert total == pytest.approx(4.0, rel=0.01)


def _textured_plane_pair(a: float, b: float, g: float) -> tuple[np.ndarray, np.ndarray]:
    """A rectified pair of a textured plane with disparity d(u, v) = a·u + b·v + g (pixels):
    right(x, v) = left(x + d), d taken at the left pixel x + d (solved by fixed point)."""
    import cv2

    h, w = 120, 200
    rng = np.random.default_rng(3)
    tex = cv2.GaussianBlur(rng.normal(0.0, 1.0, (h, w + 40)).astype(np.float32), (0, 0), 1.3)
    tex = 128.0 + 40.0 * tex / tex.std()
    vs, xs = np.mgrid[0:h, 0:w].astype(np.float64)
    ul = xs.copy()
    for _ in range(30):  # u_l = x_r + d(u_l, v)
        ul = xs + a * ul + b * vs + g
    left = tex[:, :w]
    right = cv2.remap(tex, ul.astype(np.float32), vs.astype(np.float32), cv2.INTER_CUBIC)
    return left.astype(np.float32), np.asarray(right, np.float32)


def test_photometric_refinement_recovers_a_slanted_plane() -> None:
    a, b, g = 0.012, -0.006, 6.3
    left, right = _textured_plane_pair(a, b, g)
    pair = photometric_pair(left, right, 7)
    vs, us = np.mgrid[15:105, 30:185]
    # a start 0.4 px off at the corners, as a biased disparity fit would give
    start = DisparityPlane(
        a=a + 0.002,
        b=b - 0.002,
        g=g - 0.1,
        inliers=np.ones(1, bool),
        weights=np.ones(1),
        scale_px=0.1,
    )
    ref = refine_plane_photometric(pair, us.ravel(), vs.ravel(), start)
    assert ref is not None
    assert ref.a == pytest.approx(a, abs=2e-4)
    assert ref.b == pytest.approx(b, abs=2e-4)
    assert ref.a * 100 + ref.b * 60 + ref.g == pytest.approx(a * 100 + b * 60 + g, abs=0.02)
    assert ref.inliers.mean() > 0.95


def test_photometric_refinement_gives_up_without_texture() -> None:
    flat = np.full((80, 120), 90.0, np.float32)
    pair = photometric_pair(flat, flat, 7)
    vs, us = np.mgrid[10:70, 20:100]
    start = DisparityPlane(
        a=0.0, b=0.0, g=4.0, inliers=np.ones(1, bool), weights=np.ones(1), scale_px=0.1
    )
    assert refine_plane_photometric(pair, us.ravel(), vs.ravel(), start) is None
    with pytest.raises(VisionError, match="odd"):
        photometric_pair(flat, flat, 6)
