"""The texture factor: a patch of a reference image seen again through another camera.

A patch holds N sample pixels of a reference image (the first view's left image, whose camera
is held fixed). Sample i looks along the ray ``r_i`` from the reference camera's centre ``o``;
it meets the plane ``n·X = d`` of the constraint's part in

    t_i = (d - n·o) / (n·r_i),        X_i = o + t_i r_i,

which camera k projects to ``q_i = pi_k(X_i)`` (`aida_kb.geometry.camera`); there its image
reads ``y_i = I_k(q_i)`` (bilinear interpolation, `bilinear`). The two images differ by a gain
and an offset per patch (lighting, exposure, a surface's sheen), ``y ≈ a·x + b`` with ``x`` the
reference grey levels: both are eliminated (variable projection). With ``Q`` an orthonormal
basis of ``span{1, x}`` (N x 2, from the reference alone: a constant), the residual is what the
best gain and offset leave,

    e = P y,         P = I - Q Qᵀ,

N components in grey levels of which N - 2 are free (``P`` has rank N - 2). ``P`` does not
depend on the unknowns, so the Jacobians are exactly ``P`` times those of ``y``:

    dy_i/dX_i = g_iᵀ dq_i/dX_i        (g_i the interpolated image's gradient at q_i)
    dX_i/dd   = r_i / (n·r_i)
    dX_i/dn   = -r_i X_iᵀ / (n·r_i)
    dy_i/dpose = g_iᵀ dq_i/dpose      (camera k's pose ``[rvec, C]``)

All patches of a block are evaluated together; the only loop is over the distinct cameras.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from aida_kb.constraints.factor import TextureImage
from aida_kb.errors import GeometryError, SolveError
from aida_kb.geometry.camera import PinholeCamera

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

MIN_INCIDENCE = 1e-9
"""|n·r| / |r| below this: a sample's ray runs along its plane and meets it nowhere (a face
seen edge-on; the builders drop faces seen far more obliquely than this)."""

FLAT_PATCH = 1e-9
"""A patch whose reference grey levels vary by less than this (their centred norm) has no
gain to fit: only its offset is eliminated."""


def bilinear(image: FloatArray, q: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Bilinear interpolation of ``image`` and its exact derivative.

    Parameters
    ----------
    image : (H, W) grey levels, pixel centres at integer coordinates (H, W >= 2).
    q : (S, 2) positions, pixels (x right, y down).

    Returns
    -------
    values : (S,) the interpolated grey levels; gradient : (S, 2) their derivative by x and y
    (the interpolant's own, piecewise constant across pixel cells). Outside the image the
    border's value is repeated and the derivative across the border is zero.
    """
    H, W = image.shape
    x = np.clip(q[:, 0], 0.0, W - 1.0)
    y = np.clip(q[:, 1], 0.0, H - 1.0)
    x0 = np.minimum(np.floor(x).astype(np.intp), W - 2)
    y0 = np.minimum(np.floor(y).astype(np.intp), H - 2)
    fx, fy = x - x0, y - y0
    i00, i01 = image[y0, x0], image[y0, x0 + 1]
    i10, i11 = image[y0 + 1, x0], image[y0 + 1, x0 + 1]
    top = i00 + fx * (i01 - i00)
    bottom = i10 + fx * (i11 - i10)
    values = top + fy * (bottom - top)
    inside_x = (q[:, 0] >= 0.0) & (q[:, 0] <= W - 1.0)
    inside_y = (q[:, 1] >= 0.0) & (q[:, 1] <= H - 1.0)
    gx = np.where(inside_x, (1.0 - fy) * (i01 - i00) + fy * (i11 - i10), 0.0)
    gy = np.where(inside_y, bottom - top, 0.0)
    return values, np.stack([gx, gy], axis=1)


def gain_offset_basis(values: FloatArray) -> FloatArray:
    """(M, N) unit vectors along each patch's centred reference grey levels ``values`` (M, N)
    (zero for a flat patch): with the constant ``1/sqrt(N)`` they span ``{1, x}``."""
    centred = values - values.mean(axis=1, keepdims=True)
    norm = np.linalg.norm(centred, axis=1, keepdims=True)
    out: FloatArray = np.where(norm > FLAT_PATCH, centred / np.maximum(norm, FLAT_PATCH), 0.0)
    return out


