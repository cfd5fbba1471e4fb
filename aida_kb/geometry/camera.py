"""Cameras: the OpenCV pinhole model (K, R, t) and the CAHV model, with exact conversion.

Conventions (docs DOMAIN.md). World coordinates are metres; a point maps into the camera frame
by ``x_cam = R_cam_world @ x_world + t_cam_world`` (OpenCV: x right, y down, z forward) and
into pixels by ``K``. The centre is ``C = -R^T t``. The CAHV model (Yakimovsky and
Cunningham) describes the same camera by four world vectors: the centre C, the unit optical
axis A, ``H = fx·h + s·v + cx·A`` and ``V = fy·v + cy·A`` where h, v are the camera's x and y
axes in world coordinates (the rows of R) and s the skew of K (zero for OpenCV calibrations);
a point P then projects to ``x = (P-C)·H / (P-C)·A``, ``y = (P-C)·V / (P-C)·A``.

Neither model has lens distortion: these cameras describe undistorted (or rectified) images.
Undistort with the calibration's D vector (cv2.undistortPoints) before using them.

A camera's 6 extrinsic degrees of freedom (paper §3) are its *pose*: the rotation vector of
``R_cam_world`` (radians) followed by the centre C (metres), a (6,) array. Jacobians with
respect to the pose are with respect to exactly these six numbers.

Points on or behind the camera's focal plane (z_cam <= 0) have no projection: `project`
raises `GeometryError` for them; filter with `PinholeCamera.in_front` first.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from aida_kb.errors import GeometryError
from aida_kb.geometry.rotation import (
    check_rotation,
    rotation_from_rvec,
    rotation_from_rvec_jacobian,
    rvec_from_rotation,
)

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

__all__ = [
    "Cahv",
    "PinholeCamera",
    "Projection",
    "RayJacobians",
    "Rt_from_pose",
    "pose_from_Rt",
]


def _frozen(a: npt.ArrayLike, shape: tuple[int, ...], what: str) -> FloatArray:
    arr = np.array(a, dtype=np.float64)  # a copy: the camera owns its arrays
    if arr.shape != shape:
        raise GeometryError(f"{what} must have shape {shape}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise GeometryError(f"{what} has non-finite entries: {arr.tolist()}")
    arr.setflags(write=False)
    return arr


def _points(points: npt.ArrayLike, what: str = "points") -> FloatArray:
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise GeometryError(f"{what} must have shape (N, 3), got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise GeometryError(f"{what} have non-finite coordinates")
    return p


def _pixels(pixels: npt.ArrayLike) -> FloatArray:
    q = np.asarray(pixels, dtype=np.float64)
    if q.ndim != 2 or q.shape[1] != 2:
        raise GeometryError(f"pixels must have shape (N, 2), got {q.shape}")
    if not np.all(np.isfinite(q)):
        raise GeometryError("pixels have non-finite coordinates")
    return q


def pose_from_Rt(R_cam_world: npt.ArrayLike, t_cam_world: npt.ArrayLike) -> FloatArray:
    """The 6-vector pose (rotation vector of R_cam_world, radians; centre C, metres).

    Parameters
    ----------
    R_cam_world : (3, 3) array
    t_cam_world : (3,) array, metres

    Returns
    -------
    (6,) array
        ``[rvec, C]`` with ``C = -R^T t``.
    """
    R = check_rotation(R_cam_world, "R_cam_world")
    t = _frozen(t_cam_world, (3,), "t_cam_world")
    return np.concatenate([rvec_from_rotation(R), -R.T @ t])


def Rt_from_pose(pose: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
    """R_cam_world (3, 3) and t_cam_world (3,) metres from a pose ``[rvec, C]`` (6,)."""
    p = _frozen(pose, (6,), "pose")
    R = rotation_from_rvec(p[:3])
    return R, -R @ p[3:]


class Projection(NamedTuple):
    """Pixels of N points with their derivatives.

    pixels : (N, 2) array, pixels
    d_pixels_d_points : (N, 2, 3) array, pixels per metre (world frame)
    d_pixels_d_pose : (N, 2, 6) array, per radian (rotation vector) and per metre (centre)
    """

    pixels: FloatArray
    d_pixels_d_points: FloatArray
    d_pixels_d_pose: FloatArray


class RayJacobians(NamedTuple):
    """Back-projected rays with their derivatives.

    centre : (3,) array, metres, world frame
    rays : (N, 3) array, unit directions, world frame
    d_rays_d_rvec : (N, 3, 3) array, per radian: ``d rays[n, j] / d rvec[i]`` at ``[n, j, i]``;
        the rays do not depend on the centre, the centre's derivative is the identity.
    d_rays_d_pixels : (N, 3, 2) array, per pixel
    """

    centre: FloatArray
    rays: FloatArray
    d_rays_d_rvec: FloatArray
    d_rays_d_pixels: FloatArray


@dataclass(frozen=True, eq=False)
class Cahv:
    """A CAHV camera: four world vectors, C (metres), A (unit), H and V (pixels).

    A point P projects to ``((P-C)·H / (P-C)·A, (P-C)·V / (P-C)·A)``. Build one from a
    pinhole camera with `PinholeCamera.to_cahv`; convert back with `PinholeCamera.from_cahv`.
    Arrays are read-only copies.
    """

    C: FloatArray
    A: FloatArray
    H: FloatArray
    V: FloatArray

    def __post_init__(self) -> None:
        for name in ("C", "A", "H", "V"):
            object.__setattr__(self, name, _frozen(getattr(self, name), (3,), f"CAHV {name}"))
        norm = float(np.linalg.norm(self.A))
        if abs(norm - 1.0) > 1e-9:
            raise GeometryError(f"CAHV axis A must be a unit vector, has length {norm:.12g}")

    def project(self, points_world: npt.ArrayLike) -> FloatArray:
        """Pixels (N, 2) of world points (N, 3), metres, by the CAHV formula.

        Raises `GeometryError` if a point lies on or behind the camera ((P-C)·A <= 0).
        """
        P = _points(points_world) - self.C
        z = P @ self.A
        _check_in_front(z)
        return np.stack([P @ self.H, P @ self.V], axis=1) / z[:, None]

    def as_tuple(self) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """(C, A, H, V), each (3,)."""
        return self.C, self.A, self.H, self.V


def _check_in_front(z: FloatArray) -> None:
    bad = np.flatnonzero(~(z > 0.0))
    if bad.size:
        i = int(bad[0])
        raise GeometryError(
            f"{bad.size} of {z.size} points lie on or behind the camera's focal plane "
            f"(first: point {i}, depth {float(z[i]):.6g} m); filter them with in_front()"
        )


@dataclass(frozen=True, eq=False)
class PinholeCamera:
    """An OpenCV pinhole camera of an undistorted image: ``x_cam = R_cam_world x + t_cam_world``.

    Parameters
    ----------
    K : (3, 3) array, pixels
        ``[[fx, s, cx], [0, fy, cy], [0, 0, 1]]`` with fx, fy > 0 (s, the skew, is usually 0).
    R_cam_world : (3, 3) array
        Rotation world -> camera (checked orthonormal to 1e-9, determinant +1).
    t_cam_world : (3,) array, metres
    width, height : int
        Image size in pixels (pixel centres at integer coordinates, OpenCV convention).

    Instances are immutable (read-only array copies); derive new ones with `with_pose`.
    """

    K: FloatArray
    R_cam_world: FloatArray
    t_cam_world: FloatArray
    width: int
    height: int

    def __post_init__(self) -> None:
        K = _frozen(self.K, (3, 3), "K")
        if K[1, 0] != 0.0 or K[2, 0] != 0.0 or K[2, 1] != 0.0 or K[2, 2] != 1.0:
            raise GeometryError(
                f"K must be [[fx, s, cx], [0, fy, cy], [0, 0, 1]], got {K.tolist()}"
            )
        if not (K[0, 0] > 0.0 and K[1, 1] > 0.0):
            raise GeometryError(f"K must have positive focal lengths, got {K[0, 0]}, {K[1, 1]}")
        R = _frozen(check_rotation(self.R_cam_world, "R_cam_world"), (3, 3), "R_cam_world")
        t = _frozen(self.t_cam_world, (3,), "t_cam_world")
        for side in (self.width, self.height):
            if isinstance(side, bool) or not np.isfinite(side) or side != int(side):
                raise GeometryError(f"image size must be whole pixels, got {side!r}")
        if int(self.width) <= 0 or int(self.height) <= 0:
            raise GeometryError(f"image size must be positive, got {self.width}x{self.height}")
        object.__setattr__(self, "K", K)
        object.__setattr__(self, "R_cam_world", R)
        object.__setattr__(self, "t_cam_world", t)
        object.__setattr__(self, "width", int(self.width))
        object.__setattr__(self, "height", int(self.height))

    # ---- construction -------------------------------------------------------------------

    @classmethod
    def from_pose(
        cls, K: npt.ArrayLike, pose: npt.ArrayLike, width: int, height: int
    ) -> PinholeCamera:
        """A camera from intrinsics and a pose ``[rvec, C]`` (6,) (radians, metres)."""
        R, t = Rt_from_pose(pose)
        return cls(np.asarray(K, dtype=np.float64), R, t, width, height)

    @classmethod
    def from_cahv(cls, cahv: Cahv, width: int, height: int) -> PinholeCamera:
        """The pinhole camera equal to a CAHV camera (exact up to rounding).

        Recovers ``cx = H·A``, ``cy = V·A``, ``fy = |V - cy A|``, ``v = (V - cy A)/fy``,
        ``s = H'·v`` and ``fx = |H' - s v|`` with ``H' = H - cx A``; R has rows h, v, A.

        Raises
        ------
        GeometryError
            If H or V is parallel to A (no focal length) or (h, v, A) is left-handed.
        """
        C, A, H, V = cahv.as_tuple()
        cx, cy = float(H @ A), float(V @ A)
        Vp = V - cy * A
        fy = float(np.linalg.norm(Vp))
        if not fy > 0.0:
            raise GeometryError("CAHV: V is parallel to A (zero vertical focal length)")
        v = Vp / fy
        Hp = H - cx * A
        s = float(Hp @ v)
        Hpp = Hp - s * v
        fx = float(np.linalg.norm(Hpp))
        if not fx > 1e-12 * fy:
            raise GeometryError("CAHV: H is in the plane of V and A (zero horizontal focal length)")
        h = Hpp / fx
        R = np.stack([h, v, A])
        if float(np.cross(h, v) @ A) < 0:
            raise GeometryError("CAHV: (H, V, A) is left-handed; not a camera of this convention")
        # h, v, A are orthonormal up to rounding; snap to the nearest rotation
        U, _, Wt = np.linalg.svd(R)
        R = U @ Wt
        K = np.array([[fx, s, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
        return cls(K, R, -R @ C, width, height)

    def with_pose(self, pose: npt.ArrayLike) -> PinholeCamera:
        """The same intrinsics and image size at pose ``[rvec, C]`` (6,)."""
        return PinholeCamera.from_pose(self.K, pose, self.width, self.height)

    # ---- derived quantities -------------------------------------------------------------

    @property
    def centre(self) -> FloatArray:
        """Camera centre C = -R^T t, (3,) metres, world frame."""
        return -self.R_cam_world.T @ self.t_cam_world

    @property
    def optical_axis(self) -> FloatArray:
        """Unit viewing direction A (3,) in the world frame (the camera's +z axis)."""
        return np.array(self.R_cam_world[2], dtype=np.float64)

    @property
    def pose(self) -> FloatArray:
        """The 6 extrinsic parameters ``[rvec of R_cam_world (rad), C (m)]``, (6,) (a copy)."""
        return self._pose.copy()

    @cached_property
    def _pose(self) -> FloatArray:
        # a camera is immutable: its pose and rotation derivative are worked out once (the
        # adjustments evaluate each camera's projections several times per iteration)
        pose = pose_from_Rt(self.R_cam_world, self.t_cam_world)
        pose.setflags(write=False)
        return pose

    @cached_property
    def _K_inv(self) -> FloatArray:
        K_inv = np.asarray(np.linalg.inv(self.K), dtype=np.float64)
        K_inv.setflags(write=False)
        return K_inv

    @cached_property
    def rotation_jacobian(self) -> tuple[FloatArray, FloatArray]:
        """The rotation of `pose` and its derivative by the rotation vector (read-only).

        Returns
        -------
        R : (3, 3) array
            ``rotation_from_rvec(pose[:3])``: ``R_cam_world`` to rounding.
        dR_drvec : (3, 3, 3) array, per radian
            ``dR_drvec[j, k, i] = d R[j, k] / d pose[i]`` (`rotation_from_rvec_jacobian`).
        """
        R, dR = rotation_from_rvec_jacobian(self._pose[:3])
        R.setflags(write=False)
        dR.setflags(write=False)
        return R, dR

    @property
    def P(self) -> FloatArray:
        """The 3x4 projection matrix ``K [R | t]``."""
        return self.K @ np.hstack([self.R_cam_world, self.t_cam_world[:, None]])

    def to_cahv(self) -> Cahv:
        """The equal CAHV camera."""
        K, R = self.K, self.R_cam_world
        h, v, A = R[0], R[1], R[2]
        H = K[0, 0] * h + K[0, 1] * v + K[0, 2] * A
        V = K[1, 1] * v + K[1, 2] * A
        return Cahv(self.centre, A, H, V)

    # ---- projection ---------------------------------------------------------------------

    def to_camera(self, points_world: npt.ArrayLike) -> FloatArray:
        """Camera-frame coordinates (N, 3), metres, of world points (N, 3)."""
        return _points(points_world) @ self.R_cam_world.T + self.t_cam_world

    def depth(self, points_world: npt.ArrayLike) -> FloatArray:
        """z_cam (N,), metres: the distance of each point in front of the focal plane."""
        z: FloatArray = _points(points_world) @ self.R_cam_world[2] + self.t_cam_world[2]
        return z

    def in_front(self, points_world: npt.ArrayLike) -> BoolArray:
        """(N,) bool: True where a point lies strictly in front of the camera (z_cam > 0)."""
        return self.depth(points_world) > 0.0

    def in_image(self, pixels: npt.ArrayLike, margin: float = 0.0) -> BoolArray:
        """(N,) bool: True where a pixel lies inside the image shrunk by `margin` pixels.

        The image covers ``[-0.5, width - 0.5] x [-0.5, height - 0.5]`` (pixel centres at
        integers).
        """
        q = _pixels(pixels)
        if not np.isfinite(margin):
            raise GeometryError(f"margin must be a finite number of pixels, got {margin}")
        lo = -0.5 + margin
        return (
            (q[:, 0] >= lo)
            & (q[:, 1] >= lo)
            & (q[:, 0] <= self.width - 0.5 - margin)
            & (q[:, 1] <= self.height - 0.5 - margin)
        )

    def project(self, points_world: npt.ArrayLike) -> FloatArray:
        """Pixels of world points.

        Parameters
        ----------
        points_world : (N, 3) array, metres, world frame

        Returns
        -------
        (N, 2) array, pixels

        Raises
        ------
        GeometryError
            If a point lies on or behind the focal plane (z_cam <= 0); filter with `in_front`.
        """
        Xc = self.to_camera(points_world)
        _check_in_front(Xc[:, 2])
        q = Xc @ self.K.T
        return q[:, :2] / q[:, 2:3]

    def project_with_jacobians(self, points_world: npt.ArrayLike) -> Projection:
        """Pixels of world points and their derivatives w.r.t. the points and the pose.

        Parameters
        ----------
        points_world : (N, 3) array, metres, world frame

        Returns
        -------
        Projection
            ``pixels`` (N, 2); ``d_pixels_d_points`` (N, 2, 3); ``d_pixels_d_pose`` (N, 2, 6)
            for the pose ``[rvec, C]`` (see `pose`).

        Raises
        ------
        GeometryError
            If a point lies on or behind the focal plane.
        """
        Pw = _points(points_world)
        R = self.R_cam_world
        dR = self.rotation_jacobian[1]
        C = self.centre
        D = Pw - C  # (N, 3)
        Xc = D @ R.T
        z = Xc[:, 2]
        _check_in_front(z)
        K = self.K
        fx, s, cx, fy, cy = K[0, 0], K[0, 1], K[0, 2], K[1, 1], K[1, 2]
        x, y = Xc[:, 0] / z, Xc[:, 1] / z
        pixels = np.stack([fx * x + s * y + cx, fy * y + cy], axis=1)
        inv_z = 1.0 / z
        # d pixels / d x_cam = [[j00, j01, j02], [0, j11, j12]] per point
        j00, j01, j02 = fx * inv_z, s * inv_z, -(fx * x + s * y) * inv_z
        j11, j12 = fy * inv_z, -fy * y * inv_z
        n = Pw.shape[0]
        # d x_cam / d rvec_i = dR_i (P - C): (N, 3, 3) with the last axis i (no BLAS: tiny K)
        dXc_drvec = (
            D[:, 0, None, None] * dR[:, 0, :]
            + D[:, 1, None, None] * dR[:, 1, :]
            + D[:, 2, None, None] * dR[:, 2, :]
        )
        # [R | dXc/drvec] stacked along the last axis: (N, 3, 6), then J applied row-wise
        M = np.concatenate([np.broadcast_to(R, (n, 3, 3)), dXc_drvec], axis=2)
        JM = np.empty((n, 2, 6))
        JM[:, 0] = j00[:, None] * M[:, 0] + j01[:, None] * M[:, 1] + j02[:, None] * M[:, 2]
        JM[:, 1] = j11[:, None] * M[:, 1] + j12[:, None] * M[:, 2]
        d_points = JM[:, :, :3].copy()
        d_pose = np.concatenate([JM[:, :, 3:], -d_points], axis=2)
        return Projection(pixels, d_points, d_pose)

    def unproject(self, pixels: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Back-projected rays of pixels: the centre and unit directions in the world frame.

        Parameters
        ----------
        pixels : (N, 2) array, pixels

        Returns
        -------
        centre : (3,) array, metres, world frame
        rays : (N, 3) array, unit directions (world frame) pointing into the scene
            (positive depth); ``centre + lam * rays[n]`` projects to ``pixels[n]`` for lam > 0.
        """
        q = _pixels(pixels)
        rays = self._rays_cam(q) @ self.R_cam_world
        return self.centre, rays

    def unproject_with_jacobians(self, pixels: npt.ArrayLike) -> RayJacobians:
        """`unproject` with the rays' derivatives w.r.t. the rotation vector and the pixels."""
        mh, norm = self._directions(_pixels(pixels))
        rays, d_rvec = self._rays_and_rotation_jacobian(mh)
        # d mh / d m = (I - mh mh^T)/|m|; d m / d pixel = Kinv[:, :2]
        P_perp = (np.eye(3)[None] - mh[:, :, None] * mh[:, None, :]) / norm[:, None, None]
        d_pix = np.einsum("kj,nkl,lp->njp", self.R_cam_world, P_perp, self._K_inv[:, :2])
        return RayJacobians(self.centre, rays, d_rvec, d_pix)

    def unproject_with_rotation_jacobian(
        self, pixels: npt.ArrayLike
    ) -> tuple[FloatArray, FloatArray]:
        """The rays of `unproject` (N, 3), unit, world frame, and their derivatives by the
        rotation vector (N, 3, 3), per radian, ``d rays[n, j] / d rvec[i]`` at ``[n, j, i]``
        (`RayJacobians` without the pixels' derivatives, which the edge kernel does not use)."""
        return self._rays_and_rotation_jacobian(self._directions(_pixels(pixels))[0])

    def unit_rays(self, pixels: npt.ArrayLike) -> FloatArray:
        """The rays of `unproject_with_rotation_jacobian` (N, 3), unit, world frame, without
        their derivatives (the same operations: bit for bit the same rays)."""
        rays: FloatArray = self._directions(_pixels(pixels))[0] @ self.R_cam_world
        return rays

    def _directions(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """The unit camera-frame directions (N, 3) of pixels ``q`` (N, 2), through K's
        inverse, and the lengths (N,) of the unnormalised ``K⁻¹ [q, 1]`` they were scaled by."""
        m = np.hstack([q, np.ones((q.shape[0], 1))]) @ self._K_inv.T  # (N, 3), camera frame
        norm = np.linalg.norm(m, axis=1)
        return m / norm[:, None], norm

    def _rays_and_rotation_jacobian(self, mh: FloatArray) -> tuple[FloatArray, FloatArray]:
        """World rays ``R^T mh`` of unit camera-frame directions ``mh`` (N, 3) and their
        derivatives by the rotation vector (N, 3, 3) at ``[n, j, i]``."""
        dR = self.rotation_jacobian[1]
        rays = mh @ self.R_cam_world
        # ray = R^T mh: d ray_j / d rvec_i = dR[k, j, i] mh_k (the norm is rotation invariant)
        d_rvec = np.einsum("kji,nk->nji", dR, mh)
        return rays, d_rvec

    def _rays_cam(self, q: FloatArray) -> FloatArray:
        m = np.linalg.solve(self.K, np.vstack([q.T, np.ones((1, q.shape[0]))])).T
        rays: FloatArray = m / np.linalg.norm(m, axis=1, keepdims=True)
        return rays
