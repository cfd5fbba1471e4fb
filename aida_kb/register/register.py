"""Registration of a new view against a fixed model (paper §5, §6.2).

`register_view` finds the pose of a camera that saw image segments (and, optionally, regions
with depth) of a known model, without an initial guess:

1. **Coarse search.** The new camera is assumed to have moved about the model's vertical axis
   (a turntable, or a walk around a building): candidate poses are the reference camera turned
   about the vertical through the point it looks at (`orbit_pivot`) and through the model's
   middle (`orbit_pivots`), every few degrees over
   the whole circle (or about ``init_angle_deg``). Each candidate is scored by the chamfer
   distance of its projected model edges to the image segments.
   Where the view has regions with depth, starts from its own planes are added
   (`plane_starts`, `aida_kb.register.planes`): they need no orbit, so a view taken at
   another distance or height is found too.
2. **Refinement** from the best few distinct candidates: project the model edges, match them
   to the segments by distance and direction, solve for the six pose parameters (edge and
   position constraints), match again with a tighter tolerance, and so on. The wide first
   rounds match clutter too and can end in a wrong basin that fits the segments about as
   well (dev seeds 61402, 61410, 61427: 3-6 degrees off, their regions' normals 3.4-5.9
   degrees off their parts'). Where the caller gives the regions' own normal sigmas, every
   distinct refined pose is refined once more from the rotation its matched regions give
   and the position their planes give (`realigned`), with tight rounds only.
3. **Choice by residual**, among the poses the depth evidence does not contradict (their
   regions' normals agree with their parts', and they put about as many regions on the
   model's parts as the best pose does). The refined candidate with the smallest chamfer
   cost wins; only poses its model's symmetry makes alike are decided by the smallest turn
   from the start, and poses far from it that explain the image about as well are reported
   (`Registration.alternatives`). A model that looks the same turned by 360/n degrees (a box,
   a gable house: n = 2) is searched over 360/n degrees about the expected turn only: its
   images cannot tell the others apart. Where its images still fit a pose best whose twin
   lies nearer the expected turn (the model's small asymmetries, clutter), the evidence does
   not decide between them: the view is not registered (`SolveError` naming both turns),
   never registered 180 degrees off.
4. **Polish** (`polish`), when the view's images are given: the model's visible edges are
   fitted to the image along their whole length at the chosen pose and the pose solved again
   from them (a line detector gives fragments of an edge; the image holds all of it).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from aida_kb.errors import GeometryError, SolveError
from aida_kb.geometry.camera import PinholeCamera
from aida_kb.geometry.rig import Rig
from aida_kb.geometry.rotation import rotation_from_rvec, rvec_from_rotation
from aida_kb.register.match import chamfer_cost, match_segments
from aida_kb.register.model import RigidModel
from aida_kb.register.planes import part_boxes, plane_poses, regions_explained
from aida_kb.register.pose import (
    EdgeObservations,
    RegionObservations,
    fit_pose,
    pose_covariance,
)
from aida_kb.register.twins import (
    RIVAL_COST_RATIO,
    PhotometricJudge,
    PoseSupport,
    photometric_choice,
    rivals_of,
    undecided_rivals,
    unsupported_twin,
)

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

__all__ = [
    "RIVAL_RETRIES",
    "RegionMeasurements",
    "Registration",
    "RegistrationOptions",
    "StereoSegments",
    "angle_about",
    "image_edges",
    "match_regions",
    "orbit_pivot",
    "orbit_pivots",
    "polish",
    "realigned",
    "refine",
    "region_parts",
    "register_view",
    "rival_turns",
    "rivals_left",
    "symmetry_order",
    "turned",
    "vertical_axis",
]


@dataclass(frozen=True)
class RegionMeasurements:
    """Plane fits of a view's regions in its own camera frame (before matching to parts).

    normal_cam : (R, 3) unit normals (towards the camera); centre_cam : (R, 3) metres;
    rms_m : (R,) the fits' RMS distances, metres; inliers : (R,) the pixels each fit kept and
    area_m2 : (R,) each region's area on its plane, m² (None: not known; 0 where unknown) — what
    a fit's own uncertainty is figured from (`aida_kb.interpret.observe.fit_sigma_rad`).
    """

    normal_cam: FloatArray
    centre_cam: FloatArray
    rms_m: FloatArray
    inliers: FloatArray | None = None
    area_m2: FloatArray | None = None

    @property
    def size(self) -> int:
        """Number of regions R."""
        return int(self.normal_cam.shape[0])


@dataclass(frozen=True)
class RegistrationOptions:
    """Tuning of `register_view`.

    step_deg : spacing of the coarse search; span_deg : half width of the search about
    ``init_angle_deg`` when one is given (else the whole circle); starts : how many distinct
    coarse candidates are refined; schedules_px : the matching distance of each refinement
    round, pixels — every start is refined with each schedule (a tight one first: it ignores
    clutter; a wide one catches a start further off); max_angle_deg : the matching direction
    tolerance; tie_tolerance : refined candidates whose cost is within this fraction (plus
    `tie_floor`) of the best explain the image about as well (the lowest cost is taken, or of
    those the model's symmetry makes alike the one turned least from the start; the others are
    the registration's ``alternatives``); sigma_px : the standard deviation of an edge
    point across its edge, pixels; min_segment_px : shorter segments are ignored;
    region_sigma_rel : the position constraints' distance sigma as a fraction of the model's
    size (at least the fit's RMS); region_sigma_deg : their normal's sigma;
    region_disagree_sigmas : a refined pose whose matched regions' normals lie, in the median,
    more than this many region sigmas off their parts' is not a pose of the view (see
    `region_disagreement_deg`).
    """

    step_deg: float = 5.0
    span_deg: float = 30.0
    starts: int = 4
    schedules_px: tuple[tuple[float, ...], ...] = (
        (12.0, 6.0, 3.0, 2.0, 2.0),
        (24.0, 12.0, 6.0, 3.0, 2.0, 2.0),
    )
    max_angle_deg: float = 6.0
    tie_tolerance: float = 0.15
    tie_floor: float = 0.01
    sigma_px: float = 1.0
    region_sigma_rel: float = 0.01
    region_sigma_deg: float = 2.0
    min_segment_px: float = 10.0
    region_disagree_sigmas: float = 3.0


@dataclass(frozen=True)
class Registration:
    """The outcome of `register_view`.

    camera : the registered camera (world frame). angle_deg : its turn about the vertical axis
    relative to the reference camera, degrees in (-180, 180]. rms_px : RMS edge residual of the
    matched segments, pixels. cost : the chamfer cost at the pose (0 perfect, 1 nothing
    matched). n_edges, n_regions : the matched segments and regions of the last round.
    candidates : (start angle, final angle, cost) of every refined start, degrees.
    covariance : (6, 6) of the pose ``[rvec (rad), C (m)]`` from its final matches
    (`aida_kb.register.pose.pose_covariance`; infinite where undetermined). turn_sigma_deg :
    the standard deviation of ``angle_deg`` it implies; rotation_sigma_deg : of the rotation
    about its least determined axis, degrees. alternatives : (final angle, cost) of the refined
    poses more than ``span_deg`` from this one whose cost is as low within the tie tolerance:
    the images do not tell them apart (a symmetric model's twin, a look-alike); empty when the
    pose is unambiguous. undecided : the turns (degrees, as ``angle_deg``) of the poses more
    than ``span_deg`` from this one that nothing in the view rules out: rivals whose edges fit
    about as well and which the images, carried through the model, do not correlate clearly
    worse (`twins.undecided_rivals`); without images, a symmetric model's twins. Non-empty:
    the pose taken is a choice the evidence has not made (the verdict doubts the view).
    undecided_support : the images' support of each of them (`twins.PoseSupport`, as
    ``undecided``; empty without images), for judging them again at an adjusted pose
    (`rivals_left`).
    """

    camera: PinholeCamera
    angle_deg: float
    rms_px: float
    cost: float
    n_edges: int
    n_regions: int
    candidates: tuple[tuple[float, float, float], ...]
    covariance: FloatArray
    turn_sigma_deg: float
    rotation_sigma_deg: float
    alternatives: tuple[tuple[float, float], ...] = ()
    undecided: tuple[float, ...] = ()
    undecided_support: tuple[PoseSupport, ...] = ()


def vertical_axis(model: RigidModel, reference: PinholeCamera) -> FloatArray:
    """The model's vertical (3,), unit, world frame, pointing up in the reference image.

    The normal of the part most nearly along the reference camera's image y axis (a floor, a
    flat roof, the top of a box).
    """
    down = reference.R_cam_world[1]
    along = model.normals @ down
    n = model.normals[int(np.argmax(np.abs(along)))]
    up: FloatArray = -n if float(n @ down) > 0 else n.copy()
    return up


def turned(
    reference: PinholeCamera, axis: FloatArray, pivot: FloatArray, angle_rad: float
) -> PinholeCamera:
    """The reference camera seeing the scene turned by ``angle_rad`` about ``axis`` at ``pivot``.

    With ``Ra`` the rotation about the axis, ``R = R_ref Ra`` and ``t = t_ref + R_ref (p - Ra p)``:
    the camera that sees the world turned by Ra about the pivot p as the reference saw it.
    """
    Ra = rotation_from_rvec(axis * angle_rad)
    R = reference.R_cam_world @ Ra
    t = reference.t_cam_world + reference.R_cam_world @ (pivot - Ra @ pivot)
    return PinholeCamera(reference.K, R, t, reference.width, reference.height)


def angle_about(reference: PinholeCamera, camera: PinholeCamera, axis: FloatArray) -> float:
    """The turn of ``camera`` relative to ``reference`` about ``axis``, degrees in (-180, 180].

    The signed angle of the relative rotation ``R_ref^T R`` about the axis (its swing-twist
    twist component).
    """
    rel = reference.R_cam_world.T @ camera.R_cam_world
    rv = rvec_from_rotation(rel)
    theta = float(np.linalg.norm(rv))
    if theta < 1e-15:
        return 0.0
    w = math.cos(theta / 2.0)
    v = rv / theta * math.sin(theta / 2.0)
    twist = 2.0 * math.atan2(float(v @ axis), w)
    deg = math.degrees(twist)
    return deg - 360.0 if deg > 180.0 else (deg + 360.0 if deg <= -180.0 else deg)


def orbit_pivot(model: RigidModel, reference: PinholeCamera) -> FloatArray:
    """(3,) the point the search turns the camera about: where the reference camera looks.

    The point of the reference camera's optical axis nearest the model's centroid (a camera
    walked around an object keeps it in the middle of the image: the vertical it turns about
    runs through the point it looks at).
    """
    A = reference.optical_axis
    C = reference.centre
    out: FloatArray = C + A * float((model.centroid - C) @ A)
    return out


ORBIT_SEPARATE_REL = 0.05
"""The search also turns the camera about the vertical through the model's middle
(`orbit_pivots`) when that vertical lies farther than this fraction of the model's size from
the one through the point the reference camera looks at: nearer, its starts are the same
poses within a start's basin."""


