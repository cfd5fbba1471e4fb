"""Rectification of a calibrated stereo pair to epipolar geometry, and the way back.

`stereo_rectification` takes the rotations R1, R2 of cv2.stereoRectify (Bouguet's: each
camera turned by half the relative rotation, then both so that the baseline is their x axis)
and chooses the rectified cameras so that the building is kept. Where cv2's own grid (alpha
0) keeps nearly all of the left image (MIN_KEPT_ALPHA0, nearly parallel rigs) it is used;
otherwise (cv2's alpha = 0 crops 25-42 % of real toed-in pairs, alpha = 1 shrinks them by
30 %) the focal length is the original left camera's (zoom 1: no resolution lost or invented)
and the rectified image is as large as the whole original left image seen through R1.
Both cameras share the principal point (zero disparity at infinity). A pair whose rectified
left image would be more than MAX_SIZE_FACTOR times the original's pixels, or would have to
show rays at more than MAX_RAY_ANGLE_DEG from its axis, is refused with the reason: that is
forward motion (the right camera in front of the left one), where planar rectification blows
the image up.

The rectified left camera is the original left camera turned by R1 (same centre): a point
x_orig in the original left camera frame is x_rect = R1·x_orig. Disparity d at a rectified
left pixel means depth z_rect = f·B / d.
`to_original` resamples any per-pixel map of the rectified left image back onto the original
(distorted) left image, so that evidence is given in the original camera.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from aida_kb.errors import VisionError
from aida_kb.io.scene import StereoCalib

F32 = npt.NDArray[np.float32]
F64 = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Rectification:
    """A rectified stereo rig and its remap tables.

    R1, R2 : (3, 3) rotations original -> rectified camera (left, right).
    P1, P2 : (3, 4) projection matrices of the rectified cameras (pixels; P2 holds -f·B).
    size : (width, height) of the original images, pixels.
    rect_size : (width, height) of the rectified images, pixels.
    map_left, map_right : two (H', W') float32 arrays (x, y): for each rectified pixel, where to
        sample the original image.
    inverse_left : two (H, W) float32 arrays (x, y): for each original left pixel, its
        position in the rectified left image.
    zoom : rectified focal length / original left focal length (fx).
    kept_fraction : fraction of the original left image's pixels inside the rectified image.
    """

    R1: F64
    R2: F64
    P1: F64
    P2: F64
    size: tuple[int, int]
    map_left: tuple[F32, F32]
    map_right: tuple[F32, F32]
    inverse_left: tuple[F32, F32]
    rect_size: tuple[int, int] = (0, 0)
    zoom: float = 1.0
    kept_fraction: float = 1.0

    @property
    def size_factor(self) -> float:
        """Pixels of the rectified image / pixels of the original."""
        W, H = self.size
        Wr, Hr = self.rect_size
        return (Wr * Hr) / max(1, W * H)

    def summary(self) -> str:
        """One line: rectified size, zoom and how much of the left image was kept."""
        Wr, Hr = self.rect_size
        return (
            f"rectified {Wr}x{Hr} ({self.size_factor:.2f}x the pixels), zoom {self.zoom:.2f}, "
            f"{100.0 * self.kept_fraction:.0f} % of the left image kept"
        )

    @property
    def focal_px(self) -> float:
        """Focal length of the rectified cameras, pixels."""
        return float(self.P1[0, 0])

    @property
    def baseline_m(self) -> float:
        """Baseline of the rectified pair, metres."""
        return float(-self.P2[0, 3] / self.P2[0, 0])

    def rectify(
        self, left: npt.NDArray[np.uint8], right: npt.NDArray[np.uint8]
    ) -> tuple[npt.NDArray[np.uint8], npt.NDArray[np.uint8]]:
        """Resample an original pair onto the rectified grids (bicubic: bilinear interpolation
        displaces fine texture towards whole source pixels, and the two cameras' sampling
        phases differ, which biases disparities by a few hundredths of a pixel)."""
        for what, img in (("left", left), ("right", right)):
            if img.shape[1::-1] != self.size:
                raise VisionError(
                    f"{what} image is {img.shape[1]}x{img.shape[0]}, the calibration is "
                    f"{self.size[0]}x{self.size[1]}"
                )
        rl = remap(left, self.map_left, border=0.0, interpolation=cv2.INTER_CUBIC)
        rr = remap(right, self.map_right, border=0.0, interpolation=cv2.INTER_CUBIC)
        return np.asarray(rl, np.uint8), np.asarray(rr, np.uint8)

    def points_from_disparity(self, disparity: F32) -> F32:
        """3-D points (H, W, 3), metres, in the ORIGINAL left camera frame; NaN where none.

        disparity : (H, W) float32 on the rectified left image, pixels, NaN where none.
        """
        H, W = disparity.shape
        f = self.focal_px
        cx, cy = self.P1[0, 2], self.P1[1, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            z = np.where(disparity > 0, f * self.baseline_m / disparity, np.nan)
        xs = (np.arange(W, dtype=np.float64) - cx) / f
        ys = (np.arange(H, dtype=np.float64) - cy) / self.P1[1, 1]
        pts = np.empty((H, W, 3), np.float64)
        pts[..., 0] = xs[None, :] * z
        pts[..., 1] = ys[:, None] * z
        pts[..., 2] = z
        # x_orig = R1^T · x_rect  (row vectors: x_rect · R1)
        return (pts @ self.R1).astype(np.float32)

    def to_original(self, values: npt.NDArray[np.generic], *, nearest: bool = False) -> F32:
        """Resample a map of the rectified left image onto the original left image.

        values : (H, W) or (H, W, C) float map on the rectified grid; NaN marks no value.
        Bilinear (any NaN neighbour gives NaN: no value is invented across a dropout) or
        nearest. Pixels that fall outside the rectified image get NaN.
        """
        arr = np.asarray(values, dtype=np.float32)
        return np.asarray(remap(arr, self.inverse_left, nearest=nearest), dtype=np.float32)


def remap(
    image: npt.NDArray[np.generic],
    xy: tuple[F32, F32],
    *,
    nearest: bool = False,
    border: float = float("nan"),
    interpolation: int | None = None,
) -> npt.NDArray[np.generic]:
    """Sample `image` at the positions `xy` (two (H, W) float32 maps, pixels); cv2.remap.

    Bilinear unless `nearest` or another cv2 `interpolation` flag is given; positions outside
    the image get `border`.
    """
    mode = cv2.INTER_NEAREST if nearest else cv2.INTER_LINEAR
    if interpolation is not None:
        mode = interpolation
    out = cv2.remap(
        np.asarray(image), xy[0], xy[1], mode, borderMode=cv2.BORDER_CONSTANT, borderValue=border
    )
    return np.asarray(out)


SAMPLE_ROW = 4096
"""`sample_points` lays its points out in rows of this many: cv2.remap's maps must stay below
32767 pixels a side."""


def sample_points(
    image: npt.NDArray[np.generic],
    x: npt.ArrayLike,
    y: npt.ArrayLike,
    *,
    interpolation: int = cv2.INTER_LINEAR,
    border: int = cv2.BORDER_CONSTANT,
) -> npt.NDArray[np.float64]:
    """``image`` (H, W) or (H, W, C) at N arbitrary points x, y (pixels, centres at integer
    coordinates), with cv2.remap's ``interpolation`` and ``border`` mode (constant: 0).

    Returns (N,) for a one-channel image, else (N, C), float64.
    """
    xs = np.asarray(x, dtype=np.float32).ravel()
    ys = np.asarray(y, dtype=np.float32).ravel()
    n = xs.size
    arr = np.asarray(image)
    channels = 1 if arr.ndim == 2 else int(arr.shape[2])
    rows = max(1, -(-n // SAMPLE_ROW))
    mx = np.zeros(rows * SAMPLE_ROW, np.float32)
    my = np.zeros(rows * SAMPLE_ROW, np.float32)
    mx[:n], my[:n] = xs, ys
    out = cv2.remap(
        arr,
        mx.reshape(rows, SAMPLE_ROW),
        my.reshape(rows, SAMPLE_ROW),
        interpolation,
        borderMode=border,
    )
    flat = np.asarray(out, dtype=np.float64).reshape(rows * SAMPLE_ROW, channels)[:n]
    return flat[:, 0] if arr.ndim == 2 else flat


def distort_pixels(pixels: F64, K: F64, D: F64) -> F64:
    """Pixels (N, 2) where pinhole camera K sees points, moved to the original (distorted)
    image: the inverse of `undistort_pixels`.

    OpenCV's distortion model; the common 4- and 5-coefficient forms (k1 k2 p1 p2 [k3]) are
    evaluated here, longer ones by ``cv2.projectPoints``. With no distortion (D empty or all
    zero) ``pixels`` is returned unchanged.
    """
    if D.size == 0 or not np.any(D) or pixels.shape[0] == 0:
        return pixels
    rays = np.linalg.solve(K, np.vstack([pixels.T, np.ones(len(pixels))])).T  # (N, 3)
    if D.size > 5:
        out, _ = cv2.projectPoints(rays, np.zeros(3), np.zeros(3), K, D)
        return np.asarray(out, np.float64).reshape(-1, 2)
    k = np.zeros(5)
    k[: D.size] = D.ravel()
    x, y = rays[:, 0] / rays[:, 2], rays[:, 1] / rays[:, 2]
    r2 = x * x + y * y
    radial = 1.0 + r2 * (k[0] + r2 * (k[1] + r2 * k[4]))
    xd = x * radial + 2.0 * k[2] * x * y + k[3] * (r2 + 2.0 * x * x)
    yd = y * radial + k[2] * (r2 + 2.0 * y * y) + 2.0 * k[3] * x * y
    return np.stack([K[0, 0] * xd + K[0, 1] * yd + K[0, 2], K[1, 1] * yd + K[1, 2]], axis=1)


def undistort_pixels(pixels: F64, K: F64, D: F64) -> F64:
    """Pixels (N, 2) of the original (distorted) image moved to where pinhole camera K sees them.

    Evidence pixels are those of the original image; the model's cameras are pinhole cameras.
    With no distortion (D empty or all zero) or no pixels, ``pixels`` is returned unchanged.
    """
    if D.size == 0 or not np.any(D) or pixels.shape[0] == 0:
        return pixels
    out = cv2.undistortPoints(pixels.reshape(-1, 1, 2), K, D, P=K)
    result: F64 = np.asarray(out, dtype=np.float64).reshape(-1, 2)
    return result


# Refusals. A rectified image more than this many times the original's pixels is forward
# motion being rectified: the epipole near the image, rays stretched towards infinity (Strecha's
# castle 21-22 blows cv2's focal length up 75 times); sane pairs need 1.0-1.3.
MAX_SIZE_FACTOR = 3.0
# ... and so is a ray of the original image more than this far from the rectified axis (its
# pixel would lie tan(80 deg) = 5.7 focal lengths from the principal point).
MAX_RAY_ANGLE_DEG = 80.0
BORDER_SAMPLES = 64  # points per side of the image whose rectified positions bound it
# cv2.stereoRectify's own grid (alpha 0: the largest rectangle of valid pixels, zoomed) is kept
# where it loses nothing that matters, less than 3 % of the left image, at a zoom of 0.8-1.5
# (nearly parallel rigs, the synthetic scenes). Its pixels are not the original's but
# interpolated in both images alike; moving the grid's sub-pixel phase changed the synthetic
# normals by up to 0.6 degree, so it is not moved without need.
MIN_KEPT_ALPHA0 = 0.97
MIN_ZOOM_ALPHA0 = 0.8
MAX_ZOOM_ALPHA0 = 1.5
KEPT_STEP_PX = 4


def stereo_rectification(calib: StereoCalib) -> Rectification:
    """Rectify the rig of `calib`, keeping the whole left image (see the module docstring).

    Raises VisionError for a vertical rig, and for a pair that cannot be rectified sanely
    (MAX_SIZE_FACTOR, MAX_RAY_ANGLE_DEG), saying why.
    """
    size = (int(calib.image_size[0]), int(calib.image_size[1]))
    try:
        R1_cv, R2_cv, P1_cv, P2_cv, _Q, _roi1, _roi2 = cv2.stereoRectify(
            calib.K1,
            calib.D1,
            calib.K2,
            calib.D2,
            size,
            calib.R,
            calib.T.reshape(3, 1),
            flags=cv2.CALIB_ZERO_DISPARITY,
            alpha=0.0,
        )
    except cv2.error as exc:
        raise VisionError(f"stereo rectification failed: {exc}") from None
    if abs(P2_cv[1, 3]) > 1e-9 * max(1.0, abs(P2_cv[0, 3])) or P2_cv[0, 3] >= 0:
        raise VisionError(
            "the stereo rig is not horizontal with the right camera on the right "
            "(vertical rigs are not supported)"
        )
    R1: F64 = np.asarray(R1_cv, np.float64)
    R2: F64 = np.asarray(R2_cv, np.float64)
    baseline_x = float(P2_cv[0, 3] / P2_cv[0, 0])  # (R2·T)_x, metres, negative
    W, H = size
    f = float(calib.K1[0, 0])
    rays = _border_rays(calib.K1, calib.D1, size) @ R1.T  # rectified left frame
    forward = math.degrees(math.asin(min(1.0, abs(float(calib.T[2])) / calib.baseline_m)))
    angle = np.degrees(np.arccos(np.clip(rays[:, 2] / np.linalg.norm(rays, axis=1), -1, 1)))
    if float(angle.max()) > MAX_RAY_ANGLE_DEG:
        raise VisionError(
            f"the pair cannot be rectified sanely: the left image would need rays "
            f"{angle.max():.0f} deg off the rectified axis (limit {MAX_RAY_ANGLE_DEG:.0f}); the "
            f"right camera lies {forward:.0f} deg in front of or behind the left one's image "
            "plane (forward motion); take pairs side by side"
        )
    xy = rays[:, :2] / rays[:, 2:]
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    Wr = math.ceil(f * float(hi[0] - lo[0])) + 1
    Hr = math.ceil(f * float(hi[1] - lo[1])) + 1
    factor = Wr * Hr / (W * H)
    # the right image may reach further left than the left one (a toed-in rig): the grid starts
    # where it starts, so that the left image's left part keeps its partners (x_r = x_l - d);
    # else a wall's left part has no depth (castle: 12 % of the main wall)
    right_rays = _border_rays(calib.K2, calib.D2, size) @ R2.T
    right_ok = right_rays[:, 2] > 1e-6
    if np.any(right_ok):
        right_lo = float(np.min(right_rays[right_ok, 0] / right_rays[right_ok, 2]))
        extra = max(0, math.ceil(f * (float(lo[0]) - right_lo)))
        extra = min(extra, max(0, int(MAX_SIZE_FACTOR * W * H / Hr) - Wr))
        lo = lo - np.array([extra / f, 0.0])
        Wr += extra
    if factor > MAX_SIZE_FACTOR:
        raise VisionError(
            f"the pair cannot be rectified sanely: keeping the left image at its resolution "
            f"needs a {Wr}x{Hr} image ({factor:.1f}x its pixels, limit {MAX_SIZE_FACTOR:g}); the "
            f"right camera lies {forward:.0f} deg in front of or behind the left one's image "
            "plane (forward motion); take pairs side by side"
        )
    K_rect = np.array([[f, 0.0, -f * float(lo[0])], [0.0, f, -f * float(lo[1])], [0, 0, 1.0]])
    rect_size = (Wr, Hr)
    K_cv = np.asarray(P1_cv, np.float64)[:, :3]
    zoom_cv = float(K_cv[0, 0]) / f
    if MIN_ZOOM_ALPHA0 <= zoom_cv <= MAX_ZOOM_ALPHA0 and (
        _kept(calib, R1, K_cv, size) >= MIN_KEPT_ALPHA0
    ):
        K_rect, rect_size = K_cv, size  # cv2's grid crops nothing that matters: keep it
    P1 = np.hstack([K_rect, np.zeros((3, 1))])
    P2 = np.hstack([K_rect, K_rect @ np.array([[baseline_x], [0.0], [0.0]])])
    m1x, m1y = cv2.initUndistortRectifyMap(calib.K1, calib.D1, R1, P1, rect_size, cv2.CV_32FC1)
    m2x, m2y = cv2.initUndistortRectifyMap(calib.K2, calib.D2, R2, P2, rect_size, cv2.CV_32FC1)
    ys, xs = np.mgrid[0:H, 0:W].astype(np.float64)
    pts = np.stack([xs.ravel(), ys.ravel()], axis=1).reshape(-1, 1, 2)
    inv = cv2.undistortPoints(
        pts,
        calib.K1,
        calib.D1,
        R=R1,
        P=P1,
        criteria=(cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 40, 1e-6),
    )
    inv_xy = np.asarray(inv, np.float32).reshape(H, W, 2)
    inside = _inside(inv_xy, rect_size)
    return Rectification(
        R1=R1,
        R2=R2,
        P1=P1,
        P2=P2,
        size=size,
        map_left=(np.asarray(m1x, np.float32), np.asarray(m1y, np.float32)),
        map_right=(np.asarray(m2x, np.float32), np.asarray(m2y, np.float32)),
        inverse_left=(
            np.ascontiguousarray(inv_xy[..., 0], np.float32),
            np.ascontiguousarray(inv_xy[..., 1], np.float32),
        ),
        rect_size=rect_size,
        zoom=float(K_rect[0, 0]) / f,
        kept_fraction=float(np.mean(inside)),
    )


def _inside(xy: F32 | F64, size: tuple[int, int]) -> npt.NDArray[np.bool_]:
    """Which positions (..., 2) (x, y), pixels, lie inside an image of `size` (width, height)."""
    W, H = size
    inside: npt.NDArray[np.bool_] = (
        (xy[..., 0] >= -0.5)
        & (xy[..., 0] <= W - 0.5)
        & (xy[..., 1] >= -0.5)
        & (xy[..., 1] <= H - 0.5)
    )
    return inside


def _kept(calib: StereoCalib, R1: F64, K_rect: F64, size: tuple[int, int]) -> float:
    """Fraction of the original left image inside the rectified image of camera K_rect (3, 3)
    and `size`, sampled every KEPT_STEP_PX pixels."""
    W, H = calib.image_size
    ys, xs = np.mgrid[0:H:KEPT_STEP_PX, 0:W:KEPT_STEP_PX].astype(np.float64)
    pts = np.stack([xs.ravel(), ys.ravel()], axis=1).reshape(-1, 1, 2)
    P = np.hstack([K_rect, np.zeros((3, 1))])
    xy = np.asarray(cv2.undistortPoints(pts, calib.K1, calib.D1, R=R1, P=P), np.float64)
    return float(np.mean(_inside(xy.reshape(-1, 2), size)))


def _border_rays(K: F64, D: F64, size: tuple[int, int]) -> F64:
    """Viewing rays (N, 3) (x, y, 1) of points along an image's border, its camera's frame."""
    W, H = size
    t = np.linspace(0.0, 1.0, BORDER_SAMPLES)
    xs = np.concatenate([t * (W - 1), np.full_like(t, W - 1.0), t * (W - 1), np.zeros_like(t)])
    ys = np.concatenate([np.zeros_like(t), t * (H - 1), np.full_like(t, H - 1.0), t * (H - 1)])
    pts = np.stack([xs, ys], axis=1).reshape(-1, 1, 2)
    crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 40, 1e-8)
    norm = np.asarray(cv2.undistortPoints(pts, K, D, criteria=crit), np.float64)
    norm = norm.reshape(-1, 2)
    return np.hstack([norm, np.ones((len(norm), 1))])
