"""A tilted part no region shows starts at the slope its walls' outlines give (`outline`):
a shed's side wall is a trapezoid whose top runs along the roof, a gable wall rises to the
ridge along each rake; the eaves wall tells nothing."""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from aida_kb.interpret.alternative import (
    OUTLINE_CONTRADICTED_DEG,
    level_violation,
    outline_contradiction,
)
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
        camera=CAMERA,
    )
    return SimpleNamespace(evidence=evidence)


def _part(role: str, direction: str) -> PlanarPart:
    return PlanarPart(role, role.rsplit(".", 1)[-1], "RoofPlane", (0.0, 75.0), True, direction)


def _structure(*pairs: tuple[str, str]) -> Any:
    return SimpleNamespace(adjacency=pairs)


def _side(top: Any, x: float = X) -> Any:
    """The right wall's outline: the ground at the front, its top ((y, z) each), the back."""
    return [[x, 2.0, FRONT], *([x, y, z] for y, z in top), [x, 2.0, BACK]]


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


def _gable_end(front_pitch: float, back_pitch: float, x: float = X) -> Any:
    """The right wall's outline under a gable of these slopes (degrees), eaves level, the
    wall at ``x`` (m)."""
    run_front, run_back = (1 / math.tan(math.radians(p)) for p in (front_pitch, back_pitch))
    rise = (BACK - FRONT) / (run_front + run_back)
    ridge_z = FRONT + rise * run_front
    return _side([(-3.0, FRONT), (-3.0 - rise, ridge_z), (-3.0, BACK)], x)


def _incidence_deg(outline: Any) -> float:
    """The angle between the line of sight to the right wall's outline and its normal."""
    centre = np.asarray(outline, dtype=np.float64).mean(axis=0)
    return math.degrees(math.acos(abs(centre[0]) / float(np.linalg.norm(centre))))


def test_a_wall_seen_edge_on_measures_no_slope_when_asked() -> None:
    outline = _gable_end(35.0, 35.0)
    ctx = _ctx([(_wall(outline, [1.0, 0.0, 0.0]), outline)])
    back = _part("body.roof.back", "backward")
    adjacency = _structure(("body.right", "body.roof.back"))
    binding = {"00/1": "body.right"}
    seen = _incidence_deg(outline)  # about 80 deg: the wall 4 m aside, 24 m ahead
    found = outline_pitch(ctx, adjacency, back, FRAME, binding, max_incidence_deg=seen + 1.0)
    assert found is not None
    assert abs(found - 35.0) <= 0.5
    assert outline_pitch(ctx, adjacency, back, FRAME, binding, max_incidence_deg=seen - 1.0) is None


def test_a_slope_placed_by_a_relation_against_its_walls_outline_is_rejected() -> None:
    # a gable end wall rising at 30 deg to the front and 50 deg to the back, seen at a slant
    # (8 m aside, 24 m ahead: 72 deg from square on)
    outline = _gable_end(30.0, 50.0, x=-8.0)
    ctx = _ctx([(_wall(outline, [1.0, 0.0, 0.0]), outline)])
    back = _part("body.roof.back", "backward")
    structure = SimpleNamespace(leaves=(back,), adjacency=(("body.right", "body.roof.back"),))
    binding = {"00/1": "body.right"}
    placed = frozenset({"body.roof.back"})
    inserted = ("body.roof.back",)

    def planes(pitch: float) -> Any:
        t = math.radians(pitch)  # backward: its normal leans to +z (away from the camera)
        return {"body.roof.back": (np.array([0.0, -math.cos(t), math.sin(t)]), 0.0)}

    face = {"body.right": np.asarray(outline, dtype=np.float64)}  # the wall's face: its region

    def why(pitch: float, **change: Any) -> str:
        args: dict[str, Any] = {"polygons": face, "inserted": inserted, "placed": placed}
        args.update(change)
        return outline_contradiction(ctx, structure, FRAME, binding, planes(pitch), **args)

    # the symmetry put it at the front's 30 deg: the outline shows 50
    said = why(30.0)
    assert "body.roof.back" in said
    assert "30.0 deg" in said
    assert f"at most {OUTLINE_CONTRADICTED_DEG:g} deg apart" in said
    # near the outline's slope, a part no relation places, or a part a region shows: nothing
    assert why(50.0 - OUTLINE_CONTRADICTED_DEG / 2) == ""
    assert why(30.0, placed=frozenset()) == ""
    assert why(30.0, inserted=()) == ""
    # a region mostly outside its wall's face (merged with another wall in its plane) is not
    # that face's outline: it measures nothing
    corner = np.asarray(outline, dtype=np.float64)[:3]  # the front's ground, eave and ridge
    assert why(30.0, polygons={"body.right": corner}) == ""


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
