"""The evidence as the interpreter uses it: regions as planes, segments, cameras, the vertical.

`EvidenceView` is a numpy view of one evidence file (built by `view_of`): every region with
its plane fit (unit normal pointing towards the camera that saw it, centroid, weight), every
line segment with the regions it borders and its end points back-projected onto those
regions' planes. World frame: the left camera of view 00 (OpenCV axes: x right, y down,
z forward), metres.

The vertical. Walls and roofs are defined relative to "up", which the evidence does not
state. Two walls that are not parallel give it as the cross product of their normals. So
`estimate_up` tries the cross products of pairs of heavy regions, keeps those within 60
degrees of the camera's -y axis (a camera held roughly upright, looking down by up to that
much), and chooses the one under which the largest certainty weight of regions is vertical;
it then refines it as the direction most perpendicular to those walls, weighted by certainty
(the eigenvector of the smallest eigenvalue of sum_i w_i n_i n_i^T). But the image's line
segments give it better where there are many: the vanishing point of the vertical lines
(wall corners, window jambs, joints; `aida_kb.vision.vanishing`), within a few tenths of a
degree on real facades (where the regions' estimate was 0.5-2 degrees off), and also with
one wall direction in view and a camera pitched up at it, where the regions cannot give it.
So it comes first when VP_MIN_SUPPORT segments support it to VP_MAX_SIGMA_DEG, weighed
against the regions that may be level (the ground, flat roofs: where the knowledge orients a
part upward or downward), each by its plane fit's uncertainty (`with_level_regions`): a
street's ground, fitted over thousands of square metres, gives the vertical to hundredths of
a degree where the vanishing point was 0.05-0.86 degrees off. Without a vanishing point, the
regions; with one wall direction in view, a region taken for level (the ground, a table, a
box's lid: a turntable scene) or one taken for a wall, whichever makes more weight vertical
or level, refined within the wall's plane by the regions facing up (a roof pitched towards
the wall is no level region: `_one_direction_up`); with none of these, the camera's -y axis
is the answer.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import numpy.typing as npt

from aida_kb.errors import InterpretError
from aida_kb.geometry.camera import PinholeCamera
from aida_kb.io.evidence import Evidence
from aida_kb.vision.rectify import distort_pixels, undistort_pixels
from aida_kb.vision.vanishing import vertical_direction

FloatArray = npt.NDArray[np.float64]

# an outline vertex or segment end within this of the image's edge (pixels) is where the image
# ends, not where its surface does: no support of the surface's extent. A wall's region that
# leaks through textureless background to the image's edge (dev 63030: a gable wall seen at a
# grazing angle, 20 of its 74 outline vertices on the edge) put its far end, back-projected
# onto its plane, 7 m behind the house, and with it the inserted back wall and back slope
# (the ridge 1.95 m out: its segments, 30-50 px away, never matched)
IMAGE_EDGE_PX = 1.0


@dataclass(frozen=True)
class CameraView:
    """A view's left camera: x_cam = R_cam_world·x_world + t_cam_world (metres, pixels)."""

    view: str
    K: FloatArray  # (3, 3) pixels
    R_cam_world: FloatArray  # (3, 3)
    t_cam_world: FloatArray  # (3,) metres
    width_px: int
    height_px: int
    baseline_m: float = 0.0  # distance to the stereo partner's centre (0: unknown)
    # the original image's lens distortion (OpenCV's k1 k2 p1 p2 [k3 ...]; empty: none): K
    # describes the undistorted image, whose edge is the original's, moved by D
    D: FloatArray = field(default_factory=lambda: np.zeros(0))

    @cached_property
    def pinhole(self) -> PinholeCamera:
        """The same camera as `aida_kb.geometry.camera.PinholeCamera`."""
        return PinholeCamera(
            self.K, self.R_cam_world, self.t_cam_world, self.width_px, self.height_px
        )

    @property
    def centre_m(self) -> FloatArray:
        """Camera centre in the world frame, metres, (3,)."""
        return self.pinhole.centre

    @property
    def P(self) -> FloatArray:
        """The 3x4 projection matrix K [R | t]."""
        return self.pinhole.P

    def rays_world(self, pixels: FloatArray) -> FloatArray:
        """Unit viewing directions in the world frame, (N, 3), of pixels (N, 2)."""
        return self.pinhole.unproject(np.asarray(pixels, dtype=np.float64).reshape(-1, 2))[1]

    def on_image_edge(self, pixels: FloatArray) -> npt.NDArray[np.bool_]:
        """Which pixels (N, 2) of the undistorted image lie within `IMAGE_EDGE_PX` of the
        original image's edge, (N,) bool.

        The test is made in the original (distorted) image, where the edge is the rectangle
        of its pixels: undistorted, that edge bends (barrel distortion moves it out of the
        pinhole image by pixels, pincushion moves it in). Pixels beyond the original image
        by more than `IMAGE_EDGE_PX` (synthetic evidence's true corners) are not on its edge.
        """
        raw = distort_pixels(np.asarray(pixels, dtype=np.float64).reshape(-1, 2), self.K, self.D)
        last = np.array([self.width_px - 1.0, self.height_px - 1.0])
        near: npt.NDArray[np.bool_] = np.any(
            (np.abs(raw) <= IMAGE_EDGE_PX) | (np.abs(raw - last) <= IMAGE_EDGE_PX), axis=1
        )
        return near


