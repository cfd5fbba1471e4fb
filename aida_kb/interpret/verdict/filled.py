"""Check (j) in one view: every model face the view sees is filled by surfaces at its depth.

Checks (b) and (g) judge each region by the ray through its centre. A face whose projection
lies over the surface *behind* the object (the ground beyond a roof that is not there) is
missed when no region's centre falls inside it: a gable taken for a shed (held-out 61325,
vertices 21 % off) has the shed's tall side wall where the view sees the gable's pentagon
and, above it, the ground behind the house. Here the faces are rasterised in the view's
model camera (a depth buffer: only the visible part of each face counts) and so are the
regions (their outlines, filled); at every pixel of a face the region there, extended on its
fitted plane, is either at the face's depth (a surface is there), clearly beyond it (seen
*through* the model: a contradiction) or before it (an occluder: neither way).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from aida_kb.interpret.verdict.geometry import FloatArray, model_faces, model_size
from aida_kb.interpret.verdict.tolerances import (
    FILL_BEYOND_DEPTH,
    FILL_BEYOND_SIZE,
    FILL_CONTRADICTED_MAX,
    FILL_EDGE_PX,
    FILL_MIN_SHARE,
    FILL_NEAR_Z,
    NORMAL_TOLERANCE_DEG,
    PLANE_INLIER_SHARE,
    SPILL_MAX,
)
from aida_kb.interpret.verdict.views import normal_tolerance_cos
from aida_kb.io.evidence import ViewEvidence
from aida_kb.io.model import ModelCamera, ReconstructedModel

IntImage = npt.NDArray[np.int32]


@dataclass(frozen=True)
class FaceFill:
    """What fills one model face's visible area in one view, in pixels (after FILL_EDGE_PX
    are taken off its outline): at its depth, beyond it, before it (occluders) and unknown
    (no region there, or one whose plane fit does not tell its depth)."""

    role: str
    visible: int
    at_depth: int
    beyond: int
    before: int
    unknown: int

    @property
    def judged(self) -> int:
        """The visible pixels not covered by something in front: what judges the face."""
        return self.visible - self.before

    @property
    def contradicted(self) -> float:
        """The share of the judged pixels where the view sees beyond the face (0 if none)."""
        return self.beyond / self.judged if self.judged > 0 else 0.0


def region_map(view: ViewEvidence) -> IntImage:
    """The view's regions as an image (image_height, image_width) of region ids (0: none),
    from their outlines: each region's outer contours filled, its holes cleared, the largest
    region first (what lies in a hole is a smaller region, drawn after it)."""
    out = np.zeros((view.image_height, view.image_width), np.int32)
    outer: dict[int, list[npt.NDArray[np.int32]]] = {}
    holes: dict[int, list[npt.NDArray[np.int32]]] = {}
    for c in view.contours:
        pts = np.round(np.asarray(c.points, dtype=np.float64)).astype(np.int32)
        (holes if c.hole else outer).setdefault(c.region, []).append(pts)
    area = {r: sum(abs(cv2.contourArea(p)) for p in ps) for r, ps in outer.items()}
    for region in sorted(outer, key=lambda r: -area[r]):
        cv2.fillPoly(out, outer[region], int(region))
        if region in holes:
            cv2.fillPoly(out, holes[region], 0)
    return out


def _clipped(points_cam: FloatArray, z_min: float) -> FloatArray:
    """A polygon (N, 3), camera frame, clipped to z >= z_min (Sutherland-Hodgman, one plane)."""
    out = []
    for i in range(len(points_cam)):
        a, b = points_cam[i - 1], points_cam[i]
        if (a[2] >= z_min) != (b[2] >= z_min):
            out.append(a + (b - a) * ((z_min - a[2]) / (b[2] - a[2])))
        if b[2] >= z_min:
            out.append(b)
    return np.array(out).reshape(-1, 3)


def face_depths(
    model: ReconstructedModel, camera: ModelCamera, shape: tuple[int, int]
) -> tuple[IntImage, FloatArray]:
    """The model's faces rasterised in `camera` on an image of `shape` (height, width): the
    index (into `model_faces`) of the face each pixel sees, -1 for none, and its depth
    (camera z, metres; inf for none); both of that shape."""
    h, w = shape
    K = np.asarray(camera.K, dtype=np.float64)
    R = np.asarray(camera.R, dtype=np.float64)
    t = np.asarray(camera.t, dtype=np.float64)
    v, u = np.mgrid[0:h, 0:w]
    rays = np.stack([u, v, np.ones_like(u)], axis=-1).astype(np.float64) @ np.linalg.inv(K).T
    index = np.full((h, w), -1, np.int32)
    depth = np.full((h, w), np.inf)
    size = model_size(model)
    for i, (_, n, d, poly) in enumerate(model_faces(model)):
        cam = _clipped(poly @ R.T + t, FILL_NEAR_Z * size)
        if len(cam) < 3:
            continue
        px = cam @ K.T
        px = np.round(px[:, :2] / px[:, 2:3]).astype(np.int32)
        mask = np.zeros((h, w), np.uint8)
        cv2.fillPoly(mask, [px], 1)
        ys, xs = np.nonzero(mask)
        n_cam = R @ n
        with np.errstate(divide="ignore", invalid="ignore"):
            z = (d + n_cam @ t) / (rays[ys, xs] @ n_cam)
        nearer = np.isfinite(z) & (z > 0) & (z < depth[ys, xs])
        index[ys[nearer], xs[nearer]] = i
        depth[ys[nearer], xs[nearer]] = z[nearer]
    return index, depth


AT, BEYOND, BEFORE, UNKNOWN = 0, 1, 2, 3  # what a face's pixel shows (`FillMaps.state`)


@dataclass(frozen=True)
class FillMaps:
    """A view's regions against the model's faces, pixel by pixel (image_height, image_width):
    the face each pixel sees (`face_depths`; -1 none), the region there (`region_map`; 0 none)
    and, where a face is seen, what the region shows there: AT its depth, BEYOND it, BEFORE it
    or UNKNOWN (`fill_maps`)."""

    faces: IntImage
    regions: IntImage
    state: npt.NDArray[np.uint8]
    normals: dict[int, FloatArray]  # region id -> its plane's unit normal (3,), world frame


def fill_maps(view: ViewEvidence, model: ReconstructedModel) -> FillMaps | None:
    """The view's `FillMaps` at its model camera (None without one). A face's pixel is AT its
    depth when the region there, on its fitted plane along the pixel's ray, lies within the
    larger of FILL_BEYOND_DEPTH of the face's depth and FILL_BEYOND_SIZE of the model's size
    of the face; BEYOND or BEFORE it otherwise. Regions whose plane fit does not tell their
    orientation to NORMAL_TOLERANCE_DEG (`views.normal_tolerance_cos`), or whose plane the
    ray does not meet in front of the camera, leave their pixels UNKNOWN."""
    camera = next((c for c in model.cameras if c.view == view.id), None)
    if camera is None:
        return None
    ids = region_map(view)
    index, depth = face_depths(model, camera, ids.shape)
    regions = view.regions
    R = np.asarray(camera.R, dtype=np.float64)
    t = np.asarray(camera.t, dtype=np.float64)
    # each region's plane in the model camera's frame (n . x = d; a "camera" view's frame is
    # its own left camera, which the model camera stands for, as in check (b))
    normals = np.array([r.n_init for r in regions], dtype=np.float64).reshape(-1, 3)
    offsets = np.array([r.d_init for r in regions], dtype=np.float64)
    world = normals @ R if view.frame == "camera" else normals.copy()
    if view.frame != "camera":
        normals = normals @ R.T
        offsets = offsets + normals @ t
    told = normal_tolerance_cos(regions) >= math.cos(math.radians(NORMAL_TOLERANCE_DEG)) - 1e-12
    has_plane = told & np.array(
        [r.w_c > 0 and r.inlier_count >= PLANE_INLIER_SHARE * r.pixel_count for r in regions], bool
    )
    lookup = np.full(max(int(ids.max(initial=0)), max((r.id for r in regions), default=0)) + 1, -1)
    lookup[[r.id for r in regions]] = np.arange(len(regions))
    state = np.full(ids.shape, UNKNOWN, np.uint8)
    ys, xs = np.nonzero(index >= 0)
    k = lookup[ids[ys, xs]]
    known = k >= 0
    known[known] = has_plane[k[known]]
    K_inv = np.linalg.inv(np.asarray(camera.K, dtype=np.float64))
    rays = np.stack([xs[known], ys[known], np.ones(np.count_nonzero(known))], axis=-1) @ K_inv.T
    z_region = np.full(len(ys), np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        z_region[known] = offsets[k[known]] / np.einsum("ij,ij->i", rays, normals[k[known]])
    known &= np.isfinite(z_region) & (z_region > 0)
    z_face = depth[ys, xs]
    tol = np.maximum(FILL_BEYOND_DEPTH * z_face, FILL_BEYOND_SIZE * model_size(model))
    shown = np.full(len(ys), UNKNOWN, np.uint8)
    shown[known] = np.where(
        z_region[known] > z_face[known] + tol[known],
        BEYOND,
        np.where(z_region[known] < z_face[known] - tol[known], BEFORE, AT),
    )
    state[ys, xs] = shown
    return FillMaps(index, ids, state, {r.id: world[k] for k, r in enumerate(regions)})


def _kernel() -> npt.NDArray[np.uint8]:
    """A square of side 2 FILL_EDGE_PX + 1: erodes a face's area, grows the projection."""
    return np.ones((2 * int(FILL_EDGE_PX) + 1,) * 2, np.uint8)


