"""Regions an object explains without binding them: those lying on its faces (a window band,
a sliver of a side wall), and those the other objects of a scene explain.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from aida_kb.interpret.observe import EvidenceView
from aida_kb.interpret.party import extent_m, object_parts
from aida_kb.interpret.result import (
    Interpretation,
)
from aida_kb.io.evidence import Evidence
from aida_kb.io.model import ModelPart, ReconstructedModel

if TYPE_CHECKING:
    pass


FloatArray = npt.NDArray[np.float64]

# a region unbound by an object lies on one of its faces (and is explained by it) when its
# plane's normal (towards the camera, out of the solid) is within this angle of the face's
# outward normal ...
ON_FACE_ANGLE_DEG = 15.0
# ... its centroid within this fraction of the object's size (bounding-box diagonal) of the
# face's plane (stereo planes of small regions scatter by a few per cent) ...
ON_FACE_DISTANCE = 0.03
# ... and inside the face's polygon grown by this fraction of the object's size
ON_FACE_MARGIN = 0.03


def _inside(point: FloatArray, polygon: FloatArray, normal: FloatArray, margin: float) -> bool:
    """True if `point` (3,) projected on the plane of `polygon` (K, 3, convex, any order) lies
    inside it grown by `margin` metres."""
    u = polygon[1] - polygon[0]
    u = u / float(np.linalg.norm(u))
    v = np.cross(normal, u)
    q = np.stack([polygon @ u, polygon @ v], axis=1)
    p = np.array([point @ u, point @ v])
    centre = q.mean(axis=0)
    # a convex polygon: inside all half-planes of its sides, each moved out by the margin
    edges = np.roll(q, -1, axis=0) - q
    outward = np.stack([edges[:, 1], -edges[:, 0]], axis=1)
    outward /= np.linalg.norm(outward, axis=1, keepdims=True) + 1e-12
    flip = np.sign(np.sum((centre - q) * outward, axis=1))
    outward *= -np.where(flip == 0, 1.0, flip)[:, None]
    return bool(np.all(np.sum((p - q) * outward, axis=1) <= margin))


def on_faces(view: EvidenceView, model: ReconstructedModel, candidates: set[str]) -> set[str]:
    """The region ids of `candidates` lying on a face of `model` (see the module constants)."""
    size = extent_m(model.parts)
    return {
        rid
        for rid in sorted(candidates)
        if on_face(view.regions[rid].normal, view.regions[rid].centroid_m, model.parts, size)
    }


def on_face(
    normal: FloatArray,
    centroid_m: FloatArray,
    parts: Sequence[ModelPart],
    size_m: float,
) -> bool:
    """True if a region's plane (unit `normal` (3,), `centroid_m` (3,), world frame) lies on one
    of the parts (see the module constants; `size_m` the object's size)."""
    cos = math.cos(math.radians(ON_FACE_ANGLE_DEG))
    for part in parts:
        n = np.asarray(part.normal, dtype=np.float64)
        # facing the face's way: a region facing the other way on its plane is another
        # object's face there (the neighbour's gable wall above a terrace house's roof, on its
        # party wall's plane)
        if float(normal @ n) < cos:
            continue
        if abs(float(n @ centroid_m) - part.offset_m) > ON_FACE_DISTANCE * size_m:
            continue
        poly = np.asarray(part.polygon, dtype=np.float64)
        if _inside(centroid_m, poly, n, ON_FACE_MARGIN * size_m):
            return True
    return False


def explained_by_others(evidence: Evidence, interp: Interpretation, role: str) -> set[str]:
    """The region ids ('VIEW/REGION') of every view that the scene's objects other than
    `role` explain: in the interpreted view those they bound or lie on their faces (their
    `SceneObject.evidence`), in every other view with a camera in the model those lying on
    their faces (a view in its camera's frame is moved into the world frame by it)."""
    model = interp.model
    out = {r for o in interp.objects if o.role != role for r in o.evidence}
    if model is None:
        return out
    others = [
        (object_parts(model, o.role), extent_m(object_parts(model, o.role)))
        for o in interp.objects
        if o.role != role and object_parts(model, o.role)
    ]
    cameras = {c.view: c for c in model.cameras}
    interpreted = {r.split("/", 1)[0] for o in interp.objects for r in o.evidence}
    for v in evidence.views:
        if v.id in interpreted or v.id not in cameras:
            continue
        R = np.asarray(cameras[v.id].R, dtype=np.float64)
        t = np.asarray(cameras[v.id].t, dtype=np.float64)
        for r in v.regions:
            n = np.asarray(r.n_init, dtype=np.float64)
            c = np.asarray(r.c_init, dtype=np.float64)
            if v.frame == "camera":  # x_cam = R x_world + t
                n, c = R.T @ n, R.T @ (c - t)
            if any(on_face(n, c, parts, size) for parts, size in others):
                out.add(f"{v.id}/{r.id}")
    return out
