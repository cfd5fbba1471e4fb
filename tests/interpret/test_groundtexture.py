"""The ground under a model (`aida_kb.interpret.groundtexture`): its plane and polygon from the
model's vertical alone, and its texture's patches, which bring a later camera back where the
model's own faces' patches are left out."""

from __future__ import annotations

import numpy as np

from aida_kb.constraints import TextureImage
from aida_kb.geometry.camera import PinholeCamera
from aida_kb.interpret.groundtexture import (
    GROUND_GRAZING_DEG,
    GROUND_REACH,
    GROUND_SEEN_SHARE,
    MIN_GROUND_PATCHES,
    bottom_face,
    bottom_on_ground,
    ground_plane,
    ground_seen_share,
)
from aida_kb.interpret.photometric import TEXTURE_GRAZING_DEG, texture_factors
from aida_kb.register import RigidModel
from aida_kb.solve import build_problem, solve
from tests.interpret.test_photometric import H, K, W, _box, _image

UP = np.array([0.0, -1.0, 0.0])  # the first camera's frame: y points down


def _with_ground(model: RigidModel) -> RigidModel:
    n, d, polygon = ground_plane(model, UP, bottom_face(model, UP))
    return RigidModel.from_polygons(
        [*model.names, "ground"],
        np.vstack([model.normals, n]),
        np.append(model.offsets, d),
        [*model.polygons, polygon],
    )


def test_the_ground_lies_square_to_up_under_the_lowest_point() -> None:
    model = _box()
    n, d, polygon = ground_plane(model, 2.0 * UP, None)  # any length: made unit
    np.testing.assert_allclose(n, UP)
    vertices = np.vstack(model.polygons)
    assert d == float((vertices @ UP).min())
    np.testing.assert_allclose(polygon @ n, d, atol=1e-9)  # every corner on the plane
    centre = vertices.mean(axis=0)
    foot = polygon.mean(axis=0)
    np.testing.assert_allclose(foot - (foot @ n) * n, centre - (centre @ n) * n, atol=1e-9)
    size = float(np.ptp(vertices, axis=0).max())
    sides = np.linalg.norm(np.diff(np.vstack([polygon, polygon[:1]]), axis=0), axis=1)
    np.testing.assert_allclose(sides, 2.0 * GROUND_REACH * size)
    # counter-clockwise seen from above: its own normal is up
    assert float(np.cross(polygon[1] - polygon[0], polygon[2] - polygon[0]) @ n) > 0.0


def _looking_at(centre: np.ndarray, target: np.ndarray) -> PinholeCamera:
    """A level camera at `centre` looking at `target` (y down, as the world's)."""
    z = (target - centre) / np.linalg.norm(target - centre)
    x = np.cross([0.0, 1.0, 0.0], z)
    x /= np.linalg.norm(x)
    R = np.stack([x, np.cross(z, x), z])
    return PinholeCamera(K, R, -R @ centre, W, H)


def _cameras() -> tuple[PinholeCamera, PinholeCamera]:
    """Both cameras 3 m above the ground (the box's bottom at y = 5 m), 30 deg apart about the
    box, looking at its foot."""
    target = np.array([0.0, 5.0, 30.0])
    turn = np.radians(30.0)
    later = np.array([30.0 * np.sin(turn), 2.0, 30.0 - 30.0 * np.cos(turn)])
    return _looking_at(np.array([0.0, 2.0, 0.0]), target), _looking_at(later, target)


def test_only_the_grounds_patches_and_only_within_its_grazing_limit() -> None:
    scene = _with_ground(_box())
    cam0, cam1 = _cameras()
    g = len(scene.names) - 1
    ref, later = _image(scene, cam0), TextureImage(_image(scene, cam1))
    cs = texture_factors(
        scene, cam0, ref, cam1, 1, later, 1.0, "01", only_face=g, grazing_deg=GROUND_GRAZING_DEG
    )
    assert len(cs) >= MIN_GROUND_PATCHES
    assert {c.parts[0] for c in cs} == {g}
    # seen 80 deg and more from its normal: the faces' own limit leaves the ground out
    faces_limit = texture_factors(
        scene, cam0, ref, cam1, 1, later, 1.0, "01", only_face=g, grazing_deg=TEXTURE_GRAZING_DEG
    )
    assert faces_limit == []


def test_the_grounds_patches_bring_a_later_camera_back() -> None:
    scene = _with_ground(_box())
    cam0, cam1 = _cameras()
    g = len(scene.names) - 1
    image = TextureImage(_image(scene, cam1))
    ref = _image(scene, cam0)
    start = cam1.with_pose(cam1.pose + np.array([0.0, 0.0015, 0.0, 0.04, 0.0, 0.0]))
    cs = texture_factors(
        scene, cam0, ref, start, 1, image, 1.0, "01", only_face=g, grazing_deg=GROUND_GRAZING_DEG
    )
    problem = build_problem(
        scene.normals,
        scene.offsets,
        cs,
        cameras=[cam0, start],
        free_cameras=[1],
        fixed_parts=range(len(scene.names)),
    )
    result = solve(problem, loss="huber", f_scale=10.0)
    moved = result.cameras[1]
    # a swing about the box of 0.09 deg and 0.04 m: back to a quarter of it (the bilinear
    # lookups' error on ground seen at 84 deg from its normal is what is left)
    turn = np.linalg.norm(moved.pose[:3] - cam1.pose[:3])
    assert turn < 0.25 * 0.0015, turn
    assert np.linalg.norm(moved.centre - cam1.centre) < 0.25 * np.linalg.norm(
        start.centre - cam1.centre
    )


