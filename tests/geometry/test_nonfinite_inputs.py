"""Public geometry functions given NaN/infinite/degenerate input raise GeometryError, not NaN."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from aida_kb.errors import GeometryError
from aida_kb.geometry import camera, frames, polygon, polyhedron, rotation

NAN = float("nan")
K = np.array([[800.0, 0.0, 320.0], [0.0, 800.0, 240.0], [0.0, 0.0, 1.0]])
CAM = camera.PinholeCamera(K, np.eye(3), np.zeros(3), 640, 480)
TRIANGLE = np.array([[NAN, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
UP = np.array([0.0, 0.0, 1.0])
SEG = np.array([[0.0, 0.0]])
NAMES = ["x0", "x1", "y0", "y1", "z0", "z1"]
NORMALS = np.array([[-1, 0, 0], [1, 0, 0], [0, -1, 0], [0, 1, 0], [0, 0, -1], [0, 0, 1.0]])
ADJ = [(a, b) for a in NAMES for b in NAMES if a < b and a[0] != b[0]]
CUBE = polyhedron.Polyhedron.from_adjacency(NAMES, NORMALS, np.array([0, 1, 0, 1, 0, 1.0]), ADJ)


CASES: dict[str, tuple[Callable[[], object], str]] = {
    "camera width NaN": (
        lambda: camera.PinholeCamera(K, np.eye(3), np.zeros(3), NAN, 480),  # type: ignore[arg-type]
        "whole pixels",
    ),
    "in_image margin NaN": (lambda: CAM.in_image(np.array([[1.0, 1.0]]), margin=NAN), "margin"),
    "skew NaN": (lambda: rotation.skew(np.array([NAN, 0.0, 1.0])), "non-finite"),
    "skew wrong shape": (lambda: rotation.skew(np.zeros(2)), "shape"),
    "plane_basis NaN": (lambda: polygon.plane_basis(np.array([NAN, 0.0, 1.0])), "non-finite"),
    "plane_basis zero": (lambda: polygon.plane_basis(np.zeros(3)), "zero vector"),
    "plane_bases NaN": (lambda: polygon.plane_bases(np.array([[0.0, NAN, 1.0]])), "non-finite"),
    "to_plane_2d NaN": (lambda: polygon.to_plane_2d(TRIANGLE, UP), "non-finite"),
    "signed_area_2d NaN": (lambda: polygon.signed_area_2d(TRIANGLE[:, :2]), "non-finite"),
    "polygon_area NaN": (lambda: polygon.polygon_area(TRIANGLE, UP), "non-finite"),
    "polygon_area NaN normal": (
        lambda: polygon.polygon_area(np.abs(np.nan_to_num(TRIANGLE)), np.array([NAN, 0, 1])),
        "polygon normal",
    ),
    "polygon_centroid NaN": (lambda: polygon.polygon_centroid(TRIANGLE, UP), "non-finite"),
    "self_intersections NaN": (
        lambda: polygon.self_intersections(np.array([[NAN, 0], [1, 0], [1, 1], [0, 1.0]])),
        "non-finite",
    ),
    "self_intersections tol NaN": (
        lambda: polygon.self_intersections(np.array([[0, 0], [1, 0], [1, 1], [0, 1.0]]), NAN),
        "tolerance",
    ),
    "segments_touch 1-D": (lambda: polygon.segments_touch(SEG[0], SEG[0], SEG, SEG), "shape"),
    "segments_touch NaN": (
        lambda: polygon.segments_touch(SEG, np.array([[NAN, 1.0]]), SEG, SEG),
        "non-finite",
    ),
    "frame_axes NaN": (lambda: frames.frame_axes(np.array([[NAN, 0.0, 1.0]])), "non-finite"),
    "frame_axes zero": (lambda: frames.frame_axes(np.zeros((1, 3))), "zero vector"),
    "is_convex tol NaN": (lambda: CUBE.is_convex(NAN), "tolerance"),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_bad_input_is_a_geometry_error(name: str) -> None:
    call, message = CASES[name]
    with pytest.raises(GeometryError, match=message):
        call()


def test_valid_input_still_works() -> None:
    assert CAM.in_image(np.array([[1.0, 1.0], [700.0, 1.0]]), margin=2.0).tolist() == [False, False]
    assert CAM.in_image(np.array([[10.0, 10.0]]), margin=2.0).tolist() == [True]
    square = np.array([[0.0, 0.0, 1.0], [2.0, 0.0, 1.0], [2.0, 2.0, 1.0], [0.0, 2.0, 1.0]])
    assert polygon.polygon_area(square, UP) == pytest.approx(4.0)
    np.testing.assert_allclose(polygon.polygon_centroid(square, UP), [1.0, 1.0, 1.0])
    assert CUBE.is_convex()
    assert CUBE.volume() == pytest.approx(1.0)
    np.testing.assert_allclose(rotation.skew([1.0, 2.0, 3.0]) @ [0.0, 0.0, 1.0], [2.0, -1.0, 0.0])
