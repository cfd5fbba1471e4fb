"""The joint adjustment of a model and its views' cameras (paper §5): its factors and their
noise models.

`joint_problem` builds one problem of `aida_kb.solve` from a model, its cameras and each view's
measurements: edge factors (the line detector's segments matched to the model's projected edges,
or the model's edges fitted along the images, `aida_kb.interpret.imagefit`), the regions' plane
fits in their cameras' frames, the knowledge base's constraints and attributes of the
interpreted objects and, loosely, the first shape's angles between adjacent parts the knowledge
does not relate; `joint_adjustment` solves it. The
sequence that calls them is `aida_kb.interpret.multiview`."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from aida_kb.constraints import CameraPositionData, Constraint, EdgeData, Origin
from aida_kb.constraints.kernels import meeting_angle
from aida_kb.constraints.kinds.edge import MIN_FIT_POINTS, segment_sqrt_information
from aida_kb.errors import SolveError
from aida_kb.geometry.camera import PinholeCamera
from aida_kb.geometry.rig import Rig
from aida_kb.interpret.closure import closing_ties
from aida_kb.interpret.feet import foot_leans, lean_scale
from aida_kb.interpret.hypotheses import DOWNWARD, UPWARD
from aida_kb.interpret.knowledge import Knowledge
from aida_kb.interpret.observe import FIT_CORRELATED_PX, fit_sigma_rad
from aida_kb.interpret.party import touching_ties
from aida_kb.interpret.result import INSERTED, Interpretation
from aida_kb.interpret.uncertainty import IMAGE_EDGE_LABEL
from aida_kb.interpret.verify import orientation_priors, tilt_constraints
from aida_kb.kb.paths import RolePath
from aida_kb.register import (
    EdgeObservations,
    RegionMeasurements,
    RegistrationOptions,
    RigidModel,
    StereoSegments,
    match_regions,
    match_segments,
)
from aida_kb.register.evidence import (
    ViewMeasurements,
)
from aida_kb.register.match import Matches
from aida_kb.register.pose import point_sigma
from aida_kb.solve import ResidualReport, build_problem, constraints_from_kb, solve
from aida_kb.solve.problem import Loss, Problem

if TYPE_CHECKING:
    from aida_kb.kb.model import KnowledgeBase, OrientationModel

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

__all__ = [
    "CORNER_MIN_DET",
    "CORNER_SHARE",
    "CORNER_SIGMA_M",
    "FOOT_BIAS_PX",
    "FOOT_SHARE",
    "GRAZING_DEG",
    "IMAGE_KEEP_SEGMENTS",
    "IMAGE_SCATTER_BIAS",
    "JOINT_ANGLE_SIGMA_DEG",
    "JOINT_EDGE_SIGMA_PX",
    "JOINT_F_SCALE",
    "JOINT_LOSS",
    "JOINT_MATCH_PX",
    "JOINT_REGION_LOOSENESS",
    "PRIOR_ANGLE_SIGMA_DEG",
    "REGION_BIAS_DEG",
    "REGION_FIT_SCALE",
    "STEREO_FIT_CORRELATION",
    "JointInputs",
    "corner_ties",
    "edge_keys",
    "fit_point_sigma",
    "foot_grazing_deg",
    "joint_adjustment",
    "joint_problem",
    "kb_constraints",
    "meeting_angles",
    "part_centres",
    "region_normal_sigma_rad",
]

JOINT_EDGE_SIGMA_PX = 4.0
"""Edge constraints of the joint adjustment: an edge point's standard deviation across its
edge, pixels (loose: a model edge is not exactly an image edge — eaves, shading, texture); a
segment's mean end-point residual gets ``sigma / sqrt(length)``, their half difference
``sigma·sqrt(3/length)`` (`segment_sqrt_information`)."""

REGION_FIT_SCALE = 1.25
"""A region's normal is known to its plane fit's own 1-σ tilt
(`aida_kb.interpret.observe.fit_sigma_rad`: the fit's RMS over the root of its independent
points — neighbouring disparities share their NCC window, so one pixel per window,
`FIT_CORRELATED_PX`, counts — and the region's spread) times this, with `REGION_BIAS_DEG` added
in quadrature (`region_normal_sigma_rad`); the scale and the floor stand for what no fit
statistic shows (the disparity refinement's bias, a region's rim on a neighbouring face).
Measured on the regions of dev seeds 60000-60023 and 61100-61123 against their TRUE faces and
cameras (347 regions, `benchmarks/camera_sd.py --keep`): the normal's error over the fit's
tilt has a median of 1.16 and a 90th percentile of 3.4 (1.25 and 3.0 for fits under 0.1 deg);
an honest 1-σ per axis gives 1.18 and 2.15 (a 2-D error). With the scale and the floor: 0.93
and 2.8 over all, 0.90 and 2.2 for the fits of 0.02-0.3 deg; 10 % of the regions (small,
unlabelled, straddling a crease) lie beyond 3 of their sigmas, which the robust loss
(`JOINT_LOSS`) takes. Before: every region 2 deg
(`aida_kb.register.RegistrationOptions.region_sigma_deg`), 5-100 times its fit's, and a large
wall weighed as a sliver."""

REGION_BIAS_DEG = 0.02
"""... and a region's normal is not known better than this, degrees (see `REGION_FIT_SCALE`:
the largest fits, 0.01-0.05 deg, were off by 1.25 of their sigma in the median)."""

JOINT_REGION_LOOSENESS = 8.0
"""In the adjustments a region's normal takes that sigma times this: the regions are weighed
against the segments as their honest noise models weigh them, and the segments' is loose
(`JOINT_EDGE_SIGMA_PX`, 4 px, eight times the 0.4-0.5 px they scatter by: their variance factor
0.010-0.016 on dev seeds and in the synthetic calibration). The deviations
(`aida_kb.interpret.uncertainty`) rescale each kind of measurement by its own variance factor,
so the regions' deviations follow their scatter. Weighed at their honest sigma against the
loose segments, the regions pulled the models off what the edges fix: dev 61108 normals 0.06
-> 0.13 deg, cameras 0.04 / 0.05 -> 0.08 / 0.16 deg; the 135-degree L-shape's view 01 0.06 ->
0.19 m (tests/interpret/test_multiview.py: at most 0.15); with this, 0.06 deg and 0.05 / 0.06
deg, the L-shape within the test's 0.15 m again."""

