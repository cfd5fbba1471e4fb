"""Block-wise normalised cross-correlation (NCC) stereo with a certainty map (paper §2).

For a rectified pair, every left pixel x is compared with the right pixel x - d for each
disparity d of the range with the zero-mean NCC of a square window; box filters give the
window sums for all pixels of one disparity at once, so the work is one loop over the
disparity range of whole-image operations (no per-pixel Python). The scores of a disparity are
stored as int32 keys (the quantised score in the high bits, the disparity index in the low
bits), so that one max-reduction yields the best score and its disparity together, for the
left image and, through a strided view of the same volume, for the right image (left-right
consistency). Subpixel disparity comes from a parabola through the three scores around the
peak. Rows are processed in bands, in parallel threads (OpenCV and numpy release the GIL).

The certainty map (0..1) is the product of three factors: the NCC peak, its distinctiveness
(peak minus the best score at least two disparities away) and the local image gradient.
"""

from __future__ import annotations

import math
import os
import threading
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import cv2
import numpy as np
import numpy.typing as npt

from aida_kb.errors import VisionError

F32 = npt.NDArray[np.float32]

# certainty model (module constants, documented in `ncc_disparity`)
PEAK_FLOOR = 0.3  # NCC at or below this gets certainty 0
DISTINCT_SCALE = 0.15  # distinctiveness at which the factor reaches 1
GRADIENT_SCALE = 4.0  # grey levels / pixel: gradient factor 0.5 at this mean gradient
MIN_STD = 1.0  # grey levels: windows flatter than this in either image get no disparity
_BAND_ROWS = 48


@dataclass(frozen=True)
class DisparityMap:
    """The result of `ncc_disparity`, all arrays (H, W) on the left image of a rectified pair.

    disparity : float32, pixels (x_left - x_right), NaN where there is none.
    certainty : float32 in [0, 1], 0 where disparity is NaN.
    peak : float32, the NCC score at the chosen disparity (-1..1), NaN where none.
    distinctiveness : float32, peak minus the best score >= 2 disparities away, NaN where none.
    """

    disparity: F32
    certainty: F32
    peak: F32
    distinctiveness: F32

    @property
    def density(self) -> float:
        """Fraction of pixels that have a disparity."""
        return float(np.count_nonzero(~np.isnan(self.disparity))) / max(1, self.disparity.size)


def _as_grey_f32(image: npt.NDArray[np.generic], what: str) -> F32:
    arr = np.asarray(image)
    if arr.ndim == 3 and arr.shape[2] == 3:
        arr = cv2.cvtColor(arr.astype(np.uint8), cv2.COLOR_BGR2GRAY)
    if arr.ndim != 2:
        raise VisionError(f"{what}: expected a grey (H, W) or BGR (H, W, 3) image, got {arr.shape}")
    out = arr.astype(np.float32)
    if not np.all(np.isfinite(out)):
        raise VisionError(f"{what}: image contains NaN or infinite values")
    out -= 128.0  # keeps the box-filter variances well conditioned in float32
    return out


def ncc_disparity(
    left: npt.NDArray[np.generic],
    right: npt.NDArray[np.generic],
    *,
    min_disp: int = 0,
    num_disp: int = 64,
    window: int = 15,
    lr_tolerance_px: float = 1.0,
    workers: int | None = None,
    exact: bool = False,
    adaptive_range: bool = True,
) -> DisparityMap:
    """Dense disparity of a rectified pair by zero-mean NCC, with a certainty map.

    Parameters
    ----------
    left, right : (H, W) grey or (H, W, 3) BGR images of a rectified pair (same size).
    min_disp, num_disp : the disparities tried are min_disp .. min_disp + num_disp - 1 (pixels,
        x_left - x_right); min_disp >= 0, 3 <= num_disp <= 256.
    window : odd side length of the square correlation window, pixels.
    lr_tolerance_px : a left pixel keeps its disparity only if the right image's best match
        points back to within this many pixels (left-right consistency).
    workers : threads for the row bands (default: the number of CPUs).

    Returns
    -------
    DisparityMap
        Disparity (subpixel, parabola fit), certainty, NCC peak and distinctiveness. No
        disparity where a window is flat (std < MIN_STD grey levels), where the peak lies on
        the end of the range, or where the left-right check fails. Certainty =
        clip((peak - PEAK_FLOOR) / (1 - PEAK_FLOOR)) * clip(distinctiveness / DISTINCT_SCALE)
        * g² / (g² + GRADIENT_SCALE²), g the mean gradient magnitude in the window.
    """
    L = _as_grey_f32(left, "left image")
    R = _as_grey_f32(right, "right image")
    if L.shape != R.shape:
        raise VisionError(f"left and right images differ in size: {L.shape} vs {R.shape}")
    if window < 3 or window % 2 == 0:
        raise VisionError(f"window must be odd and >= 3, got {window}")
    if min_disp < 0 or not 3 <= num_disp <= 256:
        raise VisionError(
            f"need min_disp >= 0 and 3 <= num_disp <= 256, got {min_disp}, {num_disp}"
        )
    H, W = L.shape
    if min_disp + window >= W or window > H:
        raise VisionError(f"image of {W}x{H} pixels is too small for the disparity range")
    n_workers = workers if workers is not None else (os.cpu_count() or 1)
    return _ncc(L, R, min_disp, num_disp, window, lr_tolerance_px, exact, adaptive_range, n_workers)


