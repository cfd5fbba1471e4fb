"""Party walls: a terrace's touching houses told apart in the reference view's evidence.

Without labels the segmentation grows one region over a terrace's coplanar fronts, and one over
roof slopes of one pitch side by side (`vision.merge`: regions of one plane merged): the
houses' fronts are one region, and the scene's rounds (`interpret.scene`) find at most one
house there. Where two houses touch, the image shows their party wall on the front as a
vertical line inside that region (a change of material or colour, the end of an eave, of a
plinth): image segments with the region on both sides and one plane across them (not
structural: no depth step, as at a house's end), vertical on its plane, one above the other
along one line, together longer than a window or a door is tall. Each such line splits
the front region, and every region above it that the party wall's plane cuts (the roof slopes
over both houses), along that plane: the vertical plane through the line, square to the front.
The pieces keep their region's plane (they are parts of it; but see below); their areas,
weights and centres are their share of it; the segments bordering a split region go to the
piece on their side, and the party wall's own segments border the two pieces.

Where the view's stereo depth is at hand (`StereoDepth`, the pipeline's), a piece whose depths
the region's plane does not hold takes its own plane, fitted to them (`_refit`): the
segmentation merges a terrace's roofs as one plane, but they differ in pitch and height (dev
terrace 66100: pitches 33-39 deg, eaves 6.1-7.3 m), and the merged plane lay 6-12 deg off each
house's roof and up to 0.33 m from it. The middle house's roof piece then put a small region
of its own roof 0.83 m inside its model, and that house was not found.

Only `scene.reconstruct_objects` calls this, for a goal holding several objects (a street): a
single object's evidence is never split.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from aida_kb.constraints import Constraint, Origin
from aida_kb.io.evidence import Contour, Evidence, LineSegment, Region, ViewEvidence
from aida_kb.io.model import ModelPart, ReconstructedModel

if TYPE_CHECKING:
    from aida_kb.vision.evidence import ViewProducts

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int32]
Float32Array = npt.NDArray[np.float32]

# a region faces sideways (a front a party wall may split) when its normal is within this of
# horizontal, and is level (the ground, never split) within this of the vertical
VERTICAL_REGION_DEG = 10.0
# a segment runs along a party wall when its direction on the region's plane is within this of
# the vertical (walls stand within a few degrees of it)
PARTY_VERTICAL_DEG = 5.0
# segments continue one line when their horizontal places on the plane differ by less than
# this, metres (a segment's ends are good to a pixel: 6 cm at 100 m with f = 1600 px)
CHAIN_GAP_M = 0.25
# ... and one above the other with gaps of at most this, metres (a line broken where its
# contrast fades; the wall between two storeys' windows, 1.5 m and more, breaks a run)
CHAIN_STEP_M = 0.8
# the segments of one party wall together span at least this much of its height, metres (from
# the lowest end of a run to its highest, its faded gaps bridged: dev terrace 66103's wall
# between a plaster house and one with a brick ground floor shows as two segments, 0.95 and
# 0.84 m, 0.27 m apart; summed, 1.79 m missed this by 1 cm and the house was not found):
# longer than a window is tall (1.2-1.5 m), shorter than the lowest house's wall (a storey,
# 2.5-3 m); a door's side (2.0-2.2 m) passes it: where a door stands more than PIECE_MIN_M from
# a front's ends, the front is cut there (a front too narrow for a house then; doubted)
PARTY_MIN_M = 1.8
# every piece of a split region is at least this wide along the row, metres (narrower than any
# house; a sliver of a neighbour's roof beyond a line is no house's); of two lines closer than
# this the one covering more of its wall cuts
PIECE_MIN_M = 2.0
# a segment lies on a split line within this distance, pixels, and this angle
ON_LINE_PX = 3.0
ON_LINE_DEG = 5.0


# a piece's plane is fitted again only from at least this many pixels with a depth (the
# segmentation's own least for a plane fit, `vision.evidence.MIN_FIT_SAMPLES`); fewer keep the
# region's plane
REFIT_MIN_PIXELS = 30
# ... and takes the piece's own plane only where the region's plane misses the piece's depths
# (median absolute disparity residual) by more than this many times the piece's own plane
# does: coplanar fronts are held as well by the region's plane, fitted to all of them and
# refined photometrically (dev terrace 66100: ratios 0.97-1.01; a side wall's two pieces 1.08
# and 1.26, their own planes 0.2 and 7 deg off the region's, the 7 deg a narrow piece's
# noise), roofs of other pitches and heights are not (1.65-5.6, the region's plane 6-11 deg off
# them, their own planes within 0.3-1.4 deg of the truth)
REFIT_GAIN = 1.5


@dataclass(frozen=True)
class StereoDepth:
    """What the reference view's stereo measured, to fit a split region's pieces again.

    regions : (H, W) int32, the region id of each pixel of the original left image (0: none).
    points : (H, W, 3) float32, metres, the original left camera's frame (NaN: no depth).
    certainty : (H, W) float32 in [0, 1], each depth's certainty.
    """

    regions: IntArray
    points: Float32Array
    certainty: Float32Array


def stereo_depth(products: Sequence[ViewProducts], view_id: str) -> StereoDepth | None:
    """The stereo depth of view `view_id` among a scene's `products` (`vision.evidence`), None
    when none is of that view."""
    for prod in products:
        if prod.evidence.id == view_id:
            return StereoDepth(prod.regions, prod.depth.points, prod.depth.certainty)
    return None


@dataclass(frozen=True)
class PartyWall:
    """A party wall found on a front region: the vertical plane m·x = offset (world frame, m a
    unit horizontal normal along the row) and the region it was found on."""

    region: int
    normal: FloatArray  # (3,) unit, horizontal, along the row
    offset_m: float
    height_m: float  # the length its segments cover


def _camera(view: ViewEvidence) -> tuple[FloatArray, FloatArray, FloatArray]:
    """K (3, 3), R_cam_world (3, 3), t_cam_world (3,) of the view's left camera."""
    return (
        np.asarray(view.left.K, dtype=np.float64),
        np.asarray(view.left.R, dtype=np.float64),
        np.asarray(view.left.t, dtype=np.float64).ravel(),
    )


