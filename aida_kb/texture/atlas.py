"""Texture the model: back-project the images of every view onto its faces, into one atlas.

For each face a grid of texels is laid on its plane (metres per texel from the finest view
that sees the model, within an atlas budget). Each camera of each view (left and right of a
stereo pair; poses from the model file, distortion from the scene's calibration) offers a
colour for a texel when

* the face is turned towards the camera,
* the texel's pixel, and its 2x2 bilinear neighbourhood, see that same face in the camera's
  face buffer (`raycast.face_buffer`, a depth test against the model itself: a wing's face
  hidden behind the body does not receive the body's pixels),

sampled bilinearly from the *original* image at the texel's distorted projection
(OpenCV's distortion model with the calibration's coefficients: no rectification involved).
A face takes its colour from the view that sees it best (the largest sum over its texels of
cos(angle) · pixels per metre², raised to `DOMINANCE` against the best), blended with the
others where that view's visibility ends (weights feathered over `FEATHER_TEXELS` from the
edge of each camera's visible area), so that seams are soft. Texels no camera sees take the
colour of the nearest seen texel within `EDGE_FILL_TEXELS`, else the neutral grey; a face with
less than `MIN_SEEN_FRACTION` of its texels seen is *unseen*: neutral material, marked so.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt
from scipy import ndimage

from aida_kb.geometry.camera import PinholeCamera
from aida_kb.io.export import UNSEEN_RGB, Atlas
from aida_kb.io.model import ReconstructedModel
from aida_kb.io.scene import Scene, read_image
from aida_kb.register.evidence import camera_of
from aida_kb.texture.raycast import Faces, IntArray, face_buffer, inside_polygon
from aida_kb.texture.sample import sample_bilinear
from aida_kb.vision.rectify import distort_pixels

FloatArray = npt.NDArray[np.float64]
U8 = npt.NDArray[np.uint8]

# the atlas holds at most this many texels (a 2048 x 2048 texture: every viewer loads it)
MAX_ATLAS_TEXELS = 2048 * 2048
# texels of padding around each face's rectangle (texture filtering reads neighbours)
PAD_TEXELS = 2
# a texel finer than this fraction of the finest view's pixel footprint adds no detail
TEXEL_PER_PIXEL = 1.0
# weights fall to zero over this many texels towards the edge of a camera's visible area
FEATHER_TEXELS = 6.0
# how strongly the best view dominates: weight (score / best score) ** DOMINANCE
DOMINANCE = 4.0
# unseen texels this close to seen ones take the nearest seen colour (the 2x2 rule and a
# model a pixel off leave a thin unseen band along a face's edges)
EDGE_FILL_TEXELS = 4.0
# a face no camera sees gets a chart this many texels a side (it is drawn neutral anyway)
UNSEEN_CHART_TEXELS = 4
# a face with less than this fraction of its texels seen is unseen (neutral, marked)
MIN_SEEN_FRACTION = 0.02


@dataclass(frozen=True)
class TextureCamera:
    """One camera that took an image: its name ("00/left"), pinhole model, distortion, image.

    image : (H, W, 3) uint8 RGB, the original (distorted) image. D : OpenCV coefficients.
    """

    name: str
    camera: PinholeCamera
    D: FloatArray
    image: U8


def scene_cameras(model: ReconstructedModel, scene: Scene) -> list[TextureCamera]:
    """The left and right cameras of every view of `model` that `scene` holds.

    Poses: the model file's (x_cam = R·x_world + t); the right camera follows the left by the
    calibration (R_right = R_calib·R, t_right = R_calib·t + T_calib).
    """
    known = {v.id for v in scene.views}
    out = []
    for cam in model.cameras:
        if cam.view not in known:
            continue
        view = scene.view(cam.view)
        calib = view.rig
        left = camera_of(cam)
        R, t = left.R_cam_world, left.t_cam_world
        w, h = left.width, left.height
        right = PinholeCamera(
            np.asarray(calib.K2, dtype=np.float64), calib.R @ R, calib.R @ t + calib.T, w, h
        )
        for side, pin, D, path in (
            ("left", left, calib.D1, view.left),
            ("right", right, calib.D2, view.right),
        ):
            image = read_image(path)[:, :, ::-1].copy()
            out.append(TextureCamera(f"{cam.view}/{side}", pin, np.asarray(D, np.float64), image))
    return out


@dataclass(frozen=True)
class _Chart:
    """A face's rectangle in the atlas and its texels' 3-D points."""

    x0: int
    y0: int
    w: int
    h: int
    origin: FloatArray  # (2,) plane coordinates (u_min, v_max) of the rectangle's corner
    inside: npt.NDArray[np.bool_]  # (h, w) texel centre inside the face's polygon


def _texel_sizes(
    faces: Faces, cameras: Sequence[TextureCamera], buffers: Sequence[tuple[IntArray, FloatArray]]
) -> FloatArray:
    """Metres per texel of each face (F,): the finest pixel footprint any camera has on it.

    A face no camera sees gets `UNSEEN_CHART_TEXELS` texels a side. Within the atlas budget
    every size grows by one factor.
    """
    n = len(faces.polygons)
    sizes = np.full(n, np.inf)
    extents = []
    for f, polygon in enumerate(faces.polygons):
        flat = faces.flat(f, polygon)
        extents.append(np.ptp(flat, axis=0))
    for cam, (face, depth) in zip(cameras, buffers, strict=True):
        hits = face >= 0
        if not np.any(hits):
            continue
        ids = face[hits]
        count = np.bincount(ids, minlength=n)
        mean_depth = np.bincount(ids, weights=depth[hits], minlength=n) / np.maximum(count, 1)
        footprint = mean_depth / float(cam.camera.K[0, 0]) / TEXEL_PER_PIXEL
        sizes = np.where(count > 0, np.minimum(sizes, footprint), sizes)
    for f in range(n):
        if not np.isfinite(sizes[f]):
            sizes[f] = max(float(np.max(extents[f])), 1e-6) / UNSEEN_CHART_TEXELS
    area = sum(
        float((e[0] / s + 2 * PAD_TEXELS) * (e[1] / s + 2 * PAD_TEXELS))
        for e, s in zip(extents, sizes, strict=True)
    )
    if area > MAX_ATLAS_TEXELS:
        sizes *= math.sqrt(area / MAX_ATLAS_TEXELS)
    return sizes


def _layout(faces: Faces, sizes: FloatArray) -> tuple[list[_Chart], int, int]:
    """Shelf-pack the faces' rectangles; the charts and the atlas width and height."""
    dims = []
    for f, polygon in enumerate(faces.polygons):
        flat = faces.flat(f, polygon)
        lo, hi = flat.min(axis=0), flat.max(axis=0)
        w = math.ceil((hi[0] - lo[0]) / sizes[f]) + 2 * PAD_TEXELS
        h = math.ceil((hi[1] - lo[1]) / sizes[f]) + 2 * PAD_TEXELS
        dims.append((w, h, np.array([lo[0], hi[1]])))
    total = sum(w * h for w, h, _ in dims)
    width = max(max(w for w, _, _ in dims), math.ceil(math.sqrt(total * 1.2)))
    order = sorted(range(len(dims)), key=lambda k: -dims[k][1])
    x = y = shelf = 0
    place: dict[int, tuple[int, int]] = {}
    for k in order:
        w, h, _ = dims[k]
        if x + w > width:
            x, y, shelf = 0, y + shelf, 0
        place[k] = (x, y)
        x += w
        shelf = max(shelf, h)
    height = y + shelf
    charts = []
    for k, (w, h, origin) in enumerate(dims):
        x0, y0 = place[k]
        flat = faces.flat(k, faces.polygons[k])
        cols, rows = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
        pu = origin[0] + (cols - PAD_TEXELS) * sizes[k]
        pv = origin[1] - (rows - PAD_TEXELS) * sizes[k]
        inside = inside_polygon(np.stack([pu.ravel(), pv.ravel()], axis=1), flat).reshape(h, w)
        charts.append(_Chart(x0, y0, w, h, origin, inside))
    return charts, width, height


