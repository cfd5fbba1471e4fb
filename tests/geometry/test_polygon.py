"""Plane intersections (batched, with Jacobians and degeneracy errors) and planar polygons."""

from __future__ import annotations

import numpy as np
import pytest

from aida_kb.errors import GeometryError
from aida_kb.geometry.polygon import (
    face_polygon,
    intersect_planes,
    intersect_planes_with_jacobians,
    plane_basis,
    polygon_area,
    polygon_centroid,
    self_intersections,
    signed_area_2d,
    to_plane_2d,
)


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def test_three_axis_planes() -> None:
    N = np.eye(3)[None]
    np.testing.assert_array_equal(intersect_planes(N, [[1.0, -2.0, 3.0]]), [[1.0, -2.0, 3.0]])


def test_batched_solve_matches_linalg_solve() -> None:
    rng = np.random.default_rng(0)
    N = _unit(rng.normal(size=(500, 3, 3)))
    d = rng.normal(scale=10.0, size=(500, 3))
    cond = np.linalg.cond(N)
    N, d, cond = N[cond < 1e4], d[cond < 1e4], cond[cond < 1e4]
    x = intersect_planes(N, d)
    ref = np.linalg.solve(N, d[..., None])[..., 0]
    # both are backward stable: they agree to about eps * condition * |x|
    err = np.linalg.norm(x - ref, axis=1) / np.linalg.norm(ref, axis=1)
    assert np.all(err < 1e-14 * cond)
    np.testing.assert_allclose(np.einsum("mkj,mj->mk", N, x), d, atol=1e-10)


def test_least_squares_point_of_concurrent_planes() -> None:
    rng = np.random.default_rng(1)
    X = rng.normal(size=(20, 3))
    N = _unit(rng.normal(size=(20, 5, 3)))
    d = np.einsum("mkj,mj->mk", N, X)
    res = intersect_planes_with_jacobians(N, d)
    np.testing.assert_allclose(res.points, X, atol=1e-12)
    assert np.max(np.abs(res.residuals)) < 1e-12


def test_near_parallel_planes_are_named() -> None:
    n = np.array([[1.0, 0.0, 0.0], _unit(np.array([1.0, 1e-9, 0.0])), [0.0, 0.0, 1.0]])
    with pytest.raises(GeometryError, match=r"front, left, roof: planes 0 and 1 are .* parallel"):
        intersect_planes(n[None], [[0.0, 1.0, 2.0]], names=[("front", "left", "roof")])


def test_vertex_at_infinity() -> None:
    # three vertical planes: their three lines of intersection are parallel (vertical)
    n = _unit(np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 1.0]]))
    with pytest.raises(GeometryError, match=r"infinity.*condition number"):
        intersect_planes(n[None], [[0.0, 0.0, 5.0]], names=[("a", "b", "c")])


def test_exactly_singular_and_nan() -> None:
    n = np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    with pytest.raises(GeometryError, match="system 0"):
        intersect_planes(n[None], [[0.0, 1.0, 0.0]])
    with pytest.raises(GeometryError, match="non-finite"):
        intersect_planes(np.eye(3)[None], [[0.0, np.nan, 0.0]])
    with pytest.raises(GeometryError, match="k >= 3"):
        intersect_planes(np.eye(3)[None, :2], [[0.0, 0.0]])


@pytest.mark.parametrize("k", [3, 4, 6])
def test_jacobians_match_finite_differences(k: int) -> None:
    rng = np.random.default_rng(k)
    N = _unit(rng.normal(size=(8, k, 3)))
    d = rng.normal(scale=3.0, size=(8, k))  # k > 3: not concurrent, residuals non-zero
    res = intersect_planes_with_jacobians(N, d)
    if k > 3:
        assert np.max(np.abs(res.residuals)) > 1e-3
    h = 1e-6
    for p in range(k):
        e = np.zeros((8, k))
        e[:, p] = h
        fd = (intersect_planes(N, d + e) - intersect_planes(N, d - e)) / (2 * h)
        np.testing.assert_allclose(res.d_points_d_offsets[:, :, p], fd, atol=1e-7)
        for comp in range(3):
            E = np.zeros((8, k, 3))
            E[:, p, comp] = h
            fd = (intersect_planes(N + E, d) - intersect_planes(N - E, d)) / (2 * h)
            np.testing.assert_allclose(res.d_points_d_normals[:, :, p, comp], fd, atol=1e-6)


def test_face_polygon_of_a_box_face() -> None:
    # the top face z = 1 of the unit cube, neighbours counter-clockwise seen from above
    n_top = np.array([0.0, 0.0, 1.0])
    nb = np.array([[1.0, 0, 0], [0, 1.0, 0], [-1.0, 0, 0], [0, -1.0, 0]])
    dn = np.array([1.0, 1.0, 0.0, 0.0])
    P = face_polygon(n_top, 1.0, nb, dn)
    np.testing.assert_allclose(P, [[1, 1, 1], [0, 1, 1], [0, 0, 1], [1, 0, 1]], atol=1e-15)
    assert polygon_area(P, n_top) == pytest.approx(1.0)
    with pytest.raises(GeometryError, match="top: a polygon needs at least 3"):
        face_polygon(n_top, 1.0, nb[:2], dn[:2], name="top")
    with pytest.raises(GeometryError, match="top, east, west"):
        face_polygon(
            n_top,
            1.0,
            nb[[0, 2, 1]],
            dn[[0, 2, 1]],
            name="top",
            neighbour_names=["east", "west", "n"],
        )


def test_plane_basis_is_right_handed() -> None:
    rng = np.random.default_rng(2)
    for n in _unit(rng.normal(size=(50, 3))):
        u, v = plane_basis(n)
        np.testing.assert_allclose([u @ u, v @ v, u @ v, u @ n], [1, 1, 0, 0], atol=1e-15)
        np.testing.assert_allclose(np.cross(u, v), n, atol=1e-15)


def _l_polygon() -> np.ndarray:
    # an L in the plane z = 2, counter-clockwise seen from +z: area 3, centroid (5/6, 5/6)
    return np.array([[0, 0, 2], [2, 0, 2], [2, 1, 2], [1, 1, 2], [1, 2, 2], [0, 2, 2]], dtype=float)


def test_area_and_centroid_of_an_l() -> None:
    P = _l_polygon()
    n = np.array([0.0, 0.0, 1.0])
    assert polygon_area(P, n) == pytest.approx(3.0, abs=1e-14)
    assert polygon_area(P[::-1], n) == pytest.approx(-3.0, abs=1e-14)
    np.testing.assert_allclose(polygon_centroid(P, n), [5 / 6, 5 / 6, 2.0], atol=1e-14)
    assert signed_area_2d(to_plane_2d(P, n)) == pytest.approx(3.0, abs=1e-14)
    assert self_intersections(to_plane_2d(P, n)) == []
    with pytest.raises(GeometryError, match="zero area"):
        polygon_centroid(np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]]), n)


def test_self_intersections() -> None:
    bowtie = np.array([[0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0]])
    assert self_intersections(bowtie) == [(0, 2)]
    # a vertex touching a non-adjacent edge
    touching = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [1.0, 0.0], [0.0, 2.0]])
    assert self_intersections(touching) != []
    # collinear consecutive edges are allowed
    straight = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]])
    assert self_intersections(straight) == []
    near = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [1.0, 1e-7], [0.0, 2.0]])
    assert self_intersections(near) == []
    assert self_intersections(near, tol=1e-6) != []