def _on_plane(view: ViewEvidence, pixels: FloatArray, n: FloatArray, d: float) -> FloatArray:
    """Pixels (N, 2) back-projected onto the plane n·x = d: (N, 3) world points (nan where the
    ray runs along the plane)."""
    K, R, t = _camera(view)
    centre = -R.T @ t
    homog = np.column_stack([pixels, np.ones(len(pixels))])
    rays = (R.T @ np.linalg.solve(K, homog.T)).T
    denom = rays @ n
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (d - float(centre @ n)) / denom
    s = np.where(np.abs(denom) > 1e-12, s, np.nan)
    out: FloatArray = centre[None, :] + s[:, None] * rays
    return out


def _project(view: ViewEvidence, points: FloatArray) -> FloatArray:
    """World points (N, 3) -> pixels (N, 2) in the view's left image (no distortion)."""
    K, R, t = _camera(view)
    cam = points @ R.T + t
    uv = cam @ K.T
    out: FloatArray = uv[:, :2] / uv[:, 2:3]
    return out


def _outline(view: ViewEvidence, rid: int) -> FloatArray | None:
    """The region's outer contour (K, 2) pixels (the longest one), None when it has none."""
    polys = [c.points for c in view.contours if c.region == rid and not c.hole]
    if not polys:
        return None
    return np.asarray(max(polys, key=len), dtype=np.float64)


