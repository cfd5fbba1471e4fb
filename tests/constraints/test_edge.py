"""The edge constraint (paper eq. 5): zero on the true edge; Jacobians by planes and pose."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from aida_kb.constraints.edge import edge_kernel
from aida_kb.geometry.camera import PinholeCamera

K = np.array([[800.0, 0.0, 320.0], [0.0, 800.0, 240.0], [0.0, 0.0, 1.0]])


def _scene() -> tuple[list[PinholeCamera], np.ndarray, np.ndarray]:
    # a box corner 20 m ahead: front wall z = 20 (normal -z, towards the camera), a side wall
    # x = 3 (normal +x) and a roof-like plane; world = camera 0 frame (y down)
    n = np.array([[0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [0.0, -0.8, -0.6]])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    points = np.array([[0.0, 0.0, 20.0], [3.0, 0.0, 20.0], [0.0, -4.0, 20.0]])
    d = np.einsum("ij,ij->i", n, points)
    cam0 = PinholeCamera(K, np.eye(3), np.zeros(3), 640, 480)
    cam1 = PinholeCamera.from_pose(K, [0.02, -0.15, 0.01, -4.0, 0.3, 1.0], 640, 480)
    return [cam0, cam1], n, d


def _segment(cam: PinholeCamera, n: np.ndarray, d: np.ndarray, a: int, b: int) -> np.ndarray:
    direction = np.cross(n[a], n[b])
    point = np.linalg.lstsq(np.stack([n[a], n[b]]), np.array([d[a], d[b]]), rcond=None)[0]
    ends = point + np.array([-1.0, 2.5])[:, None] * direction
    return cam.project(ends)


def _inputs() -> tuple:
    cams, n, d = _scene()
    idx = np.array([[0, 1], [0, 2], [0, 1], [1, 2]])
    camera = np.array([0, 0, 1, 1])
    segs = [_segment(cams[c], n, d, int(i[0]), int(i[1])) for i, c in zip(idx, camera, strict=True)]
    p1 = np.array([s[0] for s in segs])
    p2 = np.array([s[1] for s in segs])
    return cams, n, d, idx, camera, p1, p2


@pytest.mark.parametrize("pixels", [False, True])
def test_edge_residual_vanishes_on_the_true_edge_and_grows_off_it(pixels: bool) -> None:
    cams, n, d, idx, camera, p1, p2 = _inputs()
    px = np.full(4, pixels)
    r, _, _ = edge_kernel(n, d, idx, cams, camera, p1, p2, px)
    np.testing.assert_allclose(r, 0.0, atol=1e-8)
    d2 = d.copy()
    d2[1] += 0.2  # move the side wall 20 cm: edge (front, side) moves sideways
    r2, _, _ = edge_kernel(n, d2, idx, cams, camera, p1, p2, px)
    assert np.all(np.abs(r2[[0, 2]]) > (1.0 if pixels else 0.05))
    np.testing.assert_allclose(r2[1], 0.0, atol=1e-8)  # edge (front, roof) is unaffected


@pytest.mark.parametrize("pixels", [False, True])
def test_edge_jacobians_match_finite_differences(
    pixels: bool, plane_derivative: Callable[..., np.ndarray]
) -> None:
    cams, n, d, idx, camera, p1, p2 = _inputs()
    rng = np.random.default_rng(0)
    n = n + 0.02 * rng.normal(size=n.shape)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    d = d + 0.1 * rng.normal(size=3)
    px = np.array([pixels, not pixels, pixels, not pixels])
    _, J, Jc = edge_kernel(n, d, idx, cams, camera, p1, p2, px)
    eps = 1e-6

    def at(nn: np.ndarray, dd: np.ndarray, cc: list[PinholeCamera]) -> np.ndarray:
        return edge_kernel(nn, dd, idx, cc, camera, p1, p2, px)[0]

    for p in range(3):
        for f in range(4):
            num = plane_derivative(lambda nn, dd: at(nn, dd, cams), n, d, p, f, eps)
            ana = np.zeros_like(num)
            for slot in range(2):
                hit = idx[:, slot] == p
                ana[hit] += J[hit, :, slot, f]
            np.testing.assert_allclose(ana, num, atol=1e-5, rtol=1e-5)
    for c in range(2):
        pose = cams[c].pose
        for q in range(6):
            dp = np.zeros(6)
            dp[q] = eps
            plus, minus = list(cams), list(cams)
            plus[c] = cams[c].with_pose(pose + dp)
            minus[c] = cams[c].with_pose(pose - dp)
            num = (at(n, d, plus) - at(n, d, minus)) / (2 * eps)
            sel = camera == c
            np.testing.assert_allclose(Jc[sel, :, q], num[sel], atol=1e-4, rtol=1e-5)
            np.testing.assert_allclose(num[~sel], 0.0, atol=1e-9)


@pytest.mark.parametrize("pixels", [False, True])
def test_without_the_camera_jacobian_the_residuals_and_plane_jacobian_are_the_same(
    pixels: bool,
) -> None:
    # a problem whose cameras are held asks for no pose derivatives: the kernel skips them and
    # what it does return is bit for bit what the full evaluation gives
    cams, n, d, idx, camera, p1, p2 = _inputs()
    d = d + np.array([0.1, -0.2, 0.05])
    px = np.array([pixels, not pixels, pixels, not pixels])
    r, J, Jc = edge_kernel(n, d, idx, cams, camera, p1, p2, px)
    r0, J0, Jc0 = edge_kernel(n, d, idx, cams, camera, p1, p2, px, camera_jacobian=False)
    assert Jc is not None
    assert Jc0 is None
    assert np.abs(r).max() > 1e-3  # off the true edges, so the comparison means something
    np.testing.assert_array_equal(r0, r)
    np.testing.assert_array_equal(J0, J)


def _leaning(lean: int, scale: float) -> list:
    """The four edges of `_inputs` as edge constraints with the given lean."""
    from aida_kb.constraints import Constraint, EdgeData

    _, _, _, idx, camera, p1, p2 = _inputs()
    return [
        Constraint(
            kind="edge",
            parts=(int(a), int(b)),
            sigma=1.0,
            unit="px",
            measurement=True,
            edge=EdgeData(int(c), tuple(q1), tuple(q2), lean, scale),  # type: ignore[arg-type]
        )
        for (a, b), c, q1, q2 in zip(idx, camera, p1, p2, strict=True)
    ]


def test_a_leaning_edge_scales_its_biased_side_only_with_exact_jacobians() -> None:
    from aida_kb.constraints import compile_blocks

    cams, n, d, idx, _, _, _ = _inputs()
    # the side wall moved and turned: the edges (front, side) lie off their segments, the end
    # points' residuals on both sides of zero
    d = d.copy()
    d[1] += 0.02
    n = n.copy()
    n[1] = n[1] + np.array([0.0, 0.05, 0.0])
    n[1] /= np.linalg.norm(n[1])
    (plain,) = compile_blocks(_leaning(0, 1.0), 3, 2)
    r0, J0, Jc0 = plain.evaluate(n, d, cams)
    assert np.any(r0 > 0.5)
    assert np.any(r0 < -0.5)
    eps = 1e-6
    for lean in (-1, 1):
        (b,) = compile_blocks(_leaning(lean, 0.25), 3, 2)
        r, J, Jc = b.evaluate(n, d, cams)
        scale = np.where(lean * r0 > 0, 0.25, 1.0)
        np.testing.assert_allclose(r, r0 * scale)
        np.testing.assert_allclose(J, J0 * scale[:, :, None, None])
        assert Jc is not None
        assert Jc0 is not None
        np.testing.assert_allclose(Jc, Jc0 * scale[:, :, None])
        for p in range(3):  # the scaled residuals' own derivatives
            for f in range(4):
                n_p, n_m, d_p, d_m = n.copy(), n.copy(), d.copy(), d.copy()
                if f < 3:
                    n_p[p, f] += eps
                    n_m[p, f] -= eps
                else:
                    d_p[p] += eps
                    d_m[p] -= eps
                num = (b.evaluate(n_p, d_p, cams)[0] - b.evaluate(n_m, d_m, cams)[0]) / (2 * eps)
                ana = sum(J[:, :, s, f] * (idx[:, s] == p)[:, None] for s in range(2))
                away = np.abs(r0) > 1e-3  # a residual at zero has no derivative there
                np.testing.assert_allclose(ana[away], num[away], atol=1e-5, rtol=1e-5)


@pytest.mark.parametrize(("lean", "scale"), [(2, 0.5), (1, 0.0), (-1, 1.5)])
def test_a_bad_lean_is_refused_in_one_line(lean: int, scale: float) -> None:
    from aida_kb.constraints import validate
    from aida_kb.errors import SolveError

    with pytest.raises(SolveError, match="lean") as info:
        validate(_leaning(lean, scale), 3, 2)
    assert "\n" not in str(info.value)