JOINT_ANGLE_SIGMA_DEG = 0.3
"""The first shape's angles between adjacent parts, kept to this standard deviation."""

PRIOR_ANGLE_SIGMA_DEG = 2.0
"""... or to this one, where the knowledge base's own constraints are in the adjustment (and
only for the pairs whose angle they do not state, `STATED_KINDS`)."""

STATED_KINDS = frozenset({"angle", "parallel"})
"""The kinds of constraint between two planes that state the angle at which they meet: where
the knowledge's constraints (`kb_constraints`) state it, the first shape's angle of that pair
(`PRIOR_ANGLE_SIGMA_DEG`) is left out. It is the first view's measurement, which the adjustment
holds already: kept, it counted the first view twice, and it carried the first view's tilt of
the floor into the final model (dev 65006: walls within 0.15 deg, the floor 1.23 deg off)."""

JOINT_LOSS: Loss = "soft_l1"
"""The robust loss of the joint adjustments' measurements (segments and regions) ..."""

JOINT_F_SCALE = 2.0
"""... acting beyond this many standard deviations of a factor's whitened block."""

JOINT_MATCH_PX = 3.0
"""Segments within this distance of a projected model edge are its evidence."""

TWO_EDGE_SHARE = 0.25
"""A segment matched to a model edge that also runs along another visible model edge for at
least this share of its length (within `JOINT_MATCH_PX` and the matcher's angle) shows two edges
meeting nearly in line, and is left out of the joint adjustments (`_along_two_edges`): its line
is a compromise of both. Seen at a grazing angle a house's two feet meet nearly in line at their
corner, and the line detector draws one segment across it (dev 65032 view 00: 256 px, 141 on the
left wall's foot, 113 on the front's; it tilted the floor 0.94 deg at a deviation of 0.30)."""

IMAGE_KEEP_SEGMENTS = True
"""In the image rounds, a model edge without a clean fit in a view is measured by that view's
line-detector segments, as in the rounds before (`JOINT_EDGE_SIGMA_PX`): without them the
parts such edges alone place drift (L-shape preset normals 0.35 -> 1.07 deg, house seed 1
0.15 -> 0.67) — with them 0.23 and 0.12 deg."""

STEREO_FIT_CORRELATION = 0.47
"""The correlation of an edge's fits in a view's left and right images: the same edge, the same
texture and shading beside it, seen from 0.1-0.3 m apart (the fits' errors against the true model
and cameras on the dev robustness seeds correlate by 0.47). Counted as independent, two fits of
one edge would weigh as two edges; their common error is kept by widening each one's sigma by
``sqrt(1 + rho)`` (the mean of two measurements correlated by rho has ``(1 + rho) / 2`` of one's
variance)."""

IMAGE_SCATTER_BIAS = 1.0
"""In the image rounds a fitted edge's mean offset is known no better than this share of its
points' scatter across its line (b of `aida_kb.register.pose.point_sigma`; the registration's
`aida_kb.register.pose.SCATTER_BIAS` is 0.5): the scatter is the texture and shading beside
the edge, the same all along it, so it does not average out over the edge's length. Against the
true edges (fits at the kept right models of the closing sets 61400-61935, 1,568 fits), whitened
with b = 0.5 the squared mean offsets grow with the points' scatter s (median 0.12, 0.27, 0.26,
0.42 and mean 1.4, 2.8, 4.5, 5.7 for s in 0-0.1, 0.1-0.2, 0.2-0.3, 0.3-0.6 px): the scattered
fits were weighed as too good against the clean ones, and the variance factor the clean ones
set (`aida_kb.interpret.uncertainty.variance_factors`) made them look better still. With b = 1:
median 0.06, 0.09, 0.08, 0.11, mean 0.74, 0.96, 1.30, 1.53 — one noise model for all of them.
The cameras' deviations recomputed at those models (error over deviation: median, 90th
percentile, within 2 sd, max): dev 61400-61935 (66 cameras) 0.72, 1.35, 0.985, 2.36 -> 0.65,
1.31, 0.985, 2.37; 63000-63035 (9) 1.07, 2.77, 0.778, 2.82 -> 0.94, 1.94, 0.889, 2.02."""

CORNER_SIGMA_M = 0.01
"""Where more than three of the model's faces meet at a vertex (a hip roof's eaves corner, a
pyramid's apex), the planes are held through one point to this sigma, metres (`corner_ties`):
a corner is one point, and a centimetre lies well under what the views measure (a pixel is
4 cm at 60 m) and under what the closure accepts (`closure.CONCURRENT_MAX_REL`, 0.5 % of the
model's size). Without it the views' adjustment, which frees every plane, opened such corners
by 0.07-0.31 m and the closure refused its model: on dev 71000-71035, 7 of 36 scenes (hips
and towers of 2-3 views) kept their first view's model; with it their parts over 0.5 deg went
39 -> 23, three of them to no part over 0.5 deg."""

