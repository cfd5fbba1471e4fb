"""Pose-only adjustment: a camera's six pose parameters against a fixed model, by `aida_kb.solve`.

The matched evidence becomes factors (`aida_kb.constraints`) of one problem whose planes are all
fixed and whose only unknowns are the camera's pose ``[rvec, C]`` (paper §5, registration
mode):

* an ``edge`` factor (eq. 5, pixels) per matched image segment against its model edge, its two
  end-point residuals whitened as those of a line fitted to one edge point per pixel
  (`aida_kb.constraints.kinds.edge.segment_sqrt_information`);
* with a stereo rig, the same for the second image's segments, through a *derived* camera
  that follows the first (`aida_kb.geometry.rig.Rig`, its pose Jacobian chained);
* where the view has depth, a ``camera_position`` factor per matched region: the region's
  centre and normal measured in the view's own camera frame against its part's plane (metres
  and radians, whitened by the region's standard deviations).

Every factor has a soft L1 loss on its whitened block. There is no least-squares loop here:
`aida_kb.solve.solve` is the one solver.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aida_kb.constraints import CameraPositionData, Constraint, EdgeData, Origin
from aida_kb.constraints.kinds.edge import segment_sqrt_information
from aida_kb.errors import SolveError
from aida_kb.geometry.camera import PinholeCamera
from aida_kb.geometry.rig import Rig
from aida_kb.register.model import RigidModel
from aida_kb.solve import Evaluation, Problem, SolveResult, build_problem, solve

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

__all__ = [
    "EdgeObservations",
    "PoseFit",
    "RegionObservations",
    "fit_pose",
    "point_sigma",
    "pose_covariance",
    "pose_factors",
]

POSE_TOLERANCE = 1e-12
"""ftol, xtol and gtol of the pose solve: a pose is six numbers; converging to rounding costs
a few evaluations and keeps the registration benchmark's hundredths of a degree honest."""

_LEFT, _RIGHT = 0, 1  # camera indices in a pose problem


@dataclass(frozen=True)
class EdgeObservations:
    """Image segments matched to model edges: faces (M, 2) part indices; p1, p2 (M, 2) px.

    sigma_px : (M,) each segment's edge-point standard deviation across its line, pixels (from
    its edge fit, `aida_kb.vision.lines.fit_segments`), or None: the same for all.
    """

    faces: IntArray
    p1: FloatArray
    p2: FloatArray
    sigma_px: FloatArray | None = None

    @property
    def size(self) -> int:
        """Number of matched segments M."""
        return int(self.faces.shape[0])


@dataclass(frozen=True)
class RegionObservations:
    """Regions with depth matched to parts, measured in the view's own camera frame.

    part : (R,) part index; normal_cam : (R, 3) unit plane normal; centre_cam : (R, 3) metres;
    sigma_m : (R,) standard deviation of the centre's distance from the plane, metres;
    sigma_rad : (R,) of the normal's angle, radians.
    """

    part: IntArray
    normal_cam: FloatArray
    centre_cam: FloatArray
    sigma_m: FloatArray
    sigma_rad: FloatArray

    @property
    def size(self) -> int:
        """Number of matched regions R."""
        return int(self.part.shape[0])


@dataclass(frozen=True)
class PoseFit:
    """The fitted camera, the RMS edge residual of its own image (pixels) and the solve's
    outcome (its eq. 6 cost without the loss, convergence, residual evaluations)."""

    camera: PinholeCamera
    rms_px: float
    cost: float
    success: bool
    n_evaluations: int


SEGMENT_FLOOR_PX = 0.05
"""With per-segment sigmas (edge fits), a segment's offset is not known better than this,
pixels, however long it is: the edge locator's bias on rendered edges is a few hundredths of
a pixel towards the darker side (`aida_kb.vision.lines.CENTROID_HALF_PX`), the same along
the whole segment, which more edge points do not average away."""
MIN_POINT_SIGMA_PX = 0.05
"""... and its edge points' sigma is taken as at least this (a fit of a few clean points can
scatter by less than the locator's own error)."""


def point_sigma(
    edges: EdgeObservations, default_px: float, scatter_bias: float | None = None
) -> FloatArray:
    """(M,) the edge-point sigma of each matched segment's factor, pixels.

    Without per-segment sigmas every segment gets ``default_px``. With them, a segment of n
    pixels gets ``sqrt(s² + n (f² + (b s)²))`` (s its own sigma, at least `MIN_POINT_SIGMA_PX`;
    f `SEGMENT_FLOOR_PX`; b `scatter_bias`, by default `SCATTER_BIAS`): its mean offset's
    standard deviation is then ``sqrt(s²/n + f² + (b s)²)``.
    """
    b = SCATTER_BIAS if scatter_bias is None else scatter_bias
    if edges.sigma_px is None:
        return np.full(edges.size, float(default_px))
    n = np.maximum(np.linalg.norm(edges.p2 - edges.p1, axis=1), 1.0)
    s = np.maximum(edges.sigma_px, MIN_POINT_SIGMA_PX)
    out: FloatArray = np.sqrt(s * s + n * (SEGMENT_FLOOR_PX**2 + (b * s) ** 2))
    return out


