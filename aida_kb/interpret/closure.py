"""Closed convex solids from the planes of a verified structure (halfspace intersection).

Every part of a house body, a wing or an oriel box is a face of a convex solid: the solid is
the intersection of the halfspaces n·x <= d of its planes (normals out of the solid), and each
part's polygon is that plane's face of it, ordered counter-clockwise seen from outside. A part
whose face is missing or tiny does not exist in the closed model: the hypothesis that needs it
predicted a face that its own planes do not produce.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy.optimize import linprog
from scipy.spatial import ConvexHull, HalfspaceIntersection, QhullError

from aida_kb.errors import GeometryError

FloatArray = npt.NDArray[np.float64]


def interior_point(normals: FloatArray, offsets_m: FloatArray) -> tuple[FloatArray, float]:
    """The point deepest inside n·x <= d (Chebyshev centre) and its depth, metres."""
    norms = np.linalg.norm(normals, axis=1)
    c = np.zeros(4)
    c[3] = -1.0
    A = np.column_stack([normals, norms])
    res = linprog(c, A_ub=A, b_ub=offsets_m, bounds=[(None, None)] * 3 + [(0, None)])
    if not res.success:
        raise GeometryError("the planes enclose no solid (no interior point)")
    return np.asarray(res.x[:3], dtype=np.float64), float(res.x[3])


def convex_faces(
    normals: FloatArray, offsets_m: FloatArray, tol_m: float = 1e-6
) -> list[FloatArray]:
    """The face polygon (N_i, 3) of each plane of the solid n·x <= d; (0, 3) when it has none.

    Raises GeometryError when the planes do not bound a solid of some thickness.
    """
    normals = np.asarray(normals, dtype=np.float64)
    offsets_m = np.asarray(offsets_m, dtype=np.float64)
    centre, depth = interior_point(normals, offsets_m)
    if depth < 1e-3:
        raise GeometryError(f"the planes enclose no solid (thickness {2 * depth:.3g} m)")
    halfspaces = np.column_stack([normals, -offsets_m])
    try:
        vertices = HalfspaceIntersection(halfspaces, centre).intersections
        hull = ConvexHull(vertices)
    except QhullError as exc:
        raise GeometryError(f"the planes do not bound a closed solid: {exc}") from None
    vertices = vertices[hull.vertices]
    if not np.all(np.isfinite(vertices)) or np.abs(vertices).max() > 1e6:
        raise GeometryError("the planes do not bound a closed solid (vertex at infinity)")
    scale = max(1.0, float(np.abs(vertices).max()))
    faces: list[FloatArray] = []
    for n, d in zip(normals, offsets_m, strict=True):
        on = vertices[np.abs(vertices @ n - d) <= 1e-6 * scale + tol_m]
        if len(on) < 3:
            faces.append(np.zeros((0, 3)))
            continue
        mid = on.mean(axis=0)
        u = on[0] - mid
        u = u / max(float(np.linalg.norm(u)), 1e-12)
        v = np.cross(n, u)
        angles = np.arctan2((on - mid) @ v, (on - mid) @ u)
        faces.append(_dedupe(on[np.argsort(angles)], 1e-9 * scale))
    return faces


def _dedupe(poly: FloatArray, tol: float) -> FloatArray:
    keep = [0]
    for i in range(1, len(poly)):
        if np.linalg.norm(poly[i] - poly[keep[-1]]) > tol:
            keep.append(i)
    if len(keep) > 1 and np.linalg.norm(poly[keep[-1]] - poly[keep[0]]) <= tol:
        keep.pop()
    out: FloatArray = poly[keep]
    return out


def polygon_area(poly: FloatArray) -> float:
    """Area of a planar polygon (N, 3), square metres."""
    if len(poly) < 3:
        return 0.0
    cross = np.cross(poly - poly[0], np.roll(poly, -1, axis=0) - poly[0])
    return 0.5 * float(np.linalg.norm(cross.sum(axis=0)))


def inside_face(face: FloatArray, point_m: FloatArray, margin: float = 0.0) -> bool:
    """True if `point_m` (3,), projected onto a convex face's plane, lies inside the face.

    The face (N, 3) is a convex polygon; `margin` widens it by that fraction of its size
    (the diagonal of its bounding box) on every side.
    """
    centre = face.mean(axis=0)
    normal = np.cross(face[1] - face[0], face[2] - face[0])
    for i in range(3, len(face)):
        if np.linalg.norm(normal) > 1e-12:
            break
        normal = np.cross(face[1] - face[0], face[i] - face[0])
    normal = normal / max(float(np.linalg.norm(normal)), 1e-12)
    p = point_m - float((point_m - centre) @ normal) * normal
    size = float(np.linalg.norm(face.max(axis=0) - face.min(axis=0)))
    slack = margin * size
    for a, b in zip(face, np.roll(face, -1, axis=0), strict=True):
        edge = b - a
        outward = np.cross(edge, normal)
        if float(np.linalg.norm(outward)) < 1e-12:
            continue
        outward = outward / float(np.linalg.norm(outward))
        if float(np.dot(outward, centre - a)) > 0:
            outward = -outward
        if float(np.dot(outward, p - a)) > slack:
            return False
    return True
