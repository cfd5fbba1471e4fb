"""Texture factors of a later view (`aida_kb.interpret.photometric`): patches on the faces both
cameras see, none across a face's outline, and a camera brought back to its pose by them."""

from __future__ import annotations

import numpy as np

from aida_kb.constraints import TextureImage, compile_blocks
from aida_kb.geometry.camera import PinholeCamera
from aida_kb.interpret.photometric import (
    MIN_FACE_PATCHES,
    model_faces,
    texture_factors,
    texture_noise_grey,
    well_posed,
)
from aida_kb.register import RigidModel
from aida_kb.solve import build_problem, solve
from aida_kb.texture.raycast import first_hits

K = np.array([[700.0, 0.0, 320.0], [0.0, 700.0, 240.0], [0.0, 0.0, 1.0]])
W, H = 640, 480


def _box(back: float = 5.0) -> RigidModel:
    """A 10 m cube about 30 m ahead, turned 45 deg about the vertical (y); its back face
    `back` m behind its centre (5: a cube)."""
    a = np.radians(45.0)
    R = np.array([[np.cos(a), 0.0, np.sin(a)], [0.0, 1.0, 0.0], [-np.sin(a), 0.0, np.cos(a)]])
    centre = np.array([0.0, 0.0, 30.0])
    corners = np.array([[x, y, z] for x in (-5, 5) for y in (-5, 5) for z in (-5, back)], float)
    quads = {
        (-1, 0, 0): [0, 1, 3, 2],
        (1, 0, 0): [4, 6, 7, 5],
        (0, -1, 0): [0, 4, 5, 1],
        (0, 1, 0): [2, 3, 7, 6],
        (0, 0, -1): [0, 2, 6, 4],
        (0, 0, 1): [1, 5, 7, 3],
    }
    world = corners @ R.T + centre
    normals = np.array(list(quads), dtype=float) @ R.T
    polygons = [world[q] for q in quads.values()]
    offsets = np.array([n @ p[0] for n, p in zip(normals, polygons, strict=True)])
    names = ["left", "right", "top", "bottom", "front", "back"]
    return RigidModel.from_polygons(names, normals, offsets, polygons)


def _image(model: RigidModel, cam: PinholeCamera) -> np.ndarray:
    """The camera's image of the model painted with a smooth pattern (grey 0 off it)."""
    ys, xs = np.mgrid[0:H, 0:W].astype(np.float64)
    pixels = np.stack([xs.ravel(), ys.ravel()], axis=1)
    face, depth, rays = first_hits(model_faces(model), cam, pixels)
    X = cam.centre + np.where(np.isfinite(depth), depth, 0.0)[:, None] * rays
    grey = 110.0 + 35.0 * np.sin(2.3 * X[:, 0] + 0.9 * X[:, 2]) * np.cos(1.9 * X[:, 1])
    grey += 15.0 * np.cos(0.8 * X[:, 0] - 2.2 * X[:, 1] + 1.4 * X[:, 2])
    return np.where(face >= 0, grey, 0.0).reshape(H, W)


def _cameras() -> tuple[PinholeCamera, PinholeCamera]:
    cam0 = PinholeCamera(K, np.eye(3), np.zeros(3), W, H)
    return cam0, PinholeCamera.from_pose(K, [0.0, 0.1, 0.0, -4.0, 0.0, 1.0], W, H)


def test_patches_lie_inside_the_faces_both_cameras_see_and_fit_at_the_truth() -> None:
    model = _box()
    cam0, cam1 = _cameras()
    ref = _image(model, cam0)
    cs = texture_factors(model, cam0, ref, cam1, 1, TextureImage(_image(model, cam1)), 1.0, "01")
    faces = {model.names[c.parts[0]] for c in cs}
    assert faces == {"right", "front"}  # the two walls both see; not the top, seen edge-on
    assert well_posed(cs, model.normals)
    assert not well_posed([c for c in cs if model.names[c.parts[0]] == "front"], model.normals)
    assert sum(1 for c in cs if model.names[c.parts[0]] == "right") >= MIN_FACE_PATCHES
    sigma = texture_noise_grey(model.normals, model.offsets, [cam0, cam1], cs)
    assert sigma < 0.5  # no patch straddles an outline: only the lookups' error
    (block,) = compile_blocks(cs, 6, 2)
    r = block.evaluate(model.normals, model.offsets, [cam0, cam1])[0]
    assert float(np.abs(r).max()) < 3.0


def test_the_factors_bring_a_later_camera_back() -> None:
    model = _box()
    cam0, cam1 = _cameras()
    image = TextureImage(_image(model, cam1))
    ref = _image(model, cam0)
    start = cam1.with_pose(cam1.pose + np.array([0.0008, -0.0015, 0.0005, 0.06, -0.03, 0.0]))
    cs = texture_factors(model, cam0, ref, start, 1, image, 1.0, "01")
    problem = build_problem(
        model.normals,
        model.offsets,
        cs,
        cameras=[cam0, start],
        free_cameras=[1],
        fixed_parts=range(6),
    )
    result = solve(problem, loss="huber", f_scale=10.0)
    np.testing.assert_allclose(result.cameras[1].pose[:3], cam1.pose[:3], atol=1e-4)
    np.testing.assert_allclose(result.cameras[1].pose[3:], cam1.pose[3:], atol=1e-2)
