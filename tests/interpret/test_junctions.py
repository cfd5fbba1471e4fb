"""Where a smaller part runs into its whole, the border of their regions is no edge of its own
(`adjust._junction`), and a wing's hidden end reaches its whole's ridge where the wing's own
ridge is (`unseen.reach_front`)."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np

from aida_kb.interpret.adjust import _junction
from aida_kb.interpret.observe import CameraView, RegionView, SegmentView
from aida_kb.interpret.unseen import reach_front

K = np.array([[500.0, 0.0, 320.0], [0.0, 500.0, 240.0], [0.0, 0.0, 1.0]])
CAMERA = CameraView("00", K, np.eye(3), np.zeros(3), 640, 480)


def _region(rid: str, normal: Any, point: Any) -> RegionView:
    n = np.asarray(normal, dtype=np.float64)
    return RegionView(rid, "00", n / np.linalg.norm(n), np.asarray(point, float), 1.0, 100.0, 0.01)


# a wall 10 m ahead facing the camera (OpenCV axes: y down, z ahead), its region 00/1; the
# segment runs down the image's middle column (x = 0 at every depth)
WALL = _region("00/1", [0.0, 0.0, -1.0], [0.0, 0.0, 10.0])
SEGMENT = SegmentView("00/l1", "00", np.array([[320.0, 200.0], [320.0, 280.0]]), ("00/1", "00/2"))


def _ctx(*regions: RegionView) -> Any:
    return SimpleNamespace(
        evidence=SimpleNamespace(cameras={"00": CAMERA}, regions={r.id: r for r in regions})
    )


def test_a_border_where_the_planes_meet_is_a_junction() -> None:
    # a wall of the whole turned 45 degrees, through the line x = 0, z = 10: the two meet there
    side = _region("00/2", [1.0, 0.0, -1.0], [0.0, 0.0, 10.0])
    binding = {"00/1": "wing.front"}
    assert _junction(_ctx(WALL, side), SEGMENT, binding, frozenset({"00/2"}))
    # the region behind is not one of the whole's: an edge of the structure's own
    assert not _junction(_ctx(WALL, side), SEGMENT, binding, frozenset())
    # both regions bound to the structure: its own edge
    both = {"00/1": "wing.front", "00/2": "wing.left"}
    assert not _junction(_ctx(WALL, side), SEGMENT, both, frozenset({"00/2"}))


def test_a_border_against_a_plane_far_behind_is_an_outline() -> None:
    # the whole's wall 2 m behind the wing's (20 %): the wing's outline seen against it
    behind = _region("00/2", [1.0, 0.0, -1.0], [0.0, 0.0, 12.0])
    assert not _junction(_ctx(WALL, behind), SEGMENT, {"00/1": "wing.front"}, frozenset({"00/2"}))


def _leaf(role: str, direction: str, pitched: bool) -> Any:
    return SimpleNamespace(role=role, direction=direction, pitched=pitched)


def _reach(points: dict[str, Any], leaves: list[Any]) -> float | None:
    seen = {role: SimpleNamespace(id=role) for role in points}
    ctx = SimpleNamespace(
        evidence=SimpleNamespace(points_on=lambda rid: np.asarray(points[rid], dtype=np.float64))
    )
    frame = SimpleNamespace(front=np.array([1.0, 0.0, 0.0]))
    return reach_front(ctx, SimpleNamespace(leaves=leaves), frame, seen)  # type: ignore[arg-type]


LEAVES = [
    _leaf("w.roof.front", "forward", True),
    _leaf("w.roof.back", "backward", True),
    _leaf("w.right", "rightward", False),
    _leaf("w.front", "forward", False),
]
# a wing 6 m wide along the frame's forward axis, its front at x = 3, its ridge at x = 0
GABLE_END = [[3.0, 0.0, 0.0], [-3.0, 0.0, 0.0], [0.0, 2.0, 0.0]]
FRONT_SLOPE = [[3.0, 1.0, 1.0], [0.1, 2.0, 1.0], [0.0, 2.0, 2.0]]
BACK_SLOPE = [[-3.0, 1.0, 1.0], [-0.1, 2.0, 1.0], [0.0, 2.0, 2.0]]
FRONT_WALL = [[3.0, 0.0, 1.0], [3.0, 1.0, 2.0]]


def test_the_reach_is_at_the_wings_own_ridge() -> None:
    # the front slope's far boundary
    assert _reach({"w.roof.front": FRONT_SLOPE, "w.right": GABLE_END}, LEAVES) == 0.0
    # else the back slope's near boundary
    assert _reach({"w.roof.back": BACK_SLOPE, "w.right": GABLE_END}, LEAVES) == 0.0
    # else the middle of a gable end seen alone (its far boundary is the wing's back, 3 m off)
    assert _reach({"w.right": GABLE_END, "w.front": FRONT_WALL}, LEAVES) == 0.0
    # else the far boundary of what is seen
    assert _reach({"w.front": FRONT_WALL}, LEAVES) == 3.0
    assert _reach({}, LEAVES) is None