def model_middle(model: RigidModel) -> FloatArray:
    """(3,) the middle of the model's extent: the centre of its vertices' bounding box,
    metres, world frame (the vertices' mean leans towards small parts rich in vertices, an
    oriel's box: 2.2-4.3 m off a house's middle on dev 70000-70035, the box's centre 0.07-0.67
    m)."""
    out: FloatArray = 0.5 * (model.vertices.min(axis=0) + model.vertices.max(axis=0))
    return out


def orbit_pivots(model: RigidModel, reference: PinholeCamera, up: FloatArray) -> list[FloatArray]:
    """(3,) points the search turns the camera about (each with the vertical ``up``, unit,
    world frame): where the reference camera looks (`orbit_pivot`), and the model's middle
    (`model_middle`) when its vertical lies farther than `ORBIT_SEPARATE_REL` of the model's
    size from that one.

    A camera walked around an object keeps its distance to the object; one that does not look
    at the object's middle (the object off the image centre) is turned about the object, not
    about the point it looks at. On dev 70000-70035 the later views' orbit lies 0.05-10.5 m
    (median 3.2) from the look point's vertical and 0-3.3 m (median 0.17) from the model's
    middle's; 70000's view 01 (5.2 m): the search's refined poses 3.5-7 deg off at chamfer
    costs 0.58-0.79, the truth's basin (0.13) unreached, and the view not registered.
    """
    look = orbit_pivot(model, reference)
    middle = model_middle(model)
    off = middle - look
    across = off - up * float(off @ up)
    if float(np.linalg.norm(across)) <= ORBIT_SEPARATE_REL * model.size:
        return [look]
    return [look, middle]


def symmetry_order(
    model: RigidModel, axis: FloatArray, pivot: FloatArray, tolerance: float = 0.03
) -> int:
    """n = 4, 2 or 1: the model's vertices are the same turned by 360/n degrees about `axis`.

    Vertices match when each turned vertex lies within ``tolerance`` times the model's size of
    an original one.
    """
    V = model.vertices - pivot
    tol = tolerance * model.size
    for n in (4, 2):
        turned_v = V @ rotation_from_rvec(axis * (2.0 * math.pi / n)).T
        gaps = np.linalg.norm(turned_v[:, None, :] - V[None, :, :], axis=2).min(axis=1)
        if float(gaps.max()) <= tol:
            return n
    return 1


def _wrap(deg: float) -> float:
    return (deg + 180.0) % 360.0 - 180.0


def _symmetric_gap(a_deg: float, b_deg: float, order: int) -> float:
    """The smallest |a - b - k·360/order| over k, degrees: how far apart two turns of a model
    that looks the same turned by 360/order degrees are."""
    step = 360.0 / order
    d = _wrap(a_deg - b_deg) % step
    return min(d, step - d)


REGION_PART_MAX_DEG = 20.0
"""A region lies on a part only if their normals are within this angle at the pose: a region's
plane fit and the pose it is judged at (from the coarse search, before refinement) may each
be degrees off."""
REGION_PART_MAX_REL = 0.15
"""A region lies on a part only if its centre lies within this fraction of the model's size of
the part's plane (a pose's error in depth, and a region reaching past its face's edge)."""


