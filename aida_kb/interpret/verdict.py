"""The verdict on an accepted interpretation: verified, doubtful (with the reasons) or nothing.

The search accepts the best hypothesis whose constraints stay under their thresholds. That
alone lets a wrong model through when the evidence it fails to use is simply ignored (a roof
"inserted from knowledge" while a roof region fills a third of the image). An interpretation
is **verified** only when it also

(a) keeps every instantiated constraint under its threshold (the residual report; the
    evidence factors a multi-view adjustment adds by code — rule ``evidence`` — are judged by
    (b) and (c) instead: an outlier among them is no contradiction of the knowledge);
(b) explains the evidence: of the certainty weight of the regions that lie inside the model's
    projection (the ray through a region's centre meets a model face), most lies on a model
    face (the region's plane within `DEPTH_TOLERANCE` of the face and its normal within
    `NORMAL_TOLERANCE_DEG`, its centre inside the face's polygon). A region the model covers
    but does not explain contradicts it: seen *through* the model (beyond the face the ray
    meets) or on a face at another orientation. A region in front of the model may be
    something standing before it (a tree) and counts neither way — unless it stands close
    before a face and parallel to it: such regions may carry STANDING_OUT_SHARE_MAX of the
    weight together (an oriel the model lacks);
(c) agrees with every registered view: the same test in each view, at the camera the
    reconstruction gave it; a view that does not explain its evidence is named, and so is a
    view where the model covers none of its regions or shows none of its edges (nothing
    there confirms the camera: a registration 100 degrees off passes every test for want
    of evidence), a view a reconstruction left without a camera (not registered: the
    result does not say where it was taken from; `judge(..., all_views=True)`), and a
    registered view (not the first, which sets the world frame) whose camera the
    adjustment fixes only to more than CAMERA_ANGLE_SD_MAX_DEG or CAMERA_CENTRE_SD_MAX of
    its distance (at two standard deviations, CAMERA_SD_CONFIDENCE, from the adjustment's
    covariance at the scatter its measurements show, `aida_kb.interpret.uncertainty`:
    segments and regions of every view, the model's planes unknowns too);
(d) meets the knowledge's attribute ranges: every attribute of an instantiated concept that
    stands for a geometric measure (`is slope(self)`, `height(self)`, ...; docs/language.md
    3.10) is measured on the model and must lie in its range; and every part the knowledge
    orients at a fixed slope (`orient top: upward`, 3.9) has it. "Up" is the direction of a
    part the knowledge orients upward or downward (the floor);
(e) measures every part (inserted from knowledge, or bound to regions none of which lies
    on it): a region of some view lies on it, the outlines of regions on the model reach
    its plane over an area inside its face (spanning OUTLINE_SPAN of it), or two of its
    edges are measured — seen (segments along half the edge) in two views, or in one view
    along a neighbour a region measures; one such edge suffices when the knowledge orients
    the part parallel or square to parts regions measure — unless that orientation is the
    choice among alternatives the evidence has not told apart (a flat roof's level top
    through its front eave: a shed's sloping top has that eave too; and the regions on such
    a part lie within CONTESTED_NORMAL_DEG of it, not only within (b)'s tolerance). A part
    not measured is where the knowledge's placement put it (a back wall mirrored about the
    ridge: the house's depth a guess; a roof's hidden back as steep as its front: a shed
    taken for a gable; a floor square to the walls), not where the scene has it. A part
    placed by its edges is placed to POSITION_TOLERANCE of the model's size (one standard
    deviation of its offset, from how far a pixel across each edge moves it in the views
    that see it, or the adjustment's covariance if larger: a wing's end from one edge seen
    at a grazing angle is not);
(f) lacks no surface joined to the object: a region outside the model's projection or in
    front of it, of at least ADJOINING_MIN_SHARE of the view's region pixels, whose outline
    meets a model face in 3-D along a quarter of the model's size, and which continues no
    face's plane (the ground continues the floor), is a part the model lacks (a hip roof's
    slopes above walls taken for a flat roof's); a tree before the house does not meet it;
(g) explains the surfaces near it: of the weight of the regions on the model and of those
    outside its projection or in front of it whose centres lie within NEAR_MARGIN of its
    size of its bounding box (and continue no face's plane), the model explains at least
    NEAR_EXPLAINED_MIN (an L-shaped house taken for its body leaves the wing's walls and
    roof there; an occluder covers at most a third of an object).

Otherwise the interpretation is **doubtful**, and the reasons say which check failed and
where. An interpretation that found no object is **nothing**; so is one whose sizes (the
attributes in metres) lie outside the knowledge's ranges: what was found is not the goal (a
0.3 m box is no house), and the reasons say which sizes; and so is a reconstruction that
registered none of the scene's other views (`unconfirmed`: no other view confirms the object;
a tree's box-shaped crown taken for a small house in one view). The summary line says the
reasons once for several parts (`summary_reasons`). Everything is read from the
compiled knowledge base and the files: no concept or attribute of a particular .kb is named.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from aida_kb.interpret.result import INSERTED, Instance, Interpretation
from aida_kb.interpret.uncertainty import Uncertainty, adjustment_uncertainty
from aida_kb.io.evidence import Evidence, ViewEvidence
from aida_kb.io.model import CameraSd, ModelCamera, PartSd, ReconstructedModel
from aida_kb.kb.model import AttributeModel, KnowledgeBase, MeasureKind

if TYPE_CHECKING:
    from aida_kb.register.model import RigidModel, VisibleEdges

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

VERIFIED, DOUBTFUL, NOTHING = "verified", "doubtful", "nothing"

DEPTH_TOLERANCE = 0.015  # a region lies on a face within 1.5 % of its distance from the camera
DEPTH_TOLERANCE_MIN_M = 0.05  # ... and never tighter than 5 cm (stereo noise of near faces)
NORMAL_TOLERANCE_DEG = 8.0  # a region's normal within 8 degrees of the face's (plane fits of
# small, slanted or weakly textured regions scatter by a few degrees)
INSIDE_MARGIN = 0.05  # a region's centre may lie this fraction of the face's size outside it
EXPLAINED_MIN = 0.75  # the explained share of the weight inside the projection, at least
CONTRADICTION_MAX = 0.08  # one region that contradicts the model may carry at most this
# share of the weight inside the projection (8 %: a misfitted roof plane is far above)
MIN_WEIGHT_SHARE = 0.002  # regions lighter than this share of a view's weight are noise
STANDING_OUT_MAX = 0.15  # a parallel region this share of the model's size in front of a
# face stands out of it (a part the model lacks), further away it may be an occluder
STANDING_OUT_SHARE_MAX = 0.02  # such regions may carry at most 2 % of a view's weight inside
# the projection together (an oriel the model lacks: 3-5 %; a stray region: well below)
ORIENTATION_TOLERANCE_DEG = 4.0  # a part the knowledge orients (a flat roof's top upward)
# lies within 4 degrees of that slope (a shed roof of 8-25 degrees is no flat roof)
SIZE_UNIT = "m"  # attributes of this unit are sizes: outside their ranges the object is another
RANGE_SLACK_REL = 1e-3  # measured attributes: a range is met within this relative slack


EDGE_TOLERANCE_PX = 3.0  # a segment shows a projected model edge within 3 px (a segment's
# ends scatter by about a pixel; a camera 0.3 degree off moves edges by several pixels)
EDGE_ANGLE_DEG = 4.0  # ... and within 4 degrees of its direction
EDGE_MIN_LENGTH_PX = 25.0  # only projected edges at least this long are checked
SEEN_EDGE_COVER_MIN = 0.4  # edges between two parts bound to the evidence: at least this share
OUTLINE_TOLERANCE_PX = 4.0  # a region's outline reaches a plane within 4 px of it
OUTLINE_STEP_PX = 3.0  # region outlines are sampled every 3 px along their sides
ADJOINING_MIN_SHARE = 0.02  # (f): a region of at least 2 % of a view's region pixels ...
ADJOINING_SPAN = 0.25  # ... meeting a face along a quarter of the model's size is a surface
# joined to the object (a roof slope above a wall's eave), not background touching it
NEAR_MARGIN = 0.25  # (g): a region whose centre lies within a quarter of the model's size of
# its bounding box is near the object (an occluder standing further off is not)
NEAR_EXPLAINED_MIN = 0.6  # ... and the model explains at least 60 % of the weight of the
# regions on it and near it (occluders cover up to 30 % of an object: their regions weigh
# less than half of what the model explains; a missing wing weighs more)
POSITION_TOLERANCE = 0.02  # (e): a part placed by its edges alone is placed to 2 % of the
# model's size (one standard deviation; the accuracy asked of its vertices)
OUTLINE_AREA_RATIO = 0.2  # outlines reaching a plane spread over an area, not along a line
OUTLINE_SPAN = 0.25  # ... along at least a quarter of the face's size (its polygon's diagonal)
CONTESTED_NORMAL_DEG = 3.0  # the regions measuring a part whose orientation is the choice
# among alternatives lie within 3 degrees of it on average (fits of regions that large agree
# with their faces to 1-2 degrees; a shed's top pitched 8 degrees is no flat roof's)
MEASURING_SHARE = 0.05  # a region measures its part's plane when it carries 5 % of the
# weight in the model's projection (a sliver's plane fit scatters by degrees)
MEASURED_LINES = 2  # a plane through two measured lines (not one) is measured ...
EXACT_DEG = 0.5  # ... or through one, parallel or square to a measured part within 0.5 deg
COS_PARALLEL = math.cos(math.radians(EXACT_DEG))
SIN_SQUARE = math.sin(math.radians(EXACT_DEG))
EDGE_SIGMA_PX = 1.0  # an image line's ends scatter by a pixel across it (the knowledge's
# `measure edge(...) +- 1 px`); how far that moves a plane through the edge is its uncertainty
CAMERA_ANGLE_SD_MAX_DEG = 0.1  # (c): the adjustment fixes a registered view's camera to
# 0.1 degree (at CAMERA_SD_CONFIDENCE sd; the accuracy asked of it, the paper's Table 1) ...
CAMERA_CENTRE_SD_MAX = 0.01  # ... and its centre to 1 % of its distance from the model
CAMERA_SD_CONFIDENCE = 2.0  # ... at this many standard deviations: an sd just under the
# target still leaves about one chance in three of an error above it (street2 dev seed 7:
# view 01 verified at sd < 0.1 deg, 0.173 deg off); two sd make it about one in twenty
EDGE_SEEN_SHARE = 0.5  # an edge is seen in a view when segments lie along half its length
EDGE_COVER_MIN = 0.5  # at least this share of the visible edges' length is seen as segments
# (edges between faces of like brightness or under an occluder show no segment: a right
# model's edges are seen along 52-96 % on development scenes, a wrong roof's or a missing
# wing's along 30-47 % — their edges run where the building has none)


@dataclass(frozen=True)
class ViewCheck:
    """How well the model explains one view's regions (weights are certainty sums, eq. 4)
    and segments (`edge_cover`: the share of the visible model edges' projected length that
    image segments lie on; None when no edge is long enough to check)."""

    view: str
    inside_weight: float  # regions inside the model's projection (explained + contradicting)
    explained_weight: float
    contradicting: list[tuple[int, float, str]]  # (region id, weight share, why)
    edge_cover: float | None = None
    explained_on: dict[str, float] = field(default_factory=dict)  # part role -> weight on it
    explained_ids: tuple[int, ...] = ()  # the regions on a model face
    free_ids: tuple[int, ...] = ()  # regions outside the projection or in front of the model
    standing_out_weight: float = 0.0  # regions parallel to a face, standing out of it
    turned_on: dict[str, float] = field(default_factory=dict)  # part role -> the weighted mean
    # angle, degrees, between its face's normal and the normals of the regions on it

    @property
    def explained_share(self) -> float:
        """The share of the weight inside the projection that the model explains."""
        return self.explained_weight / self.inside_weight if self.inside_weight > 0 else 1.0


@dataclass(frozen=True)
class Verdict:
    """The verdict and its reasons (empty when verified); views named as not explained."""

    verdict: str
    reasons: tuple[str, ...]
    views_not_explained: tuple[str, ...]
    checks: tuple[ViewCheck, ...]
    uncertainty: Uncertainty | None = None  # the adjustment's standard deviations


# ---- geometry of the model ---------------------------------------------------------------------
def _faces(model: ReconstructedModel) -> list[tuple[str, FloatArray, float, FloatArray]]:
    """(role, unit normal (3,), offset d, polygon (N, 3)) of every part, world frame."""
    return [
        (p.role, np.asarray(p.normal, dtype=np.float64), float(p.offset_m), np.asarray(p.polygon))
        for p in model.parts
    ]


def _size(model: ReconstructedModel) -> float:
    """The diagonal of the model's bounding box, metres."""
    pts = np.vstack([np.asarray(p.polygon, dtype=np.float64) for p in model.parts])
    return float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0)))


