"""Evidence of a scene whose views have their own rigs (sizes, focal lengths, baselines) and
a known pose: each view is processed with its own calibration and placed in the world."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from aida_kb.io.scene import StereoCalib, ViewData, read_scene, write_scene
from aida_kb.vision.evidence import VisionParams, scene_evidence


def _rig(f: float, baseline: float, size: tuple[int, int]) -> StereoCalib:
    w, h = size
    K = np.array([[f, 0.0, (w - 1) / 2], [0.0, f, (h - 1) / 2], [0.0, 0.0, 1.0]])
    return StereoCalib(
        K, np.zeros(5), K.copy(), np.zeros(5), np.eye(3), np.array([-baseline, 0, 0]), size
    )


def _pair(rng: np.random.Generator, w: int, h: int, shift: int) -> tuple[np.ndarray, np.ndarray]:
    base = cv2.GaussianBlur(rng.integers(0, 255, (h, w + shift), dtype=np.uint8), (3, 3), 0)
    left, right = base[:, shift:], base[:, :w]
    return np.dstack([left] * 3).copy(), np.dstack([right] * 3).copy()


def test_each_view_uses_its_own_rig_and_pose(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    pose = (np.eye(3), np.array([0.5, 0.0, 0.0]))
    views = [
        ViewData(*_pair(rng, 96, 72, 6), calib=_rig(100.0, 0.3, (96, 72))),
        ViewData(*_pair(rng, 120, 90, 8), calib=_rig(150.0, 0.5, (120, 90)), pose=pose),
    ]
    scene = read_scene(write_scene(tmp_path / "s", None, views))
    evidence, _ = scene_evidence(scene, params=VisionParams(num_disp=16))
    a, b = evidence.views
    assert (a.image_width, a.image_height, a.left.K[0][0]) == (96, 72, 100.0)
    assert (b.image_width, b.image_height, b.left.K[0][0]) == (120, 90, 150.0)
    assert b.frame == "world"  # the scene's pose places it; nothing to register
    np.testing.assert_allclose(b.left.t, [0.5, 0.0, 0.0])
