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
from aida_kb.solve import build_problem, solve

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

__all__ = ["EdgeObservations", "PoseFit", "RegionObservations", "fit_pose", "pose_factors"]

POSE_TOLERANCE = 1e-12
"""ftol, xtol and gtol of the pose solve: a pose is six numbers; converging to rounding costs
a few evaluations and keeps the registration benchmark's hundredths of a degree honest."""

_LEFT, _RIGHT = 0, 1  # camera indices in a pose problem


@dataclass(frozen=True)
class EdgeObservations:
    """Image segments matched to model edges: faces (M, 2) part indices; p1, p2 (M, 2) px."""

    faces: IntArray
    p1: FloatArray
    p2: FloatArray

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


def _edge_factors(
    edges: EdgeObservations, camera: int, sigma_px: float, f_scale: float, what: str
) -> list[Constraint]:
    out = []
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
                sqrt_information=segment_sqrt_information(p1, p2, sigma_px),
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

    Raises
    ------
    SolveError
        A degenerate edge constraint, or a start that puts the model behind the camera.
    """
    stereo = rig is not None and right_edges is not None and right_edges.size > 0
    cameras = [camera]
    derived: list[tuple[int, int, Rig]] = []
    if stereo and rig is not None:
        cameras.append(rig.right_of(camera))
        derived.append((_RIGHT, _LEFT, rig))
    factors = pose_factors(
        edges, regions, right_edges if stereo else None, sigma_px=sigma_px, f_scale=f_scale
    )
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
    result = solve(problem, max_iterations=max_evaluations, tolerance=POSE_TOLERANCE)
    fitted = result.cameras[_LEFT]
    left = [r for r, c in zip(result.report.rows, factors, strict=True) if c.edge is not None]
    left = left[: edges.size]  # the view's own segments come first
    if not left:
        raise SolveError("registration: no segment matched")
    rms = math.sqrt(sum(r.residual**2 for r in left) / (2 * len(left)))
    return PoseFit(fitted, rms, result.cost, result.success, result.n_evaluations)
