"""Pose-only least squares: a camera's six pose parameters against a fixed model.

Residuals (paper §5, registration mode): the edge constraint (eq. 5, pixels, via
`aida_kb.constraints.edge.edge_kernel`) of every matched image segment against its model edge,
and — where the view has depth — a position constraint per matched region: the distance of
the region's centre (measured in the view's camera frame, carried into the world by the pose)
from its part's plane, and the angle between the region's normal and the part's.
Both come with analytic Jacobians by the pose ``[rvec, C]``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.optimize import least_squares

from aida_kb.constraints.edge import edge_kernel
from aida_kb.errors import GeometryError, SolveError
from aida_kb.geometry.camera import PinholeCamera
from aida_kb.geometry.rotation import rotation_from_rvec_jacobian
from aida_kb.register.model import RigidModel

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

__all__ = [
    "EdgeObservations",
    "PoseFit",
    "RegionObservations",
    "Rig",
    "fit_pose",
    "region_residuals",
    "right_jacobian",
]


@dataclass(frozen=True, eq=False)
class Rig:
    """The second camera of a stereo pair, rigidly attached to the first (the registered one).

    K : (3, 3) its camera matrix; R (3, 3), T (3,) metres: ``x_right = R·x_left + T``
    (`cv2.stereoCalibrate`); width, height : its image size, pixels.
    """

    K: FloatArray
    R: FloatArray
    T: FloatArray
    width: int
    height: int

    def right_of(self, left: PinholeCamera) -> PinholeCamera:
        """The second camera when the first is `left` (world frame)."""
        return PinholeCamera(
            self.K,
            self.R @ left.R_cam_world,
            self.R @ left.t_cam_world + self.T,
            self.width,
            self.height,
        )


def right_jacobian(rig: Rig, left_pose: FloatArray) -> tuple[PinholeCamera, FloatArray]:
    """The second camera at a first-camera pose ``[rvec, C]`` and d(its pose)/d(that pose).

    Returns the camera and the (6, 6) Jacobian of its pose ``[rvec_r, C_r]`` by the first
    camera's pose: ``R_r = R_rig R`` (the rotation vectors' derivative solved from the matrix
    derivatives) and ``C_r = C + R^T b`` with b the second centre in the first camera's frame.
    """
    R, dR = rotation_from_rvec_jacobian(left_pose[:3])
    right = rig.right_of(PinholeCamera(rig.K, R, -R @ left_pose[3:], rig.width, rig.height))
    _, dRr = rotation_from_rvec_jacobian(right.pose[:3])
    # d R_r / d rvec_i = R_rig dR_i = sum_j dRr_j M[j, i]: solve for M (exact, 9 x 3 system)
    A = dRr.reshape(9, 3)
    B = np.einsum("ab,bci->aci", rig.R, dR).reshape(9, 3)
    M = np.linalg.lstsq(A, B, rcond=None)[0]
    b = -rig.R.T @ rig.T
    J = np.zeros((6, 6))
    J[:3, :3] = M
    J[3:, :3] = np.einsum("j,jmi->mi", b, dR)
    J[3:, 3:] = np.eye(3)
    return right, J


@dataclass(frozen=True)
class EdgeObservations:
    """Image segments matched to model edges: faces (M, 2) part indices; p1, p2 (M, 2) px."""

    faces: IntArray
    p1: FloatArray
    p2: FloatArray

    def whitening(self, point_sigma_px: float) -> FloatArray:
        """(M, 2, 2) matrices that whiten each segment's two end-point residuals (pixels).

        A line fitted to n edge points (one per pixel of its length) of noise sigma across it
        has its centre known to ``sigma/sqrt(n)`` and its end points' mean and half difference
        uncorrelated with standard deviations ``sigma/sqrt(n)`` and ``sigma·sqrt(3/n)``; the
        residuals (r1, r2) map to ``((r1 + r2)/2 / sd_mean, (r1 - r2)/2 / sd_diff)``.
        """
        n = np.maximum(np.linalg.norm(self.p2 - self.p1, axis=1), 4.0)
        sd_mean = point_sigma_px / np.sqrt(n)
        sd_diff = point_sigma_px * np.sqrt(3.0 / n)
        W = np.empty((n.size, 2, 2))
        W[:, 0, 0] = W[:, 0, 1] = 0.5 / sd_mean
        W[:, 1, 0] = 0.5 / sd_diff
        W[:, 1, 1] = -0.5 / sd_diff
        return W

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
    """The fitted camera, the RMS edge residual (pixels) and the optimiser's outcome."""

    camera: PinholeCamera
    rms_px: float
    cost: float
    success: bool
    n_evaluations: int


