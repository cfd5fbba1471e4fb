"""The vertical from the vanishing point of line segments: a camera pitched up at a facade."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aida_kb.interpret.observe import CameraView, RegionView, estimate_up, slope_deg
from aida_kb.vision.vanishing import vertical_direction

K = np.array([[700.0, 0.0, 383.5], [0.0, 700.0, 255.5], [0.0, 0.0, 1.0]])
W, H = 768, 512


def _pitched(pitch_deg: float, yaw_deg: float) -> np.ndarray:
    """R_cam_world of a camera pitched up by pitch_deg, turned by yaw_deg (world: x right,
    y down, z forward; up = -y)."""
    p, y = math.radians(pitch_deg), math.radians(yaw_deg)
    Rx = np.array([[1, 0, 0], [0, math.cos(p), math.sin(p)], [0, -math.sin(p), math.cos(p)]])
    Ry = np.array([[math.cos(y), 0, -math.sin(y)], [0, 1, 0], [math.sin(y), 0, math.cos(y)]])
    return Rx @ Ry


def _facade_segments(R: np.ndarray, rng: np.random.Generator, noise_px: float) -> np.ndarray:
    """Image segments (N, 2, 2) of a facade 12 m ahead: vertical jambs and corners, horizontal
    sills and eaves, and clutter (random directions), end points with Gaussian noise."""
    lines = []
    for x in np.linspace(-6, 6, 70):  # verticals of 0.8-4 m
        y0 = rng.uniform(-8, 0)
        lines.append(((x, y0, 12.0), (x, y0 - rng.uniform(0.8, 4.0), 12.0)))
    for y in np.linspace(-9, 1, 12):  # horizontals
        x0 = rng.uniform(-6, 2)
        lines.append(((x0, y, 12.0), (x0 + rng.uniform(1, 4), y, 12.0)))
    for _ in range(30):  # clutter
        a = rng.uniform(-6, 6, 3) * [1, 1, 0] + [0, -4, 12.0]
        d = rng.normal(size=3)
        lines.append((tuple(a), tuple(a + 1.5 * d / np.linalg.norm(d))))
    pts = np.array(lines, float).reshape(-1, 3) @ R.T
    pix = pts @ K.T
    pix = pix[:, :2] / pix[:, 2:]
    seg = pix.reshape(-1, 2, 2) + rng.normal(0, noise_px, (len(lines), 2, 2))
    inside = np.all(
        (seg[..., 0] > 0) & (seg[..., 0] < W) & (seg[..., 1] > 0) & (seg[..., 1] < H), axis=1
    )
    return seg[inside]


@pytest.mark.parametrize(("pitch", "yaw", "seed"), [(15.0, 10.0, 1), (18.0, -25.0, 2)])
def test_vertical_of_a_pitched_camera(pitch: float, yaw: float, seed: int) -> None:
    R = _pitched(pitch, yaw)
    up_cam = R @ np.array([0.0, -1.0, 0.0])
    seg = _facade_segments(R, np.random.default_rng(seed), noise_px=0.3)
    vp = vertical_direction(seg, K)
    assert vp is not None
    err = math.degrees(math.acos(min(1.0, float(vp.direction @ up_cam))))
    assert err < 0.5
    assert err < 3.0 * vp.sigma_deg  # the uncertainty is not overconfident
    assert vp.sigma_deg < 0.4
    assert 30 <= vp.support <= 70  # the verticals in view, not the clutter


def test_too_few_lines_give_none() -> None:
    R = _pitched(15.0, 0.0)
    seg = _facade_segments(R, np.random.default_rng(4), noise_px=0.3)[::12]
    assert vertical_direction(seg, K) is None


def test_estimate_up_with_one_wall_and_a_pitched_camera() -> None:
    """One wall in view: the regions cannot give the vertical, the camera's -y is 15 degrees
    off and the wall reads as 75 degrees; the segments put it back to 90. Too few of them
    (below VP_MIN_SUPPORT) are not trusted."""
    R = _pitched(15.0, 10.0)
    camera = CameraView("00", K, R, np.zeros(3), W, H)
    wall = RegionView(
        "00/1", "00", np.array([0.0, 0.0, -1.0]), np.array([0, -4, 12.0]), 1e4, 1e5, 0.02
    )
    up_true = np.array([0.0, -1.0, 0.0])
    without = estimate_up([wall], camera)
    assert slope_deg(wall.normal, without) == pytest.approx(75.0, abs=0.5)
    seg = _facade_segments(R, np.random.default_rng(5), noise_px=0.3)
    up = estimate_up([wall], camera, segments_px=seg)
    assert math.degrees(math.acos(min(1.0, float(up @ up_true)))) < 0.2
    assert slope_deg(wall.normal, up) == pytest.approx(90.0, abs=0.2)
    few = estimate_up([wall], camera, segments_px=seg[:20])
    np.testing.assert_allclose(few, without)