@dataclass(frozen=True)
class RegionView:
    """One evidence region seen as a plane (world frame)."""

    id: str  # "VIEW/REGION", unique over the evidence
    view: str
    normal: FloatArray  # (3,) unit, pointing towards the camera (out of the solid)
    centroid_m: FloatArray  # (3,)
    weight: float  # w_c, the summed certainty
    area_px: float
    rms_m: float
    # pixels of the original image the plane fit kept; None: unknown (a region made without
    # its fit's statistics). 0 is a count: the fit kept none of them (a dark roof: 121 of its
    # 9,409 pixels with a depth, its fit 6 degrees off its face, dev seed 61510)
    inliers: int | None = None
    area_m2: float = 0.0  # its area on the plane, m² (0: unknown)

    @property
    def normal_sigma_rad(self) -> float:
        """1-σ angular uncertainty of the fitted normal, radians (inf when unknown).

        A least-squares plane through n points scattered by rms_m about it, spread over a
        square of the region's area (radius of gyration sqrt(area / 12) along each axis),
        tilts by rms_m / (sqrt(n) · sqrt(area / 12)). Neighbouring pixels share most of their
        matching window, so only one pixel per window counts (`FIT_CORRELATED_PX`); the
        refinement's residual bias (`FIT_FLOOR_DEG`) is added in quadrature.
        """
        if self.inliers is None:
            return math.inf
        return float(fit_sigma_rad(self.rms_m, self.inliers / FIT_CORRELATED_PX, self.area_m2))

    @property
    def offset_m(self) -> float:
        """d of the plane n·x = d."""
        return float(self.normal @ self.centroid_m)


@dataclass(frozen=True)
class SegmentView:
    """One image line segment and the regions it borders."""

    id: str  # "VIEW/SEGMENT"
    view: str
    ends_px: FloatArray  # (2, 2) pixels
    regions: tuple[str, ...]  # region ids ("VIEW/REGION") on either side

    @property
    def length_px(self) -> float:
        """Length in pixels."""
        return float(np.linalg.norm(self.ends_px[1] - self.ends_px[0]))