def party_walls(view: ViewEvidence, up: FloatArray) -> list[PartyWall]:
    """The party walls on the view's vertical regions (see the module docstring). `up`: (3,)
    unit, world frame."""
    cos_side = math.sin(math.radians(VERTICAL_REGION_DEG))
    cos_vertical = math.cos(math.radians(PARTY_VERTICAL_DEG))
    walls: list[PartyWall] = []
    for region in view.regions:
        n = np.asarray(region.n_init, dtype=np.float64)
        if abs(float(n @ up)) > cos_side:
            continue
        # the region on both sides, one plane across (a structural line, the depth stepping
        # across it, is a corner or an occlusion: a house's end, not a party wall)
        inner = [
            s
            for s in view.lines
            if s.left_region == region.id and s.right_region == region.id and s.kind != "structural"
        ]
        if not inner:
            continue
        ends = np.array([[*s.p1, *s.p2] for s in inner], dtype=np.float64).reshape(-1, 2)
        pts = _on_plane(view, ends, n, region.d_init).reshape(-1, 2, 3)
        ok = np.all(np.isfinite(pts), axis=(1, 2))
        if not np.any(ok):
            continue
        pts = pts[ok]
        along = pts[:, 1] - pts[:, 0]
        length = np.linalg.norm(along, axis=1)
        vertical = np.abs(along @ up) >= cos_vertical * np.maximum(length, 1e-12)
        if not np.any(vertical):
            continue
        # the row's direction on the plane: horizontal, in the plane
        row = np.cross(up, n)
        row /= float(np.linalg.norm(row))
        place = pts[vertical].mean(axis=1) @ row  # (V,) horizontal place of each segment
        span = pts[vertical] @ up  # (V, 2) heights of its ends
        low, high = span.min(axis=1), span.max(axis=1)
        order = np.argsort(place)
        start = 0
        for k in range(1, len(order) + 1):
            if k < len(order) and place[order[k]] - place[order[k - 1]] <= CHAIN_GAP_M:
                continue
            chain = order[start:k]
            start = k
            covered = _covered(low[chain], high[chain])
            if covered >= PARTY_MIN_M:
                where = float(np.average(place[chain], weights=high[chain] - low[chain] + 1e-9))
                walls.append(PartyWall(region.id, row.copy(), where, covered))
    return walls


def _covered(low: FloatArray, high: FloatArray) -> float:
    """The longest run of the intervals [low, high] (metres) with gaps of at most
    `CHAIN_STEP_M` between them: its length from its lowest end to its highest, the gaps
    bridged (a line whose contrast fades there for a few pixels is one line)."""
    order = np.argsort(low)
    best, start, reach = 0.0, math.inf, -math.inf
    for i in order:
        a, b = float(low[i]), float(high[i])
        if b <= reach:
            continue
        if a - reach > CHAIN_STEP_M:
            start = a
        reach = b
        best = max(best, reach - start)
    return best


def _clip(poly: FloatArray, s: FloatArray) -> FloatArray:
    """The part of the polygon (K, D) where the (K,) values `s`, linear along its edges (a
    plane's points against another plane), are >= 0: one Sutherland-Hodgman clip."""
    out: list[FloatArray] = []
    k = len(poly)
    for i in range(k):
        p, q = poly[i], poly[(i + 1) % k]
        sp, sq = s[i], s[(i + 1) % k]
        if sp >= 0:
            out.append(p)
        if (sp >= 0) != (sq >= 0):
            out.append(p + (q - p) * (sp / (sp - sq)))
    return np.asarray(out, dtype=np.float64).reshape(-1, poly.shape[1])


def _slab(poly: FloatArray, m: FloatArray, low: float, high: float) -> FloatArray:
    """The part of a polygon (K, 3) on a plane between the planes m·x = low and m·x = high."""
    poly = _clip(poly, poly @ m - low) if math.isfinite(low) else poly
    if len(poly) and math.isfinite(high):
        poly = _clip(poly, high - poly @ m)
    return poly


def _area_centre(poly: FloatArray, n: FloatArray) -> tuple[float, FloatArray]:
    """Area (m²) and centroid (3,) of a planar polygon (K, 3) with unit normal n."""
    if len(poly) < 3:
        return 0.0, np.zeros(3)
    o = poly[0]
    a, b = poly[1:-1] - o, poly[2:] - o
    tri = np.cross(a, b) @ n / 2.0  # signed triangle areas of the fan
    total = float(tri.sum())
    if abs(total) < 1e-12:
        return 0.0, poly.mean(axis=0)
    centre = o + (tri[:, None] * (a + b) / 3.0).sum(axis=0) / total
    return abs(total), centre


Piece = tuple[list[FloatArray], list[FloatArray], float, FloatArray]


