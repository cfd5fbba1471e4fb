"""Geometry: planes with local frames, CAHV cameras, polygons, polyhedra.

Modules: `rotation` (rotation vectors), `camera` (pinhole and CAHV cameras with
projection Jacobians), `frames` (local part frames, owned by the solver).
"""

from aida_kb.geometry.camera import Cahv, PinholeCamera, Projection, RayJacobians

__all__ = ["Cahv", "PinholeCamera", "Projection", "RayJacobians"]