CORNER_SHARE = 1e-3
"""Polygon corners of the model lie at one vertex when they lie within this share of the
model's size of each other (`corner_ties`): the closure's polygons share their vertices to
millimetres (`closure.CONCURRENT_MAX_REL` rounds them), its shortest edges are metres long."""

CORNER_MIN_DET = 0.01
"""The three planes that fix a corner's point (`corner_ties`) must be this independent: the
absolute determinant of their unit normals (the volume they span; 1 for three square to each
other) at least this. A vertex whose most independent triple spans less gets no tie: its
point moves by the planes' offset errors over the determinant (a hundred times at the floor),
and an exactly dependent triple would leave the `concurrent` kind's solve for the point
singular. Real corners span far more: a hip's eaves corner (two walls square, a roof at 15-60
deg) 0.5-0.97, a pyramid's apex of four faces at 15 deg from level 0.13 (2 sin² p cos p for
faces at a pitch p: 0.015 at 5 deg)."""

FOOT_SHARE = 0.02
"""A model edge lies on the model's foot (where it stands on the ground) when both its ends lie
within this share of the model's height (along its vertical, `ReconstructedModel.up`) of its
lowest vertex (`foot_grazing_deg`)."""

GRAZING_DEG = 3.0
"""A camera sees the ground at a grazing angle when the ray to a foot edge's middle meets the
horizontal plane at less than this, degrees: the ground's texture beside the foot is squeezed
into a few pixels, and the foot's fitted line is pulled into it (`FOOT_BIAS_PX`). Measured at
the TRUE models and cameras of dev 64000-64035 and 63000-63035 (wall feet fitted in each view's
images, 321 fits): below 1 deg the fits' squared whitened mean offsets average 21.7 (18 % beyond
3 sigma), at 1-2 deg 17.8 (83 %), at 4-40 deg 0.12-0.21 (none); none lay at 2-4 deg. The other
edges average 0.44-0.52. The fits lie below the true foot, 0.7-1.7 px in the scenes they are
off in (64033, 64035, 63032, 63035)."""

FOOT_BIAS_PX = 0.7
"""The mean offset of a foot edge's fit seen at a grazing angle (`GRAZING_DEG`) is known no
better than this, pixels (added in quadrature to its fit's own: `fit_point_sigma`). Chosen on the
fits of dev 64000-64035 below 3 deg (73 fits, 15 scenes): squared whitened mean offsets average
0.69, none beyond 3 sigma (0.5 px: 1.29 and 1.4 %); checked on 63000-63035 (65 fits, 9 scenes):
0.63, none beyond 3 sigma (0.5 px: 1.17 and 3.1 %). The line detector's segments on such a foot
are pulled alike and get the same (`_edge_factors`): matched at the TRUE models and cameras of
dev 65000-65035 and 66000-66035 (248 segments, 29 scenes) their squared whitened mean offsets
average 2.56 (8.9 % beyond 3 sigma) without it and 0.66 (0.8 %) with it; those of the feet seen
from higher up (419) 0.17, of the other edges (1,939) 0.30."""


@dataclass(frozen=True)
class JointInputs:
    """What a joint adjustment measures besides each view's segments and regions.

    angles : the first shape's meeting angles of adjacent parts, rad, by the pair of part
        indices (a, b), a < b; None: the model's own (`meeting_angles`).
    internal : the knowledge base's constraints among the parts (`kb_constraints`); with them
        the first shape's angles are kept only loosely (`PRIOR_ANGLE_SIGMA_DEG`), and not at
        all for the pairs whose angle they state (`stated_pairs`).
    stereo : per view, the segments of its right image and its rig (or None): their edge
        factors look through a camera that follows the view's (a derived key of the solve).
    fitted : per view, the model's edges fitted to its image (`aida_kb.register.image_edges`)
        or None: where given, they are the view's edge measurements instead of its segments.
    fitted_right : per view, its rig and the model's edges fitted to its right image, or None:
        their factors look through a camera that follows the view's, as `stereo`'s do; an edge
        fitted in both images of a view is one edge seen twice (`STEREO_FIT_CORRELATION`).
    up : the model's vertical (unit, world frame, pointing up) or None (unknown): the fits of
        its foot's edges seen at a grazing angle get `FOOT_BIAS_PX` (`fit_point_sigma`).
    """

    angles: Mapping[tuple[int, int], float] | None = None
    internal: Sequence[Constraint] = ()
    stereo: Sequence[StereoSegments | None] = ()
    fitted: Sequence[EdgeObservations | None] = ()
    fitted_right: Sequence[tuple[Rig, EdgeObservations] | None] = ()
    up: tuple[float, float, float] | None = None


def joint_adjustment(
    model: RigidModel,
    cameras: Sequence[PinholeCamera],
    views: Sequence[ViewMeasurements],
    free_cameras: Sequence[int],
    inputs: JointInputs = JointInputs(),
) -> tuple[FloatArray, FloatArray, tuple[PinholeCamera, ...], ResidualReport]:
    """Adjust the model's planes and the free cameras' poses to all views at once: the
    problem of `joint_problem` (same parameters), solved with JOINT_LOSS / JOINT_F_SCALE.

    Returns
    -------
    normals (P, 3), offsets (P,), the cameras at their adjusted poses and the residual report
    of every factor of the adjustment (with its origin).

    Raises
    ------
    SolveError
        A degenerate problem.
    """
    problem = joint_problem(model, cameras, views, free_cameras, inputs)
    result = solve(problem, loss=JOINT_LOSS, f_scale=JOINT_F_SCALE)
    return result.normals, result.offsets, result.cameras[: len(cameras)], result.report