def region_parts(
    model: RigidModel,
    camera: PinholeCamera,
    regions: RegionMeasurements,
) -> tuple[npt.NDArray[np.bool_], IntArray]:
    """Which of the view's regions lie on a part at `camera`'s pose, and on which.

    A region lies on the part whose normal is within `REGION_PART_MAX_DEG` of its own and
    whose plane is nearest its centre (within `REGION_PART_MAX_REL` of the model's size).
    Returns keep : (R,) whether a part was found; part : (R,) its index (meaningless where
    not kept).
    """
    R = camera.R_cam_world
    nw = regions.normal_cam @ R
    X = regions.centre_cam @ R + camera.centre
    agree = nw @ model.normals.T  # (R, P)
    dist = np.abs(X @ model.normals.T - model.offsets)
    limit = REGION_PART_MAX_REL * model.size
    ok = (agree > math.cos(math.radians(REGION_PART_MAX_DEG))) & (dist < limit)
    score = np.where(ok, dist, np.inf)
    part = np.argmin(score, axis=1).astype(np.intp)
    keep = np.isfinite(score[np.arange(regions.size), part])
    return keep, part


def match_regions(
    model: RigidModel,
    camera: PinholeCamera,
    regions: RegionMeasurements,
    opts: RegistrationOptions,
    normal_sigma_rad: FloatArray | None = None,
) -> RegionObservations | None:
    """Pair each region with the part whose plane it lies on at `camera`'s pose.

    A region goes to the part whose normal is within 20 degrees of its own and whose plane is
    nearest its centre (within 15 % of the model's size). None when no region pairs. Each
    pair's normal sigma is ``opts.region_sigma_deg``, or the region's own from
    `normal_sigma_rad` ((R,) radians, the caller's noise model of the regions' normals).
    """
    if regions.size == 0:
        return None
    keep, part = region_parts(model, camera, regions)
    if not np.any(keep):
        return None
    sigma_m = np.maximum(regions.rms_m[keep], opts.region_sigma_rel * model.size)
    return RegionObservations(
        part[keep].astype(np.intp),
        regions.normal_cam[keep],
        regions.centre_cam[keep],
        sigma_m,
        np.full(int(keep.sum()), math.radians(opts.region_sigma_deg))
        if normal_sigma_rad is None
        else np.asarray(normal_sigma_rad, dtype=np.float64)[keep],
    )


@dataclass(frozen=True)
class StereoSegments:
    """The second image of a stereo view: its camera (`Rig`) and its segments (S, 2) pixels;
    sigma_px : (S,) their edge-point sigmas (`aida_kb.vision.lines.fit_segments`) or None;
    image : the second image itself (8-bit grey, pinhole pixels) for `polish`, or None."""

    rig: Rig
    p1: FloatArray
    p2: FloatArray
    sigma_px: FloatArray | None = None
    image: npt.NDArray[np.uint8] | None = None


def _score(
    model: RigidModel,
    camera: PinholeCamera,
    p1: FloatArray,
    p2: FloatArray,
    cap_px: float,
    max_angle: float,
    stereo: StereoSegments | None = None,
) -> float:
    vis = model.visible_edges(camera)
    cost = chamfer_cost(vis.a, vis.b, p1, p2, cap_px=cap_px, max_angle_rad=max_angle)
    if stereo is None:
        return cost
    rv = model.visible_edges(stereo.rig.right_of(camera))
    right = chamfer_cost(rv.a, rv.b, stereo.p1, stereo.p2, cap_px=cap_px, max_angle_rad=max_angle)
    return 0.5 * (cost + right)


def _matched(
    model: RigidModel,
    camera: PinholeCamera,
    p1: FloatArray,
    p2: FloatArray,
    tol: float,
    max_angle: float,
    sigma_px: FloatArray | None = None,
) -> EdgeObservations:
    vis = model.visible_edges(camera)
    m = match_segments(vis.a, vis.b, p1, p2, max_distance_px=tol, max_angle_rad=max_angle)
    return EdgeObservations(
        model.edge_faces[vis.index[m.edge]],
        p1[m.segment],
        p2[m.segment],
        None if sigma_px is None else sigma_px[m.segment],
    )


def _right_matched(
    model: RigidModel,
    camera: PinholeCamera,
    stereo: StereoSegments | None,
    tol: float,
    max_angle: float,
    own_sigma: bool,
) -> EdgeObservations | None:
    """The second image's segments matched to the model edges it sees (None without a
    stereo partner); weighed by their own edge fits when `own_sigma`."""
    if stereo is None:
        return None
    sigma = stereo.sigma_px if own_sigma else None
    right_cam = stereo.rig.right_of(camera)
    return _matched(model, right_cam, stereo.p1, stereo.p2, tol, max_angle, sigma)


POSE_F_SCALE = 3.0
"""Scale of the robust loss of the pose fits, in units of each segment's sigma: a match
more than about three sigmas off its edge (a wrong or fragmentary segment) is down-weighted."""

OWN_SIGMA_TOLERANCE_PX = 2.0
"""Rounds of `refine` that match within this distance (pixels: the last, where the matches
no longer change) weigh each segment by its own edge fit; earlier rounds give every segment
``options.sigma_px``: with the fits' tenths of a pixel from the start, a pose pulled by a few
wrong matches of the wide rounds stayed in their basin (the house preset's second view: 0.5 m
off instead of 3 mm)."""


REJECT_SIGMAS = 6.0
"""In those rounds a segment whose whitened residual exceeds this is dropped and the pose
solved again (`aida_kb.register.pose.fit_pose`): with the segments' own sigmas, 3 sigma is
about 0.16 px for a clean 100 px edge."""


def refine(
    model: RigidModel,
    start: PinholeCamera,
    p1: FloatArray,
    p2: FloatArray,
    regions: RegionMeasurements | None = None,
    options: RegistrationOptions | None = None,
    schedule_px: tuple[float, ...] = (12.0, 6.0, 3.0, 2.0, 2.0),
    stereo: StereoSegments | None = None,
    sigma_px: FloatArray | None = None,
) -> tuple[PinholeCamera, float, int, int]:
    """Match, solve, re-match: the pose from a start near it.

    Each round matches with the next distance of ``schedule_px`` (pixels). With `stereo`, the
    second image's segments are matched and solved for as well (its camera follows the first).
    ``sigma_px`` (S,): the segments' own edge-point sigmas (`EdgeObservations`); with them the
    second image's are used too (else every segment gets ``options.sigma_px``).

    Returns the camera, the RMS edge residual (pixels) and the numbers of matched segments and
    regions of the last round.

    Raises
    ------
    SolveError
        Fewer than 3 matched segments in a round, or a degenerate solve.
    """
    opts = options or RegistrationOptions()
    max_angle = math.radians(opts.max_angle_deg)
    camera = start
    rms, n_edges, n_regions = math.inf, 0, 0
    for tol in schedule_px:
        # the segments' own noise model once the matches are final (`OWN_SIGMA_TOLERANCE_PX`)
        own = sigma_px is not None and tol <= OWN_SIGMA_TOLERANCE_PX
        edges = _matched(model, camera, p1, p2, tol, max_angle, sigma_px if own else None)
        if edges.size < 3:
            raise SolveError(f"registration: only {edges.size} segments match the model edges")
        right = _right_matched(model, camera, stereo, tol, max_angle, own)
        obs = match_regions(model, camera, regions, opts) if regions is not None else None
        fit = fit_pose(
            model,
            camera,
            edges,
            obs,
            rig=None if stereo is None else stereo.rig,
            right_edges=right,
            sigma_px=opts.sigma_px,
            f_scale=POSE_F_SCALE,
            reject_sigmas=REJECT_SIGMAS if own else None,
        )
        camera = fit.camera
        n_right = 0 if right is None else right.size
        rms, n_edges, n_regions = fit.rms_px, edges.size + n_right, 0 if obs is None else obs.size
    return camera, rms, n_edges, n_regions


