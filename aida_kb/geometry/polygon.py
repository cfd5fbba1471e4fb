"""Planar polygons from plane intersections, and measures of planar polygons.

A plane is a unit normal n and an offset d with ``n·x = d`` (world frame, metres; n points
out of the solid). A part's polygon is cut out of its plane by its neighbours: taken in the
cyclic order of its neighbours, consecutive neighbours g_i, g_(i+1) and the part's own plane
meet in the polygon's i-th vertex (paper §3). Polygons are (K, 3) arrays of vertices in order,
counter-clockwise seen from outside (from the side the normal points to).

`intersect_planes` solves many plane systems at once (one batched SVD) and refuses
ill-conditioned ones with a `GeometryError` that names the planes, so that no NaN or far-away
vertex ever leaves this module.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from aida_kb.errors import GeometryError

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

DEFAULT_MAX_CONDITION = 1e6
"""Largest accepted condition number of a vertex's plane system (ratio of its singular values).

A vertex moves by about ``condition x plane error`` when its planes move; 1e6 turns a micrometre
of plane error into a metre of vertex error and is the point where we call neighbours
degenerate (near-parallel planes, or three planes whose common lines are near-parallel).
"""


class PlaneIntersection(NamedTuple):
    """Points where planes meet, with their derivatives w.r.t. the planes.

    points : (M, 3) array, metres, world frame
    d_points_d_normals : (M, 3, k, 3) array: ``d points[m, j] / d normals[m, p, l]`` at
        ``[m, j, p, l]`` (metres per unit of normal component)
    d_points_d_offsets : (M, 3, k) array: ``d points[m, j] / d offsets[m, p]`` at ``[m, j, p]``
    residuals : (M, k) array, metres: ``offsets - normals·points``; zero (to rounding) for
        three planes, the least-squares misfit for more
    """

    points: FloatArray
    d_points_d_normals: FloatArray
    d_points_d_offsets: FloatArray
    residuals: FloatArray


def _label(names: Sequence[Sequence[str]] | None, m: int, k: int) -> str:
    if names is None:
        return f"system {m}"
    return ", ".join(names[m][:k])


def _degeneracy_message(normals: FloatArray, label: str, cond: float, max_condition: float) -> str:
    k = normals.shape[0]
    unit = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    cos = np.abs(unit @ unit.T)
    np.fill_diagonal(cos, -1.0)
    i, j = divmod(int(np.argmax(cos)), k)
    angle = float(np.degrees(np.arccos(min(1.0, float(cos[i, j])))))
    cond_text = "infinite" if not np.isfinite(cond) else f"{cond:.3g}"
    what = (
        f"planes {i} and {j} are {angle:.3g} degrees from parallel"
        if angle < 1.0
        else "their lines of intersection are (nearly) parallel: the vertex lies at infinity"
    )
    return (
        f"degenerate vertex of {label}: {what} (condition number {cond_text} > {max_condition:.3g})"
    )


def _solve(
    normals: npt.ArrayLike,
    offsets: npt.ArrayLike,
    names: Sequence[Sequence[str]] | None,
    max_condition: float,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    N = np.asarray(normals, dtype=np.float64)
    d = np.asarray(offsets, dtype=np.float64)
    if N.ndim != 3 or N.shape[2] != 3 or N.shape[1] < 3 or d.shape != N.shape[:2]:
        raise GeometryError(
            f"plane systems must be normals (M, k, 3) and offsets (M, k) with k >= 3, "
            f"got {N.shape} and {d.shape}"
        )
    if not (np.all(np.isfinite(N)) and np.all(np.isfinite(d))):
        bad = int(
            np.flatnonzero(~(np.isfinite(N).all(axis=(1, 2)) & np.isfinite(d).all(axis=1)))[0]
        )
        raise GeometryError(f"non-finite plane in {_label(names, bad, N.shape[1])}")
    if names is not None and len(names) != N.shape[0]:
        raise GeometryError(f"{len(names)} name tuples for {N.shape[0]} plane systems")
    if N.shape[0] == 0:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3, 3)), np.zeros((0, N.shape[1])), N
    U, S, Vt = np.linalg.svd(N, full_matrices=False)  # (M,k,3), (M,3), (M,3,3)
    with np.errstate(divide="ignore", invalid="ignore"):
        cond = S[:, 0] / S[:, 2]
    ill = np.flatnonzero(~(cond <= max_condition))
    if ill.size:
        m = int(ill[0])
        raise GeometryError(
            _degeneracy_message(N[m], _label(names, m, N.shape[1]), float(cond[m]), max_condition)
        )
    inv_S = 1.0 / S
    Ud = np.einsum("mkj,mk->mj", U, d)
    x = np.einsum("mji,mj->mi", Vt, inv_S * Ud)
    # (N^T N)^-1 = V diag(1/S^2) V^T
    Minv = np.einsum("mji,mj,mjl->mil", Vt, inv_S * inv_S, Vt)
    r = d - np.einsum("mkj,mj->mk", N, x)
    return x, cond, Minv, r, N


def intersect_planes(
    normals: npt.ArrayLike,
    offsets: npt.ArrayLike,
    *,
    names: Sequence[Sequence[str]] | None = None,
    max_condition: float = DEFAULT_MAX_CONDITION,
) -> FloatArray:
    """The points where planes meet, for M systems of k >= 3 planes at once.

    For k = 3 the exact intersection; for k > 3 the least-squares point (exact when the
    planes are concurrent).

    Parameters
    ----------
    normals : (M, k, 3) array
        Plane normals (unit normals for a meaningful condition number).
    offsets : (M, k) array, metres
        ``n·x = d`` offsets.
    names : optional sequence of M sequences of k names
        The planes' names, for error messages (e.g. role paths).
    max_condition : float
        Largest accepted condition number (see `DEFAULT_MAX_CONDITION`).

    Returns
    -------
    (M, 3) array, metres

    Raises
    ------
    GeometryError
        A system is ill-conditioned (near-parallel planes, vertex at infinity) or not finite;
        the message names its planes.
    """
    return _solve(normals, offsets, names, max_condition)[0]


def intersect_planes_with_jacobians(
    normals: npt.ArrayLike,
    offsets: npt.ArrayLike,
    *,
    names: Sequence[Sequence[str]] | None = None,
    max_condition: float = DEFAULT_MAX_CONDITION,
) -> PlaneIntersection:
    """`intersect_planes` with the derivatives of the points w.r.t. normals and offsets.

    With ``M = N^T N`` and residuals ``r = d - N x``:
    ``dx/dd_p = M^-1 n_p`` and ``dx/dn_p = M^-1 (r_p I - n_p x^T)``
    (for three planes ``r = 0`` and ``M^-1 n_p`` is column p of ``N^-1``).
    """
    x, _, Minv, r, N = _solve(normals, offsets, names, max_condition)
    d_off = np.einsum("mil,mpl->mip", Minv, N)  # (M, 3, k): M^-1 n_p
    d_n = Minv[:, :, None, :] * r[:, None, :, None] - d_off[:, :, :, None] * x[:, None, None, :]
    return PlaneIntersection(x, d_n, d_off, r)


def _finite_points(points: npt.ArrayLike, dim: int, what: str) -> FloatArray:
    """`points` as a float (K, dim) array; GeometryError for another shape or NaN/infinity."""
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != dim:
        raise GeometryError(f"{what} must have shape (K, {dim}), got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise GeometryError(f"{what}: non-finite coordinates (NaN or infinity)")
    return p


def plane_basis(normal: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Two unit vectors (u, v) spanning a plane, with ``u x v = n`` (right-handed, n out).

    Deterministic: u is the world axis least aligned with n, projected into the plane and
    normalised. 2-D coordinates ``(x·u, x·v)`` then show the plane as seen from outside, so
    counter-clockwise polygons have positive area.

    Parameters
    ----------
    normal : (3,) array, unit

    Returns
    -------
    u, v : (3,) arrays
    """
    u, v = plane_bases(np.asarray(normal, dtype=np.float64)[None])
    return u[0], v[0]


