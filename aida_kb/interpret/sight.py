"""What the views of a synthetic scene show of its true object: the limit of any interpretation.

For evaluation only, like `aida_kb.interpret.evaluate`: it reads the scene's truth and the
renderer's depth maps (``views/NN/depth_left.npy``), which the pipeline never sees.

A true part can be measured when some view shows it:

- its **face**: at least ``SEEN_PX`` pixels of it visible in a left image (in front of the
  camera, inside the image, turned to the camera and not hidden: the rendered depth agrees
  with the face's to ``DEPTH_AGREEMENT``); fewer pixels than the vision's smallest region
  cannot become a region; or
- one of its **edges**: at least ``EDGE_SEEN_SHARE`` of the edge visible in one left image
  (the rendered depth within a pixel of it agrees with the edge's) over at least
  ``EDGE_SEEN_PX`` pixels of the image. A face that is itself hidden is placed by such an edge
  (the back wall by the side wall's far outline) and oriented by the knowledge.

A part neither way visible (the back wall of a house seen straight from the front: its
depth is the knowledge's guess) cannot be placed to the evaluation's 2 % by any
interpretation; `evaluate` reports such parts apart from the failures of the pipeline.

Visible pixels are counted from samples on a grid inside each face: a sample of area dA
(square metres) at distance r from the camera centre and depth z, on a face whose normal
makes the angle theta with the ray, covers about ``fx·fy·dA·cos(theta)·r / z**3`` pixels.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import cv2
import numpy as np
import numpy.typing as npt

from aida_kb.errors import FormatError
from aida_kb.io.scene import read_depth

if TYPE_CHECKING:
    from aida_kb.io.scene import PartTruth, Scene, SceneView

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

SEEN_PX = 200.0
"""A face is seen by a view that shows this many of its pixels: the vision's smallest region
(`aida_kb.vision.evidence.EvidenceParams.min_region_px`); fewer cannot be measured as a region."""
EDGE_SEEN_SHARE = 0.5
"""An edge is seen by a view that shows half of its length: enough for a segment to be fitted
along it (the verdict's edge checks ask for the same share of a model edge)."""
EDGE_SEEN_PX = 20.0
"""... and at least this many pixels of it: a shorter piece fixes no direction to a degree."""
DEPTH_AGREEMENT = 0.02
"""A point is visible where the rendered depth agrees with its own to 2 % (else something is in
front of it); as `aida_kb.testing.colmap` decides which tie points a view observes."""
EDGE_REACH_PX = 1
"""An edge lies on a depth step: a point of it is visible where any depth within this many
pixels agrees with its own (the pixel on the near side of the step)."""
FACE_GRID = 48
"""Samples per side of the grid laid over each face's bounding rectangle (about 48**2 / 2
inside a typical face: each covers well under a region's smallest size)."""
EDGE_SAMPLES = 32
"""Samples along each edge, ends excluded (a corner is on several edges)."""


@dataclass(frozen=True)
class PartSight:
    """How well the views show one true part.

    role : the part's role path. face_px : the most pixels of its face one view shows.
    edge_share : the largest visible share of one of its edges in one view (0 to 1), among
    edges at least ``EDGE_SEEN_PX`` long there. best_view : the view showing most of the face
    ('' when none shows any).
    """

    role: str
    face_px: float
    edge_share: float
    best_view: str

    @property
    def measurable(self) -> bool:
        """Some view shows the face or one of its edges well enough to measure it."""
        return self.face_px >= SEEN_PX or self.edge_share >= EDGE_SEEN_SHARE


def _face_samples(polygon: FloatArray, normal: FloatArray) -> tuple[FloatArray, float]:
    """Points (k, 3) on a grid inside the planar `polygon` (V, 3), metres, and the area each
    one stands for (square metres)."""
    u = polygon[1] - polygon[0]
    u = u / np.linalg.norm(u)
    v = np.cross(normal, u)
    uv = np.column_stack([(polygon - polygon[0]) @ u, (polygon - polygon[0]) @ v])
    lo, hi = uv.min(axis=0), uv.max(axis=0)
    step = np.maximum(hi - lo, 1e-9) / FACE_GRID
    # the polygon rasterised on the grid: cell (i, j) is inside when its centre is (fillPoly
    # tests the pixel at integer (i, j): the polygon is shifted by half a cell; 4 fractional bits)
    cells = np.round(((uv - lo) / step - 0.5) * 16).astype(np.int32)
    mask = np.zeros((FACE_GRID, FACE_GRID), np.uint8)
    cv2.fillPoly(mask, [cells.reshape(-1, 1, 2)], (1,), lineType=cv2.LINE_8, shift=4)
    j, i = np.nonzero(mask)
    pts = np.column_stack([lo[0] + (i + 0.5) * step[0], lo[1] + (j + 0.5) * step[1]])
    world: FloatArray = polygon[0] + pts[:, :1] * u + pts[:, 1:] * v
    return world, float(step[0] * step[1])


def _edge_samples(polygon: FloatArray) -> FloatArray:
    """Points (E, EDGE_SAMPLES, 3) along each of the polygon's E edges, ends excluded."""
    a, b = polygon, np.roll(polygon, -1, axis=0)
    s = (np.arange(EDGE_SAMPLES) + 0.5) / EDGE_SAMPLES
    out: FloatArray = a[:, None, :] + s[None, :, None] * (b - a)[:, None, :]
    return out


def _project(
    view: SceneView, R: FloatArray, t: FloatArray, world: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Pixels (N, 2) of `world` (N, 3) in the view's left image (with its distortion) and
    the points in the camera frame (N, 3), metres."""
    rig = view.rig
    cam: FloatArray = world @ R.T + t
    px, _ = cv2.projectPoints(world, cv2.Rodrigues(R)[0], t, rig.K1, rig.D1)
    return px.reshape(-1, 2).astype(np.float64), cam


def _depth_agrees(
    depth: npt.NDArray[np.float32], px: FloatArray, z: FloatArray, reach: int
) -> BoolArray:
    """Whether the rendered `depth` (H, W) within `reach` pixels of `px` (N, 2) agrees with
    the depths `z` (N,) to DEPTH_AGREEMENT; False outside the image or behind the camera."""
    h, w = depth.shape
    base = np.round(px).astype(np.int64)
    ok = np.zeros(len(px), dtype=bool)
    inside = (z > 0) & (base[:, 0] >= 0) & (base[:, 0] < w) & (base[:, 1] >= 0)
    inside &= base[:, 1] < h
    for dy in range(-reach, reach + 1):
        for dx in range(-reach, reach + 1):
            x = np.clip(base[:, 0] + dx, 0, w - 1)
            y = np.clip(base[:, 1] + dy, 0, h - 1)
            d = depth[y, x].astype(np.float64)
            ok |= np.isfinite(d) & (np.abs(d - z) <= DEPTH_AGREEMENT * np.abs(z))
    out: BoolArray = ok & inside
    return out


def _view_sight(
    view: SceneView, R: FloatArray, t: FloatArray, part: PartTruth, depth: npt.NDArray[np.float32]
) -> tuple[float, float]:
    """(visible face pixels, largest visible edge share) of `part` in one view."""
    polygon = np.asarray(part.polygon, dtype=np.float64)
    normal = np.asarray(part.normal, dtype=np.float64)
    centre = -R.T @ t
    world, area = _face_samples(polygon, normal)
    face_px = 0.0
    if len(world):
        px, cam = _project(view, R, t, world)
        ray = centre - world
        r = np.linalg.norm(ray, axis=1)
        cos = (ray @ normal) / np.maximum(r, 1e-12)
        seen = _depth_agrees(depth, px, cam[:, 2], 0) & (cos > 0)
        K = view.rig.K1
        z = np.maximum(cam[:, 2], 1e-9)
        face_px = float(np.sum(np.where(seen, K[0, 0] * K[1, 1] * area * cos * r / z**3, 0.0)))
    edges = _edge_samples(polygon)
    px, cam = _project(view, R, t, edges.reshape(-1, 3))
    seen = _depth_agrees(depth, px, cam[:, 2], EDGE_REACH_PX).reshape(edges.shape[:2])
    px = px.reshape(*edges.shape[:2], 2)
    length_px = np.linalg.norm(px[:, -1] - px[:, 0], axis=1) * EDGE_SAMPLES / (EDGE_SAMPLES - 1)
    share = seen.mean(axis=1)
    long_enough = share * length_px >= EDGE_SEEN_PX
    return face_px, float(np.max(np.where(long_enough, share, 0.0), initial=0.0))


def part_sights(scene: Scene) -> list[PartSight] | None:
    """How well the scene's views show every true part (`PartSight`, in truth.json's order).

    None when the scene has no truth or a view has no rendered depth (only synthetic scenes
    have both), or one that `read_depth` refuses (a render's depth behind the camera, seen at
    development seed 63002: negative depths).
    """
    truth = scene.truth
    if truth is None or any(v.depth_left is None for v in scene.views):
        return None
    looks: list[list[tuple[float, float, str]]] = [[] for _ in truth.parts]
    for view in scene.views:
        assert view.depth_left is not None  # checked above
        try:
            pose = truth.pose(view.id)
        except KeyError:
            continue
        R = np.asarray(pose.R, dtype=np.float64)
        t = np.asarray(pose.t, dtype=np.float64)
        try:
            depth = read_depth(view.depth_left)
        except FormatError:  # not a depth map the format allows: nothing can be claimed
            return None
        for k, part in enumerate(truth.parts):
            face_px, edge_share = _view_sight(view, R, t, part, depth)
            looks[k].append((face_px, edge_share, view.id))
    out = []
    for part, seen in zip(truth.parts, looks, strict=True):
        best = max(seen, default=(0.0, 0.0, ""))
        out.append(
            PartSight(
                part.role,
                round(best[0], 1),
                round(max((s[1] for s in seen), default=0.0), 3),
                best[2] if best[0] > 0 else "",
            )
        )
    return out


def unmeasurable(sights: list[PartSight] | None) -> tuple[str, ...] | None:
    """The role paths of the parts no view shows well enough to measure (None: not known,
    without sights)."""
    if sights is None:
        return None
    return tuple(s.role for s in sights if not s.measurable)


def unseen_parts(scene: Scene) -> tuple[str, ...] | None:
    """The role paths of the scene's true parts no view shows well enough to measure
    (`part_sights`, then `unmeasurable`); None when that is not known."""
    return unmeasurable(part_sights(scene))
