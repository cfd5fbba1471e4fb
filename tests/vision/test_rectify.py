"""Rectification that keeps the left image, refusal of forward motion, and undistortion of
evidence pixels for the pinhole camera model (aida_kb.vision.rectify)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from aida_kb.errors import VisionError
from aida_kb.io.scene import StereoCalib
from aida_kb.vision.rectify import stereo_rectification, undistort_pixels


def test_evidence_pixels_are_undistorted_for_the_pinhole_camera() -> None:
    K = np.array([[800.0, 0.0, 319.5], [0.0, 800.0, 239.5], [0.0, 0.0, 1.0]])
    D = np.array([-0.1, 0.0, 0.0, 0.0, 0.0])
    ideal = np.array([[100.0, 50.0], [600.0, 400.0], [320.0, 240.0]])
    rays = np.column_stack([(ideal - K[:2, 2]) / 800.0, np.ones(3)])
    distorted, _ = cv2.projectPoints(rays, np.zeros(3), np.zeros(3), K, D)
    distorted = distorted.reshape(-1, 2)
    assert np.abs(distorted - ideal).max() > 4.0  # the lens moves the corners visibly
    np.testing.assert_allclose(undistort_pixels(distorted, K, D), ideal, atol=0.05)
    np.testing.assert_array_equal(undistort_pixels(ideal, K, np.zeros(5)), ideal)


def _toed_in(forward_deg: float, toe_deg: float = 5.0) -> StereoCalib:
    """A 768x512 rig, the right camera turned in by toe_deg, its centre forward_deg in front
    of the left camera's image plane (baseline 2.7 m)."""
    K = np.array([[690.0, 0.0, 383.5], [0.0, 690.0, 255.5], [0.0, 0.0, 1.0]])
    a = np.radians(toe_deg)
    R = np.array([[np.cos(a), 0.0, np.sin(a)], [0.0, 1.0, 0.0], [-np.sin(a), 0.0, np.cos(a)]])
    f = np.radians(forward_deg)
    C_right = 2.7 * np.array([np.cos(f), 0.0, np.sin(f)])  # in the left camera frame
    return StereoCalib(K, np.zeros(5), K.copy(), np.zeros(5), R, -R @ C_right, (768, 512))


def test_rectification_keeps_the_whole_left_image_at_its_resolution() -> None:
    calib = _toed_in(forward_deg=-15.0)
    rect = stereo_rectification(calib)
    assert rect.zoom == pytest.approx(1.0)
    assert rect.kept_fraction == pytest.approx(1.0)
    assert 1.0 < rect.size_factor < 2.0
    # every original left pixel maps inside the rectified image, and back onto itself
    W, H = rect.rect_size
    inv_x, inv_y = rect.inverse_left
    assert inv_x.min() >= -0.5
    assert inv_x.max() <= W - 0.5
    assert inv_y.min() >= -0.5
    assert inv_y.max() <= H - 0.5
    xs = cv2.remap(rect.map_left[0], inv_x, inv_y, cv2.INTER_LINEAR)
    ref = np.mgrid[0:512, 0:768][1].astype(np.float32)
    assert np.abs(xs - ref)[5:-5, 5:-5].max() < 0.05
    # cv2's own alpha = 0 would have cropped a good part of it
    _, _, P1, *_ = cv2.stereoRectify(
        calib.K1,
        calib.D1,
        calib.K2,
        calib.D2,
        (768, 512),
        calib.R,
        calib.T.reshape(3, 1),
        alpha=0.0,
    )
    assert P1[0, 0] > 1.1 * 690.0
    assert "100 % of the left image kept" in rect.summary()


def test_forward_motion_is_refused_with_the_reason() -> None:
    with pytest.raises(VisionError, match=r"cannot be rectified sanely.*forward motion"):
        stereo_rectification(_toed_in(forward_deg=-40.0))