def region_disagreement_deg(
    model: RigidModel,
    camera: PinholeCamera,
    regions: RegionMeasurements | None,
    opts: RegistrationOptions,
) -> float | None:
    """The median angle (degrees) between the view's regions' normals, carried into the world
    by `camera`, and the normals of the parts they match (`match_regions`); None without
    regions. Edges alone can be matched by a wrong pose (an oriel's box edges onto window
    frames at 0.7 px RMS, its regions' normals 7-10 degrees off); depth cannot.
    """
    if regions is None or regions.size == 0:
        return None
    obs = match_regions(model, camera, regions, opts)
    if obs is None:
        return None
    nw = obs.normal_cam @ camera.R_cam_world
    cos = np.abs(np.einsum("ij,ij->i", nw, model.normals[obs.part]))
    return float(np.median(np.degrees(np.arccos(np.clip(cos, 0.0, 1.0)))))


Refined = tuple[float, float, PinholeCamera, float, int, int, float]
"""A refined candidate pose: (chamfer cost, turn from the reference in degrees, camera, RMS
edge residual in pixels, matched segments, matched regions, the turn it started from)."""


class _Measured(NamedTuple):
    """What `register_view` registers: the segments (S, 2) pixels, the regions, the options,
    the second image's segments and the segments' sigmas."""

    q1: FloatArray
    q2: FloatArray
    regions: RegionMeasurements | None
    opts: RegistrationOptions
    stereo: StereoSegments | None
    sig: FloatArray | None


def _refined(
    model: RigidModel,
    reference: PinholeCamera,
    up: FloatArray,
    start: PinholeCamera,
    start_angle: float,
    schedule: tuple[float, ...],
    given: _Measured,
) -> Refined | None:
    """`start` refined with `schedule` (`refine`) and scored at 2 px (`_score`), as a
    `Refined` candidate whose turn is measured from `reference` about `up`; None when the
    refinement fails or the pose degenerates."""
    q1, q2, regions, opts, stereo, sig = given
    try:
        cam, rms, ne, nr = refine(model, start, q1, q2, regions, opts, schedule, stereo, sig)
        cost = _score(model, cam, q1, q2, 2.0, math.radians(opts.max_angle_deg), stereo)
    except (SolveError, GeometryError):
        return None
    return (cost, angle_about(reference, cam, up), cam, rms, ne, nr, start_angle)


SAME_POSE_DEG = 2.0
"""Refined candidates whose turns lie within this (degrees) are one pose reached from several
starts (they converge to within a few hundredths of a degree, or to another pose)."""


PLANE_SLACK = 1
"""Plane starts that explain fewer regions than the best one less this many are not refined
(the oriel preset's view 01: the true pose explains 7 of 8 regions, wrong ones 4)."""


def plane_starts(
    model: RigidModel, reference: PinholeCamera, regions: RegionMeasurements, up: FloatArray
) -> list[PinholeCamera]:
    """Starts from the view's region planes aligned with the model's (`aida_kb.register.planes`).

    The camera is assumed upright as the reference is (its vertical, ``R_ref up``, is the new
    camera's too: a camera turned about the vertical), and at the reference's height where the
    regions leave the height open. Cameras with the reference's intrinsics; none when the model
    has no polygons.
    """
    if not model.polygons:
        return []
    boxes = part_boxes(model.polygons)
    vertical = (up, reference.R_cam_world @ up, float(up @ reference.centre))
    poses = plane_poses(
        model.normals,
        model.offsets,
        boxes,
        model.size,
        regions.normal_cam,
        regions.centre_cam,
        regions.rms_m,
        vertical=vertical,
    )
    out = []
    most = max((n for _, _, n in poses), default=0)
    for R, t, n in poses:
        if n < most - PLANE_SLACK:
            continue
        try:
            out.append(PinholeCamera(reference.K, R, t, reference.width, reference.height))
        except GeometryError:
            continue
    return out


RIVAL_RETRIES = 2
"""A later view whose registered pose its evidence does not confirm is registered again about at
most this many rival turns (`rival_turns`), the cheapest first: a box's twins (its half and
quarter turns) are two, and each try costs a registration and a joint adjustment."""


def rival_turns(reg: Registration, options: RegistrationOptions | None = None) -> list[float]:
    """The turns (degrees, as ``reg.angle_deg``) of the registration's refined poses farther
    than the search's span (``options.span_deg``) from the pose taken and from each other
    whose edges fit about as well (chamfer cost at most `twins.RIVAL_COST_RATIO` times the
    pose's), the cheapest first: at most `RIVAL_RETRIES`. Registered again about one of them
    (``init_angle_deg``), the view may land where its evidence confirms the pose."""
    span = (options or RegistrationOptions()).span_deg
    out: list[float] = []
    for _, final, cost in sorted(reg.candidates, key=lambda c: c[2]):
        if cost > RIVAL_COST_RATIO * reg.cost or len(out) == RIVAL_RETRIES:
            break
        if all(abs(_wrap(final - a)) > span for a in [reg.angle_deg, *out]):
            out.append(final)
    return out


def _local_minima(costs: FloatArray, angles: FloatArray, count: int, sep_deg: float) -> list[int]:
    order = np.argsort(costs, kind="stable")
    chosen: list[int] = []
    for i in order:
        if all(abs(_wrap(float(angles[i] - angles[j]))) >= sep_deg for j in chosen):
            chosen.append(int(i))
        if len(chosen) == count:
            break
    return chosen


