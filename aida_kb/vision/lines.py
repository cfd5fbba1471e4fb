"""Straight image line segments with subpixel end points, attached to the regions they border.

Detection is OpenCV's line segment detector (LSD, cv2.createLineSegmentDetector with standard
refinement), which fits each segment to a region of aligned gradients and so gives subpixel end
points; `refine_segments` can then move each onto its edge (subpixel edge points across it, a
robust line fit): on the rendered turntable the median distance of a segment from its true
edge falls from 0.18 to 0.075 px (0.15 to 0.063 on a render not developed on). Each segment
is then sampled a few pixels to either side to find the regions it borders and the grey-level
step across it (its contrast).
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


def detect_segments(
    grey: npt.NDArray[np.uint8], *, min_length_px: float = 15.0, refine: bool = False
) -> F64:
    """Line segments (N, 4) float64 [x1, y1, x2, y2], pixels, at least `min_length_px` long.

    With `refine` each is moved onto its edge by `refine_segments` (registration does; the
    evidence's lines are LSD's: refined, they moved the demo house's inserted floor from
    0.36 to 0.57 degrees off, although they lie nearer the true edges — median 0.12 -> 0.05
    px on that house; not yet understood).
    """
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
    seg = seg[length >= min_length_px]
    return refine_segments(grey, seg) if refine else seg


PROFILE_HALF_PX = 3.0
"""Half length of the intensity profiles sampled across a segment, pixels."""
PROFILE_STEP_PX = 0.5
"""Spacing of a profile's samples (bilinear), pixels."""
SEARCH_PX = 2.0
"""The edge is looked for within this distance of the detected line, pixels (LSD's lines lie
within 0.5 px of a rendered edge in the median, a few px for the worst, measured on the
turntable renders)."""
OUTLIER_MADS = 2.5
"""Edge points further from the fitted line than this many mean absolute deviations (and
`MIN_OUTLIER_PX`) are dropped before the line is fitted again."""
MIN_OUTLIER_PX = 0.3
"""... never fewer pixels than this (a clean edge's points scatter by a few hundredths)."""
MIN_SUPPORT = 0.5
"""A refined line needs edge points at this share of its samples; else the segment is kept
as detected."""
END_MARGIN = 0.05
"""Samples cover the segment but this share at each end (corners blur two edges)."""


@dataclass(frozen=True)
class SegmentFits:
    """Segments moved onto their edges, with how well each edge's points fit its line.

    segments : (N, 4) [x1, y1, x2, y2], pixels; sigma_px : (N,) the standard deviation of one
    edge point across the fitted line, pixels (`UNREFINED_SIGMA_PX` for a segment kept as
    detected); support : (N,) the number of edge points the line was fitted to (0 when kept
    as detected).
    """

    segments: F64
    sigma_px: F64
    support: npt.NDArray[np.intp]


CENTROID_HALF_PX = 1.0
"""An edge point is the centroid of its profile's derivative (of the segment's polarity, the
negative part clipped) within this distance of the derivative's peak, pixels. On the turntable
renders (seeds 0-2, both images) the median segment offset from its true edge is 0.052 px
against 0.065 px for a parabola through the peak, and the bias towards the darker side
-0.024 against -0.035 px (the sensor's gamma skews the blurred step)."""
UNREFINED_SIGMA_PX = 1.0
"""The edge-point sigma given to a segment that could not be refined (LSD's own line)."""


def refine_segments(grey: npt.NDArray[np.uint8], segments: F64, *, rounds: int = 2) -> F64:
    """Segments (N, 4) moved onto the edge they lie on (`fit_segments`' segments)."""
    return fit_segments(grey, segments, rounds=rounds).segments


