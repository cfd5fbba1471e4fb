"""Local part frames: axes, zero parameters, analytic Jacobian against finite differences."""

from __future__ import annotations

import numpy as np
import pytest

from aida_kb.errors import GeometryError
from aida_kb.geometry.frames import PartFrames, frame_axes


def _planes(seed: int = 0, count: int = 6) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    n = rng.normal(size=(count, 3))
    n[0] = [0.0, -1.0, 0.0]  # horizontal: the u axis falls back to world x
    n[1] = [0.0, 0.0, 1.0]
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    d = rng.normal(scale=5.0, size=count)
    c = rng.normal(scale=3.0, size=(count, 3))
    return n, d, c


def test_axes_are_right_handed_and_w_against_the_normal() -> None:
    n, _, _ = _planes()
    axes = frame_axes(n)
    for i in range(n.shape[0]):
        F = axes[i]
        np.testing.assert_allclose(F.T @ F, np.eye(3), atol=1e-12)
        assert np.linalg.det(F) == pytest.approx(1.0)
        np.testing.assert_allclose(F[:, 2], -n[i], atol=1e-12)
    np.testing.assert_allclose(axes[1][:, 0] @ np.array([0.0, -1.0, 0.0]), 0.0, atol=1e-12)


def test_zero_parameters_reproduce_the_planes_and_centres_lie_on_them() -> None:
    n, d, c = _planes()
    frames = PartFrames.from_planes(n, d, c)
    n0, d0 = frames.planes(np.zeros((6, 3)))
    np.testing.assert_allclose(n0, n, atol=1e-12)
    np.testing.assert_allclose(d0, d, atol=1e-12)
    np.testing.assert_allclose(np.einsum("ij,ij->i", n, frames.origin), d, atol=1e-12)
    # a centre moves within the plane only by the part of c that was off it
    off = c - frames.origin
    np.testing.assert_allclose(np.linalg.norm(np.cross(off, n), axis=1), 0.0, atol=1e-9)


def test_parameters_have_their_meaning() -> None:
    n, d, c = _planes()
    frames = PartFrames.from_planes(n, d, c)
    p = np.zeros((6, 3))
    p[:, 0] = 0.25
    n1, d1 = frames.planes(p)
    np.testing.assert_allclose(n1, n, atol=1e-12)
    np.testing.assert_allclose(d1, d + 0.25, atol=1e-12)
    p = np.zeros((6, 3))
    p[:, 1] = 0.1  # about u: the normal turns by 0.1 rad, staying perpendicular to u
    n2, _ = frames.planes(p)
    np.testing.assert_allclose(np.einsum("ij,ij->i", n2, n), np.cos(0.1), atol=1e-12)
    np.testing.assert_allclose(np.einsum("ij,ij->i", n2, frames.axes[:, :, 0]), 0.0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(n2, axis=1), 1.0, atol=1e-12)


def test_jacobian_matches_finite_differences() -> None:
    n, d, c = _planes(seed=3)
    frames = PartFrames.from_planes(n, d, c)
    rng = np.random.default_rng(4)
    p = rng.normal(scale=0.2, size=(6, 3))
    _, _, dn, dd = frames.planes_and_jacobian(p)
    eps = 1e-6
    for k in range(3):
        dp = np.zeros_like(p)
        dp[:, k] = eps
        n_p, d_p = frames.planes(p + dp)
        n_m, d_m = frames.planes(p - dp)
        np.testing.assert_allclose(dn[:, :, k], (n_p - n_m) / (2 * eps), atol=1e-8)
        np.testing.assert_allclose(dd[:, k], (d_p - d_m) / (2 * eps), atol=1e-8)


def test_rebased_frames_start_where_the_parameters_ended() -> None:
    n, d, c = _planes(seed=5)
    frames = PartFrames.from_planes(n, d, c)
    p = np.random.default_rng(6).normal(scale=0.1, size=(6, 3))
    n1, d1 = frames.planes(p)
    n2, d2 = frames.rebased(p).planes(np.zeros((6, 3)))
    np.testing.assert_allclose(n2, n1, atol=1e-12)
    np.testing.assert_allclose(d2, d1, atol=1e-12)


@pytest.mark.parametrize(
    ("normals", "offsets", "message"),
    [
        ([[0.0, 0.0, 0.0]], [1.0], "zero normal"),
        ([[np.nan, 0.0, 1.0]], [1.0], "non-finite"),
        ([[0.0, 0.0, 1.0]], [np.inf], "non-finite"),
        ([[0.0, 0.0, 1.0]], [1.0, 2.0], "expected"),
    ],
)
def test_bad_planes_are_rejected(
    normals: list[list[float]], offsets: list[float], message: str
) -> None:
    with pytest.raises(GeometryError, match=message):
        PartFrames.from_planes(np.array(normals), np.array(offsets))