def register_view(
    model: RigidModel,
    reference: PinholeCamera,
    p1: npt.ArrayLike,
    p2: npt.ArrayLike,
    *,
    regions: RegionMeasurements | None = None,
    intrinsics: tuple[FloatArray, int, int] | None = None,
    init_angle_deg: float | None = None,
    expected_turn_deg: float | None = None,
    axis: FloatArray | None = None,
    stereo: StereoSegments | None = None,
    options: RegistrationOptions | None = None,
    sigma_px: npt.ArrayLike | None = None,
    image: npt.NDArray[np.uint8] | None = None,
    photometric: PhotometricJudge | None = None,
    region_sigma_rad: FloatArray | None = None,
) -> Registration:
    """The pose of a new view of a fixed model, found with no initial guess.

    Parameters
    ----------
    model : the fixed model (world frame).
    reference : a registered camera (the first view, or the previous one): the start of the
        search about the vertical axis.
    p1, p2 : (S, 2) the new view's image segments, pixels of the undistorted image.
    regions : the new view's regions with depth (its camera frame), or None.
    intrinsics : (K (3, 3), width, height) of the new camera if they differ from the reference.
    init_angle_deg : a rough turn about the vertical from the reference; the search then spans
        ``options.span_deg`` about it instead of the whole circle.
    expected_turn_deg : without `init_angle_deg`, the turn a symmetric model's pose is taken
        nearest to (default 0, the reference): a model that looks the same turned by
        360/n degrees (`symmetry_order`) is searched over 360/n degrees about it.
    axis : the vertical (3,), world frame; default `vertical_axis`.
    stereo : the view's second image (a stereo pair): its segments are used as well.
    options : tuning (`RegistrationOptions`).
    sigma_px : (S,) each segment's edge-point sigma from its edge fit, pixels
        (`aida_kb.vision.lines.fit_segments`; with them the noise model of the edge factors is
        the segments' own, the second image's too: `aida_kb.register.pose.point_sigma`), or
        None: ``options.sigma_px`` for all.
    image : (H, W) the view's image, 8-bit grey, in the pinhole camera's (undistorted) pixels,
        or None; with it the chosen pose is polished against the image (`polish`; with
        ``stereo.image`` against both), and the covariance is that of the polished edges.
    photometric : the images' support of a candidate camera (`aida_kb.register.twins`: the
        registered views' images carried into the view through the model), or None. With it,
        of the refined poses whose edges fit about as well (`twins.rivals_of`) the one the
        images confirm is taken (`twins.photometric_choice`: a symmetric model's twin is
        decided by the faces' content), and where they confirm none, a pose that shares no
        face with the registered views while a rival does is not taken
        (`twins.unsupported_twin`: SolveError).
    region_sigma_rad : (R,) the caller's noise model of the `regions`' normals (each one's 1-σ
        tilt, radians), or None. With it, every refined pose is also refined again from the
        rotation its matched regions' normals give (`realigned`): a pose whose segments fit
        in a wrong basin is put back where the view's own planes say it looks.

    Raises
    ------
    SolveError
        When no start leads to a pose that matches the image.
    """
    opts = options or RegistrationOptions()
    q1 = np.asarray(p1, dtype=np.float64).reshape(-1, 2)
    q2 = np.asarray(p2, dtype=np.float64).reshape(-1, 2)
    if q1.shape != q2.shape or not (np.all(np.isfinite(q1)) and np.all(np.isfinite(q2))):
        raise SolveError("registration: segment end points must be finite (S, 2) arrays")
    sig = None if sigma_px is None else np.asarray(sigma_px, dtype=np.float64).ravel()
    if sig is not None and (sig.shape != (q1.shape[0],) or not np.all(np.isfinite(sig))):
        raise SolveError("registration: segment sigmas must be finite, one per segment")
    long = np.linalg.norm(q2 - q1, axis=1) >= opts.min_segment_px
    q1, q2 = q1[long], q2[long]
    sig = None if sig is None else sig[long]
    if q1.shape[0] < 3:
        raise SolveError(f"registration: the view has only {q1.shape[0]} usable line segments")
    if intrinsics is not None:
        K, w, h = intrinsics
        reference = PinholeCamera(K, reference.R_cam_world, reference.t_cam_world, w, h)
    up = vertical_axis(model, reference) if axis is None else np.asarray(axis, dtype=np.float64)
    up = up / np.linalg.norm(up)
    given = _Measured(q1, q2, regions, opts, stereo, sig)
    pivot = orbit_pivot(model, reference)
    if init_angle_deg is not None:
        centre, half = float(init_angle_deg), opts.span_deg
        angles = centre + np.arange(-half, half + 1e-9, opts.step_deg)
    else:
        # a model that looks the same turned by 360/n degrees cannot tell those poses apart:
        # the search spans one n-th of the circle about the expected turn
        centre = 0.0 if expected_turn_deg is None else float(expected_turn_deg)
        half = 180.0 / symmetry_order(model, up, pivot)
        angles = centre + np.arange(-half, half - 1e-9, opts.step_deg)
    max_angle = math.radians(opts.max_angle_deg)
    cap = max(max(s) for s in opts.schedules_px)
    starts: list[tuple[PinholeCamera, float, tuple[tuple[float, ...], ...]]] = []
    for about in orbit_pivots(model, reference, up):
        costs = np.empty(angles.size)
        for k, a in enumerate(angles):  # a few dozen candidates; each scored vectorised
            try:
                cam = turned(reference, up, about, math.radians(float(a)))
                costs[k] = _score(model, cam, q1, q2, cap, max_angle)
            except GeometryError:
                costs[k] = math.inf
        picks = _local_minima(costs, angles, opts.starts, sep_deg=2.5 * opts.step_deg)
        starts += [
            (turned(reference, up, about, math.radians(float(a))), float(a), opts.schedules_px)
            for a, c in zip(angles[picks], costs[picks], strict=True)
            if math.isfinite(c)
        ]
    if regions is not None and regions.size:
        # the view's own planes: no orbit assumed but the vertical (see `plane_starts`); such
        # a start is a few degrees off at most: the widest schedule alone
        for cam in plane_starts(model, reference, regions, up):
            starts.append((cam, angle_about(reference, cam, up), opts.schedules_px[-1:]))
    results: list[Refined] = []
    for start, start_angle, schedules in starts:
        for schedule in schedules:
            found = _refined(model, reference, up, start, start_angle, schedule, given)
            if found is not None:
                results.append(found)
    if not results:
        raise SolveError("registration: no start converged to a pose that matches the image")
    if regions is not None and region_sigma_rad is not None:
        results += _realigned_results(model, reference, up, results, given, region_sigma_rad)
    refined = tuple(results)  # every refined pose: the registration's candidates
    # a pose whose regions' normals disagree with the model by several sigma is not the view's
    limit = opts.region_disagree_sigmas * opts.region_sigma_deg
    agreeing = []
    worst = 0.0
    for res in results:
        off = region_disagreement_deg(model, res[2], regions, opts)
        if off is None or off <= limit:
            agreeing.append(res)
        else:
            worst = max(worst, off)
    if not agreeing:
        raise SolveError(
            "registration: every pose that matches the image's segments puts its regions' "
            f"normals more than {limit:g} degrees off the model's (up to {worst:.1f}): the "
            "view does not fit the model"
        )
    results = agreeing
    order = symmetry_order(model, up, model.centroid)  # the model's own axis
    if regions is not None and regions.size and model.polygons:
        # the depth evidence decides between poses the segments alone cannot: a pose must put
        # about as many of the view's regions on the model's parts as the best one does
        boxes = part_boxes(model.polygons)
        on = [
            regions_explained(
                model.normals,
                model.offsets,
                boxes,
                model.size,
                r[2].R_cam_world,
                r[2].t_cam_world,
                regions.normal_cam,
                regions.centre_cam,
                regions.rms_m,
            )
            for r in results
        ]
        most = max(on)
        kept = [r for r, n in zip(results, on, strict=True) if n >= most - PLANE_SLACK]
        # a symmetric model's twin puts the same regions on its parts but for the model's own
        # small asymmetries (an inserted part a little off): between twins a count is no
        # evidence, the choice below goes by the expected turn (dev seed 2009's view 02 was
        # taken 180 degrees off by 2 regions against 0)
        results = [
            r
            for r in results
            if any(r is k or _symmetric_gap(r[1], k[1], order) <= opts.span_deg for k in kept)
        ]
    # the images decide between poses the segments and depth cannot (a symmetric model's
    # twins): the registered views' images carried into the view at each rival pose
    rivals: list[tuple[float, PoseSupport]] = []
    if photometric is not None:
        if order > 1:  # the twins of a symmetric model's poses: the search spans 360/n only
            results += _twins(model, reference, up, results, order, given)
        picked = rivals_of([r[0] for r in results], [r[1] for r in results], SAME_POSE_DEG)
        supports = [photometric(results[i][2]) for i in picked]
        rivals = [(results[i][1], s) for i, s in zip(picked, supports, strict=True)]
        won = photometric_choice([a for a, _ in rivals], supports, opts.span_deg)
        if won is not None:
            chosen = results[picked[won]]
            return _registration(model, reference, up, chosen, refined, (), given, image)
    inside = [r for r in results if abs(_wrap(r[1] - centre)) <= half]
    results = inside or results
    best = min(results, key=lambda r: r[0])
    ties = [r for r in results if r[0] <= best[0] * (1.0 + opts.tie_tolerance) + opts.tie_floor]
    # the evidence decides: the lowest cost wins, unless the model's own symmetry makes poses
    # turned by 360/n degrees from it alike (their images cannot differ): of those, the one
    # nearest the expected turn; then, near it, the lowest cost
    twins = [r for r in ties if _symmetric_gap(r[1], best[1], order) <= opts.span_deg]
    near = min(twins, key=lambda r: (abs(_wrap(r[1] - centre)), r[0]))[1]
    local = [r for r in results if abs(_wrap(r[1] - near)) <= opts.span_deg]
    cost, final, cam, rms, ne, nr, _ = min(local, key=lambda r: r[0])
    if order > 1 and abs(_wrap(final - centre)) > 180.0 / order + opts.span_deg:
        # the model looks the same turned by 360/n degrees and the pose taken lies nearer a
        # twin's turn than its own to the expected one: nothing in the view decides which of
        # them it is (a flip, 180 degrees off, passes every check against the model)
        step = 360.0 / order
        twin = _wrap(final + step * round(_wrap(centre - final) / step))
        raise SolveError(
            f"registration: the model looks the same turned by {step:g} degrees; the view's "
            f"images fit a turn of {final:.1f} degrees best, its twin {twin:.1f} lies nearer "
            f"the expected {centre:.1f}: the evidence does not decide between them"
        )
    undecided: tuple[float, ...] = ()
    undecided_support: tuple[PoseSupport, ...] = ()
    if photometric is None and order > 1:  # nothing but the expected turn chose among twins
        undecided = tuple(_wrap(final + 360.0 * k / order) for k in range(1, order))
    if photometric is not None:
        taken = [s for a, s in rivals if abs(_wrap(a - final)) <= SAME_POSE_DEG]
        support = taken[0] if taken else photometric(cam)
        undecided = undecided_rivals(
            final, support, [a for a, _ in rivals], [s for _, s in rivals], opts.span_deg
        )
        undecided_support = tuple(s for a, s in rivals if a in undecided)
        if not support.shares:
            # a view of a sequence shares faces with the views before it at its true pose;
            # a symmetric model's twin sees their backs: nothing confirms such a pose
            other = unsupported_twin(
                final, support, [a for a, _ in rivals], [s for _, s in rivals], opts.span_deg
            )
            rival = "" if other is None else f" (at {other:.1f} degrees it does)"
            raise SolveError(
                f"registration: the view's segments fit a turn of {final:.1f} degrees best, "
                f"but there the view shares no textured face with the registered views"
                f"{rival}: nothing confirms the turn (a symmetric model's twin looks the same)"
            )
    # poses far from the chosen one that explain the image about as well: the view is
    # ambiguous between them (reported, not hidden)
    others: dict[float, float] = {}
    for r in ties:
        if abs(_wrap(r[1] - final)) > opts.span_deg:
            key = round(r[1], 1)
            others[key] = min(others.get(key, math.inf), r[0])
    alternatives = tuple(sorted(others.items()))
    chosen = (cost, final, cam, rms, ne, nr, 0.0)
    return _registration(
        model,
        reference,
        up,
        chosen,
        refined,
        alternatives,
        given,
        image,
        (undecided, undecided_support),
    )


