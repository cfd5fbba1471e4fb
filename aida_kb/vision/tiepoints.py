"""Tie points between two views: the same scene point found in both views' left images.

Features are OpenCV's SIFT (Lowe 2004) in each left image, undistorted with the view's
calibration to normalised rays of its pinhole camera. Two views' features are paired by the
mutual nearest neighbour with Lowe's ratio test, optionally only within a band about the
epipolar lines of a prior relative pose (guided matching). The relative pose of the two
cameras follows from a RANSAC essential matrix (OpenCV's USAC MAGSAC++) and
`cv2.recoverPose`, or is refined from a prior on the Sampson distance with a robust loss.

Frames: a view's camera frame is OpenCV's (x right, y down, z forward). A relative pose
(R, t) maps view a's camera frame to view b's: ``x_b = R x_a + t``; the essential matrix is
``E = [t]x R`` and ``x_b^T E x_a = 0`` for normalised homogeneous rays x_a, x_b of one point.
Epipolar constraints fix the rotation and the direction of t only, never its length.

Measured on dev scenes 61700-61735 (`benchmarks/tiepoints.py`, session 17; 48 view pairs):
the rendered scenes' repetitive textures (bricks, tiles, windows, the tiled ground) and the
24-63 deg between views leave 32 % of the guided pairs within 1 px of the true epipolar line
(median; 16-61 % from the 10th to the 90th percentile). Even the pairs the truth accepts fix
the turn about the camera's vertical only to 0.49 deg (median sd; 0.19-1.33 deg from the 10th
to the 90th percentile) in a 38 deg field of view: that turn moves points along the (nearly
horizontal) epipolar lines and trades against the translation's direction. Tilt and roll
they fix to 0.03 and 0.05 deg (median sd; 0.15 and 0.23 at the 90th percentile).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt
from scipy.optimize import least_squares

from aida_kb.errors import VisionError
from aida_kb.geometry.rotation import rotation_from_rvec, rvec_from_rotation, skew
from aida_kb.vision.rectify import undistort_pixels

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
BoolArray = npt.NDArray[np.bool_]

MAX_FEATURES = 4000
"""SIFT keypoints kept per image (the strongest): the guided match compares every pair, so
the distance table of two images holds at most 16 million float32 entries (64 MB)."""
SIFT_CONTRAST = 0.01
"""SIFT's contrast threshold, below OpenCV's 0.04: at 0.04 the rendered scenes' dark roofs
and walls give only 82-340 keypoints per 800 x 600 view (dev 61700, 61733), at 0.01 about
1,100-2,800 (measured with `benchmarks/tiepoints.py`)."""
RATIO = 0.8
"""Lowe's ratio test: the nearest descriptor must be closer than this times the second
nearest (Lowe 2004, Fig. 11: 0.8 keeps 95 % of the right pairs and drops 90 % of the
wrong ones)."""
GUIDED_RATIO = 0.9
"""The ratio test within an epipolar band, looser: the band already removes most rivals."""
RANSAC_PX = 1.0
"""RANSAC's inlier threshold for the essential matrix, pixels: about three times the 0.3 px
of a SIFT keypoint's position in a sharp image."""
RANSAC_CONFIDENCE = 0.9999
"""RANSAC's probability of drawing at least one all-inlier sample."""
ROBUST_SCALE_PX = 1.0
"""Where the refinement's Huber loss turns linear, pixels (as `RANSAC_PX`)."""
KEPT_SIGMAS = 3.0
"""After the first robust refinement, pairs more than this many robust sds (1.4826 x the
median absolute residual) from their epipolar line are left out, and the pose is refined
again by least squares on the rest (a mismatch within the Huber loss's linear part still
pulls: on the test's planes, 1 % of guided pairs 1-8 px off biased the rotation by 0.02 deg
with a 3 px cut, 0.004 deg with this one)."""
MAD_SCALE = 1.4826
"""The median absolute deviation of a normal distribution times this is its sd."""
MIN_PAIRS = 8
"""Fewest pairs a relative pose is estimated from (the eight-point algorithm's minimum; the
five-point solver needs five, but its RANSAC needs more to tell inliers)."""


@dataclass(frozen=True)
class Features:
    """SIFT features of one left image.

    pixels : (N, 2) float64, pixels of the original (distorted) image, x right, y down.
    rays : (N, 3) float64, the undistorted normalised homogeneous rays ``K^-1 (u, v, 1)`` of
        the view's pinhole camera (camera frame, third component 1).
    descriptors : (N, 128) float32, SIFT descriptors.
    focal_px : float, the camera's mean focal length, pixels (turns ray distances into pixels).
    """

    pixels: FloatArray
    rays: FloatArray
    descriptors: npt.NDArray[np.float32]
    focal_px: float


