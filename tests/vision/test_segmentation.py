"""Local planes, normals and planar-region segmentation in disparity space."""

from __future__ import annotations

import numpy as np

from aida_kb.vision.segmentation import local_planes, plane_normals, segment_planes


def _two_planes() -> tuple[np.ndarray, np.ndarray]:
    h, w = 120, 160
    vs, us = np.mgrid[0:h, 0:w].astype(np.float64)
    left = 0.05 * us + 0.01 * vs + 4.0
    right = -0.04 * us + 0.0 * vs + 16.0
    truth = np.where(us < 80, 1, 2)
    d = np.where(truth == 1, left, right)
    rng = np.random.default_rng(0)
    d = d + rng.normal(0.0, 0.08, d.shape)
    d[rng.random(d.shape) < 0.05] = np.nan  # dropouts
    return d.astype(np.float32), truth


def test_local_planes_recover_slopes() -> None:
    d, _truth = _two_planes()
    cert = np.ones_like(d)
    planes = local_planes(d, cert, window=15)
    inner = planes[20:-20, 15:60]
    assert np.nanmedian(np.abs(inner[..., 0] - 0.05)) < 0.003
    assert np.nanmedian(np.abs(inner[..., 1] - 0.01)) < 0.003
    normals = plane_normals(planes, 300.0, 80.0, 60.0)
    ok = np.isfinite(normals[..., 0])
    np.testing.assert_allclose(np.linalg.norm(normals[ok], axis=-1), 1.0, atol=1e-5)
    assert np.all(normals[ok][:, 2] < 0)  # facing the camera


def test_segment_planes_finds_both_planes() -> None:
    d, truth = _two_planes()
    cert = np.where(np.isnan(d), 0.0, 0.9).astype(np.float32)
    regions = segment_planes(d, cert, local_planes(d, cert, window=15), min_pixels=300)
    ids = [r for r in np.unique(regions) if r != 0]
    assert len(ids) == 2
    for rid in ids:
        mask = regions == rid
        label = np.bincount(truth[mask]).argmax()
        tmask = truth == label
        iou = (mask & tmask).sum() / (mask | tmask).sum()
        assert iou > 0.9


def test_no_depth_no_regions() -> None:
    d = np.full((50, 60), np.nan, np.float32)
    cert = np.zeros_like(d)
    assert not segment_planes(d, cert, local_planes(d, cert)).any()
