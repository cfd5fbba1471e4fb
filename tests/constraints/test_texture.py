"""The texture factor: bilinear lookups with their exact derivative, residuals that vanish on
the true planes and pose whatever the gain and offset, Jacobians against finite differences,
and a pose recovered from the texture alone."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from aida_kb.constraints import Constraint, TextureData, TextureImage, compile_blocks
from aida_kb.constraints.texture import bilinear, texture_kernel
from aida_kb.errors import SolveError
from aida_kb.geometry.camera import PinholeCamera
from aida_kb.solve import build_problem, solve

K = np.array([[700.0, 0.0, 320.0], [0.0, 700.0, 240.0], [0.0, 0.0, 1.0]])
W, H = 640, 480


def _texture(X: np.ndarray) -> np.ndarray:
    """A smooth grey-level pattern on world points (N, 3), metres."""
    return (
        110.0
        + 35.0 * np.sin(2.1 * X[:, 0] + 0.7 * X[:, 2]) * np.cos(1.7 * X[:, 1])
        + 20.0 * np.cos(1.3 * X[:, 1] - 1.9 * X[:, 2] + 0.4 * X[:, 0])
    )


def _scene() -> tuple[np.ndarray, np.ndarray, list[PinholeCamera]]:
    """Two walls of a box corner about 20 m ahead, seen by a reference camera and a second
    one 3 m to its left turned towards the corner."""
    n = np.array([[-0.6, 0.0, -0.8], [0.8, 0.0, -0.6]])
    corner = np.array([0.5, 0.0, 20.0])
    d = n @ corner
    cam0 = PinholeCamera(K, np.eye(3), np.zeros(3), W, H)
    cam1 = PinholeCamera.from_pose(K, [0.0, 0.12, 0.0, -3.0, 0.2, 0.5], W, H)
    return n, d, [cam0, cam1]


def _image(
    cam: PinholeCamera, n: np.ndarray, d: np.ndarray, gain: float, offset: float
) -> np.ndarray:
    """The camera's image of the textured walls (the solid's surface where each pixel's ray
    enters it: the farther of the two planes), times ``gain`` plus ``offset``."""
    ys, xs = np.mgrid[0:H, 0:W].astype(np.float64)
    pix = np.stack([xs.ravel(), ys.ravel(), np.ones(xs.size)], axis=1)
    rays = (pix @ np.linalg.inv(K).T) @ cam.R_cam_world
    t = (d[None, :] - n @ cam.centre) / (rays @ n.T)
    X = cam.centre + t.max(axis=1)[:, None] * rays
    return (gain * _texture(X) + offset).reshape(H, W)


def _patches(
    cam0: PinholeCamera, n: np.ndarray, d: np.ndarray, image: TextureImage, camera: int
) -> list[Constraint]:
    """4 x 4 patches of the reference camera's view on each wall, away from the corner."""
    out = []
    for part, x0 in ((0, 120.0), (1, 360.0)):
        for y0 in (150.0, 230.0, 310.0):
            for dx in (0.0, 40.0):
                u, v = np.meshgrid(x0 + dx + 3.0 * np.arange(4), y0 + 3.0 * np.arange(4))
                pix = np.stack([u.ravel(), v.ravel(), np.ones(16)], axis=1)
                rays = pix @ np.linalg.inv(K).T
                t = d[part] / (rays @ n[part])
                values = _texture(t[:, None] * rays)
                out.append(
                    Constraint(
                        kind="texture",
                        parts=(part,),
                        sigma=1.0,
                        measurement=True,
                        texture=TextureData(
                            camera,
                            (0.0, 0.0, 0.0),
                            tuple(tuple(float(x) for x in r) for r in rays),  # type: ignore[misc]
                            tuple(float(x) for x in values),
                            image,
                        ),
                    )
                )
    return out


def test_bilinear_derivative_is_exact_and_the_border_repeats() -> None:
    rng = np.random.default_rng(3)
    image = rng.uniform(0.0, 255.0, size=(20, 30))
    q = rng.uniform(0.5, 18.5, size=(50, 2)) + 0.013
    _, grad = bilinear(image, q)
    eps = 1e-7
    for axis in range(2):
        step = np.zeros(2)
        step[axis] = eps
        num = (bilinear(image, q + step)[0] - bilinear(image, q - step)[0]) / (2 * eps)
        np.testing.assert_allclose(grad[:, axis], num, rtol=1e-6, atol=1e-5)
    np.testing.assert_allclose(bilinear(image, np.array([[3.0, 4.0]]))[0], image[4, 3])
    outside, g_out = bilinear(image, np.array([[-5.0, 4.0], [40.0, 25.0]]))
    np.testing.assert_allclose(outside, [image[4, 0], image[19, 29]])
    assert g_out[0, 0] == 0.0  # flat across the border
    assert g_out[0, 1] != 0.0  # not along it
    np.testing.assert_allclose(g_out[1], 0.0)


