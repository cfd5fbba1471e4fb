"""Rotations as rotation vectors (axis times angle, radians), numpy only.

`rotation_from_rvec` is the exponential map (Rodrigues' formula), `rvec_from_rotation` its
inverse (the angle is in [0, pi]); `rotation_from_rvec_jacobian` gives the derivative of the
matrix with respect to the three components of the rotation vector itself (not a local
perturbation), so that least squares over a rotation vector can use it directly. Every function
is accurate to a few ulp for small angles (series expansions near 0) and near pi.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from aida_kb.errors import GeometryError

FloatArray = npt.NDArray[np.float64]

_SMALL_ANGLE = 0.05  # below this angle (radians) the Jacobian's coefficients use their series


def skew(v: npt.ArrayLike, *, check: bool = True) -> FloatArray:
    """The cross-product matrix [v]x, so that skew(v) @ w == cross(v, w).

    Parameters
    ----------
    v : (..., 3) array
    check : refuse non-finite components (`GeometryError`); the solver's kernels pass False
        and check their residuals instead (degenerate geometry is named by the caller).

    Returns
    -------
    (..., 3, 3) array
    """
    a = np.asarray(v, dtype=np.float64)
    if a.ndim < 1 or a.shape[-1] != 3:
        raise GeometryError(f"skew: vectors must have shape (..., 3), got {a.shape}")
    if check and not np.all(np.isfinite(a)):
        raise GeometryError("skew: vector has non-finite components")
    out = np.zeros((*a.shape[:-1], 3, 3))
    out[..., 0, 1] = -a[..., 2]
    out[..., 0, 2] = a[..., 1]
    out[..., 1, 0] = a[..., 2]
    out[..., 1, 2] = -a[..., 0]
    out[..., 2, 0] = -a[..., 1]
    out[..., 2, 1] = a[..., 0]
    return out


def _vector3(v: npt.ArrayLike, what: str) -> FloatArray:
    a = np.asarray(v, dtype=np.float64)
    if a.shape != (3,):
        raise GeometryError(f"{what} must have shape (3,), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise GeometryError(f"{what} has non-finite components: {a.tolist()}")
    return a


def _coefficients(theta: float) -> tuple[float, float]:
    """a = sin(theta)/theta and b = (1 - cos(theta))/theta**2, exact near 0."""
    a = float(np.sinc(theta / np.pi))
    half = float(np.sinc(theta / (2.0 * np.pi)))
    return a, 0.5 * half * half


def rotation_from_rvec(rvec: npt.ArrayLike) -> FloatArray:
    """The rotation matrix exp([rvec]x) of a rotation vector.

    Parameters
    ----------
    rvec : (3,) array, radians
        Unit axis times angle.

    Returns
    -------
    (3, 3) array
        A proper rotation (orthonormal, determinant +1).
    """
    v = _vector3(rvec, "rotation vector")
    a, b = _coefficients(float(np.linalg.norm(v)))
    S = skew(v)
    return np.eye(3) + a * S + b * (S @ S)


def rotation_from_rvec_jacobian(rvec: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
    """The rotation matrix and its derivative with respect to the rotation vector.

    Parameters
    ----------
    rvec : (3,) array, radians

    Returns
    -------
    R : (3, 3) array
        ``rotation_from_rvec(rvec)``.
    dR_drvec : (3, 3, 3) array, per radian
        ``dR_drvec[j, k, i] = d R[j, k] / d rvec[i]``.
    """
    v = _vector3(rvec, "rotation vector")
    theta = float(np.linalg.norm(v))
    a, b = _coefficients(theta)
    t2 = theta * theta
    if theta < _SMALL_ANGLE:
        # series of a'(theta)/theta and b'(theta)/theta
        c1 = -1.0 / 3.0 + t2 * (1.0 / 30.0 + t2 * (-1.0 / 840.0 + t2 / 45360.0))
        c2 = -1.0 / 12.0 + t2 * (1.0 / 180.0 + t2 * (-1.0 / 6720.0 + t2 / 453600.0))
    else:
        s, c = np.sin(theta), np.cos(theta)
        c1 = float((theta * c - s) / (t2 * theta))
        c2 = float((theta * s - 2.0 * (1.0 - c)) / (t2 * t2))
    S = skew(v)
    S2 = S @ S
    E = skew(np.eye(3))  # E[i] = [e_i]x
    dR = (
        c1 * v[:, None, None] * S + a * E + c2 * v[:, None, None] * S2 + b * (E @ S + S @ E)
    )  # (i, j, k)
    R = np.eye(3) + a * S + b * S2
    return R, np.moveaxis(dR, 0, -1)


def check_rotation(R: npt.ArrayLike, what: str = "rotation", tol: float = 1e-9) -> FloatArray:
    """`R` as a float (3, 3) array after checking it is a proper rotation to `tol`.

    Raises
    ------
    GeometryError
        If `R` is not (3, 3), not finite, not orthonormal or a reflection.
    """
    M = np.asarray(R, dtype=np.float64)
    if M.shape != (3, 3):
        raise GeometryError(f"{what} must have shape (3, 3), got {M.shape}")
    if not np.all(np.isfinite(M)):
        raise GeometryError(f"{what} has non-finite entries")
    err = float(np.max(np.abs(M.T @ M - np.eye(3))))
    if err > tol:
        raise GeometryError(f"{what} is not orthonormal (max |R^T R - I| = {err:.3g})")
    if np.linalg.det(M) < 0:
        raise GeometryError(f"{what} is a reflection (determinant -1), not a rotation")
    return M


def rvec_from_rotation(R: npt.ArrayLike) -> FloatArray:
    """The rotation vector of a rotation matrix (the logarithm map), angle in [0, pi].

    Parameters
    ----------
    R : (3, 3) array
        A proper rotation (checked to 1e-9).

    Returns
    -------
    (3,) array, radians
        At an angle of exactly pi either of the two opposite vectors may be returned.
    """
    M = check_rotation(R)
    w = 0.5 * np.array([M[2, 1] - M[1, 2], M[0, 2] - M[2, 0], M[1, 0] - M[0, 1]])  # sin(t)·u
    sin_t = float(np.linalg.norm(w))
    cos_t = float(np.clip(0.5 * (np.trace(M) - 1.0), -1.0, 1.0))
    theta = float(np.arctan2(sin_t, cos_t))
    if cos_t > -0.5:
        # theta / sin(theta) is well conditioned here; sinc handles theta -> 0
        if sin_t == 0.0:
            return np.zeros(3)
        return w / float(np.sinc(theta / np.pi))
    # near pi: the symmetric part is (1 - cos t) u u^T + cos t I
    B = 0.5 * (M + M.T) - cos_t * np.eye(3)
    j = int(np.argmax(np.diag(B)))
    u = B[:, j] / np.sqrt(B[j, j])
    u /= np.linalg.norm(u)
    if float(u @ w) < 0:
        u = -u
    out: FloatArray = theta * u
    return out