def plane_bases(normals: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
    """`plane_basis` for F unit normals (F, 3) at once: u, v as (F, 3) arrays."""
    n = _finite_points(normals, 3, "plane normals")
    if np.any(np.einsum("fj,fj->f", n, n) < 1e-24):
        raise GeometryError("a plane normal is the zero vector")
    e = np.zeros_like(n)
    e[np.arange(n.shape[0]), np.argmin(np.abs(n), axis=1)] = 1.0
    u = e - np.einsum("fj,fj->f", e, n)[:, None] * n
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    return u, np.cross(n, u)


def to_plane_2d(vertices: npt.ArrayLike, normal: npt.ArrayLike) -> FloatArray:
    """2-D coordinates (K, 2), metres, of points (K, 3) in the basis of `plane_basis`."""
    u, v = plane_basis(normal)
    P = _finite_points(vertices, 3, "polygon vertices")
    return np.stack([P @ u, P @ v], axis=1)


def signed_area_2d(points: npt.ArrayLike) -> float:
    """Signed area (shoelace) of a 2-D polygon (K, 2); positive when counter-clockwise."""
    p = _finite_points(points, 2, "polygon vertices")
    q = np.roll(p, -1, axis=0)
    return 0.5 * float(np.sum(p[:, 0] * q[:, 1] - p[:, 1] * q[:, 0]))


def polygon_area(vertices: npt.ArrayLike, normal: npt.ArrayLike) -> float:
    """Signed area, m², of a planar polygon (K, 3) seen from the side `normal` points to.

    Positive for counter-clockwise (outward) order. The vertices need not lie exactly in a
    plane through the origin: the area is that of their projection along `normal`.
    """
    P = _finite_points(vertices, 3, "polygon vertices")
    n = _finite_points(np.reshape(normal, (1, 3)), 3, "polygon normal")[0]
    return 0.5 * float(np.sum(np.cross(P, np.roll(P, -1, axis=0)) @ n))


def polygon_centroid(vertices: npt.ArrayLike, normal: npt.ArrayLike) -> FloatArray:
    """Area centroid (3,), metres, of a planar polygon (K, 3) with unit `normal`.

    Raises `GeometryError` for a polygon of (near) zero area.
    """
    P = _finite_points(vertices, 3, "polygon vertices")
    n = _finite_points(np.reshape(normal, (1, 3)), 3, "polygon normal")[0]
    o = P.mean(axis=0)
    a = P - o
    b = np.roll(a, -1, axis=0)
    w = np.cross(a, b) @ n  # twice the signed areas of the fan triangles (o, p_i, p_i+1)
    total = float(np.sum(w))
    scale = float(np.max(np.linalg.norm(a, axis=1))) if len(a) else 0.0
    if not abs(total) > 1e-12 * max(scale * scale, 1e-300):
        raise GeometryError("polygon has zero area: no centroid")
    c: FloatArray = o + (w @ (a + b)) / (3.0 * total)
    return c


def self_intersections(points: npt.ArrayLike, tol: float = 0.0) -> list[tuple[int, int]]:
    """Pairs (i, j) of non-adjacent edges of a closed 2-D polygon (K, 2) that touch or cross.

    Edge i runs from vertex i to vertex i+1 (mod K). Edges whose distance is at most `tol`
    (metres) count as touching. An empty list means the polygon is simple (adjacent edges
    are not tested: collinear consecutive edges are allowed).
    """
    p = _finite_points(points, 2, "polygon vertices")
    if not np.isfinite(tol):
        raise GeometryError(f"tolerance must be finite, got {tol}")
    k = p.shape[0]
    if k < 4:
        return []
    a, b = p, np.roll(p, -1, axis=0)
    i, j = np.triu_indices(k, 2)
    keep = ~((i == 0) & (j == k - 1))
    i, j = i[keep], j[keep]
    hit = np.flatnonzero(segments_touch(a[i], b[i], a[j], b[j], tol))
    return [(int(i[h]), int(j[h])) for h in hit]


def segments_touch(
    a1: FloatArray, b1: FloatArray, a2: FloatArray, b2: FloatArray, tol: float = 0.0
) -> npt.NDArray[np.bool_]:
    """(P,) bool: whether 2-D segments a1-b1 and a2-b2 (each (P, 2)) cross or come within `tol`."""
    a1, b1, a2, b2 = (_finite_points(x, 2, "segment end points") for x in (a1, b1, a2, b2))

    def cross(o: FloatArray, s: FloatArray, t: FloatArray) -> FloatArray:
        r: FloatArray = (s[:, 0] - o[:, 0]) * (t[:, 1] - o[:, 1]) - (s[:, 1] - o[:, 1]) * (
            t[:, 0] - o[:, 0]
        )
        return r

    d1, d2 = cross(a1, b1, a2), cross(a1, b1, b2)
    d3, d4 = cross(a2, b2, a1), cross(a2, b2, b1)
    proper = (d1 * d2 < 0) & (d3 * d4 < 0)
    # touching: an end point within tol of the other segment
    close = (
        (_point_segment_distance(a2, a1, b1) <= tol)
        | (_point_segment_distance(b2, a1, b1) <= tol)
        | (_point_segment_distance(a1, a2, b2) <= tol)
        | (_point_segment_distance(b1, a2, b2) <= tol)
    )
    out: npt.NDArray[np.bool_] = proper | close
    return out


def _point_segment_distance(p: FloatArray, a: FloatArray, b: FloatArray) -> FloatArray:
    ab = b - a
    den = np.einsum("ij,ij->i", ab, ab)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(den > 0, np.einsum("ij,ij->i", p - a, ab) / den, 0.0)
    t = np.clip(t, 0.0, 1.0)
    dist: FloatArray = np.linalg.norm(p - (a + t[:, None] * ab), axis=1)
    return dist


def face_polygon(
    normal: npt.ArrayLike,
    offset: float,
    neighbour_normals: npt.ArrayLike,
    neighbour_offsets: npt.ArrayLike,
    *,
    name: str = "face",
    neighbour_names: Sequence[str] | None = None,
    max_condition: float = DEFAULT_MAX_CONDITION,
) -> FloatArray:
    """A part's polygon from its plane and its neighbours' planes in cyclic order.

    Vertex i is where the part's plane meets neighbours i and i+1 (mod K), so vertex i lies
    between the edge shared with neighbour i and the edge shared with neighbour i+1.

    Parameters
    ----------
    normal : (3,) array, unit; offset : float, metres
        The part's plane.
    neighbour_normals : (K, 3) array; neighbour_offsets : (K,) array, metres
        The neighbours' planes, K >= 3, in the cyclic order of the polygon's edges.
    name, neighbour_names : str, sequence of K str
        For error messages.

    Returns
    -------
    (K, 3) array, metres, world frame

    Raises
    ------
    GeometryError
        Fewer than 3 neighbours, or a degenerate vertex (named by its three planes). The
        polygon itself is not checked for simplicity: see `self_intersections`.
    """
    Nn = np.asarray(neighbour_normals, dtype=np.float64)
    dn = np.asarray(neighbour_offsets, dtype=np.float64)
    k = Nn.shape[0] if Nn.ndim == 2 else 0
    if k < 3 or Nn.shape != (k, 3) or dn.shape != (k,):
        raise GeometryError(
            f"face {name}: a polygon needs at least 3 neighbours (normals (K, 3), offsets (K,)), "
            f"got {Nn.shape} and {dn.shape}"
        )
    nxt = np.roll(np.arange(k), -1)
    n = np.broadcast_to(np.asarray(normal, dtype=np.float64), (k, 3))
    N = np.stack([n, Nn, Nn[nxt]], axis=1)
    d = np.stack([np.full(k, float(offset)), dn, dn[nxt]], axis=1)
    names = None
    if neighbour_names is not None:
        nn = list(neighbour_names)
        names = [(name, nn[i], nn[(i + 1) % k]) for i in range(k)]
    return intersect_planes(N, d, names=names, max_condition=max_condition)
