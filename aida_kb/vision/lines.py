"""Straight image line segments with subpixel end points, attached to the regions they border.

Detection is OpenCV's line segment detector (LSD, cv2.createLineSegmentDetector with standard
refinement), which fits each segment to a region of aligned gradients and so gives subpixel end
points. Each segment is then sampled a few pixels to either side to find the regions it
borders and the grey-level step across it (its contrast).
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from aida_kb.errors import VisionError

F64 = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Segment:
    """One line segment in pixels (x, y) of the image it was detected in.

    left_region / right_region: region ids on either side of p1 -> p2 (image axes: left of a
    segment pointing right is up), None when that side is not one region.
    """

    p1: tuple[float, float]
    p2: tuple[float, float]
    contrast: float
    left_region: int | None
    right_region: int | None

    @property
    def length_px(self) -> float:
        """Length in pixels."""
        return float(np.hypot(self.p2[0] - self.p1[0], self.p2[1] - self.p1[1]))

    @property
    def regions(self) -> list[int]:
        """The distinct regions it borders (0, 1 or 2 ids)."""
        ids = [r for r in (self.left_region, self.right_region) if r is not None]
        return sorted(set(ids))


def detect_segments(grey: npt.NDArray[np.uint8], *, min_length_px: float = 15.0) -> F64:
    """Line segments (N, 4) float64 [x1, y1, x2, y2], pixels, at least `min_length_px` long."""
    if grey.ndim != 2 or grey.dtype != np.uint8:
        raise VisionError(
            f"line detection needs an 8-bit grey image, got {grey.dtype} {grey.shape}"
        )
    lsd = cv2.createLineSegmentDetector(cv2.LSD_REFINE_STD)
    found = lsd.detect(grey)[0]
    if found is None:
        return np.zeros((0, 4), np.float64)
    seg = found.reshape(-1, 4).astype(np.float64)
    length = np.hypot(seg[:, 2] - seg[:, 0], seg[:, 3] - seg[:, 1])
    return seg[length >= min_length_px]


def attach_segments(
    segments: F64,
    grey: npt.NDArray[np.uint8],
    regions: npt.NDArray[np.integer],
    *,
    offset_px: float = 3.0,
    samples: int = 9,
    agreement: float = 0.6,
) -> list[Segment]:
    """Sample each segment's two sides: bordering regions and contrast (all segments at once).

    segments : (N, 4) from `detect_segments`; grey, regions : (H, W) image and region map of
    the same image (0 = no region). A side takes a region when at least `agreement` of its
    `samples` points (spread over the middle 80 % of the segment, `offset_px` away) agree.
    """
    if grey.shape != regions.shape:
        raise VisionError(f"image {grey.shape} and region map {regions.shape} differ in size")
    n = len(segments)
    if n == 0:
        return []
    H, W = grey.shape
    p1, p2 = segments[:, :2], segments[:, 2:]
    t = (p2 - p1) / np.maximum(np.linalg.norm(p2 - p1, axis=1, keepdims=True), 1e-9)
    left_normal = np.stack([t[:, 1], -t[:, 0]], axis=1)
    s = np.linspace(0.1, 0.9, samples)
    base = p1[:, None, :] + s[None, :, None] * (p2 - p1)[:, None, :]  # (N, S, 2)

    def sample(points: F64, image: npt.NDArray[np.generic]) -> npt.NDArray[np.generic]:
        xi = np.clip(np.rint(points[..., 0]).astype(np.intp), 0, W - 1)
        yi = np.clip(np.rint(points[..., 1]).astype(np.intp), 0, H - 1)
        return image[yi, xi]

    sides = []
    grey_f = grey.astype(np.float64)
    for sign in (1.0, -1.0):
        pts = base + sign * offset_px * left_normal[:, None, :]
        sides.append((sample(pts, regions).astype(np.int64), sample(pts, grey_f)))
    (lab_l, g_l), (lab_r, g_r) = sides
    contrast = np.abs(g_l.mean(axis=1) - g_r.mean(axis=1))

    def majority(labels: npt.NDArray[np.int64]) -> list[int | None]:
        out: list[int | None] = []
        srt = np.sort(labels, axis=1)
        # the most frequent value of each row: the median of a sorted row is a candidate
        cand = srt[:, samples // 2]
        freq = (labels == cand[:, None]).sum(axis=1)
        ok = (cand != 0) & (freq >= agreement * samples)
        for c, good in zip(cand.tolist(), ok.tolist(), strict=True):
            out.append(int(c) if good else None)
        return out

    left, right = majority(lab_l), majority(lab_r)
    return [
        Segment(
            p1=(float(segments[i, 0]), float(segments[i, 1])),
            p2=(float(segments[i, 2]), float(segments[i, 3])),
            contrast=float(contrast[i]),
            left_region=left[i],
            right_region=right[i],
        )
        for i in range(n)
    ]