def face_fills(maps: FillMaps, model: ReconstructedModel) -> list[FaceFill]:
    """Check (j)'s figures in one view: per model face the view sees, its visible pixels at
    least FILL_EDGE_PX inside its outline and what fills them (`fill_maps`)."""
    out = []
    for i, (role, *_) in enumerate(model_faces(model)):
        seen = cv2.erode((maps.faces == i).astype(np.uint8), _kernel()) > 0
        counts = np.bincount(maps.state[seen], minlength=4)
        if counts.sum() > 0:
            out.append(FaceFill(role, int(counts.sum()), *(int(c) for c in counts)))
    return out


@dataclass(frozen=True)
class Spill:
    """A region explained on a face the view shows, and how much of it lies outside the
    model's projection (grown by FILL_EDGE_PX), in pixels."""

    region: int
    role: str  # the face the most of its pixels are AT
    on_face: int  # its pixels AT that face
    outside: int
    pixels: int  # all its pixels (as drawn from its outlines)
    without_depth: int  # its pixels stereo gave no depth (the segmentation's count)

    @property
    def surface_outside(self) -> int:
        """The pixels outside the projection that are surely of its surface: those outside
        less every pixel without a depth. A segmented region leaks through a gap in its
        outline into the textureless background (sky, a plain ground: 23-25 % of a true
        wall's region outside it on dev 61106 and 61121, 43-58 % of their pixels without a
        depth); its own surface, textured enough for its plane, has a depth nearly
        everywhere (the half of a gable's end wall a shed lacks: 96 %)."""
        return max(0, self.outside - self.without_depth)

    @property
    def share(self) -> float:
        """The share of its pixels that are surely of its surface and outside the model's
        projection (`surface_outside`)."""
        return self.surface_outside / self.pixels if self.pixels else 0.0


