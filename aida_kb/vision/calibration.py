"""Stereo calibration from chessboard views (Zhang's method: cv2.calibrateCamera and
cv2.stereoCalibrate; the paper used Tsai's), producing the scene format's calib.yaml.

Input: pairs of images of a planar chessboard with `pattern` = (columns, rows) inner corners
and square side `square_m` metres. Corners are found with cv2.findChessboardCornersSB
(subpixel accurate), falling back to cv2.findChessboardCorners + cornerSubPix. Each camera is
calibrated alone (k1 k2 p1 p2, k3 fixed at 0), then the pair with fixed intrinsics.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import numpy.typing as npt

from aida_kb.errors import VisionError
from aida_kb.io.scene import StereoCalib, read_image

F32 = npt.NDArray[np.float32]
F64 = npt.NDArray[np.float64]
MIN_VIEWS = 3


@dataclass(frozen=True)
class CalibrationResult:
    """A calibrated rig and how well the model fits the corners (RMS reprojection, pixels)."""

    calib: StereoCalib
    rms_left_px: float
    rms_right_px: float
    rms_stereo_px: float
    used: tuple[str, ...]
    rejected: tuple[str, ...]


def find_pairs(directory: str | os.PathLike[str]) -> list[tuple[Path, Path]]:
    """Left/right image pairs below `directory`: every *left*.png with its *right*.png twin.

    Works for a scene directory (views/NN/left.png, views/NN/right.png) and for flat folders
    (left_01.png, right_01.png). Sorted by path.
    """
    root = Path(directory)
    if not root.is_dir():
        raise VisionError(f"{root}: not a directory")
    pairs = []
    for left in sorted(root.rglob("*left*.png")):
        right = left.with_name(left.name.replace("left", "right"))
        if right.is_file():
            pairs.append((left, right))
    if not pairs:
        raise VisionError(f"{root}: no *left*.png / *right*.png image pairs found")
    return pairs


def find_corners(grey: npt.NDArray[np.uint8], pattern: tuple[int, int]) -> F32 | None:
    """Subpixel chessboard corners (N, 1, 2) float32, row by row, or None if not found."""
    ok, corners = cv2.findChessboardCornersSB(
        grey, pattern, flags=cv2.CALIB_CB_EXHAUSTIVE | cv2.CALIB_CB_ACCURACY
    )
    if ok:
        return np.asarray(corners, np.float32).reshape(-1, 1, 2)
    ok, corners = cv2.findChessboardCorners(
        grey, pattern, flags=cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
    )
    if not ok:
        return None
    crit = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 50, 1e-4)
    refined = cv2.cornerSubPix(grey, corners, (5, 5), (-1, -1), crit)
    return np.asarray(refined, np.float32).reshape(-1, 1, 2)


def board_points(pattern: tuple[int, int], square_m: float) -> F32:
    """The inner corners on the board plane (N, 3) float32, metres, z = 0, row by row."""
    cols, rows = pattern
    grid = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2).astype(np.float32)
    return np.hstack([grid * square_m, np.zeros((cols * rows, 1), np.float32)])


def calibrate_stereo(
    pairs: list[tuple[Path, Path]], pattern: tuple[int, int], square_m: float
) -> CalibrationResult:
    """Calibrate a stereo rig from chessboard image pairs (see module docstring).

    Views where either image shows no complete board are left out (listed in `rejected`);
    at least MIN_VIEWS must remain. Raises VisionError otherwise, FormatError for unreadable
    images.
    """
    if pattern[0] < 2 or pattern[1] < 2 or not (math.isfinite(square_m) and square_m > 0):
        raise VisionError(f"bad chessboard: {pattern[0]}x{pattern[1]} corners, square {square_m} m")
    obj = board_points(pattern, square_m)
    pts_l: list[F32] = []
    pts_r: list[F32] = []
    used: list[str] = []
    rejected: list[str] = []
    size: tuple[int, int] | None = None
    for left_path, right_path in pairs:
        left = read_image(left_path, grey=True)
        right = read_image(right_path, grey=True)
        here = (left.shape[1], left.shape[0])
        if right.shape != left.shape or (size is not None and here != size):
            raise VisionError(f"{right_path}: image size differs from the other images")
        size = here
        cl, cr = find_corners(left, pattern), find_corners(right, pattern)
        name = str(left_path.parent / left_path.stem)
        if cl is None or cr is None:
            rejected.append(name)
            continue
        pts_l.append(cl)
        pts_r.append(cr)
        used.append(name)
    if size is None or len(used) < MIN_VIEWS:
        raise VisionError(
            f"the chessboard ({pattern[0]}x{pattern[1]} inner corners) was found in both "
            f"images of only {len(used)} view(s); at least {MIN_VIEWS} are needed"
        )
    objs = [obj] * len(used)
    flags = cv2.CALIB_FIX_K3
    crit = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 100, 1e-9)
    rms_l, K1, D1, _, _ = cv2.calibrateCamera(
        objs, pts_l, size, None, None, flags=flags, criteria=crit
    )
    rms_r, K2, D2, _, _ = cv2.calibrateCamera(
        objs, pts_r, size, None, None, flags=flags, criteria=crit
    )
    rms_s, K1, D1, K2, D2, R, T, _, _ = cv2.stereoCalibrate(
        objs, pts_l, pts_r, K1, D1, K2, D2, size, flags=cv2.CALIB_FIX_INTRINSIC, criteria=crit
    )
    values = [np.asarray(x, np.float64) for x in (K1, D1, K2, D2, R, T)]
    if not all(np.all(np.isfinite(v)) for v in values):
        raise VisionError("calibration diverged (non-finite parameters)")
    calib = StereoCalib(
        K1=values[0],
        D1=values[1].ravel(),
        K2=values[2],
        D2=values[3].ravel(),
        R=values[4],
        T=values[5].ravel(),
        image_size=size,
    )
    return CalibrationResult(
        calib=calib,
        rms_left_px=float(rms_l),
        rms_right_px=float(rms_r),
        rms_stereo_px=float(rms_s),
        used=tuple(used),
        rejected=tuple(rejected),
    )