def test_residual_vanishes_at_the_truth_whatever_the_gain_and_grows_off_it() -> None:
    n, d, cams = _scene()
    image = TextureImage(_image(cams[1], n, d, gain=0.7, offset=25.0))
    cs = _patches(cams[0], n, d, image, 1)
    (block,) = compile_blocks(cs, 2, 2)
    r, _, _ = block.evaluate(n, d, cams)
    assert r.shape == (len(cs), 16)
    assert float(np.abs(r).max()) < 0.3  # bilinear interpolation of a smooth pattern
    off = [cams[0], cams[1].with_pose(cams[1].pose + np.array([0.0, 0.003, 0.0, 0, 0, 0]))]
    r_off, _, _ = block.evaluate(n, d, off)
    assert float(np.sqrt(np.mean(r_off**2))) > 10 * float(np.sqrt(np.mean(r**2)))


def test_kernel_jacobians_match_finite_differences_over_planes_and_cameras(
    plane_derivative: Callable[..., np.ndarray],
) -> None:
    n, d, cams = _scene()
    cams = [cams[0], cams[1], cams[1].with_pose(cams[1].pose + np.array([0, 0.02, 0, 1.0, 0, 0]))]
    cs = _patches(cams[0], n, d, TextureImage(_image(cams[1], n, d, 1.0, 0.0)), 1)
    cs += _patches(cams[0], n, d, TextureImage(_image(cams[2], n, d, 1.2, -4.0)), 2)
    (block,) = compile_blocks(cs, 2, 3)
    data = block.data
    n = n + np.array([[0.01, -0.02, 0.0], [0.0, 0.01, 0.02]])
    d = d + np.array([0.05, -0.03])

    def at(nn: np.ndarray, dd: np.ndarray, cc: list[PinholeCamera]) -> np.ndarray:
        args = (data["camera"], data["origin"], data["rays"], data["values"], list(data["image"]))
        return texture_kernel(nn, dd, block.idx, cc, *args)[0]

    args = (data["camera"], data["origin"], data["rays"], data["values"], list(data["image"]))
    _, J, Jc = texture_kernel(n, d, block.idx, cams, *args)
    # small: the interpolant's derivative jumps at pixel cells' borders, and a sample whose
    # difference straddles one spoils its patch's 16 entries
    eps = 1e-8
    for p in range(2):
        for f in range(4):
            num = plane_derivative(lambda nn, dd: at(nn, dd, cams), n, d, p, f, eps)
            ana = np.where((block.idx[:, 0] == p)[:, None], J[:, :, 0, f], 0.0)
            np.testing.assert_allclose(ana, num, rtol=1e-4, atol=1e-3, err_msg=f"{p} {f}")
    for c in (1, 2):
        for j in range(6):
            step = np.zeros(6)
            step[j] = eps
            plus, minus = list(cams), list(cams)
            plus[c] = cams[c].with_pose(cams[c].pose + step)
            minus[c] = cams[c].with_pose(cams[c].pose - step)
            num = (at(n, d, plus) - at(n, d, minus)) / (2 * eps)
            ana = np.where((data["camera"] == c)[:, None], Jc[:, :, j], 0.0)
            np.testing.assert_allclose(ana, num, rtol=1e-4, atol=1e-3, err_msg=f"{c} {j}")


def test_the_texture_alone_brings_a_camera_back_to_its_pose() -> None:
    n, d, cams = _scene()
    cs = _patches(cams[0], n, d, TextureImage(_image(cams[1], n, d, 0.8, 10.0)), 1)
    true_pose = cams[1].pose
    start = cams[1].with_pose(true_pose + np.array([0.001, -0.002, 0.0005, 0.05, 0.0, -0.05]))
    problem = build_problem(
        n, d, cs, cameras=[cams[0], start], free_cameras=[1], fixed_parts=[0, 1]
    )
    result = solve(problem, loss="huber", f_scale=10.0)
    # from 0.13 deg and 7 cm off to within the bilinear lookups' error of the smooth pattern
    np.testing.assert_allclose(result.cameras[1].pose[:3], true_pose[:3], atol=1.5e-4)
    np.testing.assert_allclose(result.cameras[1].pose[3:], true_pose[3:], atol=5e-3)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"texture": None}, "needs its patch"),
        ({"rays": ((0.0, 0.0, 1.0),) * 3}, "16 finite 3-vectors"),
        ({"values": (1.0,) * 15}, "values must have 16 components"),
        ({"camera": 5}, "unknown camera index 5"),
    ],
)
def test_a_bad_patch_is_named(change: dict[str, object], message: str) -> None:
    n, d, cams = _scene()
    (c,) = _patches(cams[0], n, d, TextureImage(np.zeros((4, 4))), 1)[:1]
    assert c.texture is not None
    if "texture" in change:
        bad = Constraint(kind="texture", parts=(0,), sigma=1.0)
    else:
        from dataclasses import replace

        bad = Constraint(
            kind="texture",
            parts=(0,),
            sigma=1.0,
            texture=replace(c.texture, **change),  # type: ignore[arg-type]
        )
    with pytest.raises(SolveError, match=message):
        compile_blocks([bad], 2, 2)
