"""A segment is evidence of an edge only with its bound region on the side of the edge where
that region's face lies (`adjust._on_its_side`): an oriel's top, with the front wall above
it, is no eave."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np

from aida_kb.interpret.adjust import _face_side, _on_its_side
from aida_kb.interpret.edges import EdgeMatch
from aida_kb.interpret.observe import CameraView, SegmentView

K = np.array([[500.0, 0.0, 320.0], [0.0, 500.0, 240.0], [0.0, 0.0, 1.0]])
CAMERA = CameraView("00", K, np.eye(3), np.zeros(3), 640, 480)
# a front wall 10 m ahead facing the camera, a flat top 2 m above the camera (OpenCV axes: y
# down); outward normals, n·x = d. Their edge is the image row v = 240 - 500 * 2 / 10 = 140,
# the wall below it.
PLANES: dict[str, tuple[Any, float]] = {
    "front": (np.array([0.0, 0.0, -1.0]), -10.0),
    "top": (np.array([0.0, -1.0, 0.0]), 2.0),
}


def _box(v0: float, v1: float) -> Any:
    return np.array([[150.0, v0], [450.0, v0], [450.0, v1], [150.0, v1]])


def _ctx(outline: Any) -> Any:
    return SimpleNamespace(
        evidence=SimpleNamespace(cameras={"00": CAMERA}, outlines={"00/1": (outline,)})
    )


def _match(v: float) -> EdgeMatch:
    seg = SegmentView("00/l1", "00", np.array([[200.0, v], [400.0, v]]), ("00/1",))
    return EdgeMatch(seg, ("front", "top"), 0.0)


def test_the_face_lies_below_its_eave_in_the_image() -> None:
    across = np.array([0.0, 1.0])  # +v: down the image
    mid = np.array([300.0, 140.0])
    assert _face_side(CAMERA, PLANES["front"], PLANES["top"], mid, across) == 1.0
    # a top above the camera is seen from below (a back face): it recedes towards the
    # horizon, down the image, on the wall's side too
    assert _face_side(CAMERA, PLANES["top"], PLANES["front"], mid, across) == 1.0
    # a top 2 m below the camera (edge at v = 340): the wall below it, the top above it
    low = (np.array([0.0, -1.0, 0.0]), -2.0)
    mid = np.array([300.0, 340.0])
    assert _face_side(CAMERA, PLANES["front"], low, mid, across) == 1.0
    assert _face_side(CAMERA, low, PLANES["front"], mid, across) == -1.0
    # a wall parallel to the top: no edge
    assert _face_side(CAMERA, low, PLANES["top"], mid, across) is None


def test_a_segment_with_the_wall_below_it_is_an_eave_with_the_wall_above_it_is_not() -> None:
    binding = {"00/1": "front"}
    # the wall's region below the segment: the eave
    assert _on_its_side(_ctx(_box(140.0, 300.0)), _match(140.0), binding, PLANES)
    # the wall's region above a segment 20 px lower (an oriel's top): not the eave
    assert not _on_its_side(_ctx(_box(60.0, 160.0)), _match(160.0), binding, PLANES)
    # the segment drawn the other way round: the same answers
    seg = SegmentView("00/l1", "00", np.array([[400.0, 160.0], [200.0, 160.0]]), ("00/1",))
    assert not _on_its_side(
        _ctx(_box(60.0, 160.0)), EdgeMatch(seg, ("front", "top"), 0.0), binding, PLANES
    )
    # the region on both sides (no border of it) or on neither: nothing is told, kept
    assert _on_its_side(_ctx(_box(60.0, 300.0)), _match(160.0), binding, PLANES)
    assert _on_its_side(_ctx(_box(300.0, 400.0)), _match(160.0), binding, PLANES)
