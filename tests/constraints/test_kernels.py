"""Constraint kernels: values and analytic Jacobians against central finite differences."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest

from aida_kb.constraints import kernels

Derivative = Callable[..., np.ndarray]
Kernel = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]


def _unit(x: np.ndarray) -> np.ndarray:
    out: np.ndarray = x / np.linalg.norm(x, axis=-1, keepdims=True)
    return out


def _planes(seed: int, count: int = 8) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return _unit(rng.normal(size=(count, 3))), rng.normal(scale=4.0, size=count)


def _check_jacobian(
    kernel: Kernel, n: np.ndarray, d: np.ndarray, idx: np.ndarray, fd: Derivative
) -> None:
    _r, J = kernel(n, d)
    for m in range(idx.shape[0]):
        for a in range(idx.shape[1]):
            p = int(idx[m, a])
            for f in range(4):
                num = fd(lambda nn, dd, m=m: kernel(nn, dd)[0][m], n, d, p, f, 1e-7)
                # a plane may occur twice in one constraint: the Jacobian adds its slots
                ana = sum(J[m, :, b, f] for b in range(idx.shape[1]) if idx[m, b] == p)
                np.testing.assert_allclose(ana, num, atol=2e-6, rtol=1e-5)


def test_rotation_vector_norm_is_the_angle_and_smooth_at_zero() -> None:
    rng = np.random.default_rng(0)
    a = _unit(rng.normal(size=(6, 3)))
    b = _unit(a + 0.5 * rng.normal(size=(6, 3)))
    b[0] = a[0]
    b[1] = _unit(a[1] + 1e-6 * rng.normal(size=3))
    r, da, db = kernels.rotation_vector(a, b)
    angle = np.arccos(np.clip(np.einsum("ij,ij->i", a, b), -1, 1))
    np.testing.assert_allclose(np.linalg.norm(r, axis=1)[2:], angle[2:], atol=1e-12)
    assert np.all(np.isfinite(da))
    assert np.all(np.isfinite(db))
    eps = 1e-7
    for j in range(3):
        e = np.zeros(3)
        e[j] = eps
        num_a = kernels.rotation_vector(a + e, b)[0] - kernels.rotation_vector(a - e, b)[0]
        num_b = kernels.rotation_vector(a, b + e)[0] - kernels.rotation_vector(a, b - e)[0]
        np.testing.assert_allclose(da[:, :, j], num_a / (2 * eps), atol=1e-7)
        np.testing.assert_allclose(db[:, :, j], num_b / (2 * eps), atol=1e-7)


def test_meeting_angle_convention() -> None:
    front = np.array([[0.0, 0.0, 1.0]])
    side = np.array([[1.0, 0.0, 0.0]])
    skew45 = _unit(np.array([[-1.0, 0.0, 1.0]]))
    assert kernels.meeting_angle(front, side)[0][0] == pytest.approx(math.pi / 2)
    assert kernels.meeting_angle(front, skew45)[0][0] == pytest.approx(math.radians(135))


def test_angle_kernel(plane_derivative: Derivative) -> None:
    n, d = _planes(1)
    idx = np.array([[0, 1], [2, 3], [4, 5]])
    value = np.array([0.5, 1.5, 2.5])
    r, _ = kernels.angle_kernel(n, idx, value)
    expected = np.pi - np.arccos(np.einsum("ij,ij->i", n[idx[:, 0]], n[idx[:, 1]])) - value
    np.testing.assert_allclose(r[:, 0], expected, atol=1e-12)
    _check_jacobian(
        lambda nn, dd: kernels.angle_kernel(nn, idx, value), n, d, idx, plane_derivative
    )


@pytest.mark.parametrize("sign", [0.0, 1.0, -1.0])
def test_parallel_kernel(sign: float, plane_derivative: Derivative) -> None:
    n, d = _planes(2)
    n[1] = _unit(-n[0] + 0.05)  # nearly opposite: auto sign flips
    n[3] = _unit(n[2] + 0.02)  # nearly the same
    idx = np.array([[0, 1], [2, 3], [4, 5]])
    signs = np.full(3, sign)
    r, _ = kernels.parallel_kernel(n, idx, signs)
    if sign == 0.0:
        assert np.linalg.norm(r[0]) < 0.2
        assert np.linalg.norm(r[1]) < 0.1
    _check_jacobian(
        lambda nn, dd: kernels.parallel_kernel(nn, idx, signs), n, d, idx, plane_derivative
    )


def test_parallel_edge_kernel(plane_derivative: Derivative) -> None:
    n, d = _planes(3)
    idx = np.array([[0, 1, 2, 3], [4, 5, 6, 7], [0, 2, 0, 3]])
    r, _ = kernels.parallel_edge_kernel(n, idx)
    e1 = _unit(np.cross(n[idx[:, 0]], n[idx[:, 1]]))
    e2 = _unit(np.cross(n[idx[:, 2]], n[idx[:, 3]]))
    line_angle = np.arccos(np.abs(np.einsum("ij,ij->i", e1, e2)))
    np.testing.assert_allclose(np.linalg.norm(r, axis=1), line_angle, atol=1e-10)
    _check_jacobian(
        lambda nn, dd: kernels.parallel_edge_kernel(nn, idx), n, d, idx, plane_derivative
    )


def test_symmetry_kernel(plane_derivative: Derivative) -> None:
    n, d = _planes(4)
    idx = np.array([[0, 1, 2, 3], [4, 5, 6, 7], [0, 1, 1, 2]])
    _check_jacobian(lambda nn, dd: kernels.symmetry_kernel(nn, idx), n, d, idx, plane_derivative)


def test_position_kernel(plane_derivative: Derivative) -> None:
    n, d = _planes(5)
    rng = np.random.default_rng(6)
    idx = np.array([[0], [1], [2], [3]])
    n_init = _unit(n[:4] + 0.05 * rng.normal(size=(4, 3)))
    n_init[3] = n[3]  # zero angle: smooth
    c_init = rng.normal(scale=3.0, size=(4, 3))
    sa = np.array([1.0, 2.0, 1.0, 0.5])
    ss = np.array([1.0, 0.5, 3.0, 1.0])

    def kern(nn: np.ndarray, dd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return kernels.position_kernel(nn, dd, idx, n_init, c_init, sa, ss)

    r, _ = kern(n, d)
    angle = np.arccos(np.clip(np.einsum("ij,ij->i", n[:4], n_init), -1, 1))
    np.testing.assert_allclose(np.linalg.norm(r[:, :3], axis=1), sa * angle, atol=1e-7)
    # moving the plane along its own normal by t shifts the centre by t·cos along n_init
    r2, _ = kern(n, d + 0.1 * (np.arange(8) < 4))
    cos = np.einsum("ij,ij->i", n[:4], n_init)
    np.testing.assert_allclose(r2[:, 3] - r[:, 3], ss * 0.1 * cos, atol=1e-12)
    _check_jacobian(kern, n, d, idx, plane_derivative)


def test_position_scales_in_pixels() -> None:
    from aida_kb.constraints import Constraint, PositionData, compile_blocks
    from aida_kb.errors import SolveError

    base = PositionData((0.0, 0.0, -1.0), (0.0, 0.0, 20.0), px_per_m=40.0, radius_m=3.0)
    tuned = PositionData(
        (0.0, 0.0, -1.0), (0.0, 0.0, 20.0), shift_px_per_m=0.8, tilt_px_per_rad=57.3
    )

    def pos(p: PositionData) -> Constraint:
        return Constraint("position", (0,), sigma=1.0, unit="px", position=p)

    (block,) = compile_blocks([pos(base), pos(tuned)], 1)
    # the rim of a 3 m region at 40 px/m; the explicit scales replace both
    np.testing.assert_allclose(block.data["scale_angle"], [120.0, 57.3])
    np.testing.assert_allclose(block.data["scale_shift"], [40.0, 0.8])
    half = PositionData((0.0, 0.0, -1.0), (0.0, 0.0, 20.0), shift_px_per_m=0.8)
    with pytest.raises(SolveError, match="px_per_m"):
        compile_blocks([pos(half)], 1)
    bad = PositionData((0.0, 0.0, -1.0), (0.0, 0.0, 20.0), shift_px_per_m=-1.0)
    with pytest.raises(SolveError, match="shift_px_per_m must be"):
        compile_blocks([pos(bad)], 1)