def _inside_polygon(points: FloatArray, poly: FloatArray, normal: FloatArray) -> FloatArray:
    """Even-odd test of points (M, 3) on the plane of `poly` (N, 3); the polygon is grown by
    INSIDE_MARGIN of its size about its centre. Returns (M,) bool."""
    centre = poly.mean(axis=0)
    grown = centre + (poly - centre) * (1.0 + INSIDE_MARGIN)
    a = np.cross(normal, [1.0, 0.0, 0.0])
    if np.linalg.norm(a) < 0.1:
        a = np.cross(normal, [0.0, 1.0, 0.0])
    u = a / np.linalg.norm(a)
    v = np.cross(normal, u)
    pu, pv = points @ u, points @ v
    qu, qv = grown @ u, grown @ v
    inside = np.zeros(len(points), bool)
    for i in range(len(qu)):
        au, av, bu, bv = qu[i], qv[i], qu[i - 1], qv[i - 1]
        if av == bv:
            continue
        crosses = (av > pv) != (bv > pv)
        inside ^= crosses & (pu < au + (pv - av) * ((bu - au) / (bv - av)))
    return inside


def check_view(view: ViewEvidence, model: ReconstructedModel) -> ViewCheck | None:
    """Check (b) for one view at the model's camera of that view (None: no such camera)."""
    camera = next((c for c in model.cameras if c.view == view.id), None)
    regions = [r for r in view.regions if r.w_c > 0 and r.depth_pixel_count > 0]
    if camera is None or not regions:
        return None
    R = np.asarray(camera.R, dtype=np.float64)
    t = np.asarray(camera.t, dtype=np.float64)
    C = -R.T @ t
    centres = np.array([r.c_init for r in regions], dtype=np.float64)
    normals = np.array([r.n_init for r in regions], dtype=np.float64)
    if view.frame == "camera":  # this view's own left camera -> world
        centres = (centres - t) @ R
        normals = normals @ R
    weights = np.array([r.w_c for r in regions], dtype=np.float64)
    keep = weights >= MIN_WEIGHT_SHARE * weights.sum()
    rays = centres - C  # (M, 3); the region's centre at parameter 1
    dist = np.linalg.norm(rays, axis=1)
    tol = np.maximum(DEPTH_TOLERANCE * dist, DEPTH_TOLERANCE_MIN_M)
    cos_tol = math.cos(math.radians(NORMAL_TOLERANCE_DEG))
    m = len(regions)
    explained = np.zeros(m, bool)
    on_face: dict[str, float] = {}
    turned_on: dict[str, float] = {}
    nearest = np.full(m, np.inf)  # ray parameter of the first model face the ray meets
    nearest_cos = np.zeros(m)  # |cos| between the region's normal and that face's
    for role, n, d, poly in _faces(model):
        # (1) the region lies on this face
        on_plane = np.abs(centres @ n - d) <= tol
        aligned = np.abs(normals @ n) >= cos_tol
        cand = on_plane & aligned
        if cand.any():
            on = np.zeros(m, bool)
            on[cand] = _inside_polygon(centres[cand], poly, n)
            explained |= on
            on_face[role] = float(weights[on & keep].sum())
            if on_face[role] > 0:
                cos = np.clip(np.abs(normals[on & keep] @ n), 0.0, 1.0)
                turned_on[role] = float(
                    np.degrees(np.arccos(cos)) @ weights[on & keep] / on_face[role]
                )
        # (2) where the ray through the region's centre meets this face
        denom = rays @ n
        with np.errstate(divide="ignore", invalid="ignore"):
            s = (d - C @ n) / denom
        hit_ok = np.isfinite(s) & (s > 0)
        if hit_ok.any():
            idx = np.nonzero(hit_ok)[0]
            pts = C + s[idx, None] * rays[idx]
            hit = np.zeros(m, bool)
            hit[idx] = _inside_polygon(pts, poly, n)
            closer = hit & (s < nearest)
            nearest[closer] = s[closer]
            nearest_cos[closer] = np.abs(normals[closer] @ n)
    inside = keep & np.isfinite(nearest)
    gap = (nearest - 1.0) * dist  # > 0: the model's surface lies beyond the region
    size = _size(model)
    # in front of the model: something standing before it (neutral) unless it is close to
    # the surface and parallel to it (a part standing out that the model lacks: an oriel)
    before = inside & ~explained & (gap > tol)
    standing_out = before & (gap < STANDING_OUT_MAX * size) & (nearest_cos >= cos_tol)
    in_front = before & ~standing_out
    counted = inside & ~in_front
    through = counted & ~explained & (gap < -tol)
    turned = counted & ~explained & ~through & ~standing_out
    total = float(weights[counted].sum())
    contradicting = []
    for i in np.nonzero(through | turned | standing_out)[0]:
        if through[i]:
            why = f"seen {-gap[i]:.2f} m beyond the model's surface"
        elif standing_out[i]:
            why = f"standing {gap[i]:.2f} m out of the model's surface, parallel to it"
        else:
            angle = math.degrees(math.acos(min(1.0, nearest_cos[i])))
            why = f"on the model's surface at {angle:.0f} deg to its face"
        contradicting.append((regions[i].id, float(weights[i]) / max(total, 1e-12), why))
    contradicting.sort(key=lambda c: -c[1])
    return ViewCheck(
        view.id,
        total,
        float(weights[counted & explained].sum()),
        contradicting,
        edge_cover(view, model),
        on_face,
        tuple(int(regions[i].id) for i in np.nonzero(counted & explained)[0]),
        tuple(int(regions[i].id) for i in np.nonzero(~counted)[0]),
        float(weights[standing_out & keep].sum()),
        turned_on,
    )