@dataclass(frozen=True)
class RelativePose:
    """The pose of view b's camera relative to view a's: ``x_b = R x_a + t``, |t| = 1.

    R : (3, 3) rotation. t : (3,) unit translation direction (its length is not observable).
    inliers : (M,) bool over the pairs it was estimated from.
    covariance : (5, 5) or None, radians²: the rotation vector's three components (a small
        turn applied before R, in view b's frame) and two of the direction's tangent plane.
    sigma_px : float, the kept pairs' residual standard deviation, pixels (NaN if unknown).
    """

    R: FloatArray
    t: FloatArray
    inliers: BoolArray
    covariance: FloatArray | None = None
    sigma_px: float = float("nan")

    def rotation_sd_deg(self) -> float:
        """The rotation's standard deviation per axis (RMS of the three), degrees."""
        if self.covariance is None:
            return float("nan")
        return float(np.degrees(np.sqrt(np.trace(self.covariance[:3, :3]) / 3.0)))


def features(grey: npt.NDArray[np.uint8], K: FloatArray, D: FloatArray) -> Features:
    """SIFT features of a grey image (H, W) uint8 of a camera with matrix K (3, 3) pixels and
    OpenCV distortion D (k1 k2 p1 p2 [k3 ...])."""
    sift = cv2.SIFT_create(  # type: ignore[attr-defined]
        nfeatures=MAX_FEATURES, contrastThreshold=SIFT_CONTRAST
    )
    keypoints, desc = sift.detectAndCompute(grey, None)
    if not keypoints:
        empty = np.zeros((0, 2))
        return Features(empty, np.zeros((0, 3)), np.zeros((0, 128), np.float32), _focal(K))
    pixels = np.array([k.pt for k in keypoints], dtype=np.float64)
    pinhole = undistort_pixels(pixels, K, np.asarray(D, dtype=np.float64).ravel())
    rays = np.c_[pinhole, np.ones(len(pinhole))] @ np.linalg.inv(K).T
    return Features(pixels, rays, np.asarray(desc, dtype=np.float32), _focal(K))


def _focal(K: FloatArray) -> float:
    return float(0.5 * (K[0, 0] + K[1, 1]))


def essential(R: FloatArray, t: FloatArray) -> FloatArray:
    """The essential matrix ``[t]x R`` (3, 3) of the relative pose ``x_b = R x_a + t``."""
    out: FloatArray = skew(t) @ R
    return out