def _pieces(
    view: ViewEvidence, region: Region, m: FloatArray, offsets: list[float]
) -> tuple[list[float], list[Piece]] | None:
    """The region cut by the planes m·x = offsets: per piece its outer polygons and holes
    (pixels) on its side, its area (m², holes taken off) and centre (3,), world frame; None
    when a piece would be narrower than `PIECE_MIN_M` or no plane cuts it."""
    n = np.asarray(region.n_init, dtype=np.float64)
    own = [c for c in view.contours if c.region == region.id]
    if not own:
        return None
    on = [
        (c, _on_plane(view, np.asarray(c.points, dtype=np.float64), n, region.d_init)) for c in own
    ]
    if not all(np.all(np.isfinite(x)) for _, x in on):
        return None
    outer = np.vstack([x for c, x in on if not c.hole])
    lo, hi = float((outer @ m).min()), float((outer @ m).max())
    taken: list[float] = []
    for o in offsets:  # the best covered first
        if lo + PIECE_MIN_M <= o <= hi - PIECE_MIN_M and all(
            abs(o - t) >= PIECE_MIN_M for t in taken
        ):
            taken.append(o)
    if not taken:
        return None
    cuts = sorted(taken)
    edges = [-math.inf, *cuts, math.inf]
    out: list[Piece] = []
    for a, b in itertools.pairwise(edges):
        polys: list[FloatArray] = []
        holes: list[FloatArray] = []
        area = 0.0
        moment = np.zeros(3)
        for c, x in on:
            part = _slab(x, m, a, b)
            if len(part) < 3:
                continue
            size, centre = _area_centre(part, n)
            sign = -1.0 if c.hole else 1.0
            area += sign * size
            moment += sign * size * centre
            (holes if c.hole else polys).append(_project(view, part))
        if not polys or area <= 0:
            return None
        out.append((polys, holes, area, moment / area))
    return cuts, out


def _up(evidence: Evidence) -> FloatArray:
    """The evidence's vertical (3,), world frame (`observe.estimate_up` on the first view)."""
    from aida_kb.interpret.observe import estimate_up, view_of

    ev = view_of(evidence)
    camera = ev.camera
    seen = [r for r in ev.regions.values() if r.view == ev.reference_view]
    return estimate_up(seen, camera, segments_px=ev.lines_px.get(camera.view))


def _above(view: ViewEvidence, front: Region, up: FloatArray) -> list[Region]:
    """The regions bordering `front` in the image (an outline vertex within `ON_LINE_PX` of
    its outline) that lie above its centre and are not level (its roof slopes)."""
    mine = _outline(view, front.id)
    if mine is None:
        return []
    cos_level = math.cos(math.radians(VERTICAL_REGION_DEG))
    centre = float(np.asarray(front.c_init) @ up)
    out = []
    for r in view.regions:
        if r.id == front.id or abs(float(np.asarray(r.n_init) @ up)) >= cos_level:
            continue
        if float(np.asarray(r.c_init) @ up) <= centre:
            continue
        other = _outline(view, r.id)
        if other is not None and bool(np.any(_near(other, mine))):
            out.append(r)
    return out


def _near(points: FloatArray, polygon: FloatArray) -> npt.NDArray[np.bool_]:
    """Which points (N, 2) lie within `ON_LINE_PX` of the closed polygon (M, 2)."""
    edge = np.roll(polygon, -1, axis=0) - polygon
    length2 = np.maximum(np.sum(edge * edge, axis=1), 1e-12)
    rel = points[:, None, :] - polygon[None, :, :]
    t = np.clip(np.sum(rel * edge[None], axis=2) / length2[None], 0.0, 1.0)
    gap = np.linalg.norm(rel - t[..., None] * edge[None], axis=2).min(axis=1)
    out: npt.NDArray[np.bool_] = gap <= ON_LINE_PX
    return out


def _places(view: ViewEvidence, region: Region, m: FloatArray, px: FloatArray) -> FloatArray:
    """Where pixels (N, 2) of the region lie along m on its plane, metres (N,)."""
    x = _on_plane(view, px, np.asarray(region.n_init, dtype=np.float64), region.d_init)
    out: FloatArray = x @ m
    return out


