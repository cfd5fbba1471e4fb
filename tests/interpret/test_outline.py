"""A tilted part no region shows starts at the slope its walls' outlines give (`outline`):
a shed's side wall is a trapezoid whose top runs along the roof, a gable wall rises to the
ridge along each rake; the eaves wall tells nothing."""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from aida_kb.interpret.alternative import level_violation
from aida_kb.interpret.hypotheses import Frame, PlanarPart
from aida_kb.interpret.observe import CameraView, RegionView
from aida_kb.interpret.outline import outline_pitch

K = np.array([[800.0, 0.0, 400.0], [0.0, 800.0, 300.0], [0.0, 0.0, 1.0]])
CAMERA = CameraView("00", K, np.eye(3), np.zeros(3), 800, 600)
# OpenCV axes (y down): the house lies left of the camera and ahead of it, its front wall at
# z = 20 facing the camera, its right wall at x = -4 facing right (+x), seen at a slant;
# walls from y = 2 (the ground) up to the eaves at y = -3, 8 m deep
UP = np.array([0.0, -1.0, 0.0])
FRAME = Frame.from_front(np.array([0.0, 0.0, -1.0]), UP)
FRONT, BACK, X = 20.0, 28.0, -4.0


def _project(points: Any) -> Any:
    p = (K @ np.asarray(points, dtype=np.float64).T).T
    return p[:, :2] / p[:, 2:]


def _wall(outline_m: Any, normal: Any, rid: str = "00/1") -> RegionView:
    outline = np.asarray(outline_m, dtype=np.float64)
    return RegionView(
        rid, "00", np.asarray(normal, dtype=np.float64), outline.mean(axis=0), 1.0, 1e4, 0.01
    )


def _ctx(regions: list[tuple[RegionView, Any]]) -> Any:
    evidence = SimpleNamespace(
        cameras={"00": CAMERA},
        regions={r.id: r for r, _ in regions},
        outlines={r.id: (_project(o),) for r, o in regions},
        segments_of=lambda rid: (),
    )
    return SimpleNamespace(evidence=evidence)


def _part(role: str, direction: str) -> PlanarPart:
    return PlanarPart(role, role.rsplit(".", 1)[-1], "RoofPlane", (0.0, 75.0), True, direction)


def _structure(*pairs: tuple[str, str]) -> Any:
    return SimpleNamespace(adjacency=pairs)


def _side(top: Any) -> Any:
    """The right wall's outline: the ground at the front, its top ((y, z) each), the back."""
    return [[X, 2.0, FRONT], *([X, y, z] for y, z in top), [X, 2.0, BACK]]


@pytest.mark.parametrize("pitch", [10.4, 13.8, 30.0])
def test_a_shed_side_wall_gives_its_roof_slope(pitch: float) -> None:
    rise = (BACK - FRONT) * math.tan(math.radians(pitch))
    outline = _side([(-3.0, FRONT), (-3.0 - rise, BACK)])
    ctx = _ctx([(_wall(outline, [1.0, 0.0, 0.0]), outline)])
    top = _part("body.roof.top", "forward")  # tilted towards the front: rising to the back
    found = outline_pitch(
        ctx, _structure(("body.right", "body.roof.top")), top, FRAME, {"00/1": "body.right"}
    )
    assert found is not None
    assert abs(found - pitch) <= 0.5


def test_a_gable_wall_gives_both_slopes() -> None:
    pitch = 35.0
    ridge = -3.0 - (BACK - FRONT) / 2 * math.tan(math.radians(pitch))
    outline = _side([(-3.0, FRONT), (ridge, (FRONT + BACK) / 2), (-3.0, BACK)])
    ctx = _ctx([(_wall(outline, [1.0, 0.0, 0.0]), outline)])
    binding = {"00/1": "body.right"}
    for role, direction in (("body.roof.front", "forward"), ("body.roof.back", "backward")):
        found = outline_pitch(
            ctx, _structure(("body.right", role)), _part(role, direction), FRAME, binding
        )
        assert found is not None
        assert abs(found - pitch) <= 0.5


def test_the_eaves_wall_or_an_unrelated_wall_tells_nothing() -> None:
    # the front wall (its normal along the lean) touches every slope's plane along its top
    front = [[X - 8, 2.0, FRONT], [X - 8, -3.0, FRONT], [X, -3.0, FRONT], [X, 2.0, FRONT]]
    ctx = _ctx([(_wall(front, [0.0, 0.0, -1.0]), front)])
    top = _part("body.roof.top", "forward")
    adjacency = _structure(("body.front", "body.roof.top"))
    assert outline_pitch(ctx, adjacency, top, FRAME, {"00/1": "body.front"}) is None
    # a side wall the knowledge does not let the part meet (a hip's slope and the gable end)
    outline = _side([(-3.0, FRONT), (-5.0, BACK)])
    ctx = _ctx([(_wall(outline, [1.0, 0.0, 0.0]), outline)])
    assert outline_pitch(ctx, _structure(), top, FRAME, {"00/1": "body.right"}) is None


def test_a_level_top_edge_gives_no_slope() -> None:
    # a tilted part started level would be the level part's twin: the default start stays
    outline = _side([(-3.0, FRONT), (-3.0, BACK)])
    ctx = _ctx([(_wall(outline, [1.0, 0.0, 0.0]), outline)])
    top = _part("body.roof.top", "forward")
    adjacency = _structure(("body.right", "body.roof.top"))
    assert outline_pitch(ctx, adjacency, top, FRAME, {"00/1": "body.right"}) is None


def test_a_part_the_knowledge_orients_level_may_not_lie_on_a_sloping_region() -> None:
    top = PlanarPart("body.roof.top", "top", "RoofPlane", (0.0, 75.0), False, "upward")
    shed_top = _part("body.roof.top", "forward")
    up = np.array([0.0, -1.0, 0.0])
    tilt = math.radians(10.6)
    sloping = np.array([0.0, -math.cos(tilt), -math.sin(tilt)])
    planes = {"body.roof.top": (sloping, 3.0)}
    binding = {"00/3": "body.roof.top"}
    why = level_violation(SimpleNamespace(leaves=(top,)), binding, planes, up)
    assert "slopes 10.6 deg" in why
    assert "upward" in why
    # a tilted part may slope; a level part inserted (no region) is the adjustment's to keep
    assert level_violation(SimpleNamespace(leaves=(shed_top,)), binding, planes, up) == ""
    assert level_violation(SimpleNamespace(leaves=(top,)), {}, planes, up) == ""
    # within the verdict's tolerance: level
    tilt = math.radians(3.0)
    planes = {"body.roof.top": (np.array([0.0, -math.cos(tilt), -math.sin(tilt)]), 3.0)}
    assert level_violation(SimpleNamespace(leaves=(top,)), binding, planes, up) == ""