def _without_gain_offset(v: FloatArray, q2: FloatArray) -> FloatArray:
    """``P v`` along axis 1 of ``v`` (M, N, ...): the mean and the ``q2`` (M, N) component
    removed."""
    extra = (1,) * (v.ndim - 2)
    q = q2.reshape(*q2.shape, *extra)
    out: FloatArray = v - v.mean(axis=1, keepdims=True) - q * np.sum(q * v, axis=1, keepdims=True)
    return out


def texture_kernel(
    normals: FloatArray,
    offsets: FloatArray,
    idx: IntArray,
    cameras: Sequence[PinholeCamera],
    camera: IntArray,
    origin: FloatArray,
    rays: FloatArray,
    values: FloatArray,
    images: Sequence[TextureImage],
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Residuals of M texture patches and their Jacobians (module docstring).

    Parameters
    ----------
    normals : (P, 3), offsets : (P,) metres: the planes of all parts (``n·X = d``), world frame.
    idx : (M, 1) the part each patch lies on.
    cameras : the problem's cameras; camera : (M,) index of the camera that sees each patch.
    origin : (M, 3) metres, the reference camera's centre; rays : (M, N, 3) the sample pixels'
        ray directions, world frame; values : (M, N) their reference grey levels.
    images : (M,) each patch's `TextureImage` (one per camera).

    Returns
    -------
    r : (M, N) grey levels; J : (M, N, 1, 4) by the plane's ``(n, d)``; J_camera : (M, N, 6)
    by the pose ``[rvec, C]`` of the patch's camera.

    Raises
    ------
    SolveError
        When a sample's ray runs along its plane or its point lies behind the camera.
    """
    M, N = values.shape
    n = normals[idx[:, 0]]
    d = offsets[idx[:, 0]]
    nr = np.einsum("mi,mni->mn", n, rays)
    ray_len = np.linalg.norm(rays, axis=2)
    if np.any(np.abs(nr) < MIN_INCIDENCE * ray_len):
        bad = int(np.argmin(np.min(np.abs(nr) / ray_len, axis=1)))
        raise SolveError(
            f"texture constraint {bad}: a sample's ray runs along the plane of part "
            f"{int(idx[bad, 0])}"
        )
    t = (d - np.einsum("mi,mi->m", n, origin))[:, None] / nr
    X = origin[:, None, :] + t[:, :, None] * rays  # (M, N, 3)
    y = np.empty((M, N))
    dy_dX = np.empty((M, N, 3))
    dy_dpose = np.empty((M, N, 6))
    for c in np.unique(camera):
        sel = np.flatnonzero(camera == c)
        try:
            q, dq_dX, dq_dpose = cameras[int(c)].project_with_jacobians(X[sel].reshape(-1, 3))
        except GeometryError as exc:
            raise SolveError(f"texture constraints of camera {int(c)}: {exc}") from exc
        val, grad = bilinear(images[int(sel[0])].pixels, q)
        y[sel] = val.reshape(sel.size, N)
        dy_dX[sel] = np.einsum("si,sij->sj", grad, dq_dX).reshape(sel.size, N, 3)
        dy_dpose[sel] = np.einsum("si,sij->sj", grad, dq_dpose).reshape(sel.size, N, 6)
    g = dy_dX / nr[:, :, None]  # dy/dX scaled by 1/(n·r)
    J = np.empty((M, N, 1, 4))
    J[:, :, 0, :3] = -np.einsum("mn,mni->mni", np.einsum("mni,mni->mn", g, rays), X)
    J[:, :, 0, 3] = np.einsum("mni,mni->mn", g, rays)
    q2 = gain_offset_basis(values)
    r = _without_gain_offset(y, q2)
    J = _without_gain_offset(J, q2)
    Jc = _without_gain_offset(dy_dpose, q2)
    return r, J, Jc