def _ncc(
    L: F32,
    R: F32,
    min_disp: int,
    num_disp: int,
    window: int,
    lr_tol: float,
    exact: bool,
    adaptive: bool,
    workers: int,
) -> DisparityMap:
    """`ncc_disparity` on validated float images (grey levels - 128)."""
    H, W = L.shape
    half = window // 2
    bands = [(y0, min(H, y0 + _BAND_ROWS)) for y0 in range(0, H, _BAND_ROWS)]
    hi_all = min_disp + num_disp - 1
    ranges = {band: (min_disp, hi_all) for band in bands}
    if adaptive and num_disp >= 16 and min(H, W) >= 8 * window:
        ranges = _band_ranges(L, R, bands, min_disp, num_disp, window, workers)
    # search one disparity beyond each end of the range, so that a peak on an end of the
    # requested range still has two neighbours for the parabola; d = -1 (min_disp 0) is
    # searched with the right image shifted left by one pixel
    shift = 1 if min_disp == 0 else 0
    if shift:
        R = np.concatenate([R[:, 1:], R[:, -1:]], axis=1)
    out = [np.full((H, W), np.nan, np.float32) for _ in range(4)]
    out[1][:] = 0.0

    def job(band: tuple[int, int]) -> None:
        y0, y1 = band
        lo, hi = ranges[band]
        a, b = max(0, y0 - half), min(H, y1 + half)
        res = _band(L[a:b], R[a:b], lo - 1 + shift, hi - lo + 3, window, lr_tol, exact)
        for dst, src in zip(out, res, strict=True):
            dst[y0:y1] = src[y0 - a : y1 - a]

    if workers <= 1:
        for band in bands:
            job(band)
    else:
        with ThreadPoolExecutor(max_workers=workers) as pool:
            list(pool.map(job, bands))
    if shift:
        out[0] -= np.float32(shift)
    return DisparityMap(disparity=out[0], certainty=out[1], peak=out[2], distinctiveness=out[3])


RANGE_MARGIN_PX = 3  # widening of each band's disparity range found at half resolution
RANGE_QUANTILE = 0.002  # coarse disparities below / above these quantiles are outliers