def _piece(
    region: Region,
    rid: int,
    share: float,
    area_m2: float,
    centre: FloatArray,
    polys: list[FloatArray],
    view: ViewEvidence,
) -> Region:
    """A piece of `region`: its plane, `share` of its pixels, weight and fit counts, its own
    area, centre and box."""
    pts = np.vstack(polys)
    x0, y0 = np.floor(pts.min(axis=0)).astype(int)
    x1, y1 = np.ceil(pts.max(axis=0)).astype(int)
    x0, y0 = max(int(x0), 0), max(int(y0), 0)
    x1 = min(max(int(x1), x0), view.image_width - 1)
    y1 = min(max(int(y1), y0), view.image_height - 1)
    pixels = max(1, min(round(region.pixel_count * share), (x1 - x0 + 1) * (y1 - y0 + 1)))
    depth = min(pixels, round(region.depth_pixel_count * share))
    inliers = min(depth, round(region.inlier_count * share))
    w_c = min(float(region.w_c) * share, float(pixels))
    n = np.asarray(region.n_init, dtype=np.float64)
    on = centre - (float(n @ centre) - region.d_init) * n
    return region.model_copy(
        update={
            "id": rid,
            "label": None,
            "pixel_count": pixels,
            "depth_pixel_count": depth,
            "inlier_count": inliers,
            "area_m2": area_m2,
            "c_init": (float(on[0]), float(on[1]), float(on[2])),
            "w_c": w_c,
            "mean_certainty": min(1.0, w_c / pixels),
            "bbox": (x0, y0, x1, y1),
        }
    )


def _refit(
    view: ViewEvidence, depth: StereoDepth, region: Region, m: FloatArray, cuts: list[float]
) -> list[tuple[FloatArray, float, FloatArray] | None]:
    """Per piece of `region` cut at the planes m·x = cuts (in order along m), its plane fitted
    to its own pixels' depths: (unit normal (3,), offset m, centre (3,)), world frame, the
    normal facing as the region's; None (the region's plane holds) for a piece with fewer than
    `REFIT_MIN_PIXELS` depths or whose depths the region's plane holds nearly as well
    (`REFIT_GAIN`).

    A plane n·x = D is linear in inverse depth: f·B/z = a·u + b·v + g with u = f·x/z,
    v = f·y/z (f the focal length, pixels; B the stereo baseline, metres), so the pixels'
    depths are fitted as the segmentation fits a region, by `vision.planes.fit_disparity_plane`
    (robust, certainty-weighted, in disparity pixels)."""
    import cv2

    from aida_kb.errors import VisionError
    from aida_kb.vision.evidence import DEFAULT_WINDOW
    from aida_kb.vision.planes import fit_disparity_plane

    n_old = np.asarray(region.n_init, dtype=np.float64)
    # away from the region's outline by more than the matcher's window, as the segmentation
    # fits its regions: a window straddling the outline smears the depth across it
    side = DEFAULT_WINDOW + 2
    inner = cv2.erode(
        (depth.regions == region.id).astype(np.uint8), np.ones((side, side), np.uint8)
    )
    ys, xs = np.nonzero(inner)
    pts = depth.points[ys, xs].astype(np.float64)
    cert = depth.certainty[ys, xs].astype(np.float64)
    ok = np.all(np.isfinite(pts), axis=1) & (pts[:, 2] > 0) & (cert > 0)
    pts, cert = pts[ok], cert[ok]
    pixels = np.column_stack([xs[ok], ys[ok]]).astype(np.float64)
    which = np.searchsorted(np.asarray(cuts), _places(view, region, m, pixels))
    K, R, t = _camera(view)
    f = float(K[0, 0])
    right_centre = (
        -np.asarray(view.right.R, dtype=np.float64).T
        @ np.asarray(view.right.t, dtype=np.float64).ravel()
    )
    baseline = float(np.linalg.norm(right_centre - (-R.T @ t))) or 1.0
    n_cam_old = R @ n_old  # the region's plane in the camera frame: n_cam_old·x = d_cam_old
    d_cam_old = region.d_init + float(n_cam_old @ t)
    out: list[tuple[FloatArray, float, FloatArray] | None] = []
    for k in range(len(cuts) + 1):
        p, w = pts[which == k], cert[which == k]
        if len(p) < REFIT_MIN_PIXELS:
            out.append(None)
            continue
        z = p[:, 2]
        u, v, disparity = f * p[:, 0] / z, f * p[:, 1] / z, f * baseline / z
        try:
            fit = fit_disparity_plane(u, v, disparity, w)
        except VisionError:
            out.append(None)
            continue
        own = np.median(np.abs(disparity - (fit.a * u + fit.b * v + fit.g)))
        # the region's plane at each pixel's ray p/z: disparity f·B·(n·ray)/d
        theirs = np.median(
            np.abs(disparity - f * baseline * (p / z[:, None]) @ n_cam_old / d_cam_old)
        )
        if not theirs > REFIT_GAIN * own:
            out.append(None)
            continue
        coef = np.array([fit.a * f, fit.b * f, fit.g])  # coef · x = f·B, camera frame
        norm = float(np.linalg.norm(coef))
        if norm == 0.0 or np.count_nonzero(fit.inliers) < REFIT_MIN_PIXELS:
            out.append(None)
            continue
        n_cam, d_cam = coef / norm, f * baseline / norm
        n = R.T @ n_cam  # x_cam = R x_world + t
        d = d_cam - float(n_cam @ t)
        if float(n @ n_old) < 0:
            n, d = -n, -d
        inl = p[fit.inliers]
        c_cam = np.average(inl, axis=0, weights=np.maximum(fit.weights[fit.inliers], 1e-12))
        c = R.T @ (c_cam - t)
        out.append((n, d, c - (float(n @ c) - d) * n))
    return out


