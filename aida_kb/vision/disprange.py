"""The disparity range of a rectified pair from sparse feature matches, and saturation checks.

Dense NCC searches a fixed interval of disparities; a building whose disparities lie beyond it
gets no depth or wrong depth (Herz-Jesu at 768 px: 127-210 px, against a default of 0-127).
`disparity_range` finds the interval from ORB features matched between the rectified images:
a match must pass Lowe's ratio test, lie on the same row (|Δy| <= EPIPOLAR_TOL_PX, what
rectification promises) and agree with the matches around it; the interval spans the
RANGE_QUANTILE quantiles of the matches' disparities, widened by RANGE_MARGIN_FRACTION of
its span and at least RANGE_MARGIN_PX.
`saturation_warnings` says when a dense result or the sparse matches run into the ends of the
interval searched.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

from aida_kb.vision.stereo import DisparityMap

F64 = npt.NDArray[np.float64]

ORB_FEATURES = 4000  # enough for a few hundred good matches on a 1-megapixel facade
RATIO_TEST = 0.8  # Lowe's ratio: best Hamming distance below this fraction of the second
EPIPOLAR_TOL_PX = 1.5  # a rectified match lies on the same row (calibration error included)
MIN_MATCHES = 30
# A match is kept when its disparity lies within max(3 px, 10 %) of the median of its 6 nearest
# matches in the image: a slanted wall changes by far less between neighbouring features.
NEIGHBOURS = 6
NEIGHBOUR_TOL_PX = 3.0
NEIGHBOUR_TOL_FRACTION = 0.1  # fewer matches than this say nothing reliable about the range
RANGE_QUANTILE = 0.002  # the extreme 0.2 % of matches on either side may be wrong matches
RANGE_MARGIN_FRACTION = 0.25  # surfaces beyond the matched features (plain walls, ground)
RANGE_MARGIN_PX = 8.0  # ... and at least this much (the subpixel peak needs neighbours)
MIN_NUM_DISP = 16  # the smallest interval searched
MAX_NUM_DISP = 256  # the matcher's limit (ncc_disparity)
# Warnings: a dense result with more than SATURATED_FRACTION of its disparities within
# SATURATION_BAND_PX of the top of the range ran into it; more than OUTSIDE_FRACTION of the
# sparse matches outside the range say the same from the features.
SATURATION_BAND_PX = 1.5
SATURATED_FRACTION = 0.01
OUTSIDE_FRACTION = 0.05


@dataclass(frozen=True)
class DisparityRange:
    """An interval of disparities to search, pixels: min_disp .. min_disp + num_disp - 1.

    matches : the sparse matches it came from; low_px, high_px : their RANGE_QUANTILE and
    1 - RANGE_QUANTILE quantiles, pixels; clipped : True when the matches needed more than
    MAX_NUM_DISP disparities and the interval lost their far end (the smallest disparities).
    """

    min_disp: int
    num_disp: int
    matches: int
    low_px: float
    high_px: float
    clipped: bool = False


def sparse_disparities(left: npt.NDArray[np.uint8], right: npt.NDArray[np.uint8]) -> F64:
    """Disparities (M,), pixels (x_left - x_right), of ORB matches of a rectified grey pair.

    left, right : (H, W) uint8 rectified images. Only matches that pass the ratio test, lie
    on the same row (EPIPOLAR_TOL_PX) and agree with their neighbours in the image are kept;
    disparities may be negative (points beyond infinity of a miscalibrated rig).
    """
    orb = cv2.ORB_create(nfeatures=ORB_FEATURES)  # type: ignore[attr-defined]
    kl, dl = orb.detectAndCompute(left, None)
    kr, dr = orb.detectAndCompute(right, None)
    if dl is None or dr is None or len(kl) < 2 or len(kr) < 2:
        return np.zeros(0)
    pairs = cv2.BFMatcher(cv2.NORM_HAMMING).knnMatch(dl, dr, k=2)
    good = [p[0] for p in pairs if len(p) == 2 and p[0].distance < RATIO_TEST * p[1].distance]
    if not good:
        return np.zeros(0)
    pl = np.array([kl[m.queryIdx].pt for m in good], np.float64)
    pr = np.array([kr[m.trainIdx].pt for m in good], np.float64)
    on_row = np.abs(pl[:, 1] - pr[:, 1]) <= EPIPOLAR_TOL_PX
    pl, d = pl[on_row], (pl[:, 0] - pr[:, 0])[on_row]
    return d[_agrees_with_neighbours(pl, d)]


def _agrees_with_neighbours(points: F64, d: F64) -> npt.NDArray[np.bool_]:
    """True for the matches (points (M, 2) pixels, disparities d (M,)) whose disparity is
    within NEIGHBOUR_TOL of the median of their NEIGHBOURS nearest matches in the image:
    surfaces are mostly smooth, so a match alone with its disparity is a wrong one (periodic
    texture: bricks, windows in a row)."""
    if len(d) <= NEIGHBOURS:
        return np.ones(len(d), bool)
    _, idx = cKDTree(points).query(points, k=NEIGHBOURS + 1)
    local = np.median(d[idx[:, 1:]], axis=1)
    tol = np.maximum(NEIGHBOUR_TOL_PX, NEIGHBOUR_TOL_FRACTION * np.abs(local))
    agrees: npt.NDArray[np.bool_] = np.abs(d - local) <= tol
    return agrees


def disparity_range(
    left: npt.NDArray[np.uint8], right: npt.NDArray[np.uint8]
) -> DisparityRange | None:
    """The interval to search on a rectified grey pair (see module docstring), or None when
    fewer than MIN_MATCHES sparse matches were found."""
    d = sparse_disparities(left, right)
    d = d[d > 0]  # a point in front of a rectified pair has positive disparity
    if len(d) < MIN_MATCHES:
        return None
    low, high = (float(x) for x in np.quantile(d, [RANGE_QUANTILE, 1.0 - RANGE_QUANTILE]))
    margin = max(RANGE_MARGIN_PX, RANGE_MARGIN_FRACTION * (high - low))
    hi = math.ceil(high + margin)
    lo = max(0, math.floor(low - margin))
    num = max(MIN_NUM_DISP, hi - lo + 1)
    if num > MAX_NUM_DISP:  # keep the near end: the building in front matters more
        lo, num = hi + 1 - MAX_NUM_DISP, MAX_NUM_DISP
    return DisparityRange(lo, num, len(d), low, high, clipped=lo > low)


def saturation_warnings(
    disparity: DisparityMap, min_disp: int, num_disp: int, sparse: F64 | None = None
) -> list[str]:
    """Sentences saying that the disparities searched (min_disp .. min_disp + num_disp - 1,
    pixels) were too few: the dense result piles up at the top of the range, or the sparse
    matches (pixels, (M,)) fall outside it. Empty when neither."""
    out = []
    top = min_disp + num_disp - 1
    d = disparity.disparity
    valid = ~np.isnan(d)
    n = int(np.count_nonzero(valid))
    if n:
        near_top = int(np.count_nonzero(d[valid] >= top - SATURATION_BAND_PX))
        if near_top > SATURATED_FRACTION * n:
            out.append(
                f"{100.0 * near_top / n:.0f} % of the disparities lie at the top of the range "
                f"searched ({min_disp}..{top} px): the range is too small (raise --max-disp)"
            )
    if sparse is not None and len(sparse):
        pos = sparse[sparse > 0]
        span_lo, span_hi = (
            np.quantile(pos, [RANGE_QUANTILE, 1 - RANGE_QUANTILE]) if pos.size else (0, 0)
        )
        outside = int(np.count_nonzero((pos < min_disp) | (pos > top)))
        if pos.size and outside > OUTSIDE_FRACTION * pos.size:
            out.append(
                f"{100.0 * outside / pos.size:.0f} % of the sparse feature matches lie outside "
                f"the range searched ({min_disp}..{top} px; they span "
                f"{span_lo:.0f}..{span_hi:.0f} px)"
            )
    return out