def test_the_bottom_is_held_level_on_the_ground() -> None:
    model = _box()
    assert model.names[bottom_face(model, UP)] == "bottom"
    scene = _with_ground(model)
    g = len(scene.names) - 1
    ties = bottom_on_ground(bottom_face(model, UP), g)
    assert [c.parts for c in ties] == [(model.names.index("bottom"), g)]
    # the bottom tilted by a degree about the x axis: the tie brings it back to the ground's
    tilt = np.radians(1.0)
    normals = scene.normals.copy()
    b = model.names.index("bottom")
    normals[b] = np.array([0.0, np.cos(tilt), np.sin(tilt)])
    others = [i for i in range(len(scene.names)) if i != b]
    problem = build_problem(normals, scene.offsets, ties, fixed_parts=others)
    result = solve(problem)
    np.testing.assert_allclose(result.normals[b], -scene.normals[g], atol=1e-6)
    # a model with no face looking down has none to hold
    keep = others[:-1]  # the box without its bottom (and the ground)
    open_box = RigidModel.from_polygons(
        [model.names[i] for i in keep],
        model.normals[keep],
        model.offsets[keep],
        [model.polygons[i] for i in keep],
    )
    assert bottom_face(open_box, UP) is None
    assert bottom_on_ground(bottom_face(open_box, UP), len(keep)) == []


def _seen_share(paint: str) -> float:
    """`ground_seen_share` of the first camera's stereo pair (a 1-m baseline along its rows)
    over the box's ground painted with the scene's pattern, or with a pattern at infinity (the
    sky behind an object on no ground: the same in both images)."""
    scene = _with_ground(_box())
    g = len(scene.names) - 1
    cam0, _ = _cameras()
    right = PinholeCamera(K, cam0.R_cam_world, cam0.t_cam_world - np.array([1.0, 0.0, 0.0]), W, H)
    if paint == "ground":
        ref, seen = _image(scene, cam0), _image(scene, right)
    else:
        ys, xs = np.mgrid[0:H, 0:W].astype(np.float64)
        ref = seen = 110.0 + 20.0 * np.sin(0.4 * xs) * np.cos(0.3 * ys)
    cs = texture_factors(
        scene,
        cam0,
        ref,
        right,
        1,
        TextureImage(seen),
        1.0,
        "00 right",
        only_face=g,
        grazing_deg=GROUND_GRAZING_DEG,
    )
    assert len(cs) >= MIN_GROUND_PATCHES
    return ground_seen_share(cs, scene.normals, scene.offsets, [cam0, right], 1)


def test_the_first_views_stereo_sees_the_ground_but_not_the_sky() -> None:
    assert _seen_share("ground") >= 0.9
    # what lies at infinity fits no baseline better than the ground's disparity
    assert _seen_share("sky") < GROUND_SEEN_SHARE


def test_a_low_camera_sees_its_near_ground_though_not_the_ground_under_the_object() -> None:
    # the first camera and its stereo partner 0.6 m above the ground (the box's bottom at
    # y = 5 m), 1 m apart: the ground under the box, 30 m off, is seen 88.9 deg from its
    # normal, the ground a few metres before the camera under the limit
    scene = _with_ground(_box())
    g = len(scene.names) - 1
    target = np.array([0.0, 5.0, 30.0])
    cam0 = _looking_at(np.array([0.0, 4.4, 0.0]), target)
    right = PinholeCamera(K, cam0.R_cam_world, cam0.t_cam_world - np.array([1.0, 0.0, 0.0]), W, H)
    n, d = scene.normals[g], float(scene.offsets[g])
    to_centre = cam0.centre - scene.polygons[g].mean(axis=0)
    assert np.degrees(np.arccos(n @ to_centre / np.linalg.norm(to_centre))) > GROUND_GRAZING_DEG
    cs = texture_factors(
        scene,
        cam0,
        _image(scene, cam0),
        right,
        1,
        TextureImage(_image(scene, right)),
        1.0,
        "00 right",
        only_face=g,
        grazing_deg=GROUND_GRAZING_DEG,
    )
    assert len(cs) >= MIN_GROUND_PATCHES
    for c in cs:  # each patch's middle seen within the limit by both cameras
        assert c.texture is not None
        o, rays = np.asarray(c.texture.origin), np.asarray(c.texture.rays)
        middle = np.mean([o + (d - n @ o) / (n @ r) * r for r in rays], axis=0)
        for cam in (cam0, right):
            to_cam = cam.centre - middle
            assert n @ to_cam / np.linalg.norm(to_cam) >= np.cos(np.radians(GROUND_GRAZING_DEG))