def _replaned(piece: Region, normal: FloatArray, offset_m: float, centre: FloatArray) -> Region:
    """`piece` on the plane normal·x = offset_m (world frame) through `centre` (3,)."""
    return piece.model_copy(
        update={
            "n_init": (float(normal[0]), float(normal[1]), float(normal[2])),
            "d_init": float(offset_m),
            "c_init": (float(centre[0]), float(centre[1]), float(centre[2])),
        }
    )


def _contour(rid: int, poly: FloatArray, hole: bool) -> Contour:
    return Contour(id=1, region=rid, hole=hole, points=[(float(x), float(y)) for x, y in poly])


def _cut_segments(
    view: ViewEvidence,
    lines: list[LineSegment],
    region: Region,
    m: FloatArray,
    cuts: list[float],
) -> list[LineSegment]:
    """The segments bordering `region` cut where they cross the cuts (m·x = cut on its plane):
    an eave along two houses is each house's own eave. New pieces take new ids."""
    n = np.asarray(region.n_init, dtype=np.float64)
    next_id = max((s.id for s in lines), default=0) + 1
    out: list[LineSegment] = []
    for s in lines:
        if region.id not in s.regions and region.id not in (s.left_region, s.right_region):
            out.append(s)
            continue
        ends = _on_plane(view, np.array([s.p1, s.p2], dtype=np.float64), n, region.d_init)
        if not np.all(np.isfinite(ends)):
            out.append(s)
            continue
        a, b = float(ends[0] @ m), float(ends[1] @ m)
        inside = [c for c in cuts if min(a, b) < c < max(a, b)]
        if not inside or abs(b - a) < 1e-9:
            out.append(s)
            continue
        u = sorted((c - a) / (b - a) for c in inside)
        points = _project(view, ends[0] + np.array([0.0, *u, 1.0])[:, None] * (ends[1] - ends[0]))
        points[0], points[-1] = s.p1, s.p2
        for k in range(len(points) - 1):
            p1, p2 = points[k], points[k + 1]
            length = float(np.linalg.norm(p2 - p1))
            if length <= 0:
                continue
            out.append(
                s.model_copy(
                    update={
                        "id": s.id if k == 0 else next_id,
                        "p1": (float(p1[0]), float(p1[1])),
                        "p2": (float(p2[0]), float(p2[1])),
                        "length_px": length,
                    }
                )
            )
            if k > 0:
                next_id += 1
    return out


