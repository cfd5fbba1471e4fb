"""Parts no view shows in a scene up to scale: the least extent the seen parts admit."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from aida_kb.interpret.knowledge import Knowledge
from aida_kb.interpret.unseen import largest_unit_m, least_extents
from aida_kb.kb.model import KnowledgeBase

# camera at the origin looking along +z; a front wall 20 units ahead facing it, seen 12
# units wide and 6 tall (a grid of its points)
UP, RIGHT, FRONT = np.array([0.0, -1.0, 0.0]), np.array([1.0, 0.0, 0.0]), np.array([0, 0, -1.0])
_xs, _ys = np.meshgrid(np.linspace(-6.0, 6.0, 13), np.linspace(0.0, -6.0, 7))
WALL = np.column_stack([_xs.ravel(), _ys.ravel(), np.full(_xs.size, 20.0)])


def _setting(kb: KnowledgeBase) -> tuple[Any, Any, Any]:
    """A context, a house body's structure (the body and its seen front) and its frame."""
    ctx = SimpleNamespace(
        evidence=SimpleNamespace(
            points_on=lambda rid: WALL, camera=SimpleNamespace(centre_m=np.zeros(3))
        ),
        knowledge=Knowledge.from_kb(kb),
    )
    structure = SimpleNamespace(
        nodes=(
            SimpleNamespace(role="body", concept="HouseBody"),
            SimpleNamespace(role="body.front", concept="Wall"),
        )
    )
    return ctx, structure, SimpleNamespace(up=UP, right=RIGHT, front=FRONT)


def test_a_unit_is_at_most_the_least_high_bound_over_the_seen_extent(
    buildings_kb: KnowledgeBase,
) -> None:
    """width <= 100 m over 12 units seen: a unit <= 8.33 m; a wall's height <= 30 m over 6
    units: <= 5 m; the depth seen is 0 units (one wall) and bounds nothing."""
    ctx, structure, frame = _setting(buildings_kb)
    unit = largest_unit_m(ctx, structure, frame, {"00/1": "body.front"})
    assert unit == pytest.approx(5.0)
    assert largest_unit_m(ctx, structure, frame, {}) == float("inf")  # nothing seen


def test_the_unseen_back_keeps_the_least_depth_in_units(buildings_kb: KnowledgeBase) -> None:
    """The back lies on the front's points (depth 0); the body is at least 2 m deep: 2 units
    in metres, 0.4 units when a unit may be 5 m."""
    ctx, structure, frame = _setting(buildings_kb)
    planes = {"body.front": (FRONT, -20.0), "body.back": (-FRONT, 20.0)}
    centre = WALL.mean(axis=0)
    for unit_m, depth in ((1.0, 2.0), (5.0, 0.4)):
        moved = least_extents(ctx, structure, frame, planes, {"body.back"}, centre, unit_m)
        n, d = moved["body.back"]
        assert np.allclose(n, -FRONT)
        assert d - 20.0 == pytest.approx(depth)
    assert least_extents(ctx, structure, frame, planes, set(), centre) == {}  # seen: kept