@dataclass(frozen=True)
class EvidenceView:
    """All views' cameras, regions and segments, indexed by id."""

    cameras: dict[str, CameraView]
    regions: dict[str, RegionView]
    segments: tuple[SegmentView, ...]
    reference_view: str = "00"
    source: str = ""
    outlines: dict[str, tuple[FloatArray, ...]] = field(default_factory=dict)
    # every line segment of each view, (N, 2, 2) undistorted pixels, bordering a region or not
    lines_px: dict[str, FloatArray] = field(default_factory=dict)
    # False when the evidence's lengths are in unknown units (a scene known up to scale): the
    # knowledge's ranges in metres say nothing about them
    metric: bool = True
    _by_region: dict[str, tuple[SegmentView, ...]] = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        if self.reference_view not in self.cameras:
            raise InterpretError(
                f"{self.source or 'evidence'}: no camera for the reference view "
                f"{self.reference_view!r}"
            )
        index: dict[str, list[SegmentView]] = {r: [] for r in self.regions}
        for seg in self.segments:
            for r in seg.regions:
                if r in index:
                    index[r].append(seg)
        self._by_region.update({r: tuple(s) for r, s in index.items()})

    @property
    def camera(self) -> CameraView:
        """The reference camera (view 00: the world frame)."""
        return self.cameras[self.reference_view]

    def segments_of(self, region_id: str) -> tuple[SegmentView, ...]:
        """The segments bordering a region."""
        return self._by_region.get(region_id, ())

    def points_on(self, region_id: str) -> FloatArray:
        """3-D points on a region's plane: its centroid, its segments' ends and its outline.

        The segments' end points and the vertices of the region's outline polygons (where the
        evidence gives them) are back-projected onto the region's plane. Returns (N, 3)
        world points, metres. Points whose rays miss the plane (parallel or behind the
        camera) are left out, and so are those within `IMAGE_EDGE_PX` of the original image's
        edge (`CameraView.on_image_edge`): there the image ends, not the surface.
        """
        region = self.regions[region_id]
        pts = [region.centroid_m[None, :]]
        cam = self.cameras[region.view]
        segs = self.segments_of(region_id)
        pixels = [s.ends_px for s in segs] + list(self.outlines.get(region_id, ()))
        if pixels:
            pix = np.concatenate(pixels)
            pix = pix[~cam.on_image_edge(pix)]
            pts.append(intersect_rays_plane(cam.centre_m, cam.rays_world(pix), region))
        out = np.concatenate(pts)
        keep: FloatArray = out[np.all(np.isfinite(out), axis=1)]
        return keep

    def beside(self, a: str, b: str, within_px: float = 5.0) -> bool:
        """True if regions `a` and `b` border each other in their image.

        They do when a segment borders both, or when a vertex of one's outline lies within
        `within_px` pixels of the other's outline (where the evidence gives outlines).
        """
        if any(b in s.regions for s in self.segments_of(a)):
            return True
        if self.regions[a].view != self.regions[b].view:
            return False
        oa, ob = self.outlines.get(a, ()), self.outlines.get(b, ())
        return any(
            _outline_gap(p, q) <= within_px or _outline_gap(q, p) <= within_px
            for p in oa
            for q in ob
        )


def _outline_gap(points: FloatArray, polygon: FloatArray) -> float:
    """The smallest distance (px) from the points (N, 2) to the closed polygon (M, 2)."""
    start = polygon
    edge = np.roll(polygon, -1, axis=0) - start
    length2 = np.maximum(np.sum(edge * edge, axis=1), 1e-12)
    rel = points[:, None, :] - start[None, :, :]
    t = np.clip(np.sum(rel * edge[None], axis=2) / length2[None], 0.0, 1.0)
    gap = rel - t[..., None] * edge[None]
    return float(np.sqrt(np.min(np.sum(gap * gap, axis=2))))


def intersect_rays_plane(centre_m: FloatArray, rays: FloatArray, region: RegionView) -> FloatArray:
    """Points where rays from `centre_m` meet a region's plane, (N, 3); NaN where they miss."""
    denom = rays @ region.normal
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = (region.offset_m - float(region.normal @ centre_m)) / denom
    lam = np.where((np.abs(denom) > 1e-9) & (lam > 0), lam, np.nan)
    out: FloatArray = centre_m[None, :] + lam[:, None] * rays
    return out


def slope_deg(normal: FloatArray, up: FloatArray) -> float:
    """Angle between a plane and the horizontal, degrees, from its outward normal.

    0 for a plane facing up (a flat roof), 90 for a vertical wall, 180 for a floor. The
    knowledge base's `tilt` (walls) and `pitch` (roof planes) attributes are this angle.
    """
    c = float(np.clip(np.dot(normal, up), -1.0, 1.0))
    return math.degrees(math.acos(c))


