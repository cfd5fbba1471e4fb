"""A tilted part facing the camera that no region shows reaches back to the far edge the
image shows of it (`outline.far_edge`): a dark roof's ridge against the sky, seen square to
the eaves. Without it both slopes of a gable started on the eave and its solid did not close
(dev seeds 61318, 61320)."""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from aida_kb.interpret.hypotheses import Frame, PlanarPart, predicted_normal, support_offset
from aida_kb.interpret.observe import CameraView
from aida_kb.interpret.outline import far_edge

K = np.array([[800.0, 0.0, 400.0], [0.0, 800.0, 300.0], [0.0, 0.0, 1.0]])
CAMERA = CameraView("00", K, np.eye(3), np.zeros(3), 800, 600)
# OpenCV axes (y down): a front wall at z = 20 facing the camera, 8 m wide (x = -4 .. 4),
# from the ground at y = 2 up to the eaves at y = -3; the gable's ridge runs 4 m behind it
UP = np.array([0.0, -1.0, 0.0])
FRAME = Frame.from_front(np.array([0.0, 0.0, -1.0]), UP)
FRONT, HALF, EAVE, GROUND = 20.0, 4.0, -3.0, 2.0
ROOF_FRONT = PlanarPart("body.roof.front", "front", "RoofPlane", (0.0, 75.0), True, "forward")


def _project(points: Any) -> Any:
    p = (K @ np.asarray(points, dtype=np.float64).T).T
    return p[:, :2] / p[:, 2:]


def _wall_points() -> Any:
    """The front wall's seen points: its corners and points along its top."""
    xs = np.linspace(-HALF, HALF, 9)
    top = np.stack([xs, np.full(9, EAVE), np.full(9, FRONT)], axis=1)
    feet = np.array([[-HALF, GROUND, FRONT], [HALF, GROUND, FRONT]])
    return np.concatenate([top, feet])


def _ridge(pitch_deg: float, length: float = 2 * HALF) -> Any:
    """The ridge of a gable of `pitch_deg` over a body 8 m deep, `length` long, centred."""
    y = EAVE - 4.0 * math.tan(math.radians(pitch_deg))
    return np.array([[-length / 2, y, FRONT + 4.0], [length / 2, y, FRONT + 4.0]])


def _ctx(lines_m: list[Any]) -> Any:
    lines = np.stack([_project(line) for line in lines_m]) if lines_m else np.zeros((0, 2, 2))
    return SimpleNamespace(evidence=SimpleNamespace(camera=CAMERA, lines_px={"00": lines}))


# a window's top on the wall, a roof tile's line: neither is the ridge (on the wall, short)
CLUTTER = [
    np.array([[-2.0, -1.0, FRONT], [2.0, -1.0, FRONT]]),
    np.array([[-1.0, -3.8, 21.0], [0.5, -3.8, 21.0]]),
]


def _plane(pitch_deg: float) -> tuple[Any, float]:
    """The front slope's plane tilted by `pitch_deg`, through the eave (the wall's top)."""
    normal = predicted_normal(ROOF_FRONT, FRAME, pitch_deg)
    return normal, support_offset(normal, _wall_points())


def _behind(ends: Any) -> Any:
    return ends[:, 2] - FRONT


@pytest.mark.parametrize("pitch", [25.0, 40.0, 50.0])
def test_a_gable_ridge_at_the_slope_the_plane_starts_at_is_found_where_it_is(
    pitch: float,
) -> None:
    ctx = _ctx([*CLUTTER, _ridge(pitch)])
    ends = far_edge(ctx, ROOF_FRONT, FRAME, _plane(pitch), _wall_points())
    assert ends is not None
    assert len(ends) == 2  # the ridge's two ends, nothing of the clutter
    # 4 m behind the front, at the ridge's height, as wide as the wall
    assert np.allclose(_behind(ends), 4.0, atol=0.05)
    assert np.allclose(ends[:, 1], _ridge(pitch)[0, 1], atol=0.05)
    assert np.ptp(ends[:, 0]) == pytest.approx(2 * HALF, rel=0.01)


def test_on_a_plane_started_shallower_the_ridge_lies_on_its_rays_farther_back() -> None:
    ctx = _ctx([*CLUTTER, _ridge(40.0)])
    ends = far_edge(ctx, ROOF_FRONT, FRAME, _plane(30.0), _wall_points())
    assert ends is not None
    # where the ridge's rays meet the 30-degree plane through the eave: the image is the same
    assert np.allclose(_project(ends), _project(_ridge(40.0)), atol=1e-6)
    rise = EAVE - ends[:, 1]
    assert np.allclose(rise / _behind(ends), math.tan(math.radians(30.0)), atol=1e-6)
    assert np.all(_behind(ends) > 4.0)


def test_no_long_line_behind_the_wall_across_it_is_no_far_edge() -> None:
    wall = _wall_points()
    assert far_edge(_ctx(CLUTTER), ROOF_FRONT, FRAME, _plane(30.0), wall) is None
    assert far_edge(_ctx([]), ROOF_FRONT, FRAME, _plane(30.0), wall) is None
    # a line shorter than half the wall is a chimney's top or a dormer's, not the ridge
    assert far_edge(_ctx([_ridge(40.0, length=3.0)]), ROOF_FRONT, FRAME, _plane(30.0), wall) is None
    # a row of short texture lines as far behind, together half the wall's width, neither
    row = [np.array([[x, -5.0, 24.0], [x + 1.0, -5.0, 24.0]]) for x in (-3.5, -1.5, 0.5, 2.5)]
    assert far_edge(_ctx(row), ROOF_FRONT, FRAME, _plane(30.0), wall) is None
    # a level part (a flat roof's top) has no far edge to reach back to
    top = PlanarPart("body.roof.top", "top", "RoofPlane", None, False, "upward")
    assert far_edge(_ctx([_ridge(40.0)]), top, FRAME, _plane(30.0), wall) is None