def region_residuals(
    model: RigidModel, pose: FloatArray, regions: RegionObservations
) -> tuple[FloatArray, FloatArray]:
    """Whitened position residuals (R, 3) and their Jacobian (R, 3, 6) by the pose.

    Per region: ``(n_p·X - d_p)/sigma_m`` with ``X = R^T c_cam + C`` the region's centre in the
    world, and ``(n_world × n_p)/sigma_rad`` (2 independent components of 3) with
    ``n_world = R^T n_cam``.
    """
    Rm, dR = rotation_from_rvec_jacobian(pose[:3])  # dR[j, k, i] = d R[j, k] / d rvec_i
    n_p = model.normals[regions.part]
    d_p = model.offsets[regions.part]
    c = regions.centre_cam
    X = c @ Rm + pose[3:]  # R^T c + C
    nw = regions.normal_cam @ Rm
    # d (R^T c)_m / d rvec_i = c_j dR[j, m, i]
    dX = np.einsum("rj,jmi->rmi", c, dR)
    dn = np.einsum("rj,jmi->rmi", regions.normal_cam, dR)
    r = np.empty((regions.size, 3))
    J = np.zeros((regions.size, 3, 6))
    r[:, 0] = (np.einsum("ri,ri->r", n_p, X) - d_p) / regions.sigma_m
    J[:, 0, :3] = np.einsum("ri,rij->rj", n_p, dX) / regions.sigma_m[:, None]
    J[:, 0, 3:] = n_p / regions.sigma_m[:, None]
    # n_world × n_p: components by the cross-product matrix of -n_p applied to n_world
    cr = np.cross(nw, n_p)
    skew_np = np.zeros((regions.size, 3, 3))
    skew_np[:, 0, 1], skew_np[:, 0, 2] = n_p[:, 2], -n_p[:, 1]
    skew_np[:, 1, 0], skew_np[:, 1, 2] = -n_p[:, 2], n_p[:, 0]
    skew_np[:, 2, 0], skew_np[:, 2, 1] = n_p[:, 1], -n_p[:, 0]
    # cross(nw, n_p) = -cross(n_p, nw) = skew_np @ nw with skew_np = -[n_p]x
    # keep the two components least aligned with n_p (the third is redundant)
    drop = np.argmax(np.abs(n_p), axis=1)
    keep = np.array([[1, 2], [0, 2], [0, 1]])[drop]  # (R, 2)
    rows = np.arange(regions.size)[:, None]
    r[:, 1:] = cr[rows, keep] / regions.sigma_rad[:, None]
    dcr = np.einsum("rab,rbi->rai", skew_np, dn)  # (R, 3, 3)
    J[:, 1:, :3] = dcr[rows, keep] / regions.sigma_rad[:, None, None]
    return r, J


def _edge_residuals(
    model: RigidModel, camera: PinholeCamera, edges: EdgeObservations
) -> tuple[FloatArray, FloatArray]:
    r, _, Jc = edge_kernel(
        model.normals,
        model.offsets,
        edges.faces,
        [camera],
        np.zeros(edges.size, dtype=np.intp),
        edges.p1,
        edges.p2,
        np.ones(edges.size, dtype=bool),
    )
    return r, Jc


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
    sigma_px : the standard deviation of an edge point across its edge, pixels; a segment's
        end-point residuals are whitened by `EdgeObservations.whitening`.
    f_scale : the soft L1 threshold in multiples of sigma.

    Raises
    ------
    SolveError
        A degenerate edge constraint, or a pose that puts the model behind the camera.
    """
    nr = 0 if regions is None else regions.size
    W = edges.whitening(sigma_px)
    stereo = rig is not None and right_edges is not None and right_edges.size > 0
    Wr = right_edges.whitening(sigma_px) if stereo and right_edges is not None else None
    n_right = right_edges.size if stereo and right_edges is not None else 0

    def fun_jac(x: FloatArray) -> tuple[FloatArray, FloatArray]:
        try:
            cam = camera.with_pose(x)
        except GeometryError as exc:
            raise SolveError(f"registration: {exc}") from exc
        r, Jc = _edge_residuals(model, cam, edges)
        rs = [np.einsum("mij,mj->mi", W, r).reshape(-1)]
        js = [np.einsum("mij,mjk->mik", W, Jc).reshape(-1, 6)]
        if rig is not None and right_edges is not None and Wr is not None:
            right, dpose = right_jacobian(rig, x)
            rr, Jr = _edge_residuals(model, right, right_edges)
            rs.append(np.einsum("mij,mj->mi", Wr, rr).reshape(-1))
            js.append(np.einsum("mij,mjk,kl->mil", Wr, Jr, dpose).reshape(-1, 6))
        if regions is not None and nr:
            rp, Jp = region_residuals(model, x, regions)
            rs.append(rp.reshape(-1))
            js.append(Jp.reshape(-1, 6))
        return np.concatenate(rs), np.concatenate(js)

    cache: dict[str, FloatArray] = {}

    n_res = 2 * edges.size + 2 * n_right + 3 * nr

    def fun(x: FloatArray) -> FloatArray:
        try:
            f, J = fun_jac(x)
        except SolveError:
            # a trial step put the model behind the camera or made an edge degenerate: a
            # cost far above any real one makes the trust region reject the step
            return np.full(n_res, 1e6)
        cache["x"], cache["J"] = x.copy(), J
        return f

    def jac(x: FloatArray) -> FloatArray:
        if "x" in cache and np.array_equal(cache["x"], x):
            return cache["J"]
        return fun_jac(x)[1]

    x0 = camera.pose
    res = least_squares(
        fun,
        x0,
        jac=jac,
        method="trf",
        loss="soft_l1",
        f_scale=f_scale,
        x_scale="jac",
        max_nfev=max_evaluations,
        ftol=1e-12,
        xtol=1e-12,
        gtol=1e-12,
    )
    cam = camera.with_pose(res.x)
    r, _ = _edge_residuals(model, cam, edges)
    rms = float(np.sqrt(np.mean(r * r))) if r.size else 0.0
    return PoseFit(cam, rms, float(res.cost), bool(res.status > 0), int(res.nfev))