# The vanishing point of the image's segments gives the vertical when it is known to better
# than this (1-σ, degrees); walls then read within about this of 90 degrees.
VP_MAX_SIGMA_DEG = 1.0
# How far from the camera's up the vanishing direction may lie: cameras pitched up at a
# facade by 10-20 degrees are common, 40 leaves room and still keeps horizontals out.
VP_PRIOR_WINDOW_DEG = 40.0
# ... and when at least this many segments support it: with fewer, one wrong bundle can carry
# it (a synthetic L-shape's 9 brick-joint and corner segments gave 3.3 degrees off, claiming
# 0.8; its 24 gave 0.6 where its walls gave 0.3); real facades give 50-200.
VP_MIN_SUPPORT = 30
# A region may be level (the ground, a flat roof: a part the knowledge orients upward or
# downward) when its normal lies within this of the vanishing point's vertical. The vanishing
# point's own cone understates its error: on the synthetic streets it was 0.05-0.86 degrees off
# while claiming 0.2-0.4 (dev terrace seed 7: 0.86 off, claiming 0.23). A pitched roof is
# pitched by more than this; a real street sloping by less is weighed, not trusted (below).
LEVEL_GATE_DEG = 1.5
# ... and within this many of their combined 1-σ of it (the cone and the region's fit).
LEVEL_GATE_SIGMAS = 5.0
# A region facing down by more than this from the vertical (slope above 90 + this) is seen
# from below: an underside (eaves, an oriel's bottom), small where buildings are photographed
# from the ground. A vertical that makes a heavy region overhang so is no vertical: the cross
# product of a small side wall and a 47-degree roof made the roof a wall and the front wall
# overhang by 42 degrees (dev seed 58002, 43 degrees off); its weight counts against it.
OVERHANG_DEG = 30.0
# Pixels that share one matching window (the block matcher's 11 x 11, vision.evidence's
# DEFAULT_WINDOW, less its tapered edge): a plane fit's residuals are correlated over it, so
# one pixel in this many is an independent measurement (`RegionView.normal_sigma_rad`).
FIT_CORRELATED_PX = 81.0
# A plane fit's normal is not known better than this (degrees), however many pixels it has:
# the disparity refinement's residual bias. The ground of the synthetic streets, 100,000-
# 360,000 inliers over 3,000-4,400 m², is 0.002-0.008 degrees off (dev seed 7), statistically
# 0.001-0.004; the floor keeps one huge region from claiming more than that.
FIT_FLOOR_DEG = 0.01


def fit_sigma_rad(
    rms_m: FloatArray | float, samples: FloatArray | float, area_m2: FloatArray | float
) -> FloatArray:
    """1-σ tilt of plane fits, radians (shape of the broadcast inputs; inf where unknown).

    A least-squares plane through ``samples`` independent points scattered by ``rms_m``
    (metres) about it, spread over a square of ``area_m2`` (radius of gyration
    ``sqrt(area / 12)`` along each axis), tilts by ``rms_m / (sqrt(samples) · sqrt(area / 12))``;
    `FIT_FLOOR_DEG` is added in quadrature. inf where ``samples < 1`` or ``area_m2 <= 0``.
    """
    rms, n, area = np.broadcast_arrays(
        np.asarray(rms_m, dtype=np.float64),
        np.asarray(samples, dtype=np.float64),
        np.asarray(area_m2, dtype=np.float64),
    )
    known = (n >= 1.0) & (area > 0.0)
    gyration = np.sqrt(np.where(known, area, 1.0) / 12.0)
    statistical = rms / (np.sqrt(np.where(known, n, 1.0)) * gyration)
    sigma = np.hypot(statistical, math.radians(FIT_FLOOR_DEG))
    return np.where(known, sigma, np.inf)


