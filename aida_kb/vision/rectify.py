"""Rectification of a calibrated stereo pair to epipolar geometry, and the way back.

`stereo_rectification` wraps cv2.stereoRectify (zero-disparity principal points, no scaling
crop: alpha = 0) and builds the remap tables. The rectified left camera is the original left
camera turned by R1 (same centre): a point x_orig in the original left camera frame is
x_rect = R1·x_orig. Disparity d at a rectified left pixel means depth z_rect = f·B / d.
`to_original` resamples any per-pixel map of the rectified left image back onto the original
(distorted) left image, so that evidence is given in the original camera.
"""

from __future__ import annotations

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
    size : (width, height) of the original and the rectified images.
    map_left, map_right : two (H, W) float32 arrays (x, y): for each rectified pixel, where to
        sample the original image.
    inverse_left : two (H, W) float32 arrays (x, y): for each original left pixel, its
        position in the rectified left image.
    """

    R1: F64
    R2: F64
    P1: F64
    P2: F64
    size: tuple[int, int]
    map_left: tuple[F32, F32]
    map_right: tuple[F32, F32]
    inverse_left: tuple[F32, F32]

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


def stereo_rectification(calib: StereoCalib) -> Rectification:
    """Rectify the rig of `calib` (cv2.stereoRectify with CALIB_ZERO_DISPARITY, alpha 0)."""
    size = (int(calib.image_size[0]), int(calib.image_size[1]))
    try:
        R1, R2, P1, P2, _Q, _roi1, _roi2 = cv2.stereoRectify(
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
    if abs(P2[1, 3]) > 1e-9 * max(1.0, abs(P2[0, 3])) or P2[0, 3] >= 0:
        raise VisionError(
            "the stereo rig is not horizontal with the right camera on the right "
            "(vertical rigs are not supported)"
        )
    m1x, m1y = cv2.initUndistortRectifyMap(calib.K1, calib.D1, R1, P1, size, cv2.CV_32FC1)
    m2x, m2y = cv2.initUndistortRectifyMap(calib.K2, calib.D2, R2, P2, size, cv2.CV_32FC1)
    W, H = size
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
    return Rectification(
        R1=np.asarray(R1, np.float64),
        R2=np.asarray(R2, np.float64),
        P1=np.asarray(P1, np.float64),
        P2=np.asarray(P2, np.float64),
        size=size,
        map_left=(np.asarray(m1x, np.float32), np.asarray(m1y, np.float32)),
        map_right=(np.asarray(m2x, np.float32), np.asarray(m2y, np.float32)),
        inverse_left=(
            np.ascontiguousarray(inv_xy[..., 0], np.float32),
            np.ascontiguousarray(inv_xy[..., 1], np.float32),
        ),
    )
