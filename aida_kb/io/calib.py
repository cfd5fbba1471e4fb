"""calib.yaml: a calibrated stereo rig (`StereoCalib`) as cv2.FileStorage writes it, read with
every field validated and written atomically; the working resolution and memory a pair of a
given size needs (docs/formats.md)."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from aida_kb.errors import FormatError
from aida_kb.io.atomic import atomic_path
from aida_kb.io.jsonio import read_text_file
from aida_kb.limits import (
    BYTES_PER_PIXEL,
    MAX_CALIB_BYTES,
    MEMORY_BUDGET_ENV,
    memory_budget,
    nesting_problem,
)

FloatArray = npt.NDArray[np.float64]


_D_LENGTHS = (4, 5, 8, 12, 14)


@dataclass(frozen=True)
class StereoCalib:
    """A calibrated stereo rig in OpenCV's stereoCalibrate conventions.

    K1, K2 : (3, 3) camera matrices, pixels. D1, D2 : (5,) distortion k1 k2 p1 p2 k3 (or any
    length OpenCV accepts: 4, 5, 8, 12, 14). R : (3, 3) and T : (3,) metres, mapping left-camera
    to right-camera coordinates, x_right = R·x_left + T. image_size : (width, height), pixels.
    """

    K1: FloatArray
    D1: FloatArray
    K2: FloatArray
    D2: FloatArray
    R: FloatArray
    T: FloatArray
    image_size: tuple[int, int]

    def __post_init__(self) -> None:
        sizes = {"K1": (9,), "D1": _D_LENGTHS, "K2": (9,), "D2": _D_LENGTHS, "R": (9,), "T": (3,)}
        for name, allowed in sizes.items():
            arr = np.asarray(getattr(self, name), dtype=np.float64)
            if arr.size not in allowed:
                raise FormatError(f"stereo calibration: field {name}: has {arr.size} elements")
            if not np.all(np.isfinite(arr)):
                raise FormatError(f"stereo calibration: field {name}: contains NaN or infinity")
        w, h = self.image_size
        if not (int(w) == w > 0 and int(h) == h > 0):
            raise FormatError(f"stereo calibration: image size {w}x{h} is not positive pixels")

    @property
    def baseline_m(self) -> float:
        """Distance between the two camera centres, metres."""
        return float(np.linalg.norm(self.T))


# Photos of 12-24 megapixels are matched at a working resolution of at most this many pixels
# (about 1730x1150 at 3:2): dense matching costs pixels x disparities, i.e. grows with the
# 1.5th power of the pixels (a 24 MP pair at full size: about 60 times the work and 7 GB of
# cost volumes), while the evidence needs plane normals, which come from thousands of pixels
# per face even at this size (the real scenes' walls within 0.7 deg at 0.7 MP). Line segments
# are still found on the full image, whose pixels the evidence is given in.
WORKING_MAX_PIXELS = 2_000_000


def working_scale(width: int, height: int) -> float:
    """The factor (<= 1) that takes a `width` x `height` image to the working resolution."""
    pixels = width * height
    return 1.0 if pixels <= WORKING_MAX_PIXELS else math.sqrt(WORKING_MAX_PIXELS / pixels)


def working_size(width: int, height: int) -> tuple[int, int]:
    """(width, height) of a `width` x `height` image at the working resolution."""
    s = working_scale(width, height)
    return (width, height) if s == 1.0 else (max(1, round(width * s)), max(1, round(height * s)))


# Peak memory per pixel of the FULL images beyond the working resolution's BYTES_PER_PIXEL
# (aida_kb.limits): the images themselves, the line segments found on them and the depth and
# region maps given back in their pixels. benchmarks/real.py measured a 17.5-megapixel pair
# (working 1732x1155) at a peak of 1.47 GB: 0.6 GB for the working size, 50 bytes a full pixel.
FULL_BYTES_PER_PIXEL = 60


def memory_problem(width: int, height: int) -> str | None:
    """Why a scene of `width` x `height` images is over the memory budget of a run, or None
    (the working resolution's cost and the full images', see FULL_BYTES_PER_PIXEL)."""
    ww, wh = working_size(width, height)
    need = BYTES_PER_PIXEL * ww * wh + FULL_BYTES_PER_PIXEL * width * height
    budget = memory_budget()
    if need <= budget:
        return None
    return (
        f"images of {width}x{height} pixels need about {need / 2**30:.1f} GiB "
        f"(matched at {ww}x{wh}), more than the memory budget of "
        f"{budget / 2**30:.1f} GiB (set {MEMORY_BUDGET_ENV} to change it)"
    )


def scaled_calib(calib: StereoCalib, size: tuple[int, int]) -> StereoCalib:
    """`calib` for its images resampled to `size` (width, height): K rows scaled about pixel
    centres at integer coordinates (c' = (c + 0.5)·s - 0.5), distortion and pose unchanged."""
    W, H = calib.image_size
    sx, sy = size[0] / W, size[1] / H

    def scale(K: FloatArray) -> FloatArray:
        out = np.array(K, dtype=np.float64)
        out[0, :] *= sx
        out[1, :] *= sy
        out[0, 2] += 0.5 * sx - 0.5
        out[1, 2] += 0.5 * sy - 0.5
        return out

    return replace(calib, K1=scale(calib.K1), K2=scale(calib.K2), image_size=size)


def write_calib(path: str | os.PathLike[str], calib: StereoCalib) -> None:
    """Write `calib` with cv2.FileStorage (YAML), atomically."""
    import cv2

    target = Path(path)
    with atomic_path(target) as tmp:
        fs = cv2.FileStorage(str(tmp), cv2.FILE_STORAGE_WRITE)
        try:
            fs.write("image_width", int(calib.image_size[0]))
            fs.write("image_height", int(calib.image_size[1]))
            fs.write("K1", np.asarray(calib.K1, dtype=np.float64).reshape(3, 3))
            fs.write("D1", np.asarray(calib.D1, dtype=np.float64).reshape(1, -1))
            fs.write("K2", np.asarray(calib.K2, dtype=np.float64).reshape(3, 3))
            fs.write("D2", np.asarray(calib.D2, dtype=np.float64).reshape(1, -1))
            fs.write("R", np.asarray(calib.R, dtype=np.float64).reshape(3, 3))
            fs.write("T", np.asarray(calib.T, dtype=np.float64).reshape(3, 1))
        finally:
            fs.release()


def _calib_matrix(fs: Any, file: Path, name: str, sizes: tuple[int, ...]) -> FloatArray:
    import cv2

    node = fs.getNode(name)
    if node.empty():
        raise FormatError(f"{file}: field {name}: missing")
    if not node.isMap():
        raise FormatError(f"{file}: field {name}: not a matrix (expected an opencv-matrix)")
    try:
        mat = node.mat()
    except cv2.error:  # e.g. a truncated file: the node lacks its dt or data entries
        raise FormatError(
            f"{file}: field {name}: malformed opencv-matrix (needs rows, cols, dt and data)"
        ) from None
    if mat is None:
        raise FormatError(f"{file}: field {name}: not a matrix (expected an opencv-matrix)")
    arr = np.asarray(mat, dtype=np.float64)
    if arr.size not in sizes:
        want = " or ".join(str(s) for s in sizes)
        raise FormatError(f"{file}: field {name}: has {arr.size} elements, expected {want}")
    if not np.all(np.isfinite(arr)):
        raise FormatError(f"{file}: field {name}: contains NaN or infinite values")
    return arr


def _calib_int(fs: Any, file: Path, name: str) -> int:
    node = fs.getNode(name)
    if node.empty():
        raise FormatError(f"{file}: field {name}: missing")
    if not node.isInt():
        raise FormatError(f"{file}: field {name}: expected a positive integer")
    value = int(node.real())
    if value <= 0:
        raise FormatError(f"{file}: field {name}: expected a positive integer, got {value}")
    return value


# A rotation written with 6 significant digits (Strecha's .camera files, many text exports) is
# orthonormal only to about 1e-6; the cameras built from it want 1e-9. Such an R is replaced by
# the nearest rotation (SVD), which moves it by no more than its own rounding. 1e-4 admits
# rotations rounded to 5 digits or more (an angle error below 0.01 deg); an R further from
# orthonormal is not a rounded rotation and is refused.
CALIB_ORTHONORMAL_TOL = 1e-4


def nearest_rotation(R: FloatArray, file: Path, name: str = "R") -> FloatArray:
    """The rotation nearest to R (3, 3) (Frobenius norm), or FormatError naming `file`.

    R must be orthonormal to CALIB_ORTHONORMAL_TOL (max |R R^T - I|) and have det > 0.
    """
    err = float(np.abs(R @ R.T - np.eye(3)).max())
    if err > CALIB_ORTHONORMAL_TOL or np.linalg.det(R) <= 0:
        raise FormatError(
            f"{file}: field {name}: not a rotation matrix (max |R R^T - I| = {err:.2g}, tolerance "
            f"{CALIB_ORTHONORMAL_TOL:g}; det {np.linalg.det(R):.6g}, must be +1)"
        )
    U, _, Vt = np.linalg.svd(R)
    nearest: FloatArray = U @ Vt
    return nearest


def read_calib(path: str | os.PathLike[str]) -> StereoCalib:
    """Read a calib.yaml (or .xml/.json) written by cv2.FileStorage; validate every field."""
    import cv2

    file = Path(path)
    if not file.exists():
        raise FormatError(f"{file}: no such file")
    # OpenCV's parser recurses per level (50,000 levels: SIGSEGV): size and nesting first
    text = read_text_file(file, MAX_CALIB_BYTES)
    problem = nesting_problem(text, indentation=True, xml=True)
    if problem is not None:
        raise FormatError(f"{file}:{problem}")
    try:
        fs = cv2.FileStorage(str(file), cv2.FILE_STORAGE_READ)
    except (cv2.error, SystemError) as exc:
        cause = exc.__cause__ or exc.__context__ or exc
        text = str(cause).strip()
        msg = text.splitlines()[-1] if text else "parse error"
        raise FormatError(f"{file}: not a cv2.FileStorage file: {msg}") from None
    try:
        if not fs.isOpened():
            raise FormatError(f"{file}: cannot be opened by cv2.FileStorage")
        width = _calib_int(fs, file, "image_width")
        height = _calib_int(fs, file, "image_height")
        K1 = _calib_matrix(fs, file, "K1", (9,)).reshape(3, 3)
        D1 = _calib_matrix(fs, file, "D1", _D_LENGTHS).ravel()
        K2 = _calib_matrix(fs, file, "K2", (9,)).reshape(3, 3)
        D2 = _calib_matrix(fs, file, "D2", _D_LENGTHS).ravel()
        R = _calib_matrix(fs, file, "R", (9,)).reshape(3, 3)
        T = _calib_matrix(fs, file, "T", (3,)).ravel()
    except cv2.error as exc:  # a truncated or hand-edited matrix node
        last = (str(exc).strip().splitlines() or ["parse error"])[-1]
        raise FormatError(f"{file}: malformed cv2.FileStorage content: {last}") from None
    finally:
        fs.release()
    for name, K in (("K1", K1), ("K2", K2)):
        if (
            K[0, 0] <= 0
            or K[1, 1] <= 0
            or abs(K[2, 2] - 1.0) > 1e-9
            or np.any(K[2, :2] != 0)
            or K[1, 0] != 0
        ):
            raise FormatError(
                f"{file}: field {name}: not a camera matrix "
                "(need [[fx, s, cx], [0, fy, cy], [0, 0, 1]] with fx, fy > 0)"
            )
    R = nearest_rotation(R, file)
    if np.linalg.norm(T) <= 0:
        raise FormatError(f"{file}: field T: zero baseline")
    return StereoCalib(K1=K1, D1=D1, K2=K2, D2=D2, R=R, T=T, image_size=(width, height))