def estimate_up(
    regions: list[RegionView],
    camera: CameraView,
    prior_window_deg: float = 60.0,
    vertical_tol_deg: float = 10.0,
    *,
    segments_px: FloatArray | None = None,
    level: bool = True,
) -> FloatArray:
    """The world's up direction (unit, (3,), world frame).

    From the regions' normals where two of them give it (see the module docstring):
    candidates are the cross products of pairs of the heaviest regions' normals that lie
    within `prior_window_deg` of the camera's -y axis; the winner makes the largest
    certainty weight of regions vertical (normal within `vertical_tol_deg` of horizontal) or
    level and facing up (the ground, flat roofs); it is then refined over the vertical
    regions as the eigenvector of the smallest eigenvalue of sum_i w_i n_i n_i^T. Before
    that, from segments_px ((N, 2, 2) the camera's line segments, undistorted pixels): their
    vertical vanishing point (`aida_kb.vision.vanishing.vertical_direction`) where at least
    VP_MIN_SUPPORT segments give it to VP_MAX_SIGMA_DEG, combined with the regions that may be
    level (`with_level_regions`) when `level` (the knowledge has parts it orients upward or
    downward: a floor on the ground, a flat roof). Else the prior (camera's -y axis).
    """
    prior: FloatArray = camera.R_cam_world.T @ np.array([0.0, -1.0, 0.0])
    from_lines = _vanishing_up(camera, segments_px, prior_window_deg)
    if from_lines is not None:
        up_vp, sigma_vp = from_lines
        return with_level_regions(up_vp, sigma_vp, regions) if level else up_vp
    fallback = prior
    heavy = sorted(regions, key=lambda r: (-r.weight, r.id))[:8]
    if len(heavy) < 2:
        return fallback
    normals = np.array([r.normal for r in regions])
    weights = np.array([max(r.weight, 1e-12) for r in regions])
    limit = math.cos(math.radians(prior_window_deg))
    tol = math.sin(math.radians(vertical_tol_deg))
    best: _Candidate | None = None
    for i in range(len(heavy)):
        for j in range(i + 1, len(heavy)):
            cross = np.cross(heavy[i].normal, heavy[j].normal)
            norm = float(np.linalg.norm(cross))
            if norm < 0.5:  # closer than 30 degrees to parallel: no reliable direction
                continue
            up = cross / norm
            if float(up @ prior) < 0:
                up = -up
            best = _better(best, up, prior, limit, normals, weights, tol)
    if best is None:
        # one wall direction (or none) in view: a region taken for level (the ground, a table,
        # a lid, a flat roof) or one taken for a wall gives it (`_one_direction_up`)
        one = _one_direction_up(heavy, normals, weights, prior, limit, tol)
        return fallback if one is None else one
    up = best[2]
    vertical = np.abs(normals @ up) < tol
    scatter = (normals[vertical] * weights[vertical, None]).T @ normals[vertical]
    values, vectors = np.linalg.eigh(scatter / weights[vertical].sum())
    if values[1] > 0.02 * values[2]:
        refined = vectors[:, 0]
        up = refined if float(refined @ up) > 0 else -refined
    result: FloatArray = np.asarray(up / np.linalg.norm(up), dtype=np.float64)
    return result


_Candidate = tuple[float, float, FloatArray]  # score, agreement with the prior, up (3,)


def _better(
    best: _Candidate | None,
    up: FloatArray,
    prior: FloatArray,
    limit: float,
    normals: FloatArray,
    weights: FloatArray,
    tol: float,
) -> _Candidate | None:
    """`best` or the candidate `up` if it is better: within the prior window (cosine `limit`)
    and making more weight of the regions (`normals` (N, 3), `weights` (N,)) vertical or level
    facing up (sine/cosine `tol`), less the weight it makes overhang (`OVERHANG_DEG`), ties to
    the one nearer the prior."""
    agreement = float(up @ prior)
    if agreement < limit:
        return best
    along = normals @ up
    score = float(weights[(np.abs(along) < tol) | (along > math.cos(tol))].sum())
    score -= float(weights[along < -math.sin(math.radians(OVERHANG_DEG))].sum())
    if best is None or (score, agreement) > (best[0], best[1]):
        return (score, agreement, up)
    return best


def _one_direction_up(
    heavy: list[RegionView],
    normals: FloatArray,
    weights: FloatArray,
    prior: FloatArray,
    limit: float,
    tol: float,
) -> FloatArray | None:
    """Up (unit, (3,), world frame) where no two heavy regions' normals give it, or None.

    Two kinds of candidate, each within the prior window (cosine `limit`) of `prior`: a
    heavy region taken for level (its normal: the ground, a table, a lid, a flat roof) and a
    heavy region taken for a wall (the prior made perpendicular to its normal: the vertical
    lies in a wall's plane, and the camera's up is the best guess of where). The winner makes
    the largest weight of regions vertical or level facing up (sine/cosine `tol`, as in
    `estimate_up`); ties go to the one nearer the prior. A wall in view and a pitched roof
    above it (a shed seen from its front, 14-22 degrees) gave the roof's normal alone, so the
    wall leaned by the pitch and no wall hypothesis fitted it (dev seed 58010): taken for a
    wall, the wall region makes more weight vertical than the roof makes level.

    The winner is refined (`_refined_one_direction`). `normals` (N, 3) and `weights` (N,)
    are all regions'.
    """
    best: _Candidate | None = None
    for region in heavy:
        n = np.asarray(region.normal, dtype=np.float64)
        best = _better(best, n, prior, limit, normals, weights, tol)
        across = prior - float(prior @ n) * n
        size = float(np.linalg.norm(across))
        if size > 1e-6:
            best = _better(best, across / size, prior, limit, normals, weights, tol)
    if best is None:
        return None
    return _refined_one_direction(best[2], normals, weights, tol)