def _band_ranges(
    L: F32,
    R: F32,
    bands: list[tuple[int, int]],
    min_disp: int,
    num_disp: int,
    window: int,
    workers: int,
) -> dict[tuple[int, int], tuple[int, int]]:
    """Each band's disparity range (inclusive), from a half-resolution NCC pass.

    The range spans the certain coarse disparities of the band's rows (and a few rows
    around) between the RANGE_QUANTILE quantiles, doubled, widened by RANGE_MARGIN_PX, clipped
    to the requested range. A band with too few certain coarse pixels keeps the full range.
    Pixels whose disparity falls outside their band's range get none (their peak lies on the
    end of the range searched), never a wrong one from this restriction.
    """
    hi_all = min_disp + num_disp - 1
    Ls = np.asarray(cv2.pyrDown(L), np.float32)
    Rs = np.asarray(cv2.pyrDown(R), np.float32)
    coarse = _ncc(
        Ls,
        Rs,
        min_disp // 2,
        (num_disp + 1) // 2 + 1,
        max(5, (window // 2) | 1),
        1.0,
        False,
        False,
        workers,
    )
    cd = coarse.disparity
    ok = (coarse.certainty > 0.1) & ~np.isnan(cd)
    hs = cd.shape[0]
    ranges = {}
    for y0, y1 in bands:
        r0, r1 = max(0, y0 // 2 - 2), min(hs, (y1 + 1) // 2 + 2)
        vals = cd[r0:r1][ok[r0:r1]]
        if vals.size < 20:
            ranges[(y0, y1)] = (min_disp, hi_all)
            continue
        v_lo, v_hi = np.quantile(vals, [RANGE_QUANTILE, 1.0 - RANGE_QUANTILE])
        lo = max(min_disp, int(np.floor(2.0 * float(v_lo))) - RANGE_MARGIN_PX)
        hi = min(hi_all, int(np.ceil(2.0 * float(v_hi))) + RANGE_MARGIN_PX)
        if hi - lo < 2:
            lo, hi = max(min_disp, lo - 1), min(hi_all, hi + 1)
        ranges[(y0, y1)] = (lo, hi)
    return ranges


def _box(img: F32, window: int) -> F32:
    return np.asarray(
        cv2.boxFilter(img, cv2.CV_32F, (window, window), borderType=cv2.BORDER_REFLECT_101),
        dtype=np.float32,
    )


_local = threading.local()


def _workspace(shape: tuple[int, int, int]) -> F32:
    """A contiguous float32 volume of `shape` on a per-thread buffer reused across bands
    (first-touch page faults of fresh memory are costly). Its content is undefined."""
    size = shape[0] * shape[1] * shape[2]
    buf: F32 | None = getattr(_local, "buffer", None)
    if buf is None or buf.size < size:
        buf = np.empty(max(size, int(1.25 * size)), np.float32)
        _local.buffer = buf
    return buf[:size].reshape(shape)


def _max_over(slices: npt.NDArray[np.int32] | list[npt.NDArray[np.int32]]) -> npt.NDArray[np.int32]:
    """Element-wise maximum of equally shaped int32 slices (cv2.max, faster than a strided
    numpy reduction over the first axis)."""
    acc = np.array(slices[0], dtype=np.int32)
    for s in slices[1:]:
        cv2.max(acc, s, dst=acc)
    return acc


def _band(
    L: F32, R: F32, min_disp: int, D: int, window: int, lr_tol: float, exact: bool
) -> tuple[F32, F32, F32, F32]:
    """NCC stereo on one band of rows (with its halo); returns full-band arrays.

    The volume holds the scores as float32 with the disparity index written into the lowest
    mantissa bits; the IEEE bits of positive floats order like integers, so an int32 max over
    the disparity axis gives the best positive score and its index at once (a pixel whose
    scores are all <= 0 gets none, as it should).
    """
    h, W = L.shape
    kbits = max(1, math.ceil(math.log2(D)))
    kmask = np.int32((1 << kbits) - 1)
    invalid = np.int32(0)  # +0.0: below the key of every positive score

    muL, muR = _box(L, window), _box(R, window)
    sdL = np.sqrt(np.maximum(_box(L * L, window) - muL * muL, 0.0))
    sdR = np.sqrt(np.maximum(_box(R * R, window) - muR * muR, 0.0))
    flatL, flatR = sdL < MIN_STD, sdR < MIN_STD
    A = (1.0 / np.maximum(sdL, MIN_STD)).astype(np.float32)
    B = (1.0 / np.maximum(sdR, MIN_STD)).astype(np.float32)
    P = (muL * A).astype(np.float32)
    Q = (muR * B).astype(np.float32)
    if not exact:
        Ln = ((L - muL) * A).astype(np.float32)
        Rn = ((R - muR) * B).astype(np.float32)

    # slice k + 1 holds disparity index k; slices 0 and D + 1 are empty sentinels, so that the
    # neighbours k - 1 and k + 1 of any peak can be read without bounds checks
    width = W + min_disp + D  # extra columns keep the right-image strided view in bounds
    vol = _workspace((D + 2, h, width))
    keys = vol.view(np.int32)
    keys[0] = invalid
    keys[D + 1] = invalid
    keys[:, :, W:] = invalid
    prod = np.empty((h, W), np.float32)
    mm = np.empty((h, W), np.float32)
    not_k = ~kmask
    for k in range(D):
        d = min_disp + k
        n = W - d
        keys[k + 1, :, : min(d, W)] = invalid
        if n <= 0:
            continue
        sl = vol[k + 1, :, d:W]
        if exact:
            p = cv2.multiply(L[:, d:], R[:, :n], dst=prod[:, :n])
            s = cv2.boxFilter(p, cv2.CV_32F, (window, window), borderType=cv2.BORDER_REFLECT_101)
            cv2.multiply(s, A[:, d:], dst=s)
            cv2.multiply(s, B[:, :n], dst=s)
            m = cv2.multiply(P[:, d:], Q[:, :n], dst=mm[:, :n])
            cv2.subtract(s, m, dst=sl)
        else:
            p = cv2.multiply(Ln[:, d:], Rn[:, :n], dst=prod[:, :n])
            cv2.boxFilter(
                p, cv2.CV_32F, (window, window), dst=sl, borderType=cv2.BORDER_REFLECT_101
            )
        # pack the disparity index into the low mantissa bits (while the slice is in cache);
        # the IEEE bits of positive floats order like integers (negative scores never win)
        ks = keys[k + 1, :, d:W]
        np.bitwise_and(ks, not_k, out=ks)
        np.bitwise_or(ks, k, out=ks)

    def score(key: npt.NDArray[np.int32]) -> F32:
        return np.asarray((key & not_k).view(np.float32), dtype=np.float32)

    inner = keys[1 : D + 1, :, :W]
    best = _max_over(inner)
    # right image: its pixel xr at disparity index k sits at left column xr + min_disp + k
    best_r = _max_over([keys[k + 1, :, min_disp + k : min_disp + k + W] for k in range(D)])

    k_best = (best & kmask).astype(np.intp)
    has = best > kmask
    peak = score(best)
    # flat indices of the neighbours k-1, k+1 in the (D, h, width) volume
    flat = keys.reshape(-1)
    plane = h * width
    i_best = np.arange(h * width, dtype=np.intp).reshape(h, width)[:, :W] + (k_best + 1) * plane
    i_m = i_best - plane
    i_p = i_best + plane
    s_m = score(flat[i_m])
    s_p = score(flat[i_p])
    # second best at least two disparities away
    flat[i_m] = invalid
    flat[i_best] = invalid
    flat[i_p] = invalid
    second = _max_over(inner)
    s_2 = np.where(second > kmask, score(second), np.float32(-1.0))

    denom = s_m - 2.0 * peak + s_p
    interior = (k_best > 0) & (k_best < D - 1) & (denom < 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        offset = np.where(interior, 0.5 * (s_m - s_p) / np.where(interior, denom, -1.0), 0.0)
    disp = (min_disp + k_best + np.clip(offset, -0.5, 0.5)).astype(np.float32)

    # left-right consistency
    d_int = min_disp + k_best
    xs = np.arange(W)[None, :]
    xr = np.clip(xs - d_int, 0, W - 1)
    rows = (np.arange(h, dtype=np.intp) * W)[:, None]
    k_r = (best_r.reshape(-1)[rows + xr] & kmask).astype(np.intp)
    consistent = np.abs(k_r - k_best) <= lr_tol
    x_ok = xs - d_int >= 0

    flat_r_at = flatR.reshape(-1)[rows + xr]
    valid = has & interior & consistent & x_ok & ~flatL & ~flat_r_at & (peak > 0.0)

    gx = cv2.Sobel(L, cv2.CV_32F, 1, 0, ksize=3, scale=0.125)
    gy = cv2.Sobel(L, cv2.CV_32F, 0, 1, ksize=3, scale=0.125)
    g = _box(np.sqrt(gx * gx + gy * gy), window)
    distinct = (peak - s_2).astype(np.float32)
    c_peak = np.clip((peak - PEAK_FLOOR) / (1.0 - PEAK_FLOOR), 0.0, 1.0)
    c_dist = np.clip(distinct / DISTINCT_SCALE, 0.0, 1.0)
    g2 = g * g
    c_grad = g2 / (g2 + GRADIENT_SCALE**2)
    certainty = np.where(valid, c_peak * c_dist * c_grad, 0.0).astype(np.float32)
    nan = np.float32(np.nan)
    return (
        np.where(valid, disp, nan).astype(np.float32),
        certainty,
        np.where(valid, peak, nan).astype(np.float32),
        np.where(valid, distinct, nan).astype(np.float32),
    )