def _edge_coverage(
    view: ViewEvidence, model: ReconstructedModel
) -> tuple[RigidModel, VisibleEdges, FloatArray] | None:
    """The model edges the view's camera sees (at least EDGE_MIN_LENGTH_PX long) and the
    length of each, pixels, that image segments lie on (within EDGE_TOLERANCE_PX and
    EDGE_ANGLE_DEG; segments undistorted with the view's distortion first). None: no camera
    or no segments."""
    from aida_kb.register.evidence import camera_of, measurements_of
    from aida_kb.register.match import match_segments
    from aida_kb.register.model import RigidModel

    camera = next((c for c in model.cameras if c.view == view.id), None)
    if camera is None or not view.lines:
        return None
    rigid = RigidModel.from_model(model)
    edges = rigid.visible_edges(camera_of(camera), min_length_px=EDGE_MIN_LENGTH_PX)
    covered = np.zeros(edges.index.size)
    if edges.index.size == 0:
        return rigid, edges, covered
    meas = measurements_of(view)
    matches = match_segments(
        edges.a,
        edges.b,
        meas.p1,
        meas.p2,
        max_distance_px=EDGE_TOLERANCE_PX,
        max_angle_rad=math.radians(EDGE_ANGLE_DEG),
    )
    if matches.size == 0:
        return rigid, edges, covered
    a, b = edges.a[matches.edge], edges.b[matches.edge]
    length = edges.length_px[matches.edge]
    u = (b - a) / np.maximum(length, 1e-12)[:, None]
    t1 = np.einsum("mk,mk->m", meas.p1[matches.segment] - a, u)
    t2 = np.einsum("mk,mk->m", meas.p2[matches.segment] - a, u)
    lo = np.clip(np.minimum(t1, t2), 0.0, length)
    hi = np.clip(np.maximum(t1, t2), 0.0, length)
    np.add.at(covered, matches.edge, hi - lo)  # pieces of one edge rarely overlap
    return rigid, edges, np.minimum(covered, edges.length_px)


def edge_cover(
    view: ViewEvidence, model: ReconstructedModel, between: frozenset[str] | None = None
) -> float | None:
    """The share of the projected length of the model edges the view's camera sees that
    image segments lie on (within EDGE_TOLERANCE_PX and EDGE_ANGLE_DEG); None: no edge to
    check or no camera. Segments are undistorted with the view's distortion first.
    between : only the edges both of whose parts are in this set of roles."""
    found = _edge_coverage(view, model)
    if found is None:
        return None
    rigid, edges, covered = found
    sel: npt.NDArray[np.bool_] = np.ones(edges.index.size, bool)
    if between is not None:
        names = np.array([n in between for n in rigid.names])
        sel = np.asarray(names[rigid.edge_faces[edges.index]].all(axis=1), dtype=bool)
    if not sel.any():
        return None
    return float(covered[sel].sum() / edges.length_px[sel].sum())


def _camera_doubts(view: str, model: ReconstructedModel, unc: Uncertainty | None) -> list[str]:
    """Check (c) for a registered view's camera (problems): the adjustment's covariance
    (`aida_kb.interpret.uncertainty`) fixes its rotation to CAMERA_ANGLE_SD_MAX_DEG and its
    centre to CAMERA_CENTRE_SD_MAX of its distance from the model's centre, both at
    CAMERA_SD_CONFIDENCE standard deviations."""
    camera = next((c for c in model.cameras if c.view == view), None)
    if camera is None:
        return []
    if unc is None or view not in unc.cameras:
        return ["camera: the adjustment's covariance could not be computed"]
    angle, centre_m = unc.cameras[view]
    corners = np.vstack([np.asarray(p.polygon, dtype=np.float64) for p in model.parts])
    R = np.asarray(camera.R, dtype=np.float64)
    C = -R.T @ np.asarray(camera.t, dtype=np.float64)
    distance = float(np.linalg.norm(C - corners.mean(axis=0)))
    centre = centre_m / max(distance, 1e-9)
    k = CAMERA_SD_CONFIDENCE
    if k * angle <= CAMERA_ANGLE_SD_MAX_DEG and k * centre <= CAMERA_CENTRE_SD_MAX:
        return []
    return [
        f"camera is fixed by the adjustment only to +-{angle:.2f} deg and +-{100 * centre:.1f}% "
        f"of its distance ({k:g} sd at most {CAMERA_ANGLE_SD_MAX_DEG:g} deg and "
        f"{100 * CAMERA_CENTRE_SD_MAX:g}%; {unc.measurements} measurements, their scatter "
        f"{unc.variance_factor**0.5:.2f} of their noise model)"
    ]


def seen_edges(
    evidence: Evidence, model: ReconstructedModel
) -> tuple[tuple[str, ...], IntArray, list[set[str]]]:
    """Which view sees which model edge: image segments lie along at least EDGE_SEEN_SHARE
    of the edge's visible projected length in that view. Returns the part names, the
    edges' two parts (E, 2) (indices into the names; the model's `RigidModel` edges) and,
    per edge, the ids of the views that see it."""
    from aida_kb.register.model import RigidModel

    rigid = RigidModel.from_model(model)
    views: list[set[str]] = [set() for _ in range(len(rigid.edge_faces))]
    for view in evidence.views:
        found = _edge_coverage(view, model)
        if found is None:
            continue
        _, edges, covered = found
        for i in edges.index[covered >= EDGE_SEEN_SHARE * edges.length_px]:
            views[int(i)].add(view.id)
    return rigid.names, np.asarray(rigid.edge_faces, dtype=np.int64), views