def _refined_one_direction(
    up: FloatArray, normals: FloatArray, weights: FloatArray, tol: float
) -> FloatArray:
    """The candidate `up` (unit, (3,)) refined over the regions vertical and facing up under it.

    The regions vertical under it (sine `tol`) share one direction here, so they fix the
    vertical only to their plane; within it, the weighted mean normal of the regions facing
    up (not vertical) made perpendicular to their weighted mean normal gives it: a level
    region or a roof pitched towards the wall (a shed's, a gable's seen from its eaves side)
    gives it exactly, where the camera's up, `up`'s source, is off by the camera's roll and
    its pitch times the wall's yaw. Without regions facing up, `up` made perpendicular to the
    walls; without vertical regions, the weighted mean normal of the regions level under it
    (cosine `tol`). `normals` (N, 3) unit, `weights` (N,).
    """
    along = normals @ up
    vertical = np.abs(along) < tol
    out = np.asarray(up, dtype=np.float64)
    if not np.any(vertical):
        level = along > math.cos(tol)
        if np.any(level):
            out = (normals[level] * weights[level, None]).sum(axis=0)
    else:
        facing_up = along >= tol
        if np.any(facing_up):
            out = (normals[facing_up] * weights[facing_up, None]).sum(axis=0)
        # one wall direction (the normals may face either way: align them with the first)
        signs = np.sign(normals[vertical] @ normals[vertical][0])
        wall = (normals[vertical] * (weights[vertical] * signs)[:, None]).sum(axis=0)
        wall = wall / np.linalg.norm(wall)
        out = out - float(out @ wall) * wall
    size = float(np.linalg.norm(out))
    if size < 1e-9:
        return np.asarray(up, dtype=np.float64)
    result: FloatArray = np.asarray(out / size, dtype=np.float64)
    return result if float(result @ up) > 0 else -result


def _vanishing_up(
    camera: CameraView, segments_px: FloatArray | None, prior_window_deg: float
) -> tuple[FloatArray, float] | None:
    """Up (unit, (3,), world frame) from the vertical vanishing point of the camera's segments
    ((N, 2, 2) undistorted pixels) and its 1-σ (radians), or None when it is not known to
    VP_MAX_SIGMA_DEG."""
    if segments_px is None or not len(segments_px):
        return None
    vp = vertical_direction(
        segments_px, camera.K, prior_window_deg=min(prior_window_deg, VP_PRIOR_WINDOW_DEG)
    )
    if vp is None or vp.sigma_deg > VP_MAX_SIGMA_DEG or vp.support < VP_MIN_SUPPORT:
        return None
    up: FloatArray = camera.R_cam_world.T @ vp.direction
    return up / float(np.linalg.norm(up)), math.radians(vp.sigma_deg)


def with_level_regions(up: FloatArray, sigma_rad: float, regions: list[RegionView]) -> FloatArray:
    """The vertical `up` (unit, (3,), world frame; 1-σ `sigma_rad`, radians) combined with the
    normals of the regions that may be level (unit, (3,), world frame).

    A region may be level when it faces up within LEVEL_GATE_DEG of `up`, and within
    LEVEL_GATE_SIGMAS of their combined 1-σ. Each such normal is a measurement of the vertical
    with its plane fit's uncertainty (`RegionView.normal_sigma_rad`), `up` one with its own:
    the result is their inverse-variance weighted mean in the plane tangent to `up` (the
    cones taken as round: the segments' cone gives its larger axis, a fit's spread differs
    little between its axes against the orders of magnitude between the sources). The
    ground of a street, fitted over thousands of square metres, then decides (hundredths of a
    degree), where the segments' vanishing point was up to 0.86 degrees off; a small or rough
    region weighs little, and with no level region `up` is returned unchanged.
    """
    if not regions:
        return up
    normals = np.array([r.normal for r in regions], dtype=np.float64)
    sigmas = np.array([r.normal_sigma_rad for r in regions], dtype=np.float64)
    off = np.arccos(np.clip(normals @ up, -1.0, 1.0))  # radians from up (facing up: < 90 deg)
    gate = np.minimum(math.radians(LEVEL_GATE_DEG), LEVEL_GATE_SIGMAS * np.hypot(sigma_rad, sigmas))
    level = np.isfinite(sigmas) & (off <= gate)
    if not np.any(level):
        return up
    # tangent-plane coordinates of each level normal about `up`, inverse-variance weights
    tangent = normals[level] - (normals[level] @ up)[:, None] * up[None, :]
    weights = 1.0 / sigmas[level] ** 2
    shift = (weights[:, None] * tangent).sum(axis=0) / (weights.sum() + 1.0 / sigma_rad**2)
    combined = up + shift
    result: FloatArray = np.asarray(combined / np.linalg.norm(combined), dtype=np.float64)
    return result