def _texel_points(faces: Faces, f: int, chart: _Chart, size_m: float) -> FloatArray:
    """World points (h·w, 3) of the chart's texel centres on face f's plane."""
    cols, rows = np.meshgrid(np.arange(chart.w) + 0.5, np.arange(chart.h) + 0.5)
    pu = chart.origin[0] + (cols.ravel() - PAD_TEXELS) * size_m
    pv = chart.origin[1] - (rows.ravel() - PAD_TEXELS) * size_m
    base = faces.offsets[f] * faces.normals[f]
    out: FloatArray = base + pu[:, None] * faces.u[f] + pv[:, None] * faces.v[f]
    return out


def distorted_pixels(points_cam: FloatArray, K: FloatArray, D: FloatArray) -> FloatArray:
    """Pixels (N, 2) of camera-frame points (N, 3) in the original (distorted) image
    (`aida_kb.vision.rectify.distort_pixels` of their pinhole pixels)."""
    pinhole = points_cam @ K.T
    return distort_pixels(pinhole[:, :2] / pinhole[:, 2:3], K, D)


def _visible(buffer: IntArray, f: int, pixels: FloatArray, z: FloatArray) -> npt.NDArray[np.bool_]:
    """Texels whose 2x2 bilinear pixel neighbourhood all sees face f (and lie in front)."""
    h, w = buffer.shape
    x0 = np.floor(pixels[:, 0]).astype(np.int64)
    y0 = np.floor(pixels[:, 1]).astype(np.int64)
    ok = (z > 0) & (x0 >= 0) & (y0 >= 0) & (x0 + 1 < w) & (y0 + 1 < h)
    xs, ys = np.where(ok, x0, 0), np.where(ok, y0, 0)
    for dx, dy in ((0, 0), (1, 0), (0, 1), (1, 1)):
        ok &= buffer[ys + dy, xs + dx] == f
    out: npt.NDArray[np.bool_] = ok
    return out