def joint_problem(
    model: RigidModel,
    cameras: Sequence[PinholeCamera],
    views: Sequence[ViewMeasurements],
    free_cameras: Sequence[int],
    inputs: JointInputs = JointInputs(),
) -> Problem:
    """The problem of adjusting the model's planes and the free cameras' poses to all views.

    Parameters
    ----------
    model : the current model (world frame); its adjacent parts' meeting angles (or
        ``inputs.angles``) are kept as soft constraints.
    cameras : one per view (world frame); views : their measurements.
    free_cameras : indices of the cameras whose poses are unknowns (the others fix the frame).
    inputs : the further measurements (`JointInputs`).

    Each view's regions are measured in its own camera frame (``camera_position`` factors):
    they follow the view's pose while it is adjusted.

    Returns
    -------
    The problem (`aida_kb.solve.Problem`): every part free, the cameras of the views (and
    of their right images) with `free_cameras` free.

    Raises
    ------
    SolveError
        A degenerate problem.
    """
    angles, internal, stereo = inputs.angles, inputs.internal, inputs.stereo
    fitted, fitted_right = inputs.fitted, inputs.fitted_right
    opts = RegistrationOptions()
    cons: list[Constraint] = []
    all_cameras = list(cameras)
    derived: list[tuple[int, int, Rig]] = []
    for ci, (cam, m) in enumerate(zip(cameras, views, strict=True)):
        own = fitted[ci] if ci < len(fitted) else None
        second = fitted_right[ci] if ci < len(fitted_right) else None
        # an edge fitted in both images of the view: its two fits' errors are correlated
        twice = (
            set()
            if own is None or second is None
            else edge_keys(own.faces) & edge_keys(second[1].faces)
        )
        if own is None:
            cons += _edge_factors(model, cam, ci, m.p1, m.p2, m.view, up=inputs.up)
        else:
            cons += _fitted_edge_factors(model, cam, ci, own, m.view, twice, inputs.up)
            if IMAGE_KEEP_SEGMENTS:  # the segments of the edges no clean fit measures
                done = edge_keys(own.faces)
                cons += _edge_factors(model, cam, ci, m.p1, m.p2, m.view, done, inputs.up)
        if second is not None:  # the right image's fitted edges: a camera following this one
            right = len(all_cameras)
            all_cameras.append(second[0].right_of(cam))
            derived.append((right, ci, second[0]))
            cons += _fitted_edge_factors(
                model, all_cameras[right], right, second[1], f"{m.view} (right)", twice, inputs.up
            )
        pair = stereo[ci] if ci < len(stereo) else None
        if pair is not None:  # the right image: a camera that follows this view's
            right = len(all_cameras)
            all_cameras.append(pair.rig.right_of(cam))
            derived.append((right, ci, pair.rig))
            cons += _edge_factors(
                model,
                all_cameras[right],
                right,
                pair.p1,
                pair.p2,
                f"{m.view} (right)",
                None,
                inputs.up,
            )
        obs = (
            match_regions(model, cam, m.regions, opts, _joint_region_sigma_rad(m.regions))
            if m.regions.size
            else None
        )
        if obs is None:
            continue
        for k in range(obs.size):
            part = int(obs.part[k])
            inv_m, inv_rad = 1.0 / float(obs.sigma_m[k]), 1.0 / float(obs.sigma_rad[k])
            n, c = obs.normal_cam[k], obs.centre_cam[k]
            cons.append(
                Constraint(
                    kind="camera_position",
                    parts=(part,),
                    measurement=True,
                    label=f"position({model.names[part]})@{m.view}",
                    camera_position=CameraPositionData(
                        ci,
                        (float(n[0]), float(n[1]), float(n[2])),
                        (float(c[0]), float(c[1]), float(c[2])),
                    ),
                    sqrt_information=((inv_m, 0.0, 0.0), (0.0, inv_rad, 0.0), (0.0, 0.0, inv_rad)),
                    origin=Origin(f"position({model.names[part]})@{m.view}", "evidence"),
                )
            )
    if angles is None:
        angles = meeting_angles(model)
    cons.extend(internal)
    cons += corner_ties(model)  # more than three faces at a vertex: one point
    sigma_deg = PRIOR_ANGLE_SIGMA_DEG if internal else JOINT_ANGLE_SIGMA_DEG
    stated = stated_pairs(internal)
    for (a, b), phi in angles.items():
        if (min(a, b), max(a, b)) in stated:
            continue  # the knowledge says this angle: the first view's would count it twice
        cons.append(
            Constraint(
                kind="angle",
                parts=(int(a), int(b)),
                value=float(phi),
                sigma=math.radians(sigma_deg),
                unit="rad",
                label=f"first-shape angle({model.names[a]}, {model.names[b]})",
                origin=Origin(f"first-shape angle({model.names[a]}, {model.names[b]})", "prior"),
            )
        )
    return build_problem(
        model.normals,
        model.offsets,
        cons,
        centres=part_centres(model),
        names=model.names,
        cameras=all_cameras,
        free_cameras=free_cameras,
        derived=derived,
    )


