"""Geometry: planes with local frames, CAHV cameras, polygons, polyhedra.

Modules: `rotation` (rotation vectors and their Jacobian), `camera` (pinhole and CAHV
cameras with projection Jacobians), `polygon` (plane intersections, planar polygons),
`polyhedron` (closed polyhedra from planes and face adjacency), `frames` (local part frames,
owned by the solver).
"""

from aida_kb.geometry.camera import Cahv, PinholeCamera, Projection, RayJacobians
from aida_kb.geometry.polygon import (
    PlaneIntersection,
    face_polygon,
    intersect_planes,
    intersect_planes_with_jacobians,
)
from aida_kb.geometry.polyhedron import Polyhedron, VertexJacobians

__all__ = [
    "Cahv",
    "PinholeCamera",
    "PlaneIntersection",
    "Polyhedron",
    "Projection",
    "RayJacobians",
    "VertexJacobians",
    "face_polygon",
    "intersect_planes",
    "intersect_planes_with_jacobians",
]
