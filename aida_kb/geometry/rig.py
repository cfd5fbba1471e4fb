"""A stereo rig: the second camera of a pair, rigidly attached to the first.

The calibration (`cv2.stereoCalibrate`) gives ``x_right = R·x_left + T``: when the first
camera has ``R_cam_world``, ``t_cam_world``, the second has ``R·R_cam_world`` and
``R·t_cam_world + T``. In a least-squares problem the second camera is a *derived* key: its
pose follows the first camera's, with the Jacobian of `Rig.pose_jacobian`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aida_kb.geometry.camera import PinholeCamera
from aida_kb.geometry.rotation import rotation_from_rvec_jacobian

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class Rig:
    """The second camera of a stereo pair, rigidly attached to the first.

    K : (3, 3) its camera matrix; R (3, 3), T (3,) metres: ``x_right = R·x_left + T``;
    width, height : its image size, pixels.
    """

    K: FloatArray
    R: FloatArray
    T: FloatArray
    width: int
    height: int

    def right_of(self, left: PinholeCamera) -> PinholeCamera:
        """The second camera when the first is ``left`` (world frame)."""
        return PinholeCamera(
            self.K,
            self.R @ left.R_cam_world,
            self.R @ left.t_cam_world + self.T,
            self.width,
            self.height,
        )

    def pose_jacobian(self, left_pose: FloatArray) -> tuple[PinholeCamera, FloatArray]:
        """The second camera at a first-camera pose ``[rvec, C]`` and d(its pose)/d(that pose).

        Returns the camera and the (6, 6) Jacobian of its pose ``[rvec_r, C_r]`` by the first
        camera's pose: ``R_r = R_rig R`` (the rotation vector's derivative solved from the
        matrix derivatives) and ``C_r = C + Rᵀ b`` with b the second centre in the first
        camera's frame.
        """
        R, dR = rotation_from_rvec_jacobian(left_pose[:3])
        right = self.right_of(PinholeCamera(self.K, R, -R @ left_pose[3:], self.width, self.height))
        dRr = right.rotation_jacobian[1]
        # d R_r / d rvec_i = R_rig dR_i = sum_j dRr_j M[j, i]: solve for M (exact, 9 x 3)
        A = dRr.reshape(9, 3)
        B = np.einsum("ab,bci->aci", self.R, dR).reshape(9, 3)
        M = np.linalg.lstsq(A, B, rcond=None)[0]
        b = -self.R.T @ self.T
        J = np.zeros((6, 6))
        J[:3, :3] = M
        J[3:, :3] = np.einsum("j,jmi->mi", b, dR)
        J[3:, 3:] = np.eye(3)
        return right, J