def build_atlas(model: ReconstructedModel, cameras: Sequence[TextureCamera]) -> Atlas:
    """The texture atlas of `model` from `cameras` (see the module docstring)."""
    faces = Faces.of(model)
    depth_buffers = [face_buffer(faces, cam.camera) for cam in cameras]
    buffers = [b for b, _ in depth_buffers]
    sizes = _texel_sizes(faces, cameras, depth_buffers)
    charts, width, height = _layout(faces, sizes)
    atlas = np.empty((height, width, 3), np.float64)
    atlas[:] = np.array(UNSEEN_RGB) * 255.0
    uvs: list[FloatArray] = []
    seen: list[bool] = []
    sources: list[tuple[str, ...]] = []
    for f, chart in enumerate(charts):
        size_m = float(sizes[f])
        points = _texel_points(faces, f, chart, size_m)
        n = faces.normals[f]
        inside = chart.inside.ravel()
        colours: list[FloatArray | None] = []
        weights: list[FloatArray] = []
        scores: list[float] = []
        for cam, buffer in zip(cameras, buffers, strict=True):
            pin = cam.camera
            towards = pin.centre - points
            dist = np.linalg.norm(towards, axis=1)
            cos = (towards @ n) / np.maximum(dist, 1e-12)
            if not np.any(cos > 0):
                colours.append(None)
                weights.append(np.zeros(len(points)))
                scores.append(0.0)
                continue
            cam_pts = points @ pin.R_cam_world.T + pin.t_cam_world
            zc = cam_pts[:, 2]
            safe = np.where(zc > 1e-9, zc, 1.0)
            pix = (cam_pts[:, :2] / safe[:, None]) @ pin.K[:2, :2].T + pin.K[:2, 2]
            vis = _visible(buffer, f, pix, zc) & inside & (cos > 0)
            if not np.any(vis):
                colours.append(None)
                weights.append(np.zeros(len(points)))
                scores.append(0.0)
                continue
            density = cos * (float(pin.K[0, 0]) / safe) ** 2  # pixels per m², foreshortened
            scores.append(float(np.sum(density[vis])))
            distorted = distorted_pixels(cam_pts[vis], pin.K, cam.D)
            colour = np.zeros((len(points), 3))
            colour[vis] = sample_bilinear(cam.image, *distorted.T)
            colours.append(colour)
            # feather towards the edge of the visible area (not towards the polygon's edge)
            mask = (vis | ~inside).reshape(chart.h, chart.w).astype(np.uint8)
            edge = cv2.distanceTransform(mask, cv2.DIST_L2, 3).ravel()
            weights.append(np.where(vis, np.clip(edge / FEATHER_TEXELS, 0.0, 1.0), 0.0))
        best = max(scores, default=0.0)  # no camera at all: every face unseen
        total = np.zeros(len(points))
        mixed = np.zeros((len(points), 3))
        for offered, weight, score in zip(colours, weights, scores, strict=True):
            if offered is None or best <= 0:
                continue
            w = weight * (score / best) ** DOMINANCE
            total += w
            mixed += w[:, None] * offered
        got = total > 0
        fraction = float(np.count_nonzero(got & inside)) / max(1, int(np.count_nonzero(inside)))
        is_seen = fraction >= MIN_SEEN_FRACTION
        tile = np.empty((len(points), 3))
        tile[:] = np.array(UNSEEN_RGB) * 255.0
        if is_seen:
            tile[got] = mixed[got] / total[got, None]
            dist, (iy, ix) = ndimage.distance_transform_edt(
                ~got.reshape(chart.h, chart.w), return_indices=True
            )
            near = tile.reshape(chart.h, chart.w, 3)[iy, ix].reshape(-1, 3)
            fill = ~got & ((dist.ravel() <= EDGE_FILL_TEXELS) | ~inside)
            tile[fill] = near[fill]
        atlas[chart.y0 : chart.y0 + chart.h, chart.x0 : chart.x0 + chart.w] = tile.reshape(
            chart.h, chart.w, 3
        )
        seen.append(is_seen)
        order = sorted((k for k, s in enumerate(scores) if s > 0), key=lambda k: -scores[k])
        sources.append(tuple(cameras[k].name for k in order))
        flat = faces.flat(f, faces.polygons[f])
        col = (flat[:, 0] - chart.origin[0]) / size_m + PAD_TEXELS + chart.x0
        row = (chart.origin[1] - flat[:, 1]) / size_m + PAD_TEXELS + chart.y0
        uvs.append(np.stack([col / width, 1.0 - row / height], axis=1))
    image = np.clip(np.round(atlas), 0, 255).astype(np.uint8)
    return Atlas(image=image, uv=tuple(uvs), seen=tuple(seen), views=tuple(sources))


def texture_model(model: ReconstructedModel, scene: Scene) -> Atlas:
    """`build_atlas` with every camera of `scene` that `model` has a pose for."""
    return build_atlas(model, scene_cameras(model, scene))
