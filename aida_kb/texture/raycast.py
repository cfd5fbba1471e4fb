"""Rays against a model's planar faces: the first face each ray meets (a z-buffer by ray casting).

Faces are convex or concave planar polygons (world frame, metres). Every ray is tested against
every face at once per face (vectorised over rays): ray-plane intersection, then a crossing-
number point-in-polygon test in the face's plane coordinates.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aida_kb.geometry.camera import PinholeCamera
from aida_kb.geometry.polygon import plane_bases
from aida_kb.io.export import model_up
from aida_kb.io.model import ReconstructedModel

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

# a face whose normal is within asin(LEVEL_SIN) of the vertical is level: no horizontal u axis
LEVEL_SIN = 0.1
# faces are clipped to what lies this far in front of a camera
MIN_DEPTH_M = 1e-6
# a ray closer than this to parallel with a face's plane (cosine) never hits it
GRAZING_COS = 1e-9


@dataclass(frozen=True)
class Faces:
    """The model's faces for ray casting: polygons, planes and in-plane bases (world, m)."""

    polygons: tuple[FloatArray, ...]  # each (K, 3)
    normals: FloatArray  # (F, 3) unit, out of the solid
    offsets: FloatArray  # (F,) n·x = d
    u: FloatArray  # (F, 3) in-plane unit vectors, u x v = n
    v: FloatArray  # (F, 3)

    @classmethod
    def of(cls, model: ReconstructedModel) -> Faces:
        """The faces of `model`, in its parts' order.

        A face's in-plane u axis is horizontal (up x n) where the face is not level, so that
        its texture stands upright in the atlas (v points up the face).
        """
        normals = np.array([p.normal for p in model.parts], dtype=np.float64)
        u, v = plane_bases(normals)
        up = model_up(model)
        across = np.cross(up, normals)
        norm = np.linalg.norm(across, axis=1)
        tilted = norm > LEVEL_SIN
        u[tilted] = across[tilted] / norm[tilted, None]
        v[tilted] = np.cross(normals[tilted], u[tilted])
        return cls(
            tuple(np.array(p.polygon, dtype=np.float64) for p in model.parts),
            normals,
            np.array([p.offset_m for p in model.parts], dtype=np.float64),
            u,
            v,
        )

    def flat(self, f: int, points: FloatArray) -> FloatArray:
        """Points (N, 3), world -> (N, 2) coordinates in face f's plane basis, metres."""
        return np.stack([points @ self.u[f], points @ self.v[f]], axis=1)


def inside_polygon(points_2d: FloatArray, polygon_2d: FloatArray) -> npt.NDArray[np.bool_]:
    """Which points (N, 2) lie inside the polygon (K, 2) (crossing number; any orientation)."""
    px, py = points_2d[:, 0], points_2d[:, 1]
    inside = np.zeros(len(points_2d), dtype=bool)
    a = polygon_2d
    b = np.roll(polygon_2d, -1, axis=0)
    for (ax, ay), (bx, by) in zip(a, b, strict=True):
        if ay == by:
            continue
        straddles = (ay > py) != (by > py)
        x_cross = ax + (py - ay) * (bx - ax) / (by - ay)
        inside ^= straddles & (px < x_cross)
    return inside


def first_hits(
    faces: Faces, camera: PinholeCamera, pixels: FloatArray, *, grid: bool = False
) -> tuple[IntArray, FloatArray, FloatArray]:
    """The first face the ray of each pixel meets, and where.

    pixels : (N, 2) undistorted pixel positions of the pinhole `camera`. Each face is tested
    only against the pixels inside its projected bounding box (all of them when the face
    reaches behind the camera). Returns face (N,) index into the faces, -1 for none; depth
    (N,) z in the camera, metres, inf for none; rays (N, 3) world-frame directions with
    z = 1 in the camera (the hit is ``centre + depth · ray``). grid : the pixels are every
    pixel centre of the camera's image, row by row (boxes are then cut out by index).
    """
    n_rays = len(pixels)
    rays_cam = np.hstack([pixels, np.ones((n_rays, 1))]) @ np.linalg.inv(camera.K).T
    rays = rays_cam @ camera.R_cam_world  # R^T · r for each row
    centre = camera.centre
    best = np.full(n_rays, np.inf)
    face = np.full(n_rays, -1, dtype=np.int64)
    for f, polygon in enumerate(faces.polygons):
        cam_pts = polygon @ camera.R_cam_world.T + camera.t_cam_world
        if np.all(cam_pts[:, 2] > MIN_DEPTH_M):
            proj = (cam_pts[:, :2] / cam_pts[:, 2:]) @ camera.K[:2, :2].T + camera.K[:2, 2]
            lo, hi = proj.min(axis=0) - 1.0, proj.max(axis=0) + 1.0
            if grid:
                x0, y0 = (max(0, math.floor(c)) for c in lo)
                x1 = min(camera.width - 1, math.ceil(hi[0]))
                y1 = min(camera.height - 1, math.ceil(hi[1]))
                if x1 < x0 or y1 < y0:
                    continue
                rows, cols = np.mgrid[y0 : y1 + 1, x0 : x1 + 1]
                box = (rows * camera.width + cols).ravel()
            else:
                box = np.nonzero(
                    (pixels[:, 0] >= lo[0])
                    & (pixels[:, 0] <= hi[0])
                    & (pixels[:, 1] >= lo[1])
                    & (pixels[:, 1] <= hi[1])
                )[0]
        elif np.any(cam_pts[:, 2] > MIN_DEPTH_M):
            box = np.arange(n_rays)
        else:
            continue
        if box.size == 0:
            continue
        n = faces.normals[f]
        denom = rays[box] @ n
        num = faces.offsets[f] - float(n @ centre)
        with np.errstate(divide="ignore", invalid="ignore"):
            lam = num / denom
        ok = (np.abs(denom) > GRAZING_COS) & (lam > 0) & (lam < best[box])
        cand = box[ok]
        if cand.size == 0:
            continue
        lam = lam[ok]
        points = centre[None, :] + lam[:, None] * rays[cand]
        hit = inside_polygon(faces.flat(f, points), faces.flat(f, polygon))
        best[cand[hit]] = lam[hit]
        face[cand[hit]] = f
    return face, best, rays


def face_buffer(faces: Faces, camera: PinholeCamera) -> tuple[IntArray, FloatArray]:
    """Which face each pixel of a pinhole camera's image sees, and the depth there.

    Returns face (H, W), -1 where no face is seen, and depth (H, W), z in metres, inf there.
    """
    ys, xs = np.mgrid[0 : camera.height, 0 : camera.width].astype(np.float64)
    pixels = np.stack([xs.ravel(), ys.ravel()], axis=1)
    face, depth, _ = first_hits(faces, camera, pixels, grid=True)
    shape = (camera.height, camera.width)
    return face.reshape(shape), depth.reshape(shape)
