"""Corners where more than three faces meet (`aida_kb.interpret.joint.corner_ties`): a
pyramid's apex is one point in the views' adjustment, its base corners (three faces) need no
tie."""

from __future__ import annotations

import numpy as np

from aida_kb.interpret.closure import close
from aida_kb.interpret.joint import CORNER_MIN_DET, CORNER_SIGMA_M, corner_ties
from aida_kb.register import RigidModel
from aida_kb.solve import build_problem, solve

UP = np.array([0.0, -1.0, 0.0])  # OpenCV world: y down
APEX = np.array([5.0, -5.0, 5.0])  # the 45-deg pyramid's


def _slopes(pitch_deg: float) -> dict[str, np.ndarray]:
    """The four slopes' outward normals at `pitch_deg` from level, south, east, north, west."""
    c, s = np.cos(np.radians(pitch_deg)), np.sin(np.radians(pitch_deg))
    return {
        "r_south": np.array([0.0, -c, -s]),
        "r_east": np.array([s, -c, 0.0]),
        "r_north": np.array([0.0, -c, s]),
        "r_west": np.array([-s, -c, 0.0]),
    }


def _pyramid(pitch_deg: float = 45.0) -> RigidModel:
    """A pyramid on a 10 m square, its floor at y = 0, its slopes at `pitch_deg`."""
    slopes = _slopes(pitch_deg)
    apex = np.array([5.0, -5.0 * np.tan(np.radians(pitch_deg)), 5.0])
    ring = list(slopes)
    adjacency = [(a, b) for a, b in zip(ring, ring[1:] + ring[:1], strict=True)]
    adjacency += [(r, "floor") for r in ring]
    faces = [(r, n, float(n @ apex)) for r, n in slopes.items()] + [("floor", -UP, 0.0)]
    polygons = close(faces, adjacency)
    names = [r for r, _, _ in faces]
    return RigidModel.from_polygons(
        names,
        np.array([n for _, n, _ in faces]),
        np.array([d for _, _, d in faces]),
        [polygons[r] for r in names],
    )


def test_the_apex_is_tied_and_the_base_corners_are_not() -> None:
    model = _pyramid()
    (tie,) = corner_ties(model)
    assert tie.kind == "concurrent"
    assert sorted(model.names[p] for p in tie.parts) == sorted(_slopes(45.0))
    assert tie.sigma == CORNER_SIGMA_M
    # one slope moved 0.3 m, the others held: the tie brings it back through the apex
    offsets = model.offsets.copy()
    moved = tie.parts[3]
    offsets[moved] += 0.3
    fixed = [i for i in range(len(model.names)) if i != moved]
    result = solve(build_problem(model.normals, offsets, [tie], fixed_parts=fixed))
    assert abs(float(result.normals[moved] @ APEX) - float(result.offsets[moved])) < 1e-6


def test_an_apex_whose_planes_fix_no_point_is_not_tied() -> None:
    # slopes at 2 deg: the most independent three span 2 sin² p cos p = 0.0024 < the floor
    flat = _pyramid(2.0)
    assert 2 * np.sin(np.radians(2.0)) ** 2 < CORNER_MIN_DET
    assert corner_ties(flat) == []
    assert len(corner_ties(_pyramid(15.0))) == 1  # 0.13: tied


def test_a_box_has_no_corner_of_four_faces() -> None:
    from tests.interpret.test_photometric import _box

    assert corner_ties(_box()) == []
