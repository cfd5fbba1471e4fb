"""Anchor candidates of the smaller parts (`aida_kb.interpret.assign.ranked_fronts`) and the
frames a wall region gives them (`assign.framings`)."""

from __future__ import annotations

from typing import Any

import numpy as np

from aida_kb.interpret.assign import framings, ranked_fronts
from aida_kb.interpret.hypotheses import Frame, faces_camera
from aida_kb.interpret.knowledge import Knowledge
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


def test_a_wing_seen_from_its_gable_end_is_framed_by_that_wall(buildings_kb: Any) -> None:
    """Held-out 61423's wing stands out of the body's front towards the camera: its gable
    end faces the camera, its front (the frame's anchor) faces away. The gable end's region
    gives the wing's frame as its front would; as the anchor, or as any wall whose frame
    turns the anchor to face the camera, it is not tried again (that anchor would be seen)."""
    knowledge = Knowledge.from_kb(buildings_kb)
    wing = next(
        s
        for s in knowledge.structures("Wing", "body.wings[0]", "body", "part-of")
        if s.describe() == "body.wings[0]=RightWing"
    )
    camera = CameraView("00", np.diag([800.0, 800.0, 1.0]), np.eye(3), np.zeros(3), 640, 480)
    up = np.array([0.0, -1.0, 0.0])
    # left of the camera's axis, facing it: the wing stands out towards the camera there
    gable_end = _wall("00/11", [0.0, 0.0, -1.0], -10.0, 2000.0)
    found = framings(wing, gable_end, up, camera)
    roles = [role for role, _ in found]
    assert roles[0] == "front"  # the anchor first, as before
    # as the wing's right end its front faces -x, away from the camera at x = 0; as its left
    # end the front would face +x, towards the camera: not tried. As its back (the front
    # facing +z, away) it lies along the anchor's own axis, tried by the anchor's framing
    assert roles[1:] == ["right"]
    framed = dict(found)
    assert np.allclose(framed["right"].direction("rightward"), gable_end.normal, atol=1e-9)
    assert np.allclose(framed["right"].up, up)
    # the anchor faces away from the camera in each frame but its own
    for role, frame in found[1:]:
        assert not faces_camera(frame.front, gable_end.centroid_m, camera), role


def test_frame_facing_turns_each_direction_onto_the_normal() -> None:
    up = np.array([0.0, -1.0, 0.0])
    normal = np.array([0.3, 0.1, -0.9]) / np.linalg.norm([0.3, 0.1, -0.9])
    horizontal = normal - (normal @ up) * up
    horizontal /= np.linalg.norm(horizontal)
    for name in ("forward", "backward", "leftward", "rightward"):
        frame = Frame.facing(normal, up, name)
        assert np.allclose(frame.direction(name), horizontal, atol=1e-12), name
        assert abs(float(frame.front @ frame.right)) < 1e-12
