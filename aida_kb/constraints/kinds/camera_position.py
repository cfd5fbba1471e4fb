"""A plane against a region measured in a free camera's frame (paper eq. 4, registration).

With the camera's pose ``[rvec, C]`` (``R = R(rvec)`` maps world to camera) the region's
centre in the world is ``X = Rᵀ c_cam + C`` and its normal ``n_w = Rᵀ n_cam``. The residual
has three components:

* ``r_0 = n·X - d``: the centre's distance from the part's plane ``n·x = d``, metres;
* ``r_1, r_2``: the two components of ``n_w × n`` least aligned with ``n`` (the third is
  redundant), about the angle between the normals in radians.

A diagonal ``sqrt_information`` ``diag(1/sigma_m, 1/sigma_rad, 1/sigma_rad)`` whitens the
metres and radians together. Jacobians: ``dr_0/dn = X``, ``dr_0/dd = -1``,
``d(n_w × n)/dn = [n_w]x``; by the pose through ``dR/drvec``
(`aida_kb.geometry.rotation.rotation_from_rvec_jacobian`) and ``dX/dC = I``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import ClassVar

import numpy as np

from aida_kb.constraints.factor import CameraPositionData, Constraint
from aida_kb.constraints.kernels import cross
from aida_kb.constraints.kinds.base import (
    BlockData,
    Evaluated,
    Evidence,
    FloatArray,
    IntArray,
    Kind,
    check_camera,
    unit_vector,
    vector,
)
from aida_kb.errors import SolveError
from aida_kb.geometry.camera import PinholeCamera
from aida_kb.geometry.rotation import skew

_KEEP = np.array([[1, 2], [0, 2], [0, 1]], dtype=np.intp)
"""The two components of a cross product with n kept when n's largest component is 0, 1, 2."""


def _data(c: Constraint) -> CameraPositionData:
    assert c.camera_position is not None
    return c.camera_position


class CameraPosition(Kind):
    """A plane against a region measured in its camera's frame."""

    name: ClassVar[str] = "camera_position"
    arity: ClassVar[int] = 1
    residual_size: ClassVar[int] = 3
    dof: ClassVar[int] = 3
    measurement: ClassVar[bool] = True
    uses_camera: ClassVar[bool] = True
    # made by code from matched regions (registration, multi-view), never from a .kb measure
    evidence: ClassVar[Evidence] = None
    summary: ClassVar[str] = (
        "distance of a region's centre (camera frame) from its plane, m, and the normals' "
        "angle, rad (eq. 4 through a camera)"
    )

    def camera(self, c: Constraint) -> int | None:
        """The camera whose frame the region was measured in."""
        return int(_data(c).camera)

    def validate(self, c: Constraint, where: str, n_cameras: int) -> None:
        """The measurement is there and finite, its normal a unit vector."""
        m = c.camera_position
        if m is None:
            raise SolveError(f"{where}: a camera position constraint needs its region")
        check_camera(where, m.camera, n_cameras)
        unit_vector(where, "normal_cam", m.normal_cam)
        vector(where, "centre_cam", m.centre_cam, 3)

    def pack(self, cs: Sequence[Constraint]) -> BlockData:
        """``camera`` (M,) int; ``normal_cam``, ``centre_cam`` (M, 3)."""
        ms = [_data(c) for c in cs]
        return {
            "camera": np.array([m.camera for m in ms], dtype=np.intp),
            "normal_cam": np.array([m.normal_cam for m in ms], dtype=np.float64).reshape(-1, 3),
            "centre_cam": np.array([m.centre_cam for m in ms], dtype=np.float64).reshape(-1, 3),
        }

    def evaluate(
        self,
        normals: FloatArray,
        offsets: FloatArray,
        cameras: Sequence[PinholeCamera],
        idx: IntArray,
        data: BlockData,
        *,
        camera_jacobian: bool = True,
    ) -> Evaluated:
        """r (M, 3), J (M, 3, 1, 4), J_camera (M, 3, 6) (None unless ``camera_jacobian``)."""
        M = idx.shape[0]
        cam_of = data["camera"]
        X = np.empty((M, 3))
        nw = np.empty((M, 3))
        dX = np.empty((M, 3, 3))  # d X_a / d rvec_i at [.., a, i]
        dn = np.empty((M, 3, 3))
        for c in np.unique(cam_of):  # one rotation per distinct camera
            sel = np.flatnonzero(cam_of == c)
            pose = cameras[int(c)].pose
            Rm, dR = cameras[int(c)].rotation_jacobian  # dR[j, k, i] = dR_jk / drvec_i
            cc = data["centre_cam"][sel]
            nc = data["normal_cam"][sel]
            X[sel] = cc @ Rm + pose[3:]
            nw[sel] = nc @ Rm
            dX[sel] = np.einsum("rj,jmi->rmi", cc, dR)
            dn[sel] = np.einsum("rj,jmi->rmi", nc, dR)
        i = idx[:, 0]
        n = normals[i]
        d = offsets[i]
        keep = _KEEP[np.argmax(np.abs(n), axis=1)]  # (M, 2)
        rows = np.arange(M)[:, None]
        cr = cross(nw, n)
        r = np.empty((M, 3))
        r[:, 0] = np.einsum("mi,mi->m", n, X) - d
        r[:, 1:] = cr[rows, keep]
        J = np.zeros((M, 3, 1, 4))
        J[:, 0, 0, :3] = X
        J[:, 0, 0, 3] = -1.0
        J[:, 1:, 0, :3] = skew(nw, check=False)[rows, keep]  # d(nw × n)/dn = [nw]x
        if not camera_jacobian:
            return r, J, None
        Jc = np.zeros((M, 3, 6))
        Jc[:, 0, :3] = np.einsum("mi,mij->mj", n, dX)
        Jc[:, 0, 3:] = n
        # d(nw × n)/d nw = -[n]x
        dcr = np.einsum("mab,mbi->mai", -skew(n, check=False), dn)
        Jc[:, 1:, :3] = dcr[rows, keep]
        return r, J, Jc


CAMERA_POSITION = CameraPosition()
