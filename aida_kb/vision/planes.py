"""Certainty-weighted robust plane fits (paper §4.5: n_init, c_init, w_c).

A plane seen by a rectified pair is a plane in disparity space too: with rectified focal length
f, principal point (cx, cy) and baseline B, the plane n·x = D (rectified left camera frame)
has disparity d(u, v) = a·u + b·v + g with (a, b, (g + a·cx + b·cy)/f) = (B/D)·n. Stereo noise
is nearly uniform in disparity (pixels) but grows with depth² in metres, so the plane is
fitted where the noise is homoscedastic: a weighted least-squares fit of d(u, v), weights =
certainty, made robust by iterative reweighting (Tukey's biweight on the residuals scaled by
their median absolute deviation).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from aida_kb.errors import VisionError
from aida_kb.vision.rectify import sample_points

F64 = npt.NDArray[np.float64]
TUKEY_C = 4.685  # biweight tuning constant (95 % efficiency for Gaussian noise)
MIN_SCALE_PX = 0.05  # floor of the robust residual scale, pixels


@dataclass(frozen=True)
class DisparityPlane:
    """A plane in disparity space, d = a·u + b·v + g (u, v rectified pixels, d pixels).

    inliers : (N,) bool over the fitted samples; weights : (N,) final weights (certainty x
    robust); scale_px : robust residual scale, pixels.
    """

    a: float
    b: float
    g: float
    inliers: npt.NDArray[np.bool_]
    weights: F64
    scale_px: float

    def plane(self, focal_px: float, cx: float, cy: float, baseline_m: float) -> tuple[F64, float]:
        """The plane as (unit normal n, offset D) in the rectified left camera frame, n·x = D.

        n points towards the camera (D < 0: the camera centre lies on the side n points to).
        """
        m = np.array([self.a, self.b, (self.g + self.a * cx + self.b * cy) / focal_px])
        norm = float(np.linalg.norm(m))
        if norm == 0.0 or not np.isfinite(norm):
            raise VisionError("degenerate plane: zero disparity everywhere (at infinity)")
        n = m / norm
        D = baseline_m / norm
        # d > 0 in front of the camera means D > 0 for n = m/|m|; flip to face the camera
        return -n, -D


def fit_disparity_plane(
    u: F64, v: F64, d: F64, certainty: F64, *, iterations: int = 8
) -> DisparityPlane:
    """Robust certainty-weighted fit of d = a·u + b·v + g.

    Parameters
    ----------
    u, v : (N,) rectified pixel coordinates. d : (N,) disparities, pixels (finite).
    certainty : (N,) weights in [0, 1].

    Raises VisionError when fewer than 3 samples with positive weight remain.
    """
    u, v, d, w0 = (np.asarray(x, np.float64).ravel() for x in (u, v, d, certainty))
    if not (len(u) == len(v) == len(d) == len(w0)):
        raise VisionError("fit_disparity_plane: u, v, d and certainty differ in length")
    if not np.all(np.isfinite(d)):
        raise VisionError("fit_disparity_plane: disparities must be finite")
    if np.count_nonzero(w0 > 0) < 3:
        raise VisionError("fit_disparity_plane: fewer than 3 samples with positive certainty")
    # centre the design matrix for conditioning
    uc, vc = float(np.average(u, weights=w0)), float(np.average(v, weights=w0))
    A = np.stack([u - uc, v - vc, np.ones_like(u)], axis=1)
    w = w0.copy()
    coef = np.zeros(3)
    scale = 1.0
    for _ in range(iterations):
        sw = np.sqrt(w)
        coef, *_ = np.linalg.lstsq(A * sw[:, None], d * sw, rcond=None)
        r = d - A @ coef
        active = w > 0
        mad = float(np.median(np.abs(r[active] - np.median(r[active]))))
        scale = max(1.4826 * mad, MIN_SCALE_PX)
        t = r / (TUKEY_C * scale)
        robust = np.where(np.abs(t) < 1.0, (1.0 - t * t) ** 2, 0.0)
        w_new = w0 * robust
        if np.count_nonzero(w_new > 0) < 3:
            break
        w = w_new
    a, b, g0 = (float(c) for c in coef)
    inliers = w > 0
    return DisparityPlane(
        a=a, b=b, g=g0 - a * uc - b * vc, inliers=inliers, weights=w, scale_px=scale
    )


@dataclass(frozen=True)
class PhotometricPair:
    """A rectified pair prepared for direct plane alignment, all (H, W) float32.

    left, right : the images normalised by the mean and standard deviation of a square
    window around each pixel (removes gain and vignetting differences between the cameras).
    right_dx : horizontal derivative of `right` (per pixel). window : the normalisation
    window's side, pixels.
    """

    left: npt.NDArray[np.float32]
    right: npt.NDArray[np.float32]
    right_dx: npt.NDArray[np.float32]
    window: int


def photometric_pair(
    left: npt.NDArray[np.generic], right: npt.NDArray[np.generic], window: int = 11
) -> PhotometricPair:
    """`PhotometricPair` of a rectified grey pair (H, W); `window` odd, pixels."""
    if window < 3 or window % 2 == 0:
        raise VisionError(f"photometric_pair: window must be odd and >= 3, got {window}")
    ln, rn = (_local_normalise(np.asarray(x, np.float32), window) for x in (left, right))
    dx = np.asarray(cv2.Sobel(rn, cv2.CV_32F, 1, 0, ksize=1, scale=0.5), np.float32)
    return PhotometricPair(left=ln, right=rn, right_dx=dx, window=window)


def _local_normalise(img: npt.NDArray[np.float32], window: int) -> npt.NDArray[np.float32]:
    size = (window, window)
    mu = cv2.boxFilter(img, cv2.CV_32F, size, borderType=cv2.BORDER_REFLECT_101)
    sq = cv2.sqrBoxFilter(img, cv2.CV_32F, size, borderType=cv2.BORDER_REFLECT_101)
    sd = np.sqrt(np.maximum(sq - mu * mu, 1.0))
    return np.asarray((img - mu) / sd, np.float32)


PHOTO_MAX_SHIFT_PX = 1.0  # the refinement may move the fitted plane by at most this much


def refine_plane_photometric(
    pair: PhotometricPair,
    u: npt.NDArray[np.integer],
    v: npt.NDArray[np.integer],
    plane: DisparityPlane,
    *,
    iterations: int = 20,
) -> DisparityPlane | None:
    """Refine a disparity-space plane by aligning the images directly (no matcher in between).

    Minimises sum w·(L(u, v) - R(u - d(u, v), v))² over the region's pixels (u, v) (integer
    rectified pixel coordinates, (N,)), d = a·u + b·v + g, by Gauss-Newton with Tukey weights
    (pixels occluded in the right image or off the plane drop out). Unlike the per-pixel
    disparities, whose subpixel parabola is biased towards whole pixels ("pixel locking"),
    this has no bias from the fractional disparity, which matters on narrow faces spanning
    less than a pixel of disparity. Returns the refined plane (inliers and weights are those
    of the photometric fit over u, v), or None when it does not converge or would move the
    plane by more than PHOTO_MAX_SHIFT_PX anywhere in the region (no texture, bad start).
    """
    W = pair.left.shape[1]
    uf, vf = np.asarray(u, np.float64), np.asarray(v, np.float64)
    if len(uf) < 50:
        return None
    lv = pair.left[np.asarray(v, np.intp), np.asarray(u, np.intp)].astype(np.float64)
    uc, vc = float(uf.mean()), float(vf.mean())
    A = np.stack([uf - uc, vf - vc, np.ones_like(uf)], axis=1)
    p0 = np.array([plane.a, plane.b, plane.a * uc + plane.b * vc + plane.g])
    p = p0.copy()
    w = np.ones_like(uf)
    converged = False
    for _ in range(iterations):
        d = A @ p
        xs = uf - d
        rv = _sample(pair.right, xs, vf, cv2.INTER_CUBIC)
        gx = _sample(pair.right_dx, xs, vf, cv2.INTER_LINEAR)
        inside = (xs >= 1.0) & (xs <= W - 2.0)
        r = lv - rv
        mad = float(np.median(np.abs(r[inside]))) if inside.any() else 0.0
        scale = max(1.4826 * mad, 1e-3)
        t = r / (TUKEY_C * scale)
        w = np.where(inside & (np.abs(t) < 1.0), (1.0 - t * t) ** 2, 0.0)
        if np.count_nonzero(w) < 50:
            return None
        J = A * gx[:, None]
        Jw = J * w[:, None]
        try:
            step = -np.linalg.solve(Jw.T @ J, Jw.T @ r)
        except np.linalg.LinAlgError:
            return None
        p += step
        if float(np.max(np.abs(A @ step))) < 1e-4:
            converged = True
            break
    shift = float(np.max(np.abs(A @ (p - p0))))
    if not (converged and np.all(np.isfinite(p)) and shift <= PHOTO_MAX_SHIFT_PX):
        return None
    a, b, g0 = (float(x) for x in p)
    return DisparityPlane(
        a=a, b=b, g=g0 - a * uc - b * vc, inliers=w > 0, weights=w, scale_px=plane.scale_px
    )


def _sample(img: npt.NDArray[np.float32], x: F64, y: F64, interpolation: int) -> F64:
    """img at the points (x, y) (N,), interpolated; 0 outside (`rectify.sample_points`)."""
    return sample_points(img, x, y, interpolation=interpolation)


def plane_depth(rays: F64, n: F64, D: float) -> F64:
    """Depth scale s with s·ray on the plane n·x = D; rays (..., 3); NaN where parallel."""
    denom = rays @ n
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(np.abs(denom) > 1e-12, D / denom, np.nan)
    return np.asarray(s, np.float64)


GRAZING_COS = 0.05  # rays closer than ~3 degrees to the plane: footprint unbounded, left out


def pixel_areas_m2(rays: F64, n: F64, D: float, fx: float, fy: float) -> F64:
    """Area (m²) of the plane seen through each pixel (rays with z = 1, undistorted).

    A pixel's footprint on the plane n·x = D is z² / (fx·fy·|n·r|), z the depth along the ray
    r = (x, y, 1): the area of the projection of a 1/fx by 1/fy patch of the normalised image.
    NaN for rays within ~3 degrees of the plane (|n·r|/|r| < GRAZING_COS) or hitting it behind
    the camera.
    """
    denom = np.abs(rays @ n)
    cos = denom / np.linalg.norm(rays, axis=-1)
    z = plane_depth(rays, n, D)
    with np.errstate(divide="ignore", invalid="ignore"):
        area = np.where((cos > GRAZING_COS) & (z > 0), z * z / (fx * fy * denom), np.nan)
    return np.asarray(area, np.float64)