def _densified(polygon_px: FloatArray) -> FloatArray:
    """A closed polygon (N, 2) sampled every OUTLINE_STEP_PX along its sides (M, 2)."""
    nxt = np.roll(polygon_px, -1, axis=0)
    steps = np.maximum(1, (np.linalg.norm(nxt - polygon_px, axis=1) // OUTLINE_STEP_PX)).astype(int)
    owner = np.repeat(np.arange(len(polygon_px)), steps)
    frac = np.arange(int(steps.sum())) - np.repeat(np.cumsum(steps) - steps, steps)
    frac = frac / steps[owner]
    out: FloatArray = polygon_px[owner] + (nxt[owner] - polygon_px[owner]) * frac[:, None]
    return out


def outline_points(
    view: ViewEvidence, region_ids: tuple[int, ...], model: ReconstructedModel
) -> tuple[FloatArray, FloatArray]:
    """The outlines of the view's regions `region_ids` on their fitted planes: points (K, 3),
    metres, world frame, and each one's tolerance (K,), metres: OUTLINE_TOLERANCE_PX at its
    distance from the camera (outlines of segmented regions are good to a few pixels; lens
    distortion is left out, as it moves them by less). Empty without the view's camera."""
    camera = next((c for c in model.cameras if c.view == view.id), None)
    wanted = set(region_ids)
    planes = {r.id: r for r in view.regions if r.id in wanted}
    contours = [c for c in view.contours if c.region in planes and not c.hole]
    if camera is None or not contours:
        return np.zeros((0, 3)), np.zeros(0)
    K = np.asarray(view.left.K, dtype=np.float64)
    R_cam_frame = np.asarray(view.left.R, dtype=np.float64)
    t_cam_frame = np.asarray(view.left.t, dtype=np.float64)
    out, tol = [], []
    for c in contours:
        r = planes[c.region]
        px = _densified(np.asarray(c.points, dtype=np.float64))
        rays = np.linalg.solve(K, np.vstack([px.T, np.ones(len(px))])).T  # (N, 3) camera frame
        n_cam = R_cam_frame @ np.asarray(r.n_init, dtype=np.float64)
        d_cam = float(r.d_init) + float(n_cam @ t_cam_frame)
        denom = rays @ n_cam
        with np.errstate(divide="ignore", invalid="ignore"):
            depth = d_cam / denom
        ok = np.isfinite(depth) & (depth > 0)  # on the plane in front of the camera
        x_cam = rays[ok] * depth[ok, None]
        x_frame = (x_cam - t_cam_frame) @ R_cam_frame
        if view.frame == "camera":  # this view's own left camera -> world, as in check_view
            R = np.asarray(camera.R, dtype=np.float64)
            t = np.asarray(camera.t, dtype=np.float64)
            x_frame = (x_frame - t) @ R
        out.append(x_frame)
        tol.append(OUTLINE_TOLERANCE_PX * x_cam[:, 2] / float(K[0, 0]))
    return np.vstack(out), np.concatenate(tol)


def _oriented(normal: FloatArray, measured: FloatArray) -> bool:
    """True if a plane of unit `normal` (3,) has its orientation from planes a region
    measures (K, 3): parallel to one, or square to two that are not parallel, within
    EXACT_DEG (a back wall parallel to the front; a floor square to the front and a side)."""
    cos = np.abs(measured @ normal)
    if (cos >= COS_PARALLEL).any():
        return True
    square = measured[cos <= SIN_SQUARE]
    if len(square) < 2:
        return False
    return bool((np.abs(square @ square.T) < COS_PARALLEL).any())


def adjoining(view: ViewEvidence, model: ReconstructedModel, check: ViewCheck) -> list[str]:
    """Check (f) in one view (reasons): a region outside the model's projection or in front
    of it (which (b) leaves alone: it may be something standing before the object) whose outline
    meets a model face in 3-D (on its plane within OUTLINE_TOLERANCE_PX, inside the face)
    along at least ADJOINING_SPAN of the model's size, and which covers at least
    ADJOINING_MIN_SHARE of the view's region pixels, is a surface joined to the object
    that the model does not have (a hip roof's slope above walls taken for a flat roof's).
    A region lying in a model face's plane continues that face (the ground the floor) and
    is not counted; nor is anything in front (its outline is nearer than the faces)."""
    camera = next((c for c in model.cameras if c.view == view.id), None)
    total = sum(r.pixel_count for r in view.regions)
    big = [
        r
        for r in view.regions
        if r.id in set(check.free_ids) and r.pixel_count >= ADJOINING_MIN_SHARE * total
    ]
    if camera is None or not big:
        return []
    R = np.asarray(camera.R, dtype=np.float64)
    t = np.asarray(camera.t, dtype=np.float64)
    faces = _faces(model)
    size = _size(model)
    cos_tol = math.cos(math.radians(NORMAL_TOLERANCE_DEG))
    reasons = []
    for r in big:
        points, tol = outline_points(view, (r.id,), model)
        if len(points) < 2:
            continue
        normal = np.asarray(r.n_init, dtype=np.float64)
        centre = np.asarray(r.c_init, dtype=np.float64)
        if view.frame == "camera":
            normal, centre = normal @ R, (centre - t) @ R
        dist = float(np.linalg.norm(centre + R.T @ t))
        on_tol = max(DEPTH_TOLERANCE * dist, DEPTH_TOLERANCE_MIN_M)
        if any(
            abs(float(normal @ n)) >= cos_tol and abs(float(centre @ n) - d) <= on_tol
            for _, n, d, _ in faces
        ):
            continue  # it continues a face's plane
        best = (0.0, "")
        for role, n, d, poly in faces:
            near = np.abs(points @ n - d) <= tol
            if np.count_nonzero(near) < 2:
                continue
            touching = points[near][_inside_polygon(points[near], poly, n)]
            if len(touching) >= 2:
                span = float(np.linalg.norm(touching.max(axis=0) - touching.min(axis=0)))
                best = max(best, (span, role))
        if best[0] >= ADJOINING_SPAN * size:
            reasons.append(
                f"view {view.id}: region {view.id}/{r.id} ({100 * r.pixel_count / total:.0f}% "
                f"of its pixels) meets {best[1]} along {best[0]:.1f} m, but the model does "
                "not explain it (a part the model lacks)"
            )
    return reasons


def _continues_face(
    normal: FloatArray,
    centre: FloatArray,
    tol: float,
    faces: list[tuple[str, FloatArray, float, FloatArray]],
) -> bool:
    """A plane (unit normal (3,), a point (3,), world frame) lies in a face's plane within
    NORMAL_TOLERANCE_DEG and `tol` metres (the ground continues the floor)."""
    cos_tol = math.cos(math.radians(NORMAL_TOLERANCE_DEG))
    return any(
        abs(float(normal @ n)) >= cos_tol and abs(float(centre @ n) - d) <= tol
        for _, n, d, _ in faces
    )


def unexplained_near(
    view: ViewEvidence, model: ReconstructedModel, check: ViewCheck
) -> tuple[float, list[int]]:
    """Check (g) in one view: the share of the weight of the regions on the model and near
    it that the model explains, and the ids of the near regions it leaves (heaviest first).
    Near: a region outside the model's projection or in front of it (which (b) leaves
    alone), at least MIN_WEIGHT_SHARE of the view's weight, whose centre lies within
    NEAR_MARGIN of the model's size of its bounding box, and which continues no face's
    plane. An L-shaped house taken for its body leaves the wing's walls there."""
    camera = next((c for c in model.cameras if c.view == view.id), None)
    if camera is None:
        return 1.0, []
    R = np.asarray(camera.R, dtype=np.float64)
    t = np.asarray(camera.t, dtype=np.float64)
    corners = np.vstack([np.asarray(p.polygon, dtype=np.float64) for p in model.parts])
    grow = NEAR_MARGIN * _size(model)
    low, high = corners.min(axis=0) - grow, corners.max(axis=0) + grow
    faces = _faces(model)
    total = sum(r.w_c for r in view.regions)
    free = set(check.free_ids)
    near: list[tuple[float, int]] = []
    for r in view.regions:
        if r.id not in free or r.depth_pixel_count == 0 or r.w_c < MIN_WEIGHT_SHARE * total:
            continue
        normal = np.asarray(r.n_init, dtype=np.float64)
        centre = np.asarray(r.c_init, dtype=np.float64)
        if view.frame == "camera":
            normal, centre = normal @ R, (centre - t) @ R
        dist = float(np.linalg.norm(centre + R.T @ t))
        if _continues_face(
            normal, centre, max(DEPTH_TOLERANCE * dist, DEPTH_TOLERANCE_MIN_M), faces
        ):
            continue
        if bool(np.all(centre >= low)) and bool(np.all(centre <= high)):
            near.append((float(r.w_c), int(r.id)))
    left = sum(w for w, _ in near)
    explained = check.explained_weight
    share = explained / (explained + left) if explained + left > 0 else 1.0
    return share, [i for _, i in sorted(near, reverse=True)]


def _spread(points: FloatArray, size: float) -> int:
    """0, 1 or 2: points (K, 3) span less than OUTLINE_SPAN of `size` (metres, the face's),
    span it along a line, or over an area (the second principal extent, end to end, at least
    OUTLINE_AREA_RATIO of the first). A few points where outlines cross a plane (a valley
    between two roofs crossing a wing's hidden end) span nothing."""
    if len(points) < 2:
        return 0
    centred = points - points.mean(axis=0)
    axes = np.linalg.svd(centred, full_matrices=False)[2]  # (3, 3) principal directions
    along = centred @ axes[:2].T  # (K, 2)
    extent = along.max(axis=0) - along.min(axis=0)
    if extent[0] < OUTLINE_SPAN * size:
        return 0
    return 2 if extent[1] >= OUTLINE_AREA_RATIO * extent[0] else 1


def contested(kb: KnowledgeBase, interp: Interpretation, role: str) -> str | None:
    """The alternative that orients part `role` otherwise, or None.

    The part's whole (the instance at the role's parent path) was chosen among the
    specialisations of an abstract concept (a roof among gable, hip, flat and shed); when a
    sibling specialisation orients a part of that name another way or has no such part (a
    shed's top is tilted by its pitch, a flat roof's is level), the orientation the
    knowledge gives the part is the choice itself, not evidence for it."""
    if "." not in role:
        return None
    owner, name = role.rsplit(".", 1)
    inst = next((i for i in interp.instances if i.role == owner), None)
    concept = kb.concepts.get(inst.concept) if inst is not None else None
    if concept is None:
        return None
    mine = concept.orientations.get(name)
    if mine is None and name not in concept.parts:
        return None  # not the concept's own part (a wing's floor, attached by its whole)
    key = None if mine is None else (mine.direction, mine.tilt_rad, mine.tilt_from)
    lacking = None  # an alternative without such a part: its planes lie elsewhere
    for parent in concept.parents:
        general = kb.concepts.get(parent)
        for sibling in general.specialisations if general is not None else ():
            other = kb.concepts.get(sibling)
            if other is None or sibling == concept.name or other.abstract:
                continue
            theirs = other.orientations.get(name)
            if theirs is None and name not in other.parts:
                lacking = lacking or sibling
            elif (
                theirs is not None and (theirs.direction, theirs.tilt_rad, theirs.tilt_from) != key
            ):
                return sibling  # the alternative has the part, oriented otherwise
    return lacking


def _project(camera: ModelCamera, points: FloatArray) -> FloatArray:
    """Pixels (N, 2) of world points (N, 3) in a model camera (pinhole; distortion left out)."""
    x = points @ np.asarray(camera.R, dtype=np.float64).T + np.asarray(camera.t, dtype=np.float64)
    x = x @ np.asarray(camera.K, dtype=np.float64).T
    out: FloatArray = x[:, :2] / x[:, 2:3]
    return out


def line_offset_sd(
    ends: FloatArray, normal: FloatArray, within: FloatArray | None, cameras: list[ModelCamera]
) -> float:
    """How well image lines of a 3-D edge fix a plane through it: the standard deviation,
    metres, of the plane's offset along its unit `normal` (3,), when the edge (ends (2, 3),
    world frame) is seen in `cameras` with its two ends good to EDGE_SIGMA_PX across the
    line. The edge may move square to itself: within the plane of unit normal `within`
    (a neighbour a region measures) or, None, freely (triangulated from the views). inf
    when the views leave a direction unmeasured (one view, no neighbour; a line along the
    baseline)."""
    u = ends[1] - ends[0]
    u = u / max(float(np.linalg.norm(u)), 1e-12)
    if within is not None:
        w = np.cross(within, u)
        basis = (w / max(float(np.linalg.norm(w)), 1e-12))[None, :]
    else:
        a = np.cross(u, [1.0, 0.0, 0.0])
        if np.linalg.norm(a) < 0.1:
            a = np.cross(u, [0.0, 1.0, 0.0])
        a = a / np.linalg.norm(a)
        basis = np.stack([a, np.cross(u, a)])
    info = np.zeros((len(basis), len(basis)))
    h = 1e-3 * max(float(np.linalg.norm(ends[1] - ends[0])), 1e-3)  # metres
    for camera in cameras:
        px = _project(camera, ends)  # (2, 2)
        along = px[1] - px[0]
        length = float(np.linalg.norm(along))
        if length < 1e-9:
            continue
        across = np.array([-along[1], along[0]]) / length
        rows = [((_project(camera, ends + h * b) - px) @ across) / h for b in basis]  # px / m
        J = np.stack(rows, axis=1)  # (2 ends, k)
        info += J.T @ J / EDGE_SIGMA_PX**2
    if abs(float(np.linalg.det(info))) < 1e-12:
        return math.inf
    cov = np.linalg.inv(info)
    proj = basis @ normal  # (k,): how far the plane moves per metre along each direction
    return math.sqrt(max(float(proj @ cov @ proj), 0.0))


def unmeasured_parts(
    interp: Interpretation,
    evidence: Evidence,
    checks: tuple[ViewCheck, ...],
    kb: KnowledgeBase | None = None,
    uncertainty: Uncertainty | None = None,
) -> list[str]:
    """The parts whose plane the evidence does not measure (reasons): inserted from
    knowledge, or bound to regions none of which lies on the part (a region bound but left
    off the face by the adjustment measures nothing).

    A plane has three unknowns. A region on the part (in any view) measures all three; so
    do the outlines of regions on the model that reach the part's plane inside its face
    over an area. Otherwise the part needs two measured edges: seen in two views
    (triangulated), or in one view along a neighbour a region measures (the image line
    fixes the edge on that plane). An outline reaching it along a line is the edge it
    shares with the region's part, already counted when seen.
    The knowledge's orientations and placements (a back wall parallel to the front and
    mirrored about the ridge, a roof back as steep as the front, a floor square to the
    walls) fill in the rest, and that is a guess about this scene, not a measurement.
    One measured edge and an orientation the knowledge fixes (parallel or square to parts a
    region measures) measure the part too, unless that orientation is the choice among
    alternatives (`contested`, with `kb`): one edge of a level top — its front eave — lies
    on a shed's sloping top as well, so it cannot tell a flat roof from a shed; for the same
    reason the regions that measure such a part lie within CONTESTED_NORMAL_DEG of it (their
    weighted mean angle; a shed's top 8 degrees off a level face would still pass (b)).
    A part its edges measure must be placed by them to POSITION_TOLERANCE of the model's
    size: each edge, its ends good to EDGE_SIGMA_PX across it in each view that sees it,
    fixes the part's offset to `line_offset_sd` (an edge seen at a grazing angle, or along
    the baseline of the two views that see it, hardly does) — and, with the adjustment's
    `uncertainty`, its offset's standard deviation there, the larger of the two."""
    model = interp.model
    if model is None:
        return []
    inserted = {i.role for i in interp.instances if INSERTED in i.bindings}
    bound = {  # parts whose realisation (a con-of region) is bound to evidence
        i.parent
        for i in interp.instances
        if i.link == "con-of" and i.parent is not None and i.bindings and INSERTED not in i.bindings
    }
    by_view = {c.view: c for c in checks}
    pts, tols = [], []
    for view in evidence.views:
        check = by_view.get(view.id)
        if check is not None and check.explained_ids:
            p, t = outline_points(view, check.explained_ids, model)
            pts.append(p)
            tols.append(t)
    points = np.vstack(pts) if pts else np.zeros((0, 3))
    tol = np.concatenate(tols) if tols else np.zeros(0)
    from aida_kb.register.model import RigidModel

    names, edge_faces, seen_by = seen_edges(evidence, model)
    ends = RigidModel.from_model(model).edge_ends  # (E, 2, 3), the edges of `edge_faces`
    normals = {p.role: np.asarray(p.normal, dtype=np.float64) for p in model.parts}
    cameras = {c.view: c for c in model.cameras}
    size = _size(model)
    on_region = {
        role
        for role in names
        if any(c.explained_on.get(role, 0.0) >= MEASURING_SHARE * c.inside_weight for c in checks)
    }
    measured = np.array(
        [p.normal for p in model.parts if p.role in on_region], dtype=np.float64
    ).reshape(-1, 3)
    reasons = []
    for part in model.parts:
        if part.role in on_region:
            rival = contested(kb, interp, part.role) if kb is not None else None
            on = [
                (c.turned_on[part.role], c.explained_on[part.role])
                for c in checks
                if part.role in c.turned_on
            ]  # (angle, weight) in each view
            weight = sum(w for _, w in on)
            turned = sum(a * w for a, w in on) / weight if weight > 0 else 0.0
            if rival is not None and turned > CONTESTED_NORMAL_DEG:
                owner = part.role.rsplit(".", 1)[0]
                chosen = next((i.concept for i in interp.instances if i.role == owner), "")
                reasons.append(
                    f"{part.role} is oriented by the knowledge of {chosen}, not by its regions: "
                    f"they lie at {turned:.1f} deg to it (at most {CONTESTED_NORMAL_DEG:g}; "
                    f"{rival} orients it otherwise)"
                )
            continue
        if part.role not in inserted | bound:
            continue
        n = np.asarray(part.normal, dtype=np.float64)
        poly = np.asarray(part.polygon, dtype=np.float64)
        near = np.abs(points @ n - part.offset_m) <= tol
        touching = (
            points[near][_inside_polygon(points[near], poly, n)] if near.any() else points[:0]
        )
        face_size = float(np.linalg.norm(poly.max(axis=0) - poly.min(axis=0)))
        if _spread(touching, face_size) >= 2:
            continue
        me = names.index(part.role) if part.role in names else -1
        lines = 0
        information = 0.0  # 1 / m², of the part's offset from its measured edges
        for k, ((f, g), views) in enumerate(zip(edge_faces, seen_by, strict=True)):
            if me not in (f, g) or not views:
                continue
            other = names[int(g if f == me else f)]
            if len(views) >= 2 or other in on_region:
                lines += 1
                within = normals[other] if other in on_region else None
                sd = line_offset_sd(ends[k], n, within, [cameras[v] for v in sorted(views)])
                information += 1.0 / sd**2 if 0.0 < sd < math.inf else 0.0
        placed = lines >= MEASURED_LINES
        if not placed and lines >= 1 and _oriented(n, measured):
            rival = contested(kb, interp, part.role) if kb is not None else None
            placed = rival is None
            if not placed:
                owner = part.role.rsplit(".", 1)[0]
                chosen = next((i.concept for i in interp.instances if i.role == owner), "")
                reasons.append(
                    f"{part.role} is oriented by the knowledge of {chosen}, not measured: no "
                    f"region lies on it and {lines} of its edges are measured, which {rival} "
                    f"would fit as well ({MEASURED_LINES} needed to tell them apart)"
                )
                continue
        if placed:
            sd = 1.0 / math.sqrt(information) if information > 0 else math.inf
            if uncertainty is not None and part.role in uncertainty.parts:
                sd = max(sd, uncertainty.parts[part.role][1])
            if sd > POSITION_TOLERANCE * size:
                reasons.append(
                    f"{part.role} is placed by {lines} edge{'s' if lines != 1 else ''} only "
                    f"to +-{sd:.2f} m, more than "
                    f"{100 * POSITION_TOLERANCE:.0f}% of the model's size ({size:.1f} m; an "
                    f"edge's ends good to {EDGE_SIGMA_PX:g} px in the views that see it, or "
                    "the adjustment's covariance)"
                )
            continue
        how = PLACED_BY_KNOWLEDGE if part.role in inserted else BOUND_TO_NOTHING
        reasons.append(
            f"{part.role} is {how}{NOT_MEASURED}: no region lies on it and "
            f"{lines} of its edges are measured ({MEASURED_LINES} needed: seen in two views, "
            "or in one along a neighbour a region measures)"
        )
    return reasons


# ---- (d) measured attributes ------------------------------------------------------------
def _parts_under(
    model: ReconstructedModel, role: str
) -> list[tuple[FloatArray, float, FloatArray]]:
    prefix = role + "."
    return [
        (np.asarray(p.normal, dtype=np.float64), float(p.offset_m), np.asarray(p.polygon))
        for p in model.parts
        if p.role == role or p.role.startswith(prefix) or role == ""
    ]


def _join(role: str, path: str) -> str:
    if path == "self":
        return role
    return f"{role}.{path}" if role else path


def _up(kb: KnowledgeBase, interp: Interpretation, model: ReconstructedModel) -> FloatArray | None:
    """The world's up direction from a part the knowledge orients up- or downward."""
    by_role = {p.role: np.asarray(p.normal, dtype=np.float64) for p in model.parts}
    # the outermost composite's up- or downward part (the body's floor before a roof's top)
    for inst in sorted(interp.instances, key=lambda i: (i.role.count("."), i.role != "")):
        concept = kb.concepts.get(inst.concept)
        if concept is None:
            continue
        for part, o in concept.orientations.items():
            n = by_role.get(_join(inst.role, part))
            if n is not None and o.direction in ("upward", "downward"):
                return n if o.direction == "upward" else -n
    return None


def _forward(
    kb: KnowledgeBase, interp: Interpretation, model: ReconstructedModel, role: str, up: FloatArray
) -> FloatArray | None:
    """The horizontal direction the frame anchor of the composite at `role` (or a whole) faces."""
    by_role = {p.role: np.asarray(p.normal, dtype=np.float64) for p in model.parts}
    concepts = {i.role: i.concept for i in interp.instances}
    while True:
        concept = kb.concepts.get(concepts.get(role, ""))
        if concept is not None and concept.frame is not None:
            n = by_role.get(_join(role, concept.frame.anchor))
            if n is None:
                return None
            f = n - (n @ up) * up
            norm = float(np.linalg.norm(f))
            return f / norm if norm > 1e-9 else None
        if role == "":
            return None
        role = role.rsplit(".", 1)[0] if "." in role else ""


def _measure(
    kind: MeasureKind,
    args: list[str],
    model: ReconstructedModel,
    up: FloatArray,
    forward: FloatArray | None,
) -> float | None:
    """The measure's value (radians or metres) on the model, None when it cannot be taken."""
    sets = [_parts_under(model, a) for a in args]
    if any(not s for s in sets):
        return None
    if kind in (MeasureKind.HEIGHT, MeasureKind.WIDTH, MeasureKind.DEPTH):
        if kind is MeasureKind.HEIGHT:
            axis = up
        elif forward is None:
            return None
        else:
            axis = np.cross(up, forward) if kind is MeasureKind.WIDTH else forward
        pts = np.vstack([poly for _, _, poly in sets[0]]) @ axis
        return float(pts.max() - pts.min())
    if any(len(s) != 1 for s in sets):
        return None  # slope, angle and distance take one plane each
    if kind is MeasureKind.SLOPE:
        return math.acos(float(np.clip(sets[0][0][0] @ up, -1.0, 1.0)))
    (n1, d1, _), (n2, _, poly2) = sets[0][0], sets[1][0]
    if kind is MeasureKind.ANGLE:
        return math.pi - math.acos(float(np.clip(n1 @ n2, -1.0, 1.0)))
    if kind is MeasureKind.DISTANCE:
        return abs(float(poly2.mean(axis=0) @ n1) - d1)
    return None


def check_orientations(
    kb: KnowledgeBase, interp: Interpretation, model: ReconstructedModel
) -> list[str]:
    """Every planar part the knowledge orients with a fixed slope (`orient top: upward`,
    `orient front: forward` — vertical —, `tilted by 35 deg`) has that slope on the model
    within ORIENTATION_TOLERANCE_DEG (reasons). Slopes left to an attribute without a
    default are the evidence's and not checked here."""
    up = _up(kb, interp, model)
    if up is None:
        return []
    by_role = {p.role: np.asarray(p.normal, dtype=np.float64) for p in model.parts}
    reasons = []
    for inst in interp.instances:
        concept = kb.concepts.get(inst.concept)
        if concept is None:
            continue
        for part, o in concept.orientations.items():
            n = by_role.get(_join(inst.role, part))
            if n is None or o.tilt_rad is None:
                continue
            slope = math.degrees(math.acos(float(np.clip(n @ up, -1.0, 1.0))))
            if abs(slope - math.degrees(o.tilt_rad)) > ORIENTATION_TOLERANCE_DEG:
                reasons.append(
                    f"{_join(inst.role, part)}: slope {slope:.1f} deg, but {concept.name} "
                    f"orients it {o.direction} at {math.degrees(o.tilt_rad):.0f} deg "
                    f"(within {ORIENTATION_TOLERANCE_DEG:g})"
                )
    return reasons


def measured_attributes(
    kb: KnowledgeBase, interp: Interpretation, model: ReconstructedModel
) -> list[tuple[Instance, AttributeModel, float]]:
    """Every measured attribute (`is slope(self)`, ...) of every instance, measured on the
    model: (instance, attribute, value in SI: radians or metres), in the order of the
    instances and of the concept's attributes. Attributes whose measure cannot be taken
    (no up direction, a part missing from the model) are left out."""
    up = _up(kb, interp, model)
    if up is None:
        return []
    out = []
    for inst in interp.instances:
        concept = kb.concepts.get(inst.concept)
        if concept is None:
            continue
        for attr in concept.attributes.values():
            m = attr.measure
            if m is None:
                continue
            fwd = _forward(kb, interp, model, inst.role, up)
            value = _measure(m.kind, [_join(inst.role, a) for a in m.args], model, up, fwd)
            if value is not None:
                out.append((inst, attr, value))
    return out


def check_attributes(
    kb: KnowledgeBase,
    interp: Interpretation,
    model: ReconstructedModel,
    *,
    unit: str = "",
    metric: bool = True,
) -> list[str]:
    """Check (d): every measured attribute of every instance inside its range (reasons).
    unit : only the attributes of this unit ('m': the sizes); '' all. metric : False when the
    model's lengths are in unknown units (a scene up to scale): ranges in metres are skipped."""
    reasons = []
    for inst, attr, value in measured_attributes(kb, interp, model):
        if unit and attr.unit != unit:
            continue
        if not metric and attr.unit == SIZE_UNIT:
            continue
        if attr.low is None and attr.high is None:
            continue
        low = -math.inf if attr.low is None else attr.low
        high = math.inf if attr.high is None else attr.high
        slack = RANGE_SLACK_REL * max(
            abs(low) if math.isfinite(low) else 0.0, abs(high) if math.isfinite(high) else 0.0
        )
        if not low - slack <= value <= high + slack:
            shown = math.degrees(value) if attr.unit == "rad" else value
            unit = "deg" if attr.unit == "rad" else attr.unit
            lo = math.degrees(low) if attr.unit == "rad" else low
            hi = math.degrees(high) if attr.unit == "rad" else high
            reasons.append(
                f"{inst.role or inst.concept}: {attr.name} = {shown:.3g} {unit} outside "
                f"[{lo:.3g}, {hi:.3g}] ({inst.concept})"
            )
    return reasons


# ---- the verdict -----------------------------------------------------------------------
def unconfirmed(evidence: Evidence, model: ReconstructedModel) -> str | None:
    """The reason why no other view confirms the model, or None: the evidence has views
    besides the one interpreted (the first) and the model has a camera for none of them
    (the reconstruction registered none: the model's edges matched in no other image). An
    object that stands there would be found from 20-45 degrees further round; development
    scenes: 2 of 57 houses seen in several views (both doubtful for other reasons), and
    every object-less scene accepted in one view."""
    first = evidence.views[0].id
    others = [v.id for v in evidence.views[1:]]
    cameras = {c.view for c in model.cameras}
    if not others or first not in cameras or cameras & set(others):
        return None
    return (
        f"seen in view {first} alone: none of the other views ({', '.join(others)}) could "
        "be registered to the model (no other view confirms the object)"
    )


def _bound_parts(interp: Interpretation) -> set[str]:
    """Roles of the parts bound to evidence: an instance bound to regions, or the whole
    its bound con-of realisation (the region) hangs on."""
    out = set()
    for inst in interp.instances:
        if not inst.bindings or INSERTED in inst.bindings:
            continue
        out.add(inst.parent if inst.link == "con-of" and inst.parent is not None else inst.role)
    return out


def judge(
    kb: KnowledgeBase,
    interp: Interpretation,
    evidence: Evidence,
    *,
    all_views: bool = False,
    uncertainty: Uncertainty | None = None,
) -> Verdict:
    """The verdict on `interp` (see the module docstring). all_views: the result stands for
    every view of the evidence (a reconstruction registers them all), so a view it left
    without a camera is doubted; `aida-kb interpret` uses the world-frame views only.
    uncertainty: the adjustment's, where `interp` is one object of a scene adjusted as a whole
    (`interpret.scene.judge_objects`: the cameras are fixed by every object); None: that of
    `interp` alone."""
    model = interp.model
    if not interp.accepted or model is None:
        return Verdict(NOTHING, (), (), ())
    if interp.objects:  # a scene of several objects: each was judged alone (interpret.scene)
        return Verdict(interp.verdict or NOTHING, tuple(interp.doubts), (), ())
    reasons: list[str] = []
    if uncertainty is None:
        uncertainty = adjustment_uncertainty(kb, interp, evidence)
    # (a) every constraint of the knowledge (and every prior) under its threshold; the
    # evidence's own factors of a multi-view adjustment (segments, regions: robust, made by
    # code, rule "evidence") are judged by (b) and (c), not one by one — a stray region or
    # segment is an outlier there, not a contradiction of the knowledge
    for r in interp.residuals:
        if r.rejected and r.rule != "evidence":
            reasons.append(
                f"constraint {r.label} ({r.kind}, {', '.join(r.parts)}) over its threshold: "
                f"cost {r.normalised_cost:.3g} of {r.threshold:.3g}"
            )
    # (b), (c) every view's evidence explained
    checks = []
    not_explained = []
    cameras = {c.view for c in model.cameras}
    for view in evidence.views:
        check = check_view(view, model)
        if check is None:
            if view.id in cameras or all_views:
                not_explained.append(view.id)
            if view.id in cameras:  # a camera, but none of its regions has a plane
                reasons.append(f"view {view.id}: no region of it has a plane to check the model by")
            elif all_views:  # left out by the reconstruction: where it was taken from is unknown
                reasons.append(f"view {view.id}: not registered (the model has no camera for it)")
            continue
        checks.append(check)
        problems = []
        # the model, seen by the camera the reconstruction gave this view, covers none of its
        # regions or shows none of its edges: nothing confirms that camera (a registration
        # 100 degrees off lands here; every check below would pass for want of evidence)
        if check.inside_weight <= 0:
            problems.append("covers none of its regions")
        if check.edge_cover is None and view.lines:
            problems.append(f"shows no edge of at least {EDGE_MIN_LENGTH_PX:g} px")
        if check.explained_share < EXPLAINED_MIN:
            problems.append(
                f"explains {100 * check.explained_share:.0f}% of the region weight inside "
                f"its projection (at least {100 * EXPLAINED_MIN:.0f}%)"
            )
        if check.edge_cover is not None and check.edge_cover < EDGE_COVER_MIN:
            problems.append(
                f"edges are seen along {100 * check.edge_cover:.0f}% of their length "
                f"(at least {100 * EDGE_COVER_MIN:.0f}% within {EDGE_TOLERANCE_PX:g} px)"
            )
        if view.id != evidence.views[0].id and check.inside_weight > 0:
            # a registered view: the adjustment fixes its camera to what is asked of it
            problems += _camera_doubts(view.id, model, uncertainty)
        standing = check.standing_out_weight / check.inside_weight if check.inside_weight else 0.0
        if standing > STANDING_OUT_SHARE_MAX:
            problems.append(
                f"leaves regions carrying {100 * standing:.0f}% of the weight standing out of "
                f"its surface, parallel to it (at most {100 * STANDING_OUT_SHARE_MAX:.0f}%: a part "
                "the model lacks)"
            )
        worst = check.contradicting[0] if check.contradicting else None
        if worst is not None and worst[1] > CONTRADICTION_MAX:
            problems.append(
                f"region {view.id}/{worst[0]} ({100 * worst[1]:.0f}% of the weight) is {worst[2]}"
            )
        if problems:
            not_explained.append(view.id)
            reasons.append(f"view {view.id}: the model " + "; ".join(problems))
    # (c) in the interpreted view, the edges between parts bound to its evidence are seen
    reference = evidence.views[0]
    bound = _bound_parts(interp)
    seen = edge_cover(reference, model, frozenset(bound)) if len(bound) > 1 else None
    if seen is not None and seen < SEEN_EDGE_COVER_MIN:
        reasons.append(
            f"view {reference.id}: the edges between the parts bound to its evidence are seen "
            f"along {100 * seen:.0f}% of their length (at least {100 * SEEN_EDGE_COVER_MIN:.0f}%)"
        )
    # an object whose sizes the knowledge's ranges exclude is not the goal at all (a 0.3 m
    # box, a chessboard on a stand): nothing is found, and the sizes say why
    metric = evidence.units == "m"
    sizes = check_attributes(kb, interp, model, unit=SIZE_UNIT, metric=metric)
    if sizes:
        return Verdict(NOTHING, tuple(sizes), tuple(not_explained), tuple(checks), uncertainty)
    # an object no other view confirms: the scene has other views, and none of them could be
    # registered to the model (its edges are nowhere in those images) — what one view took
    # for the object is not there as the model has it (a tree's box-shaped crown taken for a
    # small house)
    alone = unconfirmed(evidence, model) if all_views else None
    if alone is not None:
        return Verdict(NOTHING, (alone,), tuple(not_explained), tuple(checks), uncertainty)
    # (f) no large surface joined to the model that the model does not explain
    by_id = {v.id: v for v in evidence.views}
    for check in checks:
        reasons += adjoining(by_id[check.view], model, check)
    # (g) the surfaces on the model and near it are mostly the model's
    for check in checks:
        share, left = unexplained_near(by_id[check.view], model, check)
        if share < NEAR_EXPLAINED_MIN:
            shown = ", ".join(f"{check.view}/{i}" for i in left[:3])
            reasons.append(
                f"view {check.view}: the model explains {100 * share:.0f}% of the region "
                f"weight on it and near it (at least {100 * NEAR_EXPLAINED_MIN:.0f}%): "
                f"regions {shown} near it are not its surfaces"
            )
    # (e) every part inserted from knowledge is measured by some evidence
    reasons += unmeasured_parts(interp, evidence, tuple(checks), kb, uncertainty)
    # (d) the knowledge's measured attributes
    reasons += check_attributes(kb, interp, model, metric=metric)
    reasons += check_orientations(kb, interp, model)
    reasons += undecided(interp)
    verdict = DOUBTFUL if reasons else VERIFIED
    return Verdict(verdict, tuple(reasons), tuple(not_explained), tuple(checks), uncertainty)


def undecided(interp: Interpretation) -> list[str]:
    """The choices along is-a the evidence does not decide (`Interpretation.ties`, from the
    interpreter: another specialisation explains the same evidence about as well)."""
    return [
        f"the evidence does not decide {tie.split('=')[0]}: {tie} explains it about as well"
        for tie in interp.ties
    ]


# The wording of (e)'s reasons for a part no evidence measures; `summary_reasons` says those
# of several parts once
PLACED_BY_KNOWLEDGE = "placed by the knowledge"
BOUND_TO_NOTHING = "bound to no region on it"
NOT_MEASURED = ", not measured"
_UNMEASURED = re.compile(
    rf"^(\S+) is ({re.escape(PLACED_BY_KNOWLEDGE)}|{re.escape(BOUND_TO_NOTHING)})"
    rf"{re.escape(NOT_MEASURED)}: "
)


def _roles_once(roles: list[str]) -> str:
    """Roles joined, each after the first written from its last dot when it shares the
    first's owner: ``body.back, .left, .floor``."""
    owner = roles[0].rsplit(".", 1)[0] + "." if "." in roles[0] else None
    rest = [
        r[len(owner) - 1 :]
        if owner is not None and r.startswith(owner) and "." not in r[len(owner) :]
        else r
        for r in roles[1:]
    ]
    return ", ".join([roles[0], *rest])


def summary_reasons(reasons: tuple[str, ...] | list[str]) -> list[str]:
    """The reasons as the summary line gives them: what (e) says of each part no evidence
    measures (placed by the knowledge, or bound to no region on it) said once for all those
    parts, where the first of them stood (``body.back, .left, .floor placed by the knowledge:
    no view measures them``); the other reasons as they are. `Verdict.reasons` (the result's
    doubts) keep each part's own reason, with its count of measured edges."""
    groups: dict[str, list[str]] = {}
    out: list[str] = []
    for reason in reasons:
        m = _UNMEASURED.match(reason)
        if m is None:
            out.append(reason)
            continue
        how = m.group(2)
        if how not in groups:
            groups[how] = []
            out.append("\0" + how)  # the group's place
        groups[how].append(m.group(1))
    said = []
    for reason in out:
        if not reason.startswith("\0"):
            said.append(reason)
            continue
        how = reason[1:]
        roles = groups[how]
        what = "them" if len(roles) > 1 else "it"
        said.append(f"{_roles_once(roles)} {how}: no view measures {what}")
    return said


def with_verdict(interp: Interpretation, verdict: Verdict) -> Interpretation:
    """`interp` carrying the verdict; a doubtful one's summary line says so first, with
    the reasons of `summary_reasons` (the doubts keep every reason in full)."""
    message = interp.message
    if verdict.verdict == DOUBTFUL:
        shown = "; ".join(summary_reasons(verdict.reasons))
        message = f"{interp.goal} doubtful: {shown} (was: {message})"
    elif verdict.verdict == NOTHING and verdict.reasons:
        message = f"no {interp.goal} found: {'; '.join(verdict.reasons)} (was: {message})"
    update: dict[str, object] = {
        "verdict": verdict.verdict,
        "doubts": list(verdict.reasons),
        "message": message,
    }
    if interp.model is not None and verdict.uncertainty is not None:
        update["model"] = with_deviations(interp.model, verdict.uncertainty)
    return interp.model_copy(update=update)


def _finite_or_none(value: float) -> float | None:
    return value if math.isfinite(value) else None


def with_deviations(model: ReconstructedModel, unc: Uncertainty) -> ReconstructedModel:
    """`model` with the adjustment's standard deviations on its parts and cameras (model.json
    `sd`: normal degrees and offset metres of each part, rotation degrees and centre metres
    of each camera the adjustment moves; null where not fixed)."""
    parts = [
        p.model_copy(
            update={
                "sd": PartSd(
                    normal_deg=_finite_or_none(unc.parts[p.role][0]),
                    offset_m=_finite_or_none(unc.parts[p.role][1]),
                )
            }
        )
        if p.role in unc.parts
        else p
        for p in model.parts
    ]
    cameras = [
        c.model_copy(
            update={
                "sd": CameraSd(
                    rotation_deg=_finite_or_none(unc.cameras[c.view][0]),
                    centre_m=_finite_or_none(unc.cameras[c.view][1]),
                )
            }
        )
        if c.view in unc.cameras
        else c
        for c in model.cameras
    ]
    return model.model_copy(update={"parts": parts, "cameras": cameras})