BOUNDARY_TOLERANCE_PX = 4.0
ALONG_SHARE = 0.75
"""`_along`: the share of a segment's length that must lie within BOUNDARY_TOLERANCE_PX of
the region's outline. A segment along the outline lies within it nearly all its length (on
the first views of the 13 unlabelled dev scenes of 61700-61735, 99 % of the segments with a
region on one side only reach 0.75, 81 % of all reach 1.0: an outline's wiggles beyond the
tolerance along a quarter of a segment keep it); a segment inside the region that only touches
the outline at its ends -- a line bridging two notches where occluders cut into the region --
is no edge of its part. The real courtyard wall (Strecha castle, exact NCC): the plinth's top
inside the wall's region, 10 px above its foot, ran between the notches of four bollards and
the tractor; matched to the wall's foot with a fragment of the true foot 20 px below, it turned
the wall's model 1.1 degrees off its region."""
ALONG_STEP_PX = 2.0  # the segment is sampled every this many pixels (half the tolerance)


def _along(ends_px: FloatArray, polygon_px: FloatArray) -> bool:
    """True if a segment runs along a closed polygon: both its ends and ALONG_SHARE of its
    length (sampled every ALONG_STEP_PX) lie within BOUNDARY_TOLERANCE_PX of it.

    Segments inside a region (window frames, texture, a line between two notches of its
    outline) are not its boundary and cannot be the edges of its part; only those along the
    region's contour are kept. ends_px (2, 2) and polygon_px (M, 2): pixels.
    """
    a = polygon_px
    ab = np.roll(polygon_px, -1, axis=0) - a
    length2 = np.maximum(np.sum(ab * ab, axis=1), 1e-12)

    def distances(points: FloatArray) -> FloatArray:
        rel = points[:, None, :] - a[None, :, :]  # (S, M, 2)
        t = np.clip(np.einsum("smk,mk->sm", rel, ab) / length2, 0.0, 1.0)
        gap = rel - t[:, :, None] * ab[None, :, :]
        out: FloatArray = np.sqrt(np.min(np.einsum("smk,smk->sm", gap, gap), axis=1))
        return out

    if float(np.max(distances(ends_px))) > BOUNDARY_TOLERANCE_PX:
        return False
    length = float(np.linalg.norm(ends_px[1] - ends_px[0]))
    count = max(2, math.ceil(length / ALONG_STEP_PX) + 1)
    s = np.linspace(0.0, 1.0, count)[:, None]
    samples = ends_px[0] + s * (ends_px[1] - ends_px[0])
    return float(np.mean(distances(samples) <= BOUNDARY_TOLERANCE_PX)) >= ALONG_SHARE


# A face of a convex part is a convex polygon in the image: its region, where a label image
# draws it (the face's visible part; a segmented region may leak across the face's edge),
# lies on one side of each of its edges' lines. A segment bordering one region whose
# line that region crosses by more than this (px; the outline's simplification and pixels put
# a face's hull within 2-3 px of its edge lines) beside the segment runs along a notch of the
# region, where something in front cuts into it (an occluder's top, a tree's side): no edge
# of the face. A stone block's top across a front wall, 15 px above the wall's foot, was
# matched to the wall's foot and tilted the model 8 degrees off its regions (dev seed 58002,
# nothing found).
CUT_PX = 6.0
# "Beside": the outline within this many of the segment's lengths beyond either of its ends.
# A short fragment's direction is not good enough to follow its line much further: a wall's
# foot broken into 30-px fragments each tilted 6 degrees by the jagged border (dev seed 58020)
# would have the wall's far corners 40 px beyond the extended line.
CUT_REACH = 1.0