def corner_ties(model: RigidModel) -> list[Constraint]:
    """Priors holding the planes of every vertex where more than three of the model's faces
    meet through one point (`concurrent` constraints, sigma `CORNER_SIGMA_M`).

    A vertex is a point that polygons of four or more faces share (within `CORNER_SHARE` of
    the model's size). Of its faces, the three whose normals are the most independent (the
    largest ``|det|``, at least `CORNER_MIN_DET`) fix the point; each other face gets one
    constraint through it.

    model : the model (world frame), its polygons closed (`closure`).
    """
    if not model.polygons:
        return []
    points = np.vstack([np.asarray(p, dtype=np.float64) for p in model.polygons])
    faces = np.concatenate([np.full(len(p), i) for i, p in enumerate(model.polygons)])
    tol = CORNER_SHARE * float(np.ptp(points, axis=0).max())
    near = np.linalg.norm(points[:, None, :] - points[None, :, :], axis=2) <= tol
    first = np.argmax(near, axis=1)  # each corner's vertex: the first corner near it
    out: list[Constraint] = []
    for v in np.unique(first):
        meeting = sorted({int(f) for f in faces[first == v]})
        if len(meeting) < 4:
            continue
        n = model.normals[meeting]
        triples = [
            (abs(float(np.linalg.det(n[[i, j, k]]))), (i, j, k))
            for i in range(len(meeting))
            for j in range(i + 1, len(meeting))
            for k in range(j + 1, len(meeting))
        ]
        det, best = max(triples)
        if det < CORNER_MIN_DET:  # no three of its planes fix a point
            continue
        base = tuple(meeting[i] for i in best)
        for i, f in enumerate(meeting):
            if i in best:
                continue
            label = "corner(" + ", ".join(model.names[p] for p in (*base, f)) + ")"
            out.append(
                Constraint(
                    kind="concurrent",
                    parts=(*base, f),
                    sigma=CORNER_SIGMA_M,
                    unit="m",
                    label=label,
                    origin=Origin(label, "prior"),
                )
            )
    return out


def stated_pairs(constraints: Sequence[Constraint]) -> frozenset[tuple[int, int]]:
    """The pairs of parts (a, b), a < b, whose angle one of `constraints` states: an
    ``angle`` or ``parallel`` constraint between those two planes."""
    return frozenset(
        (min(c.parts), max(c.parts))
        for c in constraints
        if c.kind in STATED_KINDS and len(c.parts) == 2 and c.parts[0] != c.parts[1]
    )


def part_centres(model: RigidModel) -> FloatArray | None:
    """(P, 3) each part's polygon's centroid, metres, world frame: the point its plane turns
    about in an adjustment (`aida_kb.geometry.frames.PartFrames`); None when the model has no
    polygons (the planes then turn about their feet from the world's origin).

    About the foot from the origin — the first camera, tens of metres away — a plane nothing
    measures but the knowledge's angles swings with them: a floor turned 1.5 degrees by its
    walls rose 1.2 m at the house (dev seed 61309, and the ground rule then rejected the
    house). About its own centre it stays where the knowledge put it."""
    if not model.polygons or len(model.polygons) != len(model.names):
        return None
    return np.array([np.asarray(p, dtype=np.float64).mean(axis=0) for p in model.polygons])


def region_normal_sigma_rad(regions: RegionMeasurements) -> FloatArray | None:
    """(R,) each region's normal's honest 1-σ, radians: its plane fit's own tilt
    (`REGION_FIT_SCALE`, `REGION_BIAS_DEG`); the registration's uniform sigma
    (`aida_kb.register.RegistrationOptions.region_sigma_deg`) where a fit's inliers or area are
    unknown (evidence without them); None when no region's are known. The adjustments weigh
    them `JOINT_REGION_LOOSENESS` times looser."""
    if regions.inliers is None or regions.area_m2 is None:
        return None
    inliers, area = regions.inliers, regions.area_m2
    known = (inliers > 0.0) & (area > 0.0)
    if not np.any(known):
        return None
    samples = np.maximum(inliers / FIT_CORRELATED_PX, 1.0)
    fit = fit_sigma_rad(regions.rms_m, samples, np.where(known, area, 1.0))
    own = REGION_FIT_SCALE * np.hypot(fit, math.radians(REGION_BIAS_DEG))
    uniform = math.radians(RegistrationOptions().region_sigma_deg) / JOINT_REGION_LOOSENESS
    out: FloatArray = np.where(known, own, uniform)
    return out


def _joint_region_sigma_rad(regions: RegionMeasurements) -> FloatArray | None:
    """(R,) the sigmas the joint adjustments give the regions' normals, radians
    (`region_normal_sigma_rad` times `JOINT_REGION_LOOSENESS`; None: the registration's)."""
    honest = region_normal_sigma_rad(regions)
    return None if honest is None else JOINT_REGION_LOOSENESS * honest


def _edge_factors(
    model: RigidModel,
    camera: PinholeCamera,
    index: int,
    p1: FloatArray,
    p2: FloatArray,
    view: str,
    skip: set[tuple[int, int]] | None = None,
    up: tuple[float, float, float] | None = None,
) -> list[Constraint]:
    """Edge factors of the segments (S, 2) px that match the model's edges seen by ``camera``
    (camera ``index`` of the problem): each whitened as a line fitted to one edge point per
    pixel with `JOINT_EDGE_SIGMA_PX` (`segment_sqrt_information`), a segment on the model's
    foot seen at a grazing angle (`up` the model's vertical, world frame) with `FOOT_BIAS_PX`
    as a fit there (`_foot_widened`: the line detector is pulled into the squeezed ground as
    the fit is). Segments on the edges `skip` names (their two parts' indices, ascending) are
    left out."""
    vis = model.visible_edges(camera)
    mt = match_segments(
        vis.a,
        vis.b,
        p1,
        p2,
        max_distance_px=JOINT_MATCH_PX,
        max_angle_rad=math.radians(RegistrationOptions().max_angle_deg),
    )
    single = ~_along_two_edges(vis.a, vis.b, vis.index, p1, p2, mt)
    mt = Matches(mt.edge[single], mt.segment[single], mt.distance_px[single])
    faces = model.edge_faces[vis.index[mt.edge]]
    q1, q2 = p1[mt.segment], p2[mt.segment]
    grazing = _foot_grazing_of(model, camera, faces, up)
    sigma = _foot_widened(np.full(len(faces), JOINT_EDGE_SIGMA_PX), q1, q2, grazing)
    lean, lean_scale = _foot_lean(model, camera, faces, q1, q2, sigma, up, grazing)
    out = []
    for (a, b), p, q, s, ln, ls in zip(faces, q1, q2, sigma, lean, lean_scale, strict=True):
        if skip and (int(min(a, b)), int(max(a, b))) in skip:
            continue
        e1, e2 = (float(p[0]), float(p[1])), (float(q[0]), float(q[1]))
        label = f"edge({model.names[a]}, {model.names[b]})@{view}"
        out.append(
            Constraint(
                kind="edge",
                parts=(int(a), int(b)),
                unit="px",
                measurement=True,
                label=label,
                edge=EdgeData(index, e1, e2, int(ln), float(ls)),
                sqrt_information=segment_sqrt_information(e1, e2, float(s)),
                origin=Origin(label, "evidence"),
            )
        )
    return out