def fit_segments(grey: npt.NDArray[np.uint8], segments: F64, *, rounds: int = 2) -> SegmentFits:
    """Segments moved onto the edge they lie on, to a few hundredths of a pixel, with their fit.

    LSD fits a segment to the rectangle of pixels whose gradients are aligned, which puts it
    within a few tenths of a pixel of the edge (more where a texture meets the edge). Here,
    every pixel along the segment, the intensity profile across it is sampled (bilinear,
    `PROFILE_STEP_PX` apart, `PROFILE_HALF_PX` either side) and the edge point is the
    centroid of the derivative of the segment's own polarity about its peak within
    `SEARCH_PX` (`CENTROID_HALF_PX`); a line is fitted to the points (weighted by the peak's
    height: total least squares), points off it by more than `OUTLIER_MADS` mean deviations
    dropped, `rounds` times. The end points are those of the detection projected onto the
    line. Segments with too few edge points (`MIN_SUPPORT`) are returned unchanged. Each
    segment's edge-point sigma is the RMS distance of its kept points from its line: a
    textured edge's points scatter by tenths of a pixel, a clean one's by hundredths.

    grey : (H, W) 8-bit image; segments : (N, 4) [x1, y1, x2, y2], pixels (pixel centres at
    integer coordinates).
    """
    N = len(segments)
    if N == 0:
        return SegmentFits(segments.copy(), np.zeros(0), np.zeros(0, np.intp))
    p1, p2 = segments[:, :2], segments[:, 2:]
    length = np.linalg.norm(p2 - p1, axis=1)
    t = (p2 - p1) / np.maximum(length, 1e-9)[:, None]
    n = np.stack([-t[:, 1], t[:, 0]], axis=1)
    # one sample per pixel of the segment's middle, all segments flattened: (Q,)
    k = np.maximum(np.floor(length * (1.0 - 2.0 * END_MARGIN)).astype(np.intp), 1)
    seg = np.repeat(np.arange(N), k)
    first = np.concatenate([[0], np.cumsum(k)[:-1]])
    j = np.arange(seg.size) - first[seg]
    span = (1.0 - 2.0 * END_MARGIN) * length[seg]
    s = END_MARGIN * length[seg] + (j + 0.5) * span / k[seg]
    base = p1[seg] + s[:, None] * t[seg]
    offs = np.arange(-PROFILE_HALF_PX, PROFILE_HALF_PX + 1e-9, PROFILE_STEP_PX)
    pts = base[:, None, :] + offs[None, :, None] * n[seg][:, None, :]  # (Q, O, 2)
    prof = cv2.remap(
        grey.astype(np.float32),
        pts[..., 0].astype(np.float32),
        pts[..., 1].astype(np.float32),
        cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_REPLICATE,
    ).astype(np.float64)
    der = np.zeros_like(prof)
    der[:, 1:-1] = (prof[:, 2:] - prof[:, :-2]) / (2.0 * PROFILE_STEP_PX)
    near = np.abs(offs) <= SEARCH_PX
    near[[0, -1]] = False
    polarity = np.sign(np.bincount(seg, der[:, near].sum(axis=1), minlength=N))
    g = np.where(near[None, :], der * polarity[seg][:, None], -np.inf)
    m = np.argmax(g, axis=1)
    rows = np.arange(m.size)
    b = g[rows, m]
    half = round(CENTROID_HALF_PX / PROFILE_STEP_PX)
    idx = np.clip(m[:, None] + np.arange(-half, half + 1)[None, :], 0, offs.size - 1)
    mass = np.take_along_axis(g, idx, axis=1)
    mass = np.where(np.isfinite(mass), np.maximum(mass, 0.0), 0.0)
    offset = (mass * offs[idx]).sum(axis=1) / np.maximum(mass.sum(axis=1), 1e-12)
    weight = np.maximum(b, 0.0)
    edge = base + offset[:, None] * n[seg]
    keep = weight > 0.0
    for r in range(rounds + 1):
        w = np.where(keep, weight, 0.0)
        sw = np.maximum(np.bincount(seg, w, N), 1e-12)
        cx = np.bincount(seg, w * edge[:, 0], N) / sw
        cy = np.bincount(seg, w * edge[:, 1], N) / sw
        dx, dy = edge[:, 0] - cx[seg], edge[:, 1] - cy[seg]
        sxx = np.bincount(seg, w * dx * dx, N)
        sxy = np.bincount(seg, w * dx * dy, N)
        syy = np.bincount(seg, w * dy * dy, N)
        angle = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)  # the scatter's principal direction
        d = np.stack([np.cos(angle), np.sin(angle)], axis=1)
        res = np.abs(dx * d[seg, 1] - dy * d[seg, 0])
        if r == rounds:
            break
        count = np.maximum(np.bincount(seg, keep.astype(np.float64), N), 1.0)
        mad = np.bincount(seg, np.where(keep, res, 0.0), N) / count
        keep &= res <= np.maximum(OUTLIER_MADS * mad[seg], MIN_OUTLIER_PX)
    support = np.bincount(seg, keep.astype(np.float64), N)
    good = (support >= MIN_SUPPORT * k) & (support >= 3)
    rms = np.sqrt(np.bincount(seg, np.where(keep, res * res, 0.0), N) / np.maximum(support, 1.0))
    centre = np.stack([cx, cy], axis=1)
    q1 = centre + np.einsum("ij,ij->i", p1 - centre, d)[:, None] * d
    q2 = centre + np.einsum("ij,ij->i", p2 - centre, d)[:, None] * d
    out: F64 = np.where(good[:, None], np.concatenate([q1, q2], axis=1), segments)
    sigma: F64 = np.where(good, rms, UNREFINED_SIGMA_PX)
    return SegmentFits(out, sigma, np.where(good, support, 0).astype(np.intp))


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