def _relined(
    view: ViewEvidence,
    lines: list[LineSegment],
    region: Region,
    ids: list[int],
    m: FloatArray,
    cuts: list[float],
) -> list[LineSegment]:
    """The segments bordering `region` cut at the cuts (`_cut_segments`), each bordering the
    piece on its side instead (on either side, probed `SIDE_PX` from its midpoint; a party
    wall's own segment borders both pieces)."""
    out = []
    edges = np.asarray(cuts)
    for s in _cut_segments(view, lines, region, m, cuts):
        if region.id not in s.regions and region.id not in (s.left_region, s.right_region):
            out.append(s)
            continue
        p1, p2 = np.asarray(s.p1, dtype=np.float64), np.asarray(s.p2, dtype=np.float64)
        t = (p2 - p1) / max(float(np.linalg.norm(p2 - p1)), 1e-9)
        left_n = np.array([t[1], -t[0]])
        mid = (p1 + p2) / 2.0
        probe = np.stack([mid + SIDE_PX * left_n, mid - SIDE_PX * left_n])
        side = np.searchsorted(edges, _places(view, region, m, probe))
        left_id, right_id = ids[int(side[0])], ids[int(side[1])]
        left: int | None = left_id if s.left_region == region.id else s.left_region
        right: int | None = right_id if s.right_region == region.id else s.right_region
        rest = [r for r in s.regions if r != region.id]
        mine = {x for x in (left, right) if x is not None and x in ids}
        if s.left_region is None and s.right_region is None:  # sides unknown: both probes'
            mine = {left_id, right_id}
        out.append(
            s.model_copy(
                update={
                    "regions": sorted({*rest, *mine}),
                    "left_region": left,
                    "right_region": right,
                }
            )
        )
    return out


SIDE_PX = 4.0  # which piece lies on a segment's side is probed this far from its midpoint


def split_terraces(evidence: Evidence, depth: StereoDepth | None = None) -> Evidence:
    """`evidence` with its reference view's (the first view's) regions split at the party
    walls found on them (see the module docstring); unchanged when it shows none. With
    `depth` (the reference view's), each piece's plane is fitted to its own pixels
    (`_refit`); without, the pieces keep their region's plane."""
    view = evidence.views[0]
    if view.segmentation == "labels" or view.frame != "world":
        return evidence
    up = _up(evidence)
    walls = party_walls(view, up)
    if not walls:
        return evidence
    regions = {r.id: r for r in view.regions}
    contours = list(view.contours)
    lines = list(view.lines)
    next_id = max(regions) + 1
    split: set[int] = set()
    for front_id in sorted({w.region for w in walls}):
        mine = sorted(
            (w for w in walls if w.region == front_id), key=lambda w: (-w.height_m, w.offset_m)
        )
        m = mine[0].normal
        offsets = [w.offset_m for w in mine]
        front = regions[front_id]
        for region in [front, *_above(view, front, up)]:
            if region.id in split:
                continue
            cut = _pieces(view, region, m, offsets)
            if cut is None:
                continue
            split.add(region.id)
            cuts, pieces = cut
            ids = list(range(next_id, next_id + len(pieces)))
            next_id += len(pieces)
            total = sum(p[2] for p in pieces)
            del regions[region.id]
            contours = [c for c in contours if c.region != region.id]
            planes = _refit(view, depth, region, m, cuts) if depth is not None else None
            for k, (rid, (polys, holes, area, centre)) in enumerate(zip(ids, pieces, strict=True)):
                piece = _piece(region, rid, area / total, area, centre, polys, view)
                plane = None if planes is None else planes[k]
                if plane is not None:
                    piece = _replaned(piece, *plane)
                regions[rid] = piece
                contours += [_contour(rid, p, False) for p in polys]
                contours += [_contour(rid, p, True) for p in holes]
            lines = _relined(view, lines, region, ids, m, cuts)
    contours = [c.model_copy(update={"id": i + 1}) for i, c in enumerate(contours)]
    return evidence.model_copy(
        update={
            "views": [
                view.model_copy(
                    update=dict(
                        regions=sorted(regions.values(), key=lambda r: r.id),
                        contours=contours,
                        lines=lines,
                    )
                ),
                *evidence.views[1:],
            ]
        }
    )


# ---- touching objects: a party wall is one plane of two houses ----
# Two objects touch where a face of one lies in a face of the other, facing it: a terrace's
# party wall, inserted by each house from its own evidence (no view sees it). Their normals
# are opposite within this angle (the two copies of dev terraces 62202/62205 lay 0.02-1.1 deg
# apart) ...
TOUCH_ANGLE_DEG = 3.0
# ... their planes this fraction of the smaller object's size apart (its bounding-box
# diagonal: the copies lay 0.03-0.91 m apart on houses 15-20 m across; the street presets'
# free-standing houses stand at least 3 m apart) ...
TOUCH_GAP = 0.08
# ... and their polygons' bounding boxes overlap, grown by that gap.

