"""Anchor candidates of the smaller parts (`aida_kb.interpret.assign.ranked_fronts`)."""

from __future__ import annotations

import numpy as np

from aida_kb.interpret.assign import ranked_fronts
from aida_kb.interpret.observe import CameraView, EvidenceView, RegionView


def _wall(rid: str, normal: list[float], x: float, weight: float) -> RegionView:
    n = np.array(normal) / np.linalg.norm(normal)
    return RegionView(rid, "00", n, np.array([x, 0.0, 40.0]), weight, 1000.0, 0.01)


def test_the_leftmost_wall_facing_the_camera_is_an_anchor_candidate() -> None:
    """Two oriels in view (dev seed 58019's regions): the right one's front and side are the
    best candidates by weight and facing; the left one's front, leftmost in the image, is
    tried too (parts of one slot are added from left to right: found after the right one, it
    could never be added). A wall facing away is no candidate."""
    camera = CameraView("00", np.diag([800.0, 800.0, 1.0]), np.eye(3), np.zeros(3), 640, 480)
    walls = [
        _wall("00/8", [-0.716, -0.091, -0.692], -6.0, 705.3),
        _wall("00/11", [0.673, -0.091, -0.735], -4.0, 835.4),
        _wall("00/14", [-0.696, -0.09, -0.712], 2.0, 1117.1),
        _wall("00/17", [0.704, -0.09, -0.705], 4.0, 1042.4),
        _wall("00/20", [0.0, 0.0, 1.0], -9.0, 5000.0),  # faces away from the camera
    ]
    evidence = EvidenceView({"00": camera}, {}, ())
    ranked = [r.id for r in ranked_fronts(walls, evidence)]
    assert ranked == ["00/14", "00/11", "00/8"]
    # with two walls only, both; with one, that one
    assert [r.id for r in ranked_fronts(walls[2:4], evidence)] == ["00/14", "00/17"]
    assert [r.id for r in ranked_fronts(walls[:1], evidence)] == ["00/8"]