STEP_NEAR_PX = 1.5
"""The grey-level step across a line is measured from this far on either side (pixels): the
blurred transition of an edge (anti-aliasing, defocus, the demosaic) lies within it."""
STEP_FAR_PX = 4.0
"""... out to this far (pixels): near enough that a face a few pixels wide is still itself."""
STEP_CORRELATED_PX = 3.0
"""Samples this far apart along a line are taken as independent when the step's standard
error is estimated from their scatter (texture grain and the edge's blur correlate nearer
ones)."""


def edge_steps(
    grey: npt.NDArray[np.uint8],
    ends_px: F64,
    K: F64 | None = None,
    D: F64 | None = None,
) -> tuple[F64, F64]:
    """The grey-level step across each line and its z-score: (E,) mean step, (E,) z.

    Each line (ends ``ends_px`` (E, 2, 2), pinhole pixels of camera ``K``; with distortion
    ``D`` the image is the original, distorted one and every sample is moved there first) is
    sampled once per pixel along its middle 80 %; at each sample the mean grey level from
    `STEP_NEAR_PX` to `STEP_FAR_PX` on its right (image axes) less that on its left is the
    step. The line's step is their mean, its z-score that mean over its standard error (the
    samples' scatter over the square root of their number in `STEP_CORRELATED_PX` units). A
    building's edge between two faces, however alike in brightness, shows a steady step
    along its whole length: a large z even where the step is a few grey levels, and where no
    segment was detected; a line drawn across a uniform or textured face shows none.
    """
    E = len(ends_px)
    if E == 0:
        return np.zeros(0), np.zeros(0)
    p1, p2 = ends_px[:, 0], ends_px[:, 1]
    length = np.linalg.norm(p2 - p1, axis=1)
    t = (p2 - p1) / np.maximum(length, 1e-9)[:, None]
    n = np.stack([-t[:, 1], t[:, 0]], axis=1)
    k = np.maximum(np.floor(0.8 * length).astype(np.intp), 1)
    seg = np.repeat(np.arange(E), k)
    first = np.concatenate([[0], np.cumsum(k)[:-1]])
    j = np.arange(seg.size) - first[seg]
    s = 0.1 * length[seg] + (j + 0.5) * 0.8 * length[seg] / k[seg]
    base = p1[seg] + s[:, None] * t[seg]
    offs = np.arange(STEP_NEAR_PX, STEP_FAR_PX + 1e-9, 0.5)
    offsets = np.concatenate([offs, -offs])  # right side first, then left
    pts = base[:, None, :] + offsets[None, :, None] * n[seg][:, None, :]  # (Q, O, 2)
    flat = pts.reshape(-1, 2)
    if K is not None and D is not None:
        from aida_kb.vision.rectify import distort_pixels

        flat = distort_pixels(flat, K, D)
    values = cv2.remap(
        grey.astype(np.float32),
        flat[:, 0].astype(np.float32).reshape(len(base), -1),
        flat[:, 1].astype(np.float32).reshape(len(base), -1),
        cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_REPLICATE,
    ).astype(np.float64)
    half = offs.size
    d = values[:, :half].mean(axis=1) - values[:, half:].mean(axis=1)  # (Q,)
    count = np.bincount(seg, minlength=E).astype(np.float64)
    mean = np.bincount(seg, d, minlength=E) / count
    var = np.bincount(seg, (d - mean[seg]) ** 2, minlength=E) / np.maximum(count - 1.0, 1.0)
    independent = np.maximum(count / STEP_CORRELATED_PX, 1.0)
    se = np.sqrt(var / independent)
    z = mean / np.maximum(se, 1e-6)
    return mean, z
