"""The edge constraint (paper eq. 5): a model edge against an image line segment.

The image segment's end points ``p1``, ``p2`` (pixels) back-project to rays ``r1``, ``r2``
from the camera centre ``C``; they span the *plane of sight* with unit normal
``m = (r1 × r2)/|r1 × r2|``. Through each ray ``r_k`` passes an *auxiliary plane* perpendicular
to the plane of sight, with normal ``a_k = m × r_k``. The model edge, the line where the planes
of parts a and b meet, cuts auxiliary plane k in ``S_k`` (the intersection of three planes).
The residuals are, per end point k = 1, 2:

* unit "m" (or ""): ``delta_k = m·(S_k - C)``, the distance of ``S_k`` from the plane of sight,
  metres (the paper's delta_1, delta_2);
* unit "px": the distance in the image of the projection of ``S_k`` from the image line through
  ``p1``, ``p2``, pixels (signed).

Both come with analytic Jacobians by the two planes ``(n, d)`` and by the camera pose
``[rvec, C]`` (`aida_kb.geometry.camera`). All constraints of a block are evaluated together;
the only loop is over the distinct cameras.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from aida_kb.constraints.kernels import cross, dot
from aida_kb.errors import GeometryError, SolveError
from aida_kb.geometry.camera import PinholeCamera
from aida_kb.geometry.rotation import skew

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]


def edge_kernel(
    normals: FloatArray,
    offsets: FloatArray,
    idx: IntArray,
    cameras: Sequence[PinholeCamera],
    camera: IntArray,
    p1: FloatArray,
    p2: FloatArray,
    px: npt.NDArray[np.bool_],
    *,
    camera_jacobian: bool = True,
) -> tuple[FloatArray, FloatArray, FloatArray | None]:
    """Residuals of M edge constraints and their Jacobians.

    Parameters
    ----------
    normals : (P, 3) unit normals, offsets : (P,) metres: the planes of all parts, world frame.
    idx : (M, 2) the two parts whose intersection is the model edge.
    cameras : the problem's cameras; camera : (M,) index of each constraint's camera.
    p1, p2 : (M, 2) the image segment's end points, pixels.
    px : (M,) True where the residual is in pixels, else metres.
    camera_jacobian : compute J_camera (False: None, and none of the sight planes'
        derivatives by the pose, about half the work, for problems whose cameras are held).

    Returns
    -------
    r : (M, 2); J : (M, 2, 2, 4) by (n, d) of the two planes; J_camera : (M, 2, 6) by the pose
    ``[rvec, C]`` of the constraint's camera, or None.

    Raises
    ------
    SolveError
        When a model edge is parallel to an auxiliary plane, or (unit px) its point lies
        behind the camera.
    """
    M = idx.shape[0]
    C = np.empty((M, 3))
    rays = np.empty((M, 2, 3))
    d_rays = np.empty((M, 2, 3, 3))  # d ray_j / d rvec_i at [.., j, i]
    for c in np.unique(camera):
        sel = np.flatnonzero(camera == c)
        cam = cameras[int(c)]
        ends = np.concatenate([p1[sel], p2[sel]])
        C[sel] = cam.centre
        n = sel.size
        if camera_jacobian:
            both, d_both = cam.unproject_with_rotation_jacobian(ends)
            d_rays[sel, 0], d_rays[sel, 1] = d_both[:n], d_both[n:]
        else:
            both = cam.unit_rays(ends)
        rays[sel, 0], rays[sel, 1] = both[:n], both[n:]
    r1, r2 = rays[:, 0], rays[:, 1]
    s = cross(r1, r2)
    s_len = np.sqrt(dot(s, s))
    m = s / s_len[:, None]
    dm_drvec = None
    if camera_jacobian:
        proj = (np.eye(3)[None] - np.einsum("mi,mj->mij", m, m)) / s_len[:, None, None]
        dm_drvec = (
            proj @ (-skew(r2, check=False)) @ d_rays[:, 0]
            + proj @ skew(r1, check=False) @ d_rays[:, 1]
        )
    na, nb = normals[idx[:, 0]], normals[idx[:, 1]]
    da, db = offsets[idx[:, 0]], offsets[idx[:, 1]]
    # image line normal for the pixel residuals
    t = p2 - p1
    nu = np.stack([-t[:, 1], t[:, 0]], axis=1) / np.linalg.norm(t, axis=1)[:, None]

    r = np.empty((M, 2))
    J = np.zeros((M, 2, 2, 4))
    Jc = np.zeros((M, 2, 6)) if camera_jacobian else None
    for k in range(2):
        rk = rays[:, k]
        a = cross(m, rk)
        A = np.stack([na, nb, a], axis=1)  # (M, 3, 3), rows are plane normals
        det = np.linalg.det(A)
        if np.any(np.abs(det) < 1e-12):
            bad = int(np.argmin(np.abs(det)))
            raise SolveError(
                f"edge constraint {bad}: the edge of parts {idx[bad].tolist()} is parallel to "
                "the auxiliary plane of its image segment (or the two planes are parallel)"
            )
        Ainv = np.linalg.inv(A)
        rhs = np.stack([da, db, dot(a, C)], axis=1)
        S = np.einsum("mij,mj->mi", Ainv, rhs)
        SC = S - C
        # metric residual and its gradient by S (g), plus direct terms
        g = m.copy()
        res = dot(m, SC)
        d_pose = None
        if dm_drvec is not None:
            d_pose = np.concatenate([np.einsum("mi,mij->mj", SC, dm_drvec), -m], axis=1)
        if np.any(px):
            q = np.empty((M, 2))
            dq_dS = np.zeros((M, 2, 3))
            dq_dpose = np.zeros((M, 2, 6))
            for c in np.unique(camera[px]):
                sel = np.flatnonzero(px & (camera == c))
                try:
                    pr = cameras[int(c)].project_with_jacobians(S[sel])
                except GeometryError as exc:
                    raise SolveError(f"edge constraints of camera {int(c)}: {exc}") from exc
                q[sel], dq_dS[sel], dq_dpose[sel] = pr
            g_px = np.einsum("mi,mij->mj", nu, dq_dS)
            res_px = np.sum(nu * (q - p1), axis=1)
            g = np.where(px[:, None], g_px, g)
            res = np.where(px, res_px, res)
            if d_pose is not None:
                d_pose = np.where(px[:, None], np.einsum("mi,mij->mj", nu, dq_dpose), d_pose)
        r[:, k] = res
        ga = np.einsum("mi,mi->m", g, Ainv[:, :, 0])
        gb = np.einsum("mi,mi->m", g, Ainv[:, :, 1])
        J[:, k, 0, :3] = -ga[:, None] * S
        J[:, k, 0, 3] = ga
        J[:, k, 1, :3] = -gb[:, None] * S
        J[:, k, 1, 3] = gb
        if Jc is None or d_pose is None or dm_drvec is None:
            continue
        da_drvec = (
            -skew(rk, check=False) @ dm_drvec + skew(m, check=False) @ d_rays[:, k]
        )  # (M, 3, 3)
        dS_da = np.einsum("mi,mj->mij", Ainv[:, :, 2], C - S)
        dS_dC = np.einsum("mi,mj->mij", Ainv[:, :, 2], a)
        Jc[:, k, :3] = d_pose[:, :3] + np.einsum("mi,mij,mjl->ml", g, dS_da, da_drvec)
        Jc[:, k, 3:] = d_pose[:, 3:] + np.einsum("mi,mij->mj", g, dS_dC)
    return r, J, Jc
