"""What the reference image says for and against one closed alternative, beyond its regions.

Two alternatives may bind the same regions and fit them equally well (a gable and a flat roof
over a front wall and a gable end wall when the roof shows no region of its own): the
adjustment cannot tell them apart, the image can.

- **Edges seen** (`edge_support`): every edge of the closed solid the reference camera sees
  (`register.model.RigidModel.visible_edges`: a face turned towards the camera, not hidden by
  another), projected, and how much of its length image line segments lie along (all the
  image's segments, not only those bordering bound regions: a roof's rake against the sky
  borders no roof region). A gable's rakes and ridge are seen, a flat roof's top edges across
  the gable end wall are not.
- **Outline overflow** (`overflow`): how much of each bound region's outline lies outside the
  projection of the face it is bound to. A gable end wall's triangle reaching above a flat
  roof's eave is evidence the flat roof leaves unexplained, though the region's centre lies
  on the face (`plausibility.outside`).
- **Faces over no evidence** (`uncovered`): how much of each bound face's projection no
  region of the reference view covers at the face's depth or before it. A shed's side wall,
  rising past the rake of a gable end wall whose region it binds, lies over the sky behind
  that rake; its top, running on to a back wall the knowledge placed, over more sky or the
  ground far behind. What a face predicts and the image does
  not show counts against it as much as evidence left unexplained.

The interpreter charges all three (`interpreter.Interpreter.verify_body`); they are computed for
every verified alternative of the main body: a rasterisation of a few polygons and one
vectorised segment-to-edge matching (`register.match.match_segments`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from aida_kb.errors import GeometryError
from aida_kb.interpret.context import Context
from aida_kb.interpret.observe import CameraView
from aida_kb.interpret.verdict.tolerances import (
    FILL_BEYOND_DEPTH,
    FILL_BEYOND_SIZE,
    PLANE_INLIER_SHARE,
)
from aida_kb.register.match import match_segments
from aida_kb.register.model import RigidModel

FloatArray = npt.NDArray[np.float64]

# a segment shows a projected model edge within this distance (both ends) and angle: the
# verdict's tolerance (`verdict.EDGE_TOLERANCE_PX`, 3 px) widened by a pixel, since an
# alternative is judged at its interpretation's adjustment, before the multi-view refinement
EDGE_TOLERANCE_PX = 4.0
EDGE_ANGLE_DEG = 4.0
# projected edges shorter than this are not judged (a few segment pixels decide nothing)
EDGE_MIN_LENGTH_PX = 25.0
# a region's outline may reach this far beyond its face's projection (segmentation borders
# are good to a few pixels; the plane fit and the adjustment move the face by about as much)
OVERFLOW_MARGIN_PX = 4.0
# up to this share of a region's area may lie outside its face without counting: the faces
# an alternative inserts are placed by the knowledge (least extents) and segmentation bleeds
# over corners, leaving a few per cent outside (a gable end wall's triangle above a flat
# roof's eave is a fifth to a half of the wall's region)
OVERFLOW_FREE = 0.1
# up to this share of a bound face's projection may lie where no region of the reference view
# does, without counting: segmentation leaves a few pixels' gap along borders and corners, and
# the knowledge places the unseen faces that bound it (dev 65005, a gable: its bound faces
# leave 0.9 %, 10 % and 20 % of their projections uncovered; a shed over the same regions 0.5 %,
# 29 % and 46 %)
UNCOVERED_FREE = 0.1
# outlines are rasterised at this fraction of the image's resolution (a share of an area is
# wanted, not its pixels)
RASTER_SCALE = 0.5


@dataclass(frozen=True)
class EdgeSupport:
    """The edges of a closed alternative the reference camera sees, and what segments show.

    parts : (E, 2) role paths of each edge's two faces; length_px : (E,) projected visible
    length, pixels; seen_px : (E,) of it the length image segments lie along, pixels.
    """

    parts: tuple[tuple[str, str], ...]
    length_px: FloatArray
    seen_px: FloatArray

    @classmethod
    def empty(cls) -> EdgeSupport:
        """No edge seen or visible."""
        return cls((), np.zeros(0), np.zeros(0))

    def share(self, roles: frozenset[str] | None = None) -> float | None:
        """The seen share of the visible length of the edges with a face in `roles` (None:
        of every edge); None when there is no such edge."""
        sel = np.array(
            [roles is None or bool(roles.intersection(p)) for p in self.parts], dtype=bool
        )
        if not sel.any():
            return None
        total = float(self.length_px[sel].sum())
        return float(self.seen_px[sel].sum()) / total if total > 0 else None


def edge_support(
    ctx: Context, planes: dict[str, tuple[FloatArray, float]], polygons: dict[str, FloatArray]
) -> EdgeSupport:
    """The closed solid's edges the reference camera sees and the segments along them.

    planes : role path -> (unit outward normal (3,), offset m), world frame; polygons : role
    path -> closed face (K, 3), metres, world frame (only faces with both are used).
    """
    names = [r for r in polygons if r in planes and len(polygons[r]) >= 3]
    empty = EdgeSupport.empty()
    if len(names) < 2:
        return empty
    try:
        rigid = RigidModel.from_polygons(
            names,
            [planes[r][0] for r in names],
            [planes[r][1] for r in names],
            [polygons[r] for r in names],
        )
    except GeometryError:
        return empty
    camera = ctx.evidence.camera
    edges = rigid.visible_edges(camera.pinhole, min_length_px=EDGE_MIN_LENGTH_PX)
    parts = tuple(
        (rigid.names[int(a)], rigid.names[int(b)]) for a, b in rigid.edge_faces[edges.index]
    )
    seen = np.zeros(edges.index.size)
    lines = ctx.evidence.lines_px.get(camera.view)
    if edges.index.size and lines is not None and len(lines):
        p1, p2 = lines[:, 0, :], lines[:, 1, :]
        m = match_segments(
            edges.a,
            edges.b,
            p1,
            p2,
            max_distance_px=EDGE_TOLERANCE_PX,
            max_angle_rad=math.radians(EDGE_ANGLE_DEG),
        )
        if m.size:
            a, b = edges.a[m.edge], edges.b[m.edge]
            length = edges.length_px[m.edge]
            u = (b - a) / np.maximum(length, 1e-12)[:, None]
            t1 = np.einsum("mk,mk->m", p1[m.segment] - a, u)
            t2 = np.einsum("mk,mk->m", p2[m.segment] - a, u)
            lo = np.clip(np.minimum(t1, t2), 0.0, length)
            hi = np.clip(np.maximum(t1, t2), 0.0, length)
            np.add.at(seen, m.edge, hi - lo)  # pieces of one edge rarely overlap
    return EdgeSupport(parts, edges.length_px, np.minimum(seen, edges.length_px))


def _raster(camera: CameraView) -> tuple[float, int, int, int]:
    """The raster the outlines and faces are drawn in: its scale (`RASTER_SCALE`), width and
    height, pixels, and `OVERFLOW_MARGIN_PX` in its pixels (at least one)."""
    scale = RASTER_SCALE
    width = max(1, math.ceil(camera.width_px * scale))
    height = max(1, math.ceil(camera.height_px * scale))
    return scale, width, height, max(1, round(OVERFLOW_MARGIN_PX * scale))


def _face_pixels(camera: CameraView, face: FloatArray) -> FloatArray | None:
    """(K, 2) the pinhole pixels of a face's corners (`face` (K, 3), metres, world), clipped
    to +-1e6; None unless every corner lies in front of the camera."""
    depth = face @ camera.R_cam_world[2] + camera.t_cam_world[2]
    if not np.all(depth > 0):
        return None
    return np.clip(camera.pinhole.project(face), -1e6, 1e6)


def overflow(ctx: Context, binding: dict[str, str], polygons: dict[str, FloatArray]) -> float:
    """The evidence weight of the bound regions lying outside their faces' projections.

    For each bound region (``binding``: region id -> role path), the share of its outline's
    area (reference image) farther than `OVERFLOW_MARGIN_PX` outside its face's projection
    (``polygons``: role path -> (K, 3), metres, world; `outside_share`) beyond
    `OVERFLOW_FREE`, times its weight; summed. Regions without an outline, or whose face is
    not wholly in front of the camera, count 0.
    """
    total = 0.0
    for rid, role in sorted(binding.items()):
        region = ctx.evidence.regions.get(rid)
        face = polygons.get(role)
        share = outside_share(ctx, rid, face) if face is not None else None
        if region is not None and share is not None:
            total += region.weight * max(0.0, share - OVERFLOW_FREE)
    return total


def outside_share(ctx: Context, rid: str, face: FloatArray) -> float | None:
    """The share of region `rid`'s outline area (reference image) farther than
    `OVERFLOW_MARGIN_PX` outside the projection of `face` ((K, 3), metres, world); the pieces
    outside it that reach the image's edge do not count (`_reaching_edge`). None when the
    region has no outline (or no area), the face fewer than 3 corners, or a corner behind
    the camera."""
    camera = ctx.evidence.camera
    outlines = ctx.evidence.outlines.get(rid, ())
    if not outlines or len(face) < 3 or rid not in ctx.evidence.regions:
        return None
    face_px = _face_pixels(camera, face)
    if face_px is None:
        return None
    scale, width, height, margin = _raster(camera)
    kernel = np.ones((2 * margin + 1, 2 * margin + 1), np.uint8)
    mask = np.zeros((height, width), np.uint8)
    cv2.fillPoly(mask, [np.round(o * scale).astype(np.int32) for o in outlines], 1)
    area = int(mask.sum())
    if area == 0:
        return None
    face_mask = np.zeros_like(mask)
    cv2.fillPoly(face_mask, [np.round(face_px * scale).astype(np.int32)], 1)
    near = cv2.dilate(face_mask, kernel) > 0
    beyond = ((mask > 0) & ~near).astype(np.uint8)
    outside = int(np.count_nonzero(beyond)) - _reaching_edge(beyond, outlines, camera, scale)
    return outside / area


def _reaching_edge(
    beyond: npt.NDArray[np.uint8],
    outlines: tuple[FloatArray, ...],
    camera: CameraView,
    scale: float,
) -> int:
    """How many raster pixels of ``beyond`` (H, W; a region's area outside its face) lie in
    pieces that reach the image's edge: pieces holding one of the region's outline vertices
    (pixels, undistorted) on the original image's edge (`observe.CameraView.on_image_edge`).

    There the image ends, not the surface: a region that leaks through textureless
    background to the image's edge (dev 64033: a wall's region in strips out to the left
    edge) says nothing of where its surface ends, and the faces are placed without those
    vertices (`observe.EvidenceView.points_on`); nor does a wall the image cuts off.
    """
    vertices = np.concatenate(outlines)
    on_edge = vertices[camera.on_image_edge(vertices)]
    if len(on_edge) == 0 or not beyond.any():
        return 0
    _, pieces = cv2.connectedComponents(beyond, connectivity=8)
    height, width = beyond.shape
    at = np.clip(np.round(on_edge * scale).astype(np.intp), 0, [width - 1, height - 1])
    touched = np.unique(pieces[at[:, 1], at[:, 0]])
    touched = touched[touched > 0]
    return int(np.isin(pieces, touched).sum()) if len(touched) else 0


def uncovered(ctx: Context, binding: dict[str, str], polygons: dict[str, FloatArray]) -> float:
    """The share of the reference view's region pixels that bound faces cover over nothing.

    For each face a region is bound to (``binding``: region id -> role path; ``polygons``:
    role path -> closed face (K, 3), metres, world), the pixels of its projection, at least
    `OVERFLOW_MARGIN_PX` inside its outline, where no region of the reference view lies at
    its depth or before it: no region at all (the sky), or one whose fitted plane lies
    clearly beyond the face along the pixel's ray (the ground behind the house; "clearly" as
    the verdict's check (j), `FILL_BEYOND_DEPTH` of the face's depth and `FILL_BEYOND_SIZE`
    of the solid's size). A region whose fit kept under `PLANE_INLIER_SHARE` of its pixels
    tells no depth: it covers. The pixels beyond `UNCOVERED_FREE` of each face's projection
    are summed and divided by the view's region pixels, in [0, 1) mostly. Faces not wholly
    in front of the camera count 0; so does everything where a region of the view has no
    outline (evidence without contours: where that region lies is not known).
    """
    camera = ctx.evidence.camera
    scale, width, height, margin = _raster(camera)
    view = ctx.evidence.reference_view
    regions = sorted(
        (r for r in ctx.evidence.regions.values() if r.view == view), key=lambda r: -r.area_px
    )
    if not regions or any(not ctx.evidence.outlines.get(r.id) for r in regions):
        return 0.0
    ids = np.full((height, width), -1, np.int32)  # the region each pixel shows (index), -1 none
    for k, region in enumerate(regions):  # the largest first: a smaller one in it stays
        for outline in ctx.evidence.outlines[region.id]:
            # one by one: a hole's outline (a window) is its region's too
            cv2.fillPoly(ids, [np.round(outline * scale).astype(np.int32)], k)
    normals = np.array([r.normal for r in regions], dtype=np.float64)
    offsets = np.array([r.offset_m for r in regions], dtype=np.float64)
    deep = np.array(
        [r.inliers is None or r.inliers >= PLANE_INLIER_SHARE * r.area_px for r in regions]
    )
    corners = np.concatenate([p for p in polygons.values() if len(p)])
    size = float(np.max(np.ptp(corners, axis=0))) if len(corners) else 0.0
    centre = camera.centre_m
    to_world = camera.R_cam_world.T @ np.linalg.inv(camera.K)
    kernel = np.ones((2 * margin + 1, 2 * margin + 1), np.uint8)
    bare_px = 0.0
    for role in sorted(set(binding.values())):
        face = polygons.get(role)
        if face is None or len(face) < 3:
            continue
        face_px = _face_pixels(camera, face)
        if face_px is None:
            continue
        mask = np.zeros((height, width), np.uint8)
        cv2.fillPoly(mask, [np.round(face_px * scale).astype(np.int32)], 1)
        area = int(mask.sum())
        ys, xs = np.nonzero(cv2.erode(mask, kernel))
        if area == 0 or len(ys) == 0:
            continue
        # each pixel's ray (world, unit camera depth) and the face's depth along it
        rays = np.stack([xs / scale, ys / scale, np.ones(len(xs))], axis=-1) @ to_world.T
        middle = face.mean(axis=0)
        normal = np.linalg.svd(face - middle)[2][-1]  # the face's plane (a closed polygon)
        shown = ids[ys, xs]
        at = np.maximum(shown, 0)
        with np.errstate(divide="ignore", invalid="ignore"):
            z_face = float(normal @ (middle - centre)) / (rays @ normal)
            z_region = (offsets[at] - normals[at] @ centre) / np.einsum(
                "ij,ij->i", rays, normals[at]
            )
        tol = np.maximum(FILL_BEYOND_DEPTH * z_face, FILL_BEYOND_SIZE * size)
        beyond = deep[at] & np.isfinite(z_region) & (z_region > z_face + tol)
        bare = int(np.count_nonzero((shown < 0) | beyond))
        bare_px += max(0.0, bare - UNCOVERED_FREE * area) / (scale * scale)
    total_px = sum(r.area_px for r in regions)
    return bare_px / total_px if total_px > 0 else 0.0
