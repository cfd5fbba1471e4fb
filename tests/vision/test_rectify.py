"""Undistortion of evidence pixels for the pinhole camera model (aida_kb.vision.rectify)."""

from __future__ import annotations

import cv2
import numpy as np

from aida_kb.vision.rectify import undistort_pixels


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