def _along_two_edges(
    a: FloatArray,
    b: FloatArray,
    index: npt.NDArray[np.integer],
    p1: FloatArray,
    p2: FloatArray,
    matched: Matches,
) -> BoolArray:
    """(M,) for each match of `matched` (segments `p1`, `p2` (S, 2) px to the projected edges
    `a`, `b` (E, 2) px of the model edges `index` (E,)), whether its segment also runs along
    another model edge for `TWO_EDGE_SHARE` of its length (`match_segments`' distance and
    angle): it shows two edges that meet nearly in line and measures neither."""
    if matched.segment.size == 0:
        return np.zeros(0, dtype=bool)
    others = index[:, None] != index[matched.edge][None, :]  # (E, M)
    second = match_segments(
        a,
        b,
        p1[matched.segment],
        p2[matched.segment],
        max_distance_px=JOINT_MATCH_PX,
        max_angle_rad=math.radians(RegistrationOptions().max_angle_deg),
        min_overlap=TWO_EDGE_SHARE,
        allowed=others,
    )
    out = np.zeros(matched.segment.size, dtype=bool)
    out[second.segment] = True
    return out


def edge_keys(faces: npt.NDArray[np.integer]) -> set[tuple[int, int]]:
    """The edges (E, 2) part indices as pairs (low, high)."""
    return {(int(min(a, b)), int(max(a, b))) for a, b in faces}


def edge_rows(
    model_faces: npt.NDArray[np.integer], faces: npt.NDArray[np.integer]
) -> npt.NDArray[np.intp]:
    """(F,) the row of `model_faces` (E, 2) holding each edge of `faces` (F, 2), both as part
    index pairs in either order; -1 for an edge the model does not have."""
    index = np.full(len(faces), -1, dtype=np.intp)
    if len(faces) == 0 or len(model_faces) == 0:
        return index
    model_pairs = np.sort(np.asarray(model_faces, dtype=np.int64).reshape(-1, 2), axis=1)
    pairs = np.sort(np.asarray(faces, dtype=np.int64).reshape(-1, 2), axis=1)
    base = int(max(model_pairs.max(), pairs.max())) + 1
    model_keys = model_pairs[:, 0] * base + model_pairs[:, 1]
    keys = pairs[:, 0] * base + pairs[:, 1]
    order = np.argsort(model_keys, kind="stable")
    at = np.minimum(np.searchsorted(model_keys[order], keys), len(order) - 1)
    found = model_keys[order[at]] == keys
    index[found] = order[at[found]]
    return index


def foot_grazing_deg(
    model: RigidModel,
    camera: PinholeCamera,
    edges: EdgeObservations,
    up: tuple[float, float, float] | None,
) -> FloatArray:
    """(F,) for each fitted edge on the model's foot (`FOOT_SHARE`), the angle at which the
    ray from `camera`'s centre to the edge's middle meets the horizontal plane (normal `up`,
    world frame), degrees; NaN for the other edges, or all of them when `up` is None."""
    return _foot_grazing_of(model, camera, edges.faces, up)


def _foot_grazing_of(
    model: RigidModel,
    camera: PinholeCamera,
    faces: npt.NDArray[np.integer],
    up: tuple[float, float, float] | None,
) -> FloatArray:
    """(K,) `foot_grazing_deg` of the model edges between the parts `faces` (K, 2) names."""
    out = np.full(len(faces), np.nan)
    if up is None or len(faces) == 0 or model.edge_ends.size == 0:
        return out
    u = np.asarray(up, dtype=np.float64)
    u = u / np.linalg.norm(u)
    height = model.edge_ends @ u  # (E, 2), metres along the vertical
    low, span = float(height.min()), float(np.ptp(height))
    foot = np.all(height - low <= FOOT_SHARE * span, axis=1)  # (E,)
    index = edge_rows(model.edge_faces, faces)
    on_foot = (index >= 0) & foot[np.maximum(index, 0)]
    if not on_foot.any():
        return out
    middle = model.edge_ends[index[on_foot]].mean(axis=1)  # (K, 3), world
    ray = camera.centre[None, :] - middle
    sine = np.abs(ray @ u) / np.maximum(np.linalg.norm(ray, axis=1), 1e-12)
    out[on_foot] = np.degrees(np.arcsin(np.clip(sine, 0.0, 1.0)))
    return out