def rivals_left(
    model: RigidModel,
    reference: PinholeCamera,
    reg: Registration,
    camera: PinholeCamera,
    photometric: PhotometricJudge,
    options: RegistrationOptions | None = None,
) -> tuple[Registration, PoseSupport]:
    """``reg`` with only the rivals (its ``undecided`` turns) the images still do not rule out
    once the view's pose is adjusted to ``camera``, and the images' support there.

    The registration judged its rivals at its own refined pose, which may lie a degree or two
    off: there the registered views' images carried into the view hardly correlate (dev
    73034's view 01: NCC 0.14 at 1.1 deg off, 0.83 at the adjusted pose 0.01 deg off; 73013's
    view 02: 0.22 at 1.4 deg off, 0.88 adjusted), and no rival can fall `CONFIRM_MARGIN`
    below it. At ``camera`` the pose is judged again; a rival that is the model's twin
    (`symmetry_order`: its edges are the pose's turned by 360/n) is judged at the exact twin
    of ``camera``, on the same footing, and any other at the pose the registration refined
    (`twins.undecided_rivals`). Nothing changes unless ``camera`` is
    `twins.PoseSupport.confirmed`: a pose the images do not confirm decides nothing.

    model, reference : as given to `register_view` (world frame); camera : the view's camera
    after the adjustment (world frame); photometric : the judge the registration used.
    Returns the registration (its pose unchanged, ``undecided`` and ``undecided_support``
    narrowed) and the support of ``camera``.
    """
    opts = options or RegistrationOptions()
    support = photometric(camera)
    judged = bool(reg.undecided) and len(reg.undecided_support) == len(reg.undecided)
    if not (judged and support.confirmed):
        return reg, support
    up = vertical_axis(model, reference)
    final = angle_about(reference, camera, up)
    order = symmetry_order(model, up, model.centroid)
    steps = [360.0 * k / order for k in range(1, order)]
    supports: list[PoseSupport] = []
    for turn, own in zip(reg.undecided, reg.undecided_support, strict=True):
        step = next((s for s in steps if abs(_wrap(turn - final - s)) <= opts.span_deg), None)
        supports.append(
            own
            if step is None
            else photometric(turned(camera, up, model.centroid, math.radians(step)))
        )
    left = undecided_rivals(final, support, reg.undecided, supports, opts.span_deg)
    kept = tuple(s for a, s in zip(reg.undecided, reg.undecided_support, strict=True) if a in left)
    return replace(reg, undecided=left, undecided_support=kept), support


REALIGN_SCHEDULE_PX = (6.0, 3.0, 2.0, 2.0)
"""The matching distances (pixels) of `refine` from a realigned start (`realigned`): its
rotation is the regions' (a tenth of a degree where they are well measured) and its position
follows their planes, so it starts within a few pixels; the wide rounds of the coarse starts'
schedules (12-24 px) match clutter (occluders, windows) and pull such a start off again. Dev
61427 view 02: from a start 0.06 deg off, the 24 px schedule ends 6.3 deg off (cost 0.724),
this one's 6 px rounds 0.1 deg off (cost 0.675)."""
REALIGN_MIN_ANGLE_DEG = 20.0
"""`realigned` needs two matched regions' normals at least this far apart (degrees): the
normals of parallel planes leave the rotation about them open."""
REALIGN_PRIOR_REL = 1.0
"""In `realigned`, the position the pose had (its model's centroid kept where the camera saw
it) is kept in the directions the regions' planes leave open, to this standard deviation as a
fraction of the model's size (loose: the planes' own, at least
`RegistrationOptions.region_sigma_rel` of the size, decide wherever they can)."""


