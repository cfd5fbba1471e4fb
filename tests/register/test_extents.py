"""How far a registered view's regions reach across a model's faces (`register.extents`)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aida_kb.geometry.camera import PinholeCamera
from aida_kb.register import RegionMeasurements, RigidModel
from aida_kb.register.extents import (
    REACH_MIN_REL,
    reached_offsets,
    region_samples,
)

K = np.array([[700.0, 0.0, 319.5], [0.0, 700.0, 239.5], [0.0, 0.0, 1.0]])
NAMES = ("front", "back", "left", "right", "top", "bottom")


def _box(x0: float, x1: float, y0: float, y1: float, z0: float, z1: float) -> RigidModel:
    """A box of a y-down world between the given bounds (metres): a house on the ground y=0."""
    corner = {
        (i, j, k): np.array([(x0, x1)[i], (y0, y1)[j], (z0, z1)[k]], dtype=float)
        for i in (0, 1)
        for j in (0, 1)
        for k in (0, 1)
    }
    faces = {  # outward normal, corners counter-clockwise seen from outside
        "front": ((0, 0, -1), [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]),
        "back": ((0, 0, 1), [(0, 0, 1), (0, 1, 1), (1, 1, 1), (1, 0, 1)]),
        "left": ((-1, 0, 0), [(0, 0, 0), (0, 1, 0), (0, 1, 1), (0, 0, 1)]),
        "right": ((1, 0, 0), [(1, 0, 0), (1, 0, 1), (1, 1, 1), (1, 1, 0)]),
        "top": ((0, -1, 0), [(0, 0, 0), (0, 0, 1), (1, 0, 1), (1, 0, 0)]),
        "bottom": ((0, 1, 0), [(0, 1, 0), (1, 1, 0), (1, 1, 1), (0, 1, 1)]),
    }
    normals = np.array([faces[n][0] for n in NAMES], dtype=float)
    polys = [np.array([corner[c] for c in faces[n][1]]) for n in NAMES]
    offsets = np.array([float(nrm @ p[0]) for nrm, p in zip(normals, polys, strict=True)])
    return RigidModel.from_polygons(NAMES, normals, offsets, polys)


def _looking_at(centre: np.ndarray, target: np.ndarray) -> PinholeCamera:
    z = (target - centre) / np.linalg.norm(target - centre)
    x = np.cross([0.0, 1.0, 0.0], z)
    x /= np.linalg.norm(x)
    R = np.vstack([x, np.cross(z, x), z])
    return PinholeCamera(K, R, -R @ centre, 640, 480)


# the house: 10 m wide, 6 m high, 8 m deep, its front 20 m ahead; the first view saw the
# front only, and the knowledge placed the back 2 m behind it
TRUE_BACK = 28.0
TRUTH = _box(-5.0, 5.0, -6.0, 0.0, 20.0, TRUE_BACK)
SLAB = _box(-5.0, 5.0, -6.0, 0.0, 20.0, 22.0)
TURN = math.radians(40.0)  # the later view, from the front right
CAMERA = _looking_at(
    np.array([30.0 * math.sin(TURN), -3.0, 24.0 - 30.0 * math.cos(TURN)]),
    np.array([0.0, -3.0, 24.0]),
)
RIGHT = NAMES.index("right")


def _region(polygon: np.ndarray, normal: np.ndarray) -> tuple[RegionMeasurements, np.ndarray]:
    """A region of a face polygon (K, 3) as the camera measures it: its plane fit (camera
    frame, normal towards the camera) and its outline (pixels)."""
    R, t = CAMERA.R_cam_world, CAMERA.t_cam_world
    centre = polygon.mean(axis=0)
    regions = RegionMeasurements((R @ normal)[None, :], (R @ centre + t)[None, :], np.array([0.01]))
    return regions, CAMERA.project(polygon)


def _side(z0: float, z1: float) -> np.ndarray:
    """The right wall's polygon between depths z0 and z1 (metres)."""
    return np.array([[5.0, 0.0, z0], [5.0, 0.0, z1], [5.0, -6.0, z1], [5.0, -6.0, z0]])


MOVABLE = np.array([n not in ("front", "right") for n in NAMES])


def test_a_side_region_places_the_back_the_knowledge_put_too_near() -> None:
    regions, outline = _region(_side(20.0, TRUE_BACK), np.array([1.0, 0.0, 0.0]))
    offsets, moved = reached_offsets(SLAB, CAMERA, regions, [outline], MOVABLE)
    back = NAMES.index("back")
    assert [m.part for m in moved] == [back]
    # the side's area reaches to its far edge, to the REACH_QUANTILE of its length and a
    # pixel's footprint (the adjustment's edges close the rest)
    assert offsets[back] == pytest.approx(TRUE_BACK, abs=0.25)
    assert moved[0].moved_m == pytest.approx(offsets[back] - 22.0)
    assert moved[0].region == 0
    # the side's top and bottom lie on the roof's and the floor's planes: they stay
    others = [i for i in range(len(NAMES)) if i != back]
    np.testing.assert_allclose(offsets[others], SLAB.offsets[others])