def spills(
    view: ViewEvidence, maps: FillMaps, model: ReconstructedModel, explained: tuple[int, ...]
) -> list[Spill]:
    """Per region of `explained` (check (b)'s `ViewCheck.explained_ids`) seen AT some face:
    the face it is on and the pixels it has outside the model's projection."""
    faces = model_faces(model)
    face_normals = np.array([f[1] for f in faces]).reshape(-1, 3)
    top = int(maps.regions.max(initial=0)) + 1
    pixels = np.bincount(maps.regions.ravel(), minlength=top)
    grown = cv2.dilate((maps.faces >= 0).astype(np.uint8), _kernel())
    outside = np.bincount(maps.regions[grown == 0], minlength=top)
    at = (maps.state == AT) & (maps.faces >= 0)
    on = np.bincount(  # (region id, face) -> its pixels AT that face
        maps.regions[at] * len(faces) + maps.faces[at], minlength=top * len(faces)
    ).reshape(top, len(faces))
    by_id = {r.id: r for r in view.regions}
    out = []
    for rid in explained:
        if rid not in by_id or rid >= top or rid not in maps.normals:
            continue
        # only the faces its plane lies on (the ground at a wall's foot is not on the wall)
        cos_on = float(normal_tolerance_cos([by_id[rid]])[0])
        mine = np.where(np.abs(face_normals @ maps.normals[rid]) >= cos_on, on[rid], 0)
        if mine.sum() == 0:
            continue
        best = int(np.argmax(mine))
        r = by_id[rid]
        out.append(
            Spill(
                rid,
                faces[best][0],
                int(mine[best]),
                int(outside[rid]),
                int(pixels[rid]),
                r.pixel_count - r.depth_pixel_count,
            )
        )
    return out


def unfilled(
    view: ViewEvidence, model: ReconstructedModel, explained: tuple[int, ...]
) -> list[str]:
    """Check (j)'s reasons in one view: every face whose judged pixels (visible, not behind
    an occluder) are at least FILL_MIN_SHARE of the image and of which more than
    FILL_CONTRADICTED_MAX show the surface beyond it; and every region explained on a face
    (`explained`: check (b)'s), AT it over FILL_MIN_SHARE of the image, which has more than
    SPILL_MAX of its pixels, and FILL_MIN_SHARE of the image, outside the model's projection."""
    maps = fill_maps(view, model)
    if maps is None:
        return []
    least = FILL_MIN_SHARE * view.image_width * view.image_height
    reasons = [
        f"view {view.id}: the face {f.role} is not there: {100 * f.contradicted:.0f}% of its "
        f"visible area ({f.judged} px) shows the surface beyond it (at most "
        f"{100 * FILL_CONTRADICTED_MAX:.0f}%)"
        for f in face_fills(maps, model)
        if f.judged >= least and f.contradicted > FILL_CONTRADICTED_MAX
    ]
    reasons += [
        f"view {view.id}: region {view.id}/{s.region} on {s.role} has {100 * s.share:.0f}% of "
        f"its pixels ({s.surface_outside} px) outside the model's outline (at most "
        f"{100 * SPILL_MAX:.0f}%: the surface goes on where the model has none)"
        for s in spills(view, maps, model, explained)
        if s.on_face >= least and s.surface_outside >= least and s.share > SPILL_MAX
    ]
    return reasons
