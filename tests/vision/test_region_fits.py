"""Region plane fits of the evidence: metric figures only where the stereo gives depth, regions
that are no plane left out, inlier counts on the original image (not the rectified one)."""

from __future__ import annotations

import numpy as np
import pytest

from aida_kb.io.scene import StereoCalib
from aida_kb.vision.depth import depth_map
from aida_kb.vision.evidence import original_rays
from aida_kb.vision.rectify import remap, stereo_rectification
from aida_kb.vision.regions import ViewStereo, fit_region_planes, unseen_by_right
from aida_kb.vision.stereo import DisparityMap

W, H = 320, 240
HEIGHT_M = 1.5  # camera above the ground


def _rig() -> StereoCalib:
    """A rig toed in by 6 degrees: rectification turns the left image."""
    K = np.array([[300.0, 0.0, 159.5], [0.0, 300.0, 119.5], [0.0, 0.0, 1.0]])
    a = np.radians(6.0)
    R = np.array([[np.cos(a), 0.0, np.sin(a)], [0.0, 1.0, 0.0], [-np.sin(a), 0.0, np.cos(a)]])
    return StereoCalib(K, np.zeros(5), K.copy(), np.zeros(5), R, np.array([-0.5, 0, 0]), (W, H))


def test_ground_to_the_horizon_gets_a_metric_rms_and_a_random_region_is_left_out() -> None:
    calib = _rig()
    rect = stereo_rectification(calib)
    assert rect.rect_size != rect.size  # the rectified grid is not the original one
    cy, B = float(rect.P1[1, 2]), rect.baseline_m
    Wr, Hr = rect.rect_size
    vs = np.mgrid[0:Hr, 0:Wr][0].astype(np.float64)
    rng = np.random.default_rng(3)
    # the ground y = HEIGHT_M of the rectified frame, seen down to 0.3 px of disparity
    ground = B * (vs - cy) / HEIGHT_M
    disparity = np.where(ground > 0.3, ground + rng.normal(0.0, 0.1, (Hr, Wr)), np.nan)
    outlier = rng.random((Hr, Wr)) < 0.2
    disparity[outlier & (ground > 0.3)] += rng.uniform(
        5.0, 15.0, int((outlier & (ground > 0.3)).sum())
    )
    # the upper part: random disparities, no plane at all
    upper = vs < cy - 10
    disparity[upper] = rng.uniform(5.0, 50.0, int(upper.sum()))
    disp32 = disparity.astype(np.float32)
    certainty = np.where(np.isnan(disp32), 0.0, 0.8).astype(np.float32)
    dmap = DisparityMap(disp32, certainty, certainty, certainty)
    depth = depth_map(dmap, rect)
    # regions on the original image: 1 = ground (rectified rows below the horizon), 2 = above
    rect_ids = np.where(ground > 0.3, 1, np.where(upper, 2, 0)).astype(np.float32)
    regions = np.nan_to_num(remap(rect_ids, rect.inverse_left, nearest=True, border=0.0))
    regions = regions.astype(np.int32)
    stereo = ViewStereo(dmap, depth, rect, original_rays(calib), calib)
    out = fit_region_planes(regions, stereo, 11, None, True, None)
    assert [r.id for r in out] == [1]  # the random region is no plane: not in the evidence
    g = out[0]
    # distance of the centroid ~ a few metres; RMS a small fraction of it (was kilometres)
    assert g.rms_m < 0.05 * float(np.linalg.norm(g.c_init))
    assert g.rms_m < 0.5
    n = np.array(g.n_init)
    assert abs(float(n @ (rect.R1.T @ np.array([0.0, -1.0, 0.0])))) == pytest.approx(1.0, abs=2e-3)
    # inliers counted on the original image, among its depth pixels: the fit leaves out the
    # region's border band and the outliers the depth map kept, so fewer than all of them
    # (taking the smaller of the rectified and the original count gave all of them)
    assert 0.8 * g.depth_pixel_count < g.inlier_count < 0.97 * g.depth_pixel_count


def test_the_strip_the_right_camera_cannot_see_is_a_disparity_wide() -> None:
    """A wall 20 m before a rig of baseline 0.5 m and focal length 400 px: its points in the
    left image's leftmost f·B/Z = 10 px (and the matcher's margin) lie beyond the right image;
    a plane behind the camera has no such pixels."""
    K = np.array([[400.0, 0.0, 79.5], [0.0, 400.0, 59.5], [0.0, 0.0, 1.0]])
    calib = StereoCalib(
        K, np.zeros(5), K, np.zeros(5), np.eye(3), np.array([-0.5, 0.0, 0.0]), (160, 120)
    )
    rays = original_rays(calib)
    normals = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, 1.0]])
    unseen = unseen_by_right(rays, normals, np.array([-20.0, -5.0]), calib, 2.0)
    columns = np.flatnonzero(unseen[0][10:-10].any(axis=0))  # rows well inside the margin
    assert columns.tolist() == list(range(12))  # 10 px of disparity and 2 px of margin
    assert np.all(unseen[0][10:-10, 12:] == 0)
    assert np.all(unseen[0][:2])  # the matcher's margin at the top
    assert not unseen[1].any()