def test_parts_only_move_out_and_only_where_movable() -> None:
    # the side seen only to 21 m (a tree before the rest): the back stays where it was
    regions, outline = _region(_side(20.0, 21.0), np.array([1.0, 0.0, 0.0]))
    offsets, moved = reached_offsets(SLAB, CAMERA, regions, [outline], MOVABLE)
    assert moved == []
    np.testing.assert_array_equal(offsets, SLAB.offsets)
    # measured by the first view: not moved, however far the region reaches
    regions, outline = _region(_side(20.0, TRUE_BACK), np.array([1.0, 0.0, 0.0]))
    offsets, moved = reached_offsets(SLAB, CAMERA, regions, [outline], np.zeros(6, dtype=bool))
    assert moved == []
    np.testing.assert_array_equal(offsets, SLAB.offsets)


def test_a_region_beside_the_face_in_its_plane_is_not_its() -> None:
    # a garden wall in line with the right wall, 4-10 m behind the model's back
    regions, outline = _region(_side(26.0, 32.0), np.array([1.0, 0.0, 0.0]))
    offsets, moved = reached_offsets(SLAB, CAMERA, regions, [outline], MOVABLE)
    assert moved == []
    np.testing.assert_array_equal(offsets, SLAB.offsets)


def test_a_small_overshoot_is_left_to_the_adjustment() -> None:
    # the region reaches past the back by less than REACH_MIN_REL of the model's size
    short = 22.0 + 0.5 * REACH_MIN_REL * SLAB.size
    regions, outline = _region(_side(20.0, short), np.array([1.0, 0.0, 0.0]))
    _, moved = reached_offsets(SLAB, CAMERA, regions, [outline], MOVABLE)
    assert moved == []
    # and an unknown outline says nothing
    _, moved = reached_offsets(SLAB, CAMERA, regions, [None], MOVABLE)
    assert moved == []


def test_region_samples_cover_the_outline_on_a_grid() -> None:
    square = np.array([[10.0, 20.0], [29.0, 20.0], [29.0, 39.0], [10.0, 39.0]])
    pts = region_samples(square, 64, 48, 2)
    assert pts.shape == (100, 2)
    np.testing.assert_array_equal(pts.min(axis=0), [10.0, 20.0])
    np.testing.assert_array_equal(pts.max(axis=0), [28.0, 38.0])
    # beyond the image: cut at its border
    assert region_samples(square + np.array([40.0, 0.0]), 64, 48, 2).shape == (70, 2)
    # a strand of 2 px off its side is no area of it
    strand = np.array([[10, 20], [29, 20], [29, 30], [60, 30], [60, 31], [29, 31], [29, 39]])
    np.testing.assert_array_equal(
        region_samples(np.vstack([strand, [[10, 39]]]).astype(float), 64, 48, 2), pts
    )


def test_the_truth_itself_moves_nothing() -> None:
    regions, outline = _region(_side(20.0, TRUE_BACK), np.array([1.0, 0.0, 0.0]))
    offsets, moved = reached_offsets(TRUTH, CAMERA, regions, [outline], MOVABLE)
    assert moved == []
    np.testing.assert_array_equal(offsets, TRUTH.offsets)


def test_a_region_leaking_into_the_ground_reaches_no_further() -> None:
    # the side's region runs on into the ground below it, out to 40 m: back-projected onto
    # the wall's plane the leak lies below the floor, and says nothing of the back
    leaky = np.array(
        [
            [5.0, 0.0, 20.0],
            [5.0, 0.0, 24.0],
            [5.0, 1.5, 40.0],
            [5.0, 0.0, 25.0],
            [5.0, 0.0, TRUE_BACK],
            [5.0, -6.0, TRUE_BACK],
            [5.0, -6.0, 20.0],
        ]
    )
    regions, outline = _region(leaky, np.array([1.0, 0.0, 0.0]))
    offsets, moved = reached_offsets(SLAB, CAMERA, regions, [outline], MOVABLE)
    back = NAMES.index("back")
    assert [m.part for m in moved] == [back]
    assert offsets[back] == pytest.approx(TRUE_BACK, abs=0.25)


def test_thin_strands_off_the_outline_hold_no_area() -> None:
    # the truth's side, its outline running out in 1 px strands along the grass, 10 m past
    # the back at three heights (a region's outline leaking along texture): the back stays
    pixels = CAMERA.project(_side(20.0, TRUE_BACK))
    strands = []
    for y in (-1.0, -3.0, -5.0):
        tip = CAMERA.project(np.array([[5.0, y, TRUE_BACK + 10.0]]))[0]
        base = CAMERA.project(np.array([[5.0, y, TRUE_BACK - 0.5]]))[0]
        strands.append((base, tip))
    outline = [pixels[0], pixels[1]]
    down = np.array([0.0, 1.0])
    for base, tip in strands:  # out along the strand and back, a pixel apart
        outline += [base, tip, tip + down, base + down]
    outline += [pixels[2], pixels[3]]
    regions, _ = _region(_side(20.0, TRUE_BACK), np.array([1.0, 0.0, 0.0]))
    offsets, _ = reached_offsets(TRUTH, CAMERA, regions, [np.array(outline)], MOVABLE)
    np.testing.assert_array_equal(offsets, TRUTH.offsets)