def relative_pose(
    R_a: FloatArray, t_a: FloatArray, R_b: FloatArray, t_b: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """The relative pose (R, t) of camera b to camera a, both given world -> camera
    (``x_cam = R_cam_world x + t``): ``x_b = R x_a + t``, t in the world's units."""
    R = R_b @ R_a.T
    return R, t_b - R @ t_a


def sampson_px(
    E: FloatArray, rays_a: FloatArray, rays_b: FloatArray, focal_px: float
) -> FloatArray:
    """Signed Sampson distances (N,) of pairs of rays (N, 3) from the epipolar constraint of
    E (3, 3), in pixels of a camera with focal length `focal_px` (the first-order distance of
    the pair, in both images together, from a pair that meets the constraint exactly)."""
    Ea = rays_a @ E.T
    Eb = rays_b @ E
    num = np.einsum("ij,ij->i", rays_b, Ea)
    den = np.sqrt(Ea[:, 0] ** 2 + Ea[:, 1] ** 2 + Eb[:, 0] ** 2 + Eb[:, 1] ** 2)
    out: FloatArray = focal_px * num / np.maximum(den, 1e-300)
    return out


def _descriptor_distances(a: Features, b: Features) -> npt.NDArray[np.float32]:
    """Euclidean distances (Na, Nb) between the two images' descriptors."""
    da, db = a.descriptors, b.descriptors
    sq = (da * da).sum(1)[:, None] + (db * db).sum(1)[None, :] - 2.0 * (da @ db.T)
    out: npt.NDArray[np.float32] = np.sqrt(np.maximum(sq, 0.0)).astype(np.float32)
    return out


def match(
    a: Features, b: Features, prior_E: FloatArray | None = None, band_px: float = 0.0
) -> tuple[IntArray, IntArray]:
    """Pairs of features (indices into a and b, (M,) each): mutual nearest neighbours that
    pass the ratio test (`RATIO`).

    With a prior essential matrix `prior_E` (3, 3; ``x_b^T E x_a = 0``), only features of b
    within `band_px` pixels of a feature's epipolar line in b compete for it (guided
    matching), and the ratio test is `GUIDED_RATIO`.
    """
    if len(a.rays) < 2 or len(b.rays) < 2:
        return np.zeros(0, np.intp), np.zeros(0, np.intp)
    dist = _descriptor_distances(a, b)
    ratio = RATIO
    if prior_E is not None:
        lines = a.rays @ prior_E.T
        off = np.abs(lines @ b.rays.T) / np.hypot(lines[:, 0], lines[:, 1])[:, None]
        dist[off * b.focal_px > band_px] = np.inf
        ratio = GUIDED_RATIO
    rows = np.arange(len(dist))
    two = np.argpartition(dist, 1, axis=1)[:, :2]
    d2 = dist[rows[:, None], two]
    order = np.argsort(d2, axis=1)
    nearest = two[rows, order[:, 0]]
    best, second = d2[rows, order[:, 0]], d2[rows, order[:, 1]]
    mutual = np.argmin(dist, axis=0)[nearest] == rows
    keep = np.isfinite(best) & (best < ratio * second) & mutual
    return rows[keep].astype(np.intp), nearest[keep].astype(np.intp)


def ransac_pose(rays_a: FloatArray, rays_b: FloatArray, focal_px: float) -> RelativePose:
    """The relative pose of paired rays (M, 3) each, from a RANSAC essential matrix
    (USAC MAGSAC++, threshold `RANSAC_PX`) and the cheirality test of `cv2.recoverPose`.

    Raises VisionError with fewer than `MIN_PAIRS` pairs or when no essential matrix is found.
    """
    if len(rays_a) < MIN_PAIRS:
        raise VisionError(f"{len(rays_a)} tie points: at least {MIN_PAIRS} are needed")
    xa = np.ascontiguousarray(rays_a[:, :2])
    xb = np.ascontiguousarray(rays_b[:, :2])
    E, mask = cv2.findEssentialMat(
        xa,
        xb,
        np.eye(3),
        method=cv2.USAC_MAGSAC,
        prob=RANSAC_CONFIDENCE,
        threshold=RANSAC_PX / focal_px,
    )
    if E is None or mask is None or E.shape != (3, 3):
        raise VisionError(f"no essential matrix fits the {len(rays_a)} tie points")
    inliers = mask.ravel().astype(bool)
    _, R, t, _ = cv2.recoverPose(E, xa[inliers], xb[inliers], np.eye(3))
    return RelativePose(np.asarray(R, np.float64), np.asarray(t, np.float64).ravel(), inliers)


def _tangent(t: FloatArray) -> FloatArray:
    """Two unit vectors (2, 3) orthogonal to the unit vector t (3,) and to each other."""
    basis: FloatArray = np.linalg.svd(t[None, :])[2][1:]
    return basis


def _pose_of(p: FloatArray, R0: FloatArray, t0: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The pose at parameters p (5,): a turn p[:3] (rotation vector, rad) applied after R0,
    and the unit direction t0 moved by p[3:] in its tangent plane."""
    R = rotation_from_rvec(p[:3]) @ R0
    t = t0 + _tangent(t0).T @ p[3:]
    return R, t / np.linalg.norm(t)


def refined_pose(
    rays_a: FloatArray, rays_b: FloatArray, focal_px: float, R0: FloatArray, t0: FloatArray
) -> RelativePose:
    """The relative pose refined from (R0, t0) on the pairs' Sampson distances (pixels) with a
    Huber loss (`ROBUST_SCALE_PX`); the pairs beyond `KEPT_SIGMAS` robust sds are then left
    out and the pose refined again by least squares. Its covariance is the Gauss-Newton one of
    the kept pairs scaled by their residual variance.

    Raises VisionError with fewer than `MIN_PAIRS` pairs.
    """
    if len(rays_a) < MIN_PAIRS:
        raise VisionError(f"{len(rays_a)} tie points: at least {MIN_PAIRS} are needed")
    u0 = np.asarray(t0, np.float64) / np.linalg.norm(t0)

    def residuals(p: FloatArray, xa: FloatArray, xb: FloatArray) -> FloatArray:
        return sampson_px(essential(*_pose_of(p, R0, u0)), xa, xb, focal_px)

    first = least_squares(
        residuals, np.zeros(5), loss="huber", f_scale=ROBUST_SCALE_PX, args=(rays_a, rays_b)
    )
    cut = KEPT_SIGMAS * MAD_SCALE * float(np.median(np.abs(first.fun)))
    kept = np.abs(first.fun) <= cut
    if kept.sum() < MIN_PAIRS:
        raise VisionError(f"{int(kept.sum())} tie points within {cut:.3g} px of their line")
    fit = least_squares(residuals, first.x, args=(rays_a[kept], rays_b[kept]))
    J = fit.jac
    sigma = float(np.sqrt(np.sum(fit.fun**2) / max(int(kept.sum()) - 5, 1)))
    covariance = np.linalg.pinv(J.T @ J) * sigma**2
    R, t = _pose_of(fit.x, R0, u0)
    return RelativePose(R, t, kept, covariance, sigma)


def rotation_angle_deg(R: FloatArray) -> float:
    """The angle of the rotation R (3, 3), degrees."""
    return float(np.degrees(np.linalg.norm(rvec_from_rotation(R))))