SCATTER_BIAS = 0.5
"""... nor better than this share of its edge points' scatter: points scattered by texture or
shading across an edge are not scattered about the edge (on the turntable renders the far
top edges' points scatter by 0.8 px and their line lies 1 px off the true edge)."""


def _edge_factors(
    edges: EdgeObservations, camera: int, sigma_px: float, f_scale: float, what: str
) -> list[Constraint]:
    out = []
    sigma = point_sigma(edges, sigma_px)
    for k in range(edges.size):
        p1 = (float(edges.p1[k, 0]), float(edges.p1[k, 1]))
        p2 = (float(edges.p2[k, 0]), float(edges.p2[k, 1]))
        out.append(
            Constraint(
                kind="edge",
                parts=(int(edges.faces[k, 0]), int(edges.faces[k, 1])),
                unit="px",
                measurement=True,
                edge=EdgeData(camera, p1, p2),
                sqrt_information=segment_sqrt_information(p1, p2, float(sigma[k])),
                loss="soft_l1",
                loss_scale=f_scale,
                origin=Origin(f"{what} segment {k}", "evidence"),
            )
        )
    return out


def pose_factors(
    edges: EdgeObservations,
    regions: RegionObservations | None,
    right_edges: EdgeObservations | None,
    *,
    sigma_px: float,
    f_scale: float,
) -> list[Constraint]:
    """The factors of a pose-only problem (camera 0: the view's, camera 1: its rig's second).

    ``sigma_px`` is an edge point's standard deviation across its edge (pixels); ``f_scale``
    the soft L1 threshold in sigmas.
    """
    factors = _edge_factors(edges, _LEFT, sigma_px, f_scale, "image")
    if right_edges is not None:
        factors += _edge_factors(right_edges, _RIGHT, sigma_px, f_scale, "second image")
    if regions is not None:
        for k in range(regions.size):
            inv_m, inv_rad = 1.0 / float(regions.sigma_m[k]), 1.0 / float(regions.sigma_rad[k])
            factors.append(
                Constraint(
                    kind="camera_position",
                    parts=(int(regions.part[k]),),
                    measurement=True,
                    camera_position=CameraPositionData(
                        _LEFT,
                        (
                            float(regions.normal_cam[k, 0]),
                            float(regions.normal_cam[k, 1]),
                            float(regions.normal_cam[k, 2]),
                        ),
                        (
                            float(regions.centre_cam[k, 0]),
                            float(regions.centre_cam[k, 1]),
                            float(regions.centre_cam[k, 2]),
                        ),
                    ),
                    sqrt_information=((inv_m, 0.0, 0.0), (0.0, inv_rad, 0.0), (0.0, 0.0, inv_rad)),
                    loss="soft_l1",
                    loss_scale=f_scale,
                    origin=Origin(f"region {k}", "evidence"),
                )
            )
    return factors


def _subset(edges: EdgeObservations, keep: npt.NDArray[np.bool_]) -> EdgeObservations:
    sigma = None if edges.sigma_px is None else edges.sigma_px[keep]
    return EdgeObservations(edges.faces[keep], edges.p1[keep], edges.p2[keep], sigma)


def _pose_problem(
    model: RigidModel,
    camera: PinholeCamera,
    edges: EdgeObservations,
    regions: RegionObservations | None,
    rig: Rig | None,
    right: EdgeObservations | None,
    sigma_px: float,
    f_scale: float,
) -> tuple[Problem, list[Constraint]]:
    cameras = [camera]
    derived: list[tuple[int, int, Rig]] = []
    if right is not None and rig is not None:
        cameras.append(rig.right_of(camera))
        derived.append((_RIGHT, _LEFT, rig))
    factors = pose_factors(edges, regions, right, sigma_px=sigma_px, f_scale=f_scale)
    P = model.normals.shape[0]
    problem = build_problem(
        model.normals,
        model.offsets,
        factors,
        fixed_parts=range(P),
        cameras=cameras,
        free_cameras=[_LEFT],
        derived=derived,
    )
    return problem, factors