def _cuts(ends_px: FloatArray, polygons: list[FloatArray]) -> bool:
    """True if the region's outline (closed polygons (M, 2) px) lies beyond CUT_PX on both
    sides of a segment's line (ends (2, 2) px), beside the segment (`CUT_REACH`)."""
    direction = ends_px[1] - ends_px[0]
    length = float(np.linalg.norm(direction))
    if length < 1e-9 or not polygons:
        return False
    along = direction / length
    normal = np.array([-along[1], along[0]])
    rel = np.concatenate(polygons) - ends_px[0]
    t = rel @ along
    beside = (t >= -CUT_REACH * length) & (t <= (1.0 + CUT_REACH) * length)
    signed = rel[beside] @ normal
    return bool(len(signed) and signed.max() > CUT_PX and signed.min() < -CUT_PX)


def view_of(evidence: Evidence, source: str = "") -> EvidenceView:
    """The numpy view of an evidence file: the views whose 3-D quantities are in the world frame.

    Views in their own camera frame (pose not yet registered) are left out. Segment and
    contour pixels are undistorted with the left camera's D. Region ids become
    "VIEW/REGION", segment ids "VIEW/lSEGMENT". Where the evidence gives a region's contour,
    a segment borders that region only if it runs along the contour (`_along`), and a segment
    along one region drawn in a label image only if that region does not cross its line
    beside it (`_cuts`: a notch, no edge of a face); segments that border no region are left
    out.
    """
    cameras: dict[str, CameraView] = {}
    regions: dict[str, RegionView] = {}
    segments: list[SegmentView] = []
    all_outlines: dict[str, list[FloatArray]] = {}
    lines_px: dict[str, FloatArray] = {}
    for v in evidence.views:
        if v.frame != "world":
            continue
        cameras[v.id] = CameraView(
            v.id,
            np.array(v.left.K, dtype=np.float64),
            np.array(v.left.R, dtype=np.float64),
            np.array(v.left.t, dtype=np.float64),
            v.image_width,
            v.image_height,
            float(np.linalg.norm(np.array(v.right.cahv.C) - np.array(v.left.cahv.C))),
            np.array(v.left.D, dtype=np.float64).ravel(),
        )
        for r in v.regions:
            rid = f"{v.id}/{r.id}"
            regions[rid] = RegionView(
                rid,
                v.id,
                np.array(r.n_init, dtype=np.float64),
                np.array(r.c_init, dtype=np.float64),
                float(r.w_c),
                float(r.pixel_count),
                float(r.rms_m),
                int(r.inlier_count),
                float(r.area_m2),
            )
        K = np.array(v.left.K, dtype=np.float64)
        D = np.array(v.left.D, dtype=np.float64)
        # regions drawn in a label image: each a face's visible part, exactly (`_cuts`)
        drawn = {r.id for r in v.regions if r.label is not None}
        outlines: dict[int, list[FloatArray]] = {}
        for c in v.contours:
            outline = undistort_pixels(np.array(c.points, dtype=np.float64), K, D)
            outlines.setdefault(c.region, []).append(outline)
            all_outlines.setdefault(f"{v.id}/{c.region}", []).append(outline)
        ends_all = np.array([(s.p1, s.p2) for s in v.lines], dtype=np.float64).reshape(-1, 2, 2)
        ends_all = undistort_pixels(ends_all.reshape(-1, 2), K, D).reshape(-1, 2, 2)
        lines_px[v.id] = ends_all
        for s, ends in zip(v.lines, ends_all, strict=True):
            kept = [
                r
                for r in s.regions
                if r not in outlines or any(_along(ends, poly) for poly in outlines[r])
            ]
            if len(kept) == 1 and kept[0] in drawn and _cuts(ends, outlines.get(kept[0], [])):
                kept = []
            borders = tuple(f"{v.id}/{r}" for r in kept)
            if borders:
                segments.append(SegmentView(f"{v.id}/l{s.id}", v.id, ends, borders))
    reference = evidence.views[0].id if evidence.views else "00"
    if reference not in cameras:
        raise InterpretError(
            f"{source or 'evidence'}: the first view {reference!r} is not in the world frame"
        )
    return EvidenceView(
        cameras,
        regions,
        tuple(segments),
        reference,
        source,
        {r: tuple(o) for r, o in all_outlines.items() if r in regions},
        lines_px,
        metric=evidence.units == "m",
    )