def fit_point_sigma(
    model: RigidModel,
    camera: PinholeCamera,
    edges: EdgeObservations,
    up: tuple[float, float, float] | None,
) -> FloatArray:
    """(F,) the edge-point sigma of each fitted edge seen by `camera`, pixels: its own fit's
    (`point_sigma` with `IMAGE_SCATTER_BIAS`), and for a foot edge seen at a grazing angle
    (`foot_grazing_deg` below `GRAZING_DEG`) with `FOOT_BIAS_PX` added to its mean offset's
    standard deviation in quadrature (a segment of n pixels: ``sqrt(s² + n·bias²)``)."""
    sigma = point_sigma(edges, JOINT_EDGE_SIGMA_PX, IMAGE_SCATTER_BIAS)
    grazing = foot_grazing_deg(model, camera, edges, up)
    return _foot_widened(sigma, edges.p1, edges.p2, grazing)


def _foot_widened(
    sigma: FloatArray, p1: FloatArray, p2: FloatArray, grazing: FloatArray
) -> FloatArray:
    """(K,) the edge-point sigmas `sigma` (px) of the lines from `p1` to `p2` (K, 2) px, those
    whose foot edge is seen at a grazing angle (`grazing`, degrees, below `GRAZING_DEG`; NaN:
    no foot edge) with `FOOT_BIAS_PX` added to their mean offset's deviation in quadrature (a
    line of n pixels: ``sqrt(s² + n·bias²)``)."""
    squeezed = np.nan_to_num(grazing, nan=90.0) < GRAZING_DEG
    if not squeezed.any():
        return sigma
    n = np.maximum(np.linalg.norm(p2 - p1, axis=1), 1.0)
    return np.where(squeezed, np.sqrt(sigma * sigma + n * FOOT_BIAS_PX**2), sigma)


def _foot_lean(
    model: RigidModel,
    camera: PinholeCamera,
    faces: npt.NDArray[np.integer],
    p1: FloatArray,
    p2: FloatArray,
    sigma: FloatArray,
    up: tuple[float, float, float] | None,
    grazing: FloatArray | None = None,
) -> tuple[npt.NDArray[np.int64], FloatArray]:
    """(K,), (K,): the `EdgeData.lean` and ``lean_scale`` of the edge measurements from `p1`
    to `p2` (K, 2) px of the model edges `faces` (K, 2) seen by `camera`, with edge-point
    sigmas `sigma` (K,) px: on a foot edge (`FOOT_SHARE`; `up` the model's vertical, world
    frame) the side of the wall leans (`aida_kb.interpret.feet.foot_leans`, through the edge's
    middle) and the scale is `aida_kb.interpret.feet.lean_scale` of the line's mean offset's
    sigma ``sigma / sqrt(n)``, n its length in pixels; 0 and 1 elsewhere and where `up` is
    None. `grazing` (K,): `_foot_grazing_of` of the edges where the caller has it already."""
    K = len(faces)
    lean = np.zeros(K, dtype=np.int64)
    scale = np.ones(K)
    if grazing is None:
        grazing = _foot_grazing_of(model, camera, faces, up)
    on_foot = ~np.isnan(grazing)
    if up is None or not on_foot.any():
        return lean, scale
    u = np.asarray(up, dtype=np.float64)
    middle = model.edge_ends[edge_rows(model.edge_faces, faces)[on_foot]].mean(axis=1)
    lean[on_foot] = foot_leans(camera, p1[on_foot], p2[on_foot], middle, u / np.linalg.norm(u))
    n = np.maximum(np.linalg.norm(p2[on_foot] - p1[on_foot], axis=1), MIN_FIT_POINTS)
    scale[on_foot] = np.where(lean[on_foot] != 0, lean_scale(sigma[on_foot] / np.sqrt(n)), 1.0)
    return lean, scale


def _fitted_edge_factors(
    model: RigidModel,
    camera: PinholeCamera,
    index: int,
    edges: EdgeObservations,
    view: str,
    twice: set[tuple[int, int]] | frozenset[tuple[int, int]] = frozenset(),
    up: tuple[float, float, float] | None = None,
) -> list[Constraint]:
    """Edge factors of model edges fitted to the image of `camera` (index ``index`` of the
    problem; they know their edge: no matching), each whitened with its own fit's point sigma
    (`fit_point_sigma`: `IMAGE_SCATTER_BIAS`, and `FOOT_BIAS_PX` for a foot edge seen at a
    grazing angle, `up` the model's vertical); their labels start with `IMAGE_EDGE_LABEL` (their
    own variance factor in the covariance). The edges `twice` names (part indices, ascending)
    are fitted in both images of the view: their sigma is widened by
    ``sqrt(1 + STEREO_FIT_CORRELATION)`` (`STEREO_FIT_CORRELATION`)."""
    sigma = fit_point_sigma(model, camera, edges, up)
    widen = math.sqrt(1.0 + STEREO_FIT_CORRELATION)
    keys = np.sort(np.asarray(edges.faces, dtype=np.int64).reshape(-1, 2), axis=1)
    both = np.array([(int(a), int(b)) in twice for a, b in keys], dtype=bool)
    sigma = np.where(both, sigma * widen, sigma)
    lean, lean_scale = _foot_lean(model, camera, edges.faces, edges.p1, edges.p2, sigma, up)
    out = []
    for k in range(edges.size):
        a, b = int(edges.faces[k, 0]), int(edges.faces[k, 1])
        e1 = (float(edges.p1[k, 0]), float(edges.p1[k, 1]))
        e2 = (float(edges.p2[k, 0]), float(edges.p2[k, 1]))
        label = f"{IMAGE_EDGE_LABEL}({model.names[a]}, {model.names[b]})@{view}"
        out.append(
            Constraint(
                kind="edge",
                parts=(a, b),
                unit="px",
                measurement=True,
                label=label,
                edge=EdgeData(index, e1, e2, int(lean[k]), float(lean_scale[k])),
                sqrt_information=segment_sqrt_information(e1, e2, float(sigma[k])),
                origin=Origin(label, "evidence"),
            )
        )
    return out