def pose_covariance(
    model: RigidModel,
    camera: PinholeCamera,
    edges: EdgeObservations,
    regions: RegionObservations | None = None,
    *,
    rig: Rig | None = None,
    right_edges: EdgeObservations | None = None,
    sigma_px: float = 1.0,
    f_scale: float = 2.0,
) -> FloatArray:
    """(6, 6) covariance of a fitted pose ``[rvec (rad), C (m)]`` from its matched evidence.

    The inverse of ``JᵀJ`` of the whitened, robustly weighted residuals (the same factors as
    `fit_pose`) at `camera`, scaled by their variance factor ``|r|²/(m - 6)`` when that is
    above 1 (the noise model is a lower bound: residuals larger than it widen the covariance).
    Infinite where the evidence leaves the pose undetermined (a singular ``JᵀJ``).
    """
    right = (
        right_edges if rig is not None and right_edges is not None and right_edges.size else None
    )
    problem, _ = _pose_problem(model, camera, edges, regions, rig, right, sigma_px, f_scale)
    ev = Evaluation(problem, np.zeros(0, dtype=np.intp), free_cameras=np.array([_LEFT]))
    r, J = ev.residuals_and_dense_jacobian(camera.pose)
    m = r.size
    JtJ = J.T @ J
    if m <= 6 or np.linalg.cond(JtJ) > MAX_POSE_CONDITION:
        return np.full((6, 6), np.inf)
    factor = max(1.0, float(r @ r) / (m - 6))
    cov: FloatArray = np.asarray(np.linalg.inv(JtJ), dtype=np.float64) * factor
    return cov


MAX_POSE_CONDITION = 1e14
"""A pose normal matrix ``JᵀJ`` worse conditioned than this leaves the pose undetermined."""


def _solve_pose(
    model: RigidModel,
    camera: PinholeCamera,
    edges: EdgeObservations,
    regions: RegionObservations | None,
    rig: Rig | None,
    right: EdgeObservations | None,
    sigma_px: float,
    f_scale: float,
    max_evaluations: int,
) -> tuple[SolveResult, list[Constraint]]:
    """One solve of the pose problem; its result and factors (left edges, right, regions)."""
    problem, factors = _pose_problem(model, camera, edges, regions, rig, right, sigma_px, f_scale)
    return solve(problem, max_iterations=max_evaluations, tolerance=POSE_TOLERANCE), factors


def fit_pose(
    model: RigidModel,
    camera: PinholeCamera,
    edges: EdgeObservations,
    regions: RegionObservations | None = None,
    *,
    rig: Rig | None = None,
    right_edges: EdgeObservations | None = None,
    sigma_px: float = 1.0,
    f_scale: float = 2.0,
    max_evaluations: int = 50,
    reject_sigmas: float | None = None,
) -> PoseFit:
    """The camera pose minimising the robust (soft L1) sum of edge and position residuals.

    Parameters
    ----------
    model : the fixed model; camera : the start (its intrinsics are kept).
    edges : matched segments (pixels of the undistorted image).
    regions : matched regions with depth, or None.
    rig, right_edges : the stereo pair's second camera and the segments of its image matched
        to model edges (its pose follows the first camera's), or None.
    sigma_px : the standard deviation of an edge point across its edge, pixels.
    f_scale : the soft L1 threshold in multiples of sigma.
    max_evaluations : cap on the solver's residual evaluations.
    reject_sigmas : when given, segments whose whitened residual (both end points) is larger
        are dropped after the solve and the pose is solved again without them (once): a
        segment on a texture or shadow line beside the edge pulls a soft L1 fit with the force
        of an inlier at the loss's threshold, whatever its distance.

    Raises
    ------
    SolveError
        A degenerate edge constraint, or a start that puts the model behind the camera.
    """
    stereo = rig is not None and right_edges is not None and right_edges.size > 0
    right = right_edges if stereo else None
    result, factors = _solve_pose(
        model, camera, edges, regions, rig, right, sigma_px, f_scale, max_evaluations
    )
    if reject_sigmas is not None:
        # segments off their edge by more than their noise allows: dropped, the pose solved again
        whitened = np.sqrt([r.normalised_cost for r in result.report.rows])
        n_left = edges.size
        n_right = 0 if right is None else right.size
        keep_left = whitened[:n_left] <= reject_sigmas
        keep_right = whitened[n_left : n_left + n_right] <= reject_sigmas
        if not (np.all(keep_left) and np.all(keep_right)) and int(keep_left.sum()) >= 3:
            edges = _subset(edges, keep_left)
            right = None if right is None else _subset(right, keep_right)
            result, factors = _solve_pose(
                model,
                result.cameras[_LEFT],
                edges,
                regions,
                rig,
                right if right is not None and right.size else None,
                sigma_px,
                f_scale,
                max_evaluations,
            )
    fitted = result.cameras[_LEFT]
    left = [r for r, c in zip(result.report.rows, factors, strict=True) if c.edge is not None]
    left = left[: edges.size]  # the view's own segments come first
    if not left:
        raise SolveError("registration: no segment matched")
    rms = math.sqrt(sum(r.residual**2 for r in left) / (2 * len(left)))
    return PoseFit(fitted, rms, result.cost, result.success, result.n_evaluations)