def realigned(
    model: RigidModel,
    camera: PinholeCamera,
    regions: RegionMeasurements,
    sigma_rad: FloatArray,
    opts: RegistrationOptions,
) -> PinholeCamera | None:
    """The pose whose rotation puts the regions matched at `camera` (`match_regions`) onto
    their parts' normals, and whose position puts their centres on their parts' planes.

    The rotation is the weighted least-squares one (Wahba's problem, by SVD) taking each
    matched part's normal (world frame) to its region's (camera frame), each weighed by
    ``1 / sigma_rad²`` (its fit's own tilt): a large wall measured to hundredths of a degree
    decides, a sliver hardly counts. Given the rotation, each region's plane says how far its
    centre lies along its normal, ``(R n)·t = (R n)·x - d`` for a part of normal n and offset
    d and a region centre x (camera frame), weighed by its ``sigma_m``; directions no plane
    fixes keep the pose's position (`REALIGN_PRIOR_REL`).

    sigma_rad : (R,) the regions' normals' 1-σ, radians (R: all the view's regions).
    Returns None when fewer than two regions match with normals `REALIGN_MIN_ANGLE_DEG`
    apart, or the pose is degenerate.
    """
    obs = match_regions(model, camera, regions, opts, sigma_rad)
    if obs is None or obs.size < 2:
        return None
    world = model.normals[obs.part]  # (M, 3)
    cos = np.abs(world @ world.T)
    if float(cos.min()) > math.cos(math.radians(REALIGN_MIN_ANGLE_DEG)):
        return None
    w = 1.0 / np.maximum(obs.sigma_rad, 1e-9) ** 2
    H = np.einsum("m,mi,mj->ij", w, obs.normal_cam, world)  # sum w a b^T: R b = a
    U, _, Vt = np.linalg.svd(H)
    D = np.diag([1.0, 1.0, float(np.sign(np.linalg.det(U @ Vt)))])
    R = U @ D @ Vt
    centroid = model.centroid
    t0 = camera.R_cam_world @ centroid + camera.t_cam_world - R @ centroid
    N = world @ R.T  # the parts' normals in the camera frame (M, 3)
    rhs = np.einsum("mi,mi->m", N, obs.centre_cam) - model.offsets[obs.part]
    ws = 1.0 / obs.sigma_m
    prior = 1.0 / (REALIGN_PRIOR_REL * model.size)
    A = np.vstack([N * ws[:, None], prior * np.eye(3)])
    y = np.concatenate([rhs * ws, prior * t0])
    t = np.linalg.lstsq(A, y, rcond=None)[0]
    try:
        return PinholeCamera(camera.K, R, t, camera.width, camera.height)
    except GeometryError:
        return None


def _realigned_results(
    model: RigidModel,
    reference: PinholeCamera,
    up: FloatArray,
    results: Sequence[Refined],
    given: _Measured,
    sigma_rad: FloatArray,
) -> list[Refined]:
    """Every distinct refined pose (one per `SAME_POSE_DEG` of turn, cheapest first) refined
    again from its `realigned` start with `REALIGN_SCHEDULE_PX`: the candidates its regions
    lead to. They join the others, and the choice by cost takes them or not."""
    regions, opts = given.regions, given.opts
    if regions is None or regions.size == 0:
        return []
    order = sorted(range(len(results)), key=lambda i: results[i][0])
    seen: list[float] = []
    out: list[Refined] = []
    for i in order:
        if any(abs(_wrap(results[i][1] - a)) <= SAME_POSE_DEG for a in seen):
            continue
        seen.append(results[i][1])
        start = realigned(model, results[i][2], regions, sigma_rad, opts)
        if start is None:
            continue
        start_angle = angle_about(reference, start, up)
        found = _refined(model, reference, up, start, start_angle, REALIGN_SCHEDULE_PX, given)
        if found is not None:
            out.append(found)
    return out


def _twins(
    model: RigidModel,
    reference: PinholeCamera,
    up: FloatArray,
    results: Sequence[Refined],
    order: int,
    given: _Measured,
) -> list[Refined]:
    """The refined twins of the rival poses of a model that looks the same turned by
    360/``order`` degrees about `up` through its centroid: each rival's camera turned so,
    refined with the last schedule (the model is symmetric only to `symmetry_order`'s
    tolerance), unless a refined pose is there already; those whose regions disagree with the
    model (`region_disagreement_deg`) are left out."""
    regions, opts = given.regions, given.opts
    limit = opts.region_disagree_sigmas * opts.region_sigma_deg
    picked = rivals_of([r[0] for r in results], [r[1] for r in results], SAME_POSE_DEG)
    known = [r[1] for r in results]
    out: list[Refined] = []
    for i in picked:
        for k in range(1, order):
            step = 2.0 * math.pi * k / order
            try:
                start = turned(results[i][2], up, model.centroid, step)
            except GeometryError:
                continue
            start_angle = angle_about(reference, start, up)
            if any(abs(_wrap(start_angle - a)) <= SAME_POSE_DEG for a in known):
                continue
            found = _refined(model, reference, up, start, start_angle, opts.schedules_px[-1], given)
            if found is None:
                continue
            off = region_disagreement_deg(model, found[2], regions, opts)
            if off is not None and off > limit:
                continue
            known.append(found[1])
            out.append(found)
    return out


def _registration(
    model: RigidModel,
    reference: PinholeCamera,
    up: FloatArray,
    chosen: Refined,
    results: Sequence[Refined],
    alternatives: tuple[tuple[float, float], ...],
    given: _Measured,
    image: npt.NDArray[np.uint8] | None,
    undecided: tuple[tuple[float, ...], tuple[PoseSupport, ...]] = ((), ()),
) -> Registration:
    """The `Registration` of the chosen refined candidate ``(cost, turn, camera, rms,
    n_edges, n_regions, start turn)``: polished against the image when it is given, with the
    covariance of its final measurements; ``undecided`` as `Registration.undecided` and
    `Registration.undecided_support`."""
    q1, q2, regions, opts, stereo, sig = given
    cost, final, cam, rms, ne, nr, _ = chosen
    max_angle = math.radians(opts.max_angle_deg)
    cands = tuple((r[6], r[1], r[0]) for r in results)
    polished = None if image is None else polish(model, cam, image, regions, opts, stereo)
    if polished is not None:
        cam, rms, cov = polished
        final = angle_about(reference, cam, up)
        cost = _score(model, cam, q1, q2, 2.0, max_angle, stereo)
        turn_sd, rot_sd = _turn_sigma(reference, cam, up, cov)
    else:
        cov, turn_sd, rot_sd = _uncertainty(
            model, reference, cam, up, q1, q2, regions, opts, stereo, sig
        )
    return Registration(
        cam, final, rms, cost, ne, nr, cands, cov, turn_sd, rot_sd, alternatives, *undecided
    )


def _uncertainty(
    model: RigidModel,
    reference: PinholeCamera,
    camera: PinholeCamera,
    up: FloatArray,
    p1: FloatArray,
    p2: FloatArray,
    regions: RegionMeasurements | None,
    opts: RegistrationOptions,
    stereo: StereoSegments | None,
    sigma_px: FloatArray | None,
) -> tuple[FloatArray, float, float]:
    """The pose covariance of a registered camera from its final matches, the standard
    deviation of its turn about `up` and of its rotation about the least determined axis
    (degrees). The turn's gradient is taken by central differences of `angle_about`."""
    tol = opts.schedules_px[0][-1]
    max_angle = math.radians(opts.max_angle_deg)
    edges = _matched(model, camera, p1, p2, tol, max_angle, sigma_px)
    right = _right_matched(model, camera, stereo, tol, max_angle, sigma_px is not None)
    obs = match_regions(model, camera, regions, opts) if regions is not None else None
    cov = pose_covariance(
        model,
        camera,
        edges,
        obs,
        rig=None if stereo is None else stereo.rig,
        right_edges=right,
        sigma_px=opts.sigma_px,
        f_scale=POSE_F_SCALE,
    )
    turn_sd, rot_sd = _turn_sigma(reference, camera, up, cov)
    return cov, turn_sd, rot_sd