def kb_constraints(
    kb: KnowledgeBase, interp: Interpretation, names: Sequence[str]
) -> list[Constraint]:
    """The knowledge base's internal constraints (no measurements) among the model's parts.

    For each object the interpretation found (an instance right under the goal, e.g. ``body``:
    ``HouseBody``), `aida_kb.solve.constraints_from_kb` with the parts under it and the
    concepts the interpretation chose for its roles (e.g. ``roof``: ``GableRoof``), and the
    knowledge's attributes of its parts as the single-view adjustment has them
    (`_attribute_constraints`: each part's slope to the object's ground, the level parts the
    first view inserted). Part indices are positions in `names`. Objects whose constraints
    cannot be built are skipped. Where a scene's objects touch, their shared faces are tied to
    one plane (`party.touching_ties`); a face that closes a smaller part in its whole (an
    oriel's back, a wing's floor) to the whole's plane it lies in (`closure.closing_ties`).
    """
    out: list[Constraint] = []
    knowledge = Knowledge.from_kb(kb)
    index = {path: i for i, n in enumerate(names) if (path := _role_path(n)) is not None}
    roles = [(path, inst.concept) for inst in interp.instances if (path := _role_path(inst.role))]
    # the objects of a scene of several (interpret.scene) are one level down: houses[0].body
    objects = {RolePath.parse(o.role) for o in interp.objects}
    for top, concept in roles:
        if len(top) != 1 and not (len(top) == 2 and top.parent in objects):
            continue
        assignment = {
            p.relative_to(top): i for p, i in index.items() if p.is_under(top) and p != top
        }
        fillers = {p.relative_to(top): c for p, c in roles if p.is_under(top) and p != top}
        if not assignment:
            continue
        try:
            found = constraints_from_kb(kb, concept, assignment, fillers=fillers)
        except SolveError:
            continue
        for c in found.constraints:
            if c.measurement:
                continue
            o = c.source
            out.append(replace(c, origin=replace(o, owner=top.join(o.owner))))
        out += _attribute_constraints(knowledge, interp, top, index)
    if interp.model is not None:  # touching objects' shared walls: one plane each
        out += touching_ties(interp.model, [o.role for o in interp.objects], names)
    out += closing_ties(knowledge, interp, names)  # open faces in their wholes' planes
    return out


def _attribute_constraints(
    knowledge: Knowledge, interp: Interpretation, top: RolePath, index: Mapping[RolePath, int]
) -> list[Constraint]:
    """The attributes of the object at `top` as the single-view adjustment takes them
    (`aida_kb.interpret.adjust.adjust`): each planar part's slope attribute as a soft angle to
    the object's ground (`verify.tilt_constraints`: a wall at 90 deg to the floor, the sigma the
    knowledge states), and the parts no region of the first view showed (``inserted``) that
    the knowledge orients level held level (`verify.orientation_priors`). The ground is the
    outermost part under `top` that the knowledge orients ``downward`` (as
    `unseen.ground_of`). Without them the floor, which the views measure only by its foot
    edges at grazing angles, kept the first view's tilt (dev 65006: walls within 0.15 deg, the
    floor 1.23 deg off). `index`: role path -> part index.
    """
    fillers = {inst.role: inst.concept for inst in interp.instances}
    under = {str(p): i for p, i in index.items() if p.is_under(top)}
    faces = {
        role: (o.direction, o.span)
        for role in under
        if (o := _orientation(knowledge, fillers, RolePath.parse(role))) is not None
    }
    grounds = [r for r, (direction, _) in faces.items() if direction == DOWNWARD]
    if not grounds:
        return []
    ground = min(grounds, key=lambda r: (r.count("."), r))
    planar = [(role, fillers[role]) for role in under if fillers.get(role) in knowledge.concepts]
    out = tilt_constraints(knowledge, planar, ground, under)
    level = {UPWARD: True, DOWNWARD: False}
    inserted = {inst.role for inst in interp.instances if INSERTED in inst.bindings}
    out += orientation_priors(
        [
            (role, concept, level[faces[role][0]], faces[role][1])
            for role, concept in planar
            if role in inserted and role in faces and faces[role][0] in level
        ],
        ground,
        under,
    )
    return out


def _orientation(
    knowledge: Knowledge, fillers: Mapping[str, str], path: RolePath
) -> OrientationModel | None:
    """The orientation the knowledge declares for the planar part at `path` (``orient``): the
    outermost composite's declaration that holds for the interpretation's `fillers` (role path
    -> concept; a whole's declaration overrides its parts' own, `Knowledge.structures`)."""
    found: OrientationModel | None = None
    for depth in range(len(path) - 1, -1, -1):
        owner = RolePath(path.steps[:depth])
        concept = fillers.get(str(owner))
        if concept is None or concept not in knowledge.concepts:
            continue
        o = knowledge.concept(concept).orientations.get(str(path.relative_to(owner).plain))
        if o is not None and knowledge.holds(str(owner), o.requires, fillers):
            found = o
    return found


def _role_path(text: str) -> RolePath | None:
    """The role path a part or instance name spells, None for a name that is none."""
    try:
        return RolePath.parse(text)
    except ValueError:
        return None


def meeting_angles(model: RigidModel) -> dict[tuple[int, int], float]:
    """The angle (rad) at which each pair of adjacent parts (a, b), a < b, meets."""
    a = np.minimum(model.edge_faces[:, 0], model.edge_faces[:, 1])
    b = np.maximum(model.edge_faces[:, 0], model.edge_faces[:, 1])
    phi = meeting_angle(model.normals[a], model.normals[b])[0]
    return {(int(i), int(j)): float(p) for i, j, p in zip(a, b, phi, strict=True)}