# The two copies of a party wall are one plane: in an adjustment they are tied to it
# (`touching_ties`) to an order of magnitude below what a house is judged by (normals to
# 0.5 deg, vertices to 2 % of 10-20 m: 0.2-0.4 m), so the tie holds the copies together
# without outweighing a wall a view measures (a region's normal to 0.1-0.5 deg)
TIE_SIGMA_DEG = 0.05
TIE_SIGMA_M = 0.02


def object_parts(model: ReconstructedModel, role: str) -> list[ModelPart]:
    """The parts of the object with role `role` (e.g. ``houses[1]``) in `model`."""
    return [p for p in model.parts if p.role.startswith(role + ".")]


def extent_m(parts: Sequence[ModelPart]) -> float:
    """The diagonal of the parts' bounding box, metres."""
    pts = np.vstack([np.asarray(p.polygon, dtype=np.float64) for p in parts])
    return float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0)))


def touching_faces(model: ReconstructedModel, a: str, b: str) -> list[tuple[str, str]]:
    """The faces where the objects with roles `a` and `b` in `model` touch: pairs (role of a's
    face, role of b's face) lying in one plane, facing each other (see above); empty where
    they do not touch."""
    pa, pb = object_parts(model, a), object_parts(model, b)
    if not pa or not pb:
        return []
    gap = TOUCH_GAP * min(extent_m(pa), extent_m(pb))
    na = np.array([p.normal for p in pa], dtype=np.float64)  # (A, 3)
    nb = np.array([p.normal for p in pb], dtype=np.float64)  # (B, 3)
    da = np.array([p.offset_m for p in pa], dtype=np.float64)
    db = np.array([p.offset_m for p in pb], dtype=np.float64)
    facing = na @ nb.T < -math.cos(math.radians(TOUCH_ANGLE_DEG))
    close = np.abs(da[:, None] + db[None, :]) <= gap  # opposite normals: d_a = -d_b
    out = []
    for i, j in zip(*np.nonzero(facing & close), strict=True):
        a_pts = np.asarray(pa[int(i)].polygon, dtype=np.float64)
        b_pts = np.asarray(pb[int(j)].polygon, dtype=np.float64)
        if np.all(a_pts.min(axis=0) <= b_pts.max(axis=0) + gap) and np.all(
            b_pts.min(axis=0) <= a_pts.max(axis=0) + gap
        ):
            out.append((pa[int(i)].role, pb[int(j)].role))
    return out


def touching_ties(
    model: ReconstructedModel, roles: Sequence[str], names: Sequence[str]
) -> list[Constraint]:
    """The constraints making every touching pair of the objects' (`roles`) faces one plane
    (`coincident`, opposite facing, `TIE_SIGMA_DEG` / `TIE_SIGMA_M`): a house whose party
    walls no view sees is held by its neighbours' walls — their normals and places follow from
    what the views measure of the neighbours (an end house's gable wall, its front). Part
    indices are positions in `names` (an adjustment's parts); faces not among them are
    skipped. No objects, or none touching: no constraint."""
    index = {name: i for i, name in enumerate(names)}
    out = []
    for a, b in itertools.combinations(roles, 2):
        for fa, fb in touching_faces(model, a, b):
            if fa not in index or fb not in index:
                continue
            out.append(one_plane(index[fa], index[fb], -1, f"one plane({fa}, {fb})"))
    return out


def one_plane(a: int, b: int, sign: int, label: str) -> Constraint:
    """The prior holding parts `a` and `b` (indices of an adjustment's parts) on one plane,
    facing alike (`sign` 1) or opposite (-1): a `coincident` constraint whitened by
    `TIE_SIGMA_DEG` (its rotation, rad) and `TIE_SIGMA_M` (its offset, m)."""
    info = np.diag([1.0 / math.radians(TIE_SIGMA_DEG)] * 3 + [1.0 / TIE_SIGMA_M])
    return Constraint(
        kind="coincident",
        parts=(a, b),
        sign=sign,
        sqrt_information=tuple(tuple(float(x) for x in row) for row in info),
        label=label,
        origin=Origin(label, "prior"),
    )