def _turn_sigma(
    reference: PinholeCamera, camera: PinholeCamera, up: FloatArray, cov: FloatArray
) -> tuple[float, float]:
    """The standard deviations (degrees) of a pose's turn about `up` relative to `reference`
    and of its rotation about the least determined axis, from its covariance (6, 6)."""
    if not np.all(np.isfinite(cov)):
        return math.inf, math.inf
    x = camera.pose
    grad = np.zeros(6)
    for i in range(6):
        dx = np.zeros(6)
        dx[i] = TURN_STEP
        plus = angle_about(reference, camera.with_pose(x + dx), up)
        minus = angle_about(reference, camera.with_pose(x - dx), up)
        grad[i] = _wrap(plus - minus) / (2.0 * TURN_STEP)
    turn_sd = math.sqrt(max(float(grad @ cov @ grad), 0.0))
    rot_sd = math.degrees(math.sqrt(max(float(np.linalg.eigvalsh(cov[:3, :3]).max()), 0.0)))
    return turn_sd, rot_sd


TURN_STEP = 1e-6
"""Step of the central differences of the turn angle, in pose units (rad, m)."""


POLISH_ROUNDS = 3
"""Rounds of `polish`: project the model's edges, fit each to the image, solve the pose."""
POLISH_MIN_EDGE_PX = 20.0
"""Projected model edges shorter than this (pixels) are not fitted to the image."""
POLISH_MARGIN_PX = 4.0
"""Edges are clipped to the image shrunk by this (pixels): a profile across the edge must fit
inside (`aida_kb.vision.lines.PROFILE_HALF_PX`)."""
POLISH_SEPARATION_PX = 6.0
"""An edge with another visible, nearly parallel edge (within `POLISH_SEPARATION_DEG`) closer
than this (pixels) is not fitted: the profile across it may hold the other one's step (a face
seen at a grazing angle, a corner)."""
POLISH_SEPARATION_DEG = 15.0


def _separated(a: FloatArray, b: FloatArray) -> npt.NDArray[np.bool_]:
    """(E,) the projected edges (E, 2) a -> b with no other nearly parallel edge near them.

    Distances are from samples along each edge to the other edges (point to segment)."""
    E = a.shape[0]
    if E < 2:
        return np.ones(E, dtype=bool)
    d = b - a
    length = np.maximum(np.linalg.norm(d, axis=1), 1e-9)
    u = d / length[:, None]
    s = np.linspace(0.1, 0.9, 9)
    pts = a[:, None, :] + s[None, :, None] * d[:, None, :]  # (E, K, 2)
    rel = pts[:, :, None, :] - a[None, None, :, :]  # (E, K, E, 2)
    t = np.clip(np.einsum("ikjc,jc->ikj", rel, u), 0.0, length[None, None, :])
    closest = a[None, None, :, :] + t[..., None] * u[None, None, :, :]
    dist = np.linalg.norm(pts[:, :, None, :] - closest, axis=3).min(axis=1)  # (E, E)
    sin = np.abs(u[:, None, 0] * u[None, :, 1] - u[:, None, 1] * u[None, :, 0])
    near = (dist < POLISH_SEPARATION_PX) & (sin < math.sin(math.radians(POLISH_SEPARATION_DEG)))
    np.fill_diagonal(near, False)
    out: npt.NDArray[np.bool_] = ~near.any(axis=1)
    return out


def image_edges(
    model: RigidModel, camera: PinholeCamera, grey: npt.NDArray[np.uint8]
) -> EdgeObservations:
    """The model's visible edges at `camera`, each fitted to the image along its whole length.

    Every visible edge (`RigidModel.visible_edges`, at least `POLISH_MIN_EDGE_PX` long, away
    from others: `POLISH_SEPARATION_PX`) is moved onto the image edge within
    `aida_kb.vision.lines.SEARCH_PX` of its projection (`aida_kb.vision.lines.fit_segments`:
    subpixel edge points across it, a robust line fit, its points' sigma). Edges the image
    does not show there (too few edge points) are left out. The observations know their edge:
    no matching.

    grey : (H, W) 8-bit image in the camera's pinhole (undistorted) pixels.
    """
    from aida_kb.vision.lines import fit_segments

    vis = model.visible_edges(camera, min_length_px=POLISH_MIN_EDGE_PX, margin_px=POLISH_MARGIN_PX)
    apart = _separated(vis.a, vis.b)
    a, b, index = vis.a[apart], vis.b[apart], vis.index[apart]
    fits = fit_segments(grey, np.concatenate([a, b], axis=1))
    ok = fits.support > 0
    seg = fits.segments[ok]
    return EdgeObservations(model.edge_faces[index[ok]], seg[:, :2], seg[:, 2:], fits.sigma_px[ok])


def polish(
    model: RigidModel,
    camera: PinholeCamera,
    grey: npt.NDArray[np.uint8],
    regions: RegionMeasurements | None = None,
    options: RegistrationOptions | None = None,
    stereo: StereoSegments | None = None,
) -> tuple[PinholeCamera, float, FloatArray] | None:
    """The pose refined against the image itself: every visible model edge fitted to the image
    along its whole length (`image_edges`), not only where a line detector found fragments.

    `POLISH_ROUNDS` times: fit the edges at the current pose, solve the pose with each edge
    weighted by its own fit (`aida_kb.register.pose.point_sigma`), edges off by more than
    `REJECT_SIGMAS` dropped. With `stereo` and its ``image``, the second image's edges too.
    Returns the camera, its RMS edge residual (pixels) and its covariance
    (`aida_kb.register.pose.pose_covariance`), or None when fewer than
    `MIN_POLISH_EDGES` edges are found (the pose is then the segments').
    """
    opts = options or RegistrationOptions()
    cov: FloatArray = np.full((6, 6), np.inf)
    rms = math.inf
    for _ in range(POLISH_ROUNDS):
        edges = image_edges(model, camera, grey)
        if edges.size < MIN_POLISH_EDGES:
            return None
        right = None
        rig = None
        if stereo is not None and stereo.image is not None:
            rig = stereo.rig
            right = image_edges(model, rig.right_of(camera), stereo.image)
        obs = match_regions(model, camera, regions, opts) if regions is not None else None
        try:
            fit = fit_pose(
                model,
                camera,
                edges,
                obs,
                rig=rig,
                right_edges=right,
                sigma_px=opts.sigma_px,
                f_scale=POSE_F_SCALE,
                reject_sigmas=REJECT_SIGMAS,
            )
        except (SolveError, GeometryError):
            return None
        camera, rms = fit.camera, fit.rms_px
        cov = pose_covariance(
            model,
            camera,
            edges,
            obs,
            rig=rig,
            right_edges=right,
            sigma_px=opts.sigma_px,
            f_scale=POSE_F_SCALE,
        )
    return camera, rms, cov


MIN_POLISH_EDGES = 4
"""`polish` needs at least this many model edges found in the image."""
