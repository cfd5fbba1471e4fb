"""Block-wise normalised cross-correlation (NCC) stereo with a certainty map (paper §2).

For a rectified pair, every left pixel x is compared with the right pixel x - d for each
disparity d of the range with the NCC of a square window. Each image is normalised once
(window mean and standard deviation, whole-image box filters); then, per band of rows and per
disparity, the products of the two normalised images are summed over every window at once with
one float32 integral image (no per-pixel Python). The scores of a disparity are stored as int32
keys (the quantised score in the high bits, the disparity index in the low bits), so that
running int32 maxima yield the best score and its disparity together, for the left image and,
read with the disparity's column shift, for the right image (left-right consistency). Subpixel
disparity comes from a parabola through the three scores around the peak.

Coarse to fine: a half-resolution pass over the whole range bounds each band's disparities, so
that the full-resolution pass searches only those. Bands run in parallel threads (OpenCV and
numpy release the GIL); scratch arrays are reused across bands and calls (first-touch page
faults of fresh memory cost more than the arithmetic).

The certainty map (0..1) is the product of three factors: the NCC peak, its distinctiveness
(peak minus the best score at least two disparities away) and the local image gradient.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass
from functools import lru_cache, partial
from typing import Any, TypeVar, cast

import cv2
import numpy as np
import numpy.typing as npt

from aida_kb.errors import VisionError

F32 = npt.NDArray[np.float32]
T = TypeVar("T")

# certainty model (module constants, documented in `ncc_disparity`)
PEAK_FLOOR = 0.3  # NCC at or below this gets certainty 0
DISTINCT_SCALE = 0.15  # distinctiveness at which the factor reaches 1
# the gradient factor is 0.5 where a window's mean gradient is GRADIENT_SNR times the image
# noise's sd (`image_noise_sd`): texture fainter than that is more noise than signal. 3.15 keeps
# the factor the project's renders were tuned with (4 grey levels / pixel at their noise sd of
# 1.27 as estimated on the rectified images); a cleaner image trusts fainter texture (a
# path-traced render's plaster wall, 1.8 grey levels of texture at noise 0.4: its disparities
# lie within 0.15 px of one plane), a noisier one less.
GRADIENT_SNR = 4.6
NOISE_FLAT_SHARE = 0.5  # noise measured on this share of pixels with the least gradient
QUANTISATION_SD = 1.0 / math.sqrt(12.0)  # grey levels: 8-bit rounding, the least noise there is
SATURATED_MARGIN = 1.0  # grey levels: pixels this close to an image's extremes are clipped
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


def checked_pair(
    left: npt.NDArray[np.generic],
    right: npt.NDArray[np.generic],
    min_disp: int,
    num_disp: int,
    window: int,
) -> tuple[F32, F32]:
    """The pair as float grey images (grey levels - 128), checked for a matcher: the same
    size, an odd window >= 3 smaller than the image, 0 <= min_disp, 3 <= num_disp <= 256 and
    min_disp + window below the width. VisionError says what does not fit."""
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
    if window >= min(W, H):
        raise VisionError(
            f"window {window} does not fit the {W}x{H} image: it must be odd, >= 3 and "
            f"smaller than the image"
        )
    if min_disp + window >= W:
        raise VisionError(
            f"image of {W}x{H} pixels is too small for the disparity range: min_disp {min_disp} "
            f"+ window {window} must be below the width"
        )
    return L, R


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
    workers : threads for the row bands (default: OpenCV's, ``cv2.getNumThreads()``: the
        number of CPUs unless ``cv2.setNumThreads`` lowered it, as a batch worker does).
    exact : correlate each window with its own mean and deviation (true zero-mean NCC,
        slower); default: correlate the images normalised pixel by pixel by the mean and
        deviation of the window around each pixel (nearly the same scores).
    adaptive_range : search each band of rows only over the disparities that a
        half-resolution pass finds there (plus a margin), when num_disp >= 16 and the image
        is at least 8 windows on each side; pixels whose match lies outside get none.

    Returns
    -------
    DisparityMap
        Disparity (subpixel, parabola fit), certainty, NCC peak and distinctiveness, all
        (H, W) float32 on the rectified left image. No disparity where a window is flat
        (std < MIN_STD grey levels), where the peak lies on the end of the range, or where
        the left-right check fails. Certainty =
        clip((peak - PEAK_FLOOR) / (1 - PEAK_FLOOR)) * clip(distinctiveness / DISTINCT_SCALE)
        * g² / (g² + (GRADIENT_SNR · sigma)²), g the mean gradient magnitude in the window,
        sigma the noise sd of the noisier image (`image_noise_sd`).
    """
    L, R = checked_pair(left, right, min_disp, num_disp, window)
    n_workers = workers if workers is not None else max(1, cv2.getNumThreads())
    args = (L, R, min_disp, num_disp, window, lr_tolerance_px, exact, adaptive_range)
    if n_workers <= 1:
        return _ncc(*args, None)
    with ThreadPoolExecutor(max_workers=n_workers) as pool:
        return _ncc(*args, pool)


def _ncc(
    L: F32,
    R: F32,
    min_disp: int,
    num_disp: int,
    window: int,
    lr_tol: float,
    exact: bool,
    adaptive: bool,
    pool: ThreadPoolExecutor | None,
) -> DisparityMap:
    """`ncc_disparity` on validated float images (grey levels - 128); `pool` runs the image
    preparation and the row bands in threads (None: one after another)."""
    H, W = L.shape
    bands = [(y0, min(H, y0 + _BAND_ROWS)) for y0 in range(0, H, _BAND_ROWS)]
    hi_all = min_disp + num_disp - 1
    ranges = {band: (min_disp, hi_all) for band in bands}
    if adaptive and num_disp >= 16 and min(H, W) >= 8 * window:
        ranges = _band_ranges(L, R, bands, min_disp, num_disp, window, pool)
    # search one disparity beyond each end of the range, so that a peak on an end of the
    # requested range still has two neighbours for the parabola; d = -1 (min_disp 0) is
    # searched with the right image shifted left by one pixel
    shift = 1 if min_disp == 0 else 0
    if shift:
        R = np.concatenate([R[:, 1:], R[:, -1:]], axis=1)
    out = _Output(
        disparity=np.empty((H, W), np.float32),
        certainty=np.empty((H, W), np.float32),
        peak=np.empty((H, W), np.float32),
        distinctiveness=np.empty((H, W), np.float32),
    )
    with _workspace() as wl, _workspace() as wr:
        scale = 1.0 / (window * window)  # folded into the left image: sums are NCC scores
        g_scale = GRADIENT_SNR * max(image_noise_sd(L), image_noise_sd(R))
        jobs: list[Callable[[], Any]] = [
            lambda: _prepare(L, window, exact, scale, wl, gradient_scale=g_scale),
            lambda: _prepare(R, window, exact, 1.0, wr),
        ]
        left, right = _run(pool, jobs)

        def job(band: tuple[int, int]) -> None:
            lo, hi = ranges[band]
            with _workspace() as ws:
                _band(left, right, out, band, lo - 1 + shift, hi - lo + 3, lr_tol, ws)

        _run(pool, [partial(job, band) for band in bands])
    if shift:
        np.subtract(out.disparity, np.float32(shift), out=out.disparity)
    return DisparityMap(
        disparity=out.disparity,
        certainty=out.certainty,
        peak=out.peak,
        distinctiveness=out.distinctiveness,
    )


def _run(pool: ThreadPoolExecutor | None, jobs: Sequence[Callable[[], T]]) -> list[T]:
    """The jobs' results, in order: in the pool's threads, or one after another."""
    if pool is None:
        return [job() for job in jobs]
    return list(pool.map(lambda job: job(), jobs))


RANGE_MARGIN_PX = 2  # widening of each band's disparity range found at half resolution
RANGE_QUANTILE = 0.002  # coarse disparities below / above these quantiles are outliers


def _band_ranges(
    L: F32,
    R: F32,
    bands: list[tuple[int, int]],
    min_disp: int,
    num_disp: int,
    window: int,
    pool: ThreadPoolExecutor | None,
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
        pool,
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


def _box(img: F32, window: int, dst: F32 | None = None) -> F32:
    return np.asarray(
        cv2.boxFilter(
            img, cv2.CV_32F, (window, window), dst=dst, borderType=cv2.BORDER_REFLECT_101
        ),
        dtype=np.float32,
    )


class _Workspace:
    """Named scratch arrays reused across bands and calls (first-touch page faults of fresh
    memory cost more than the arithmetic on it). Contents are undefined on `get`."""

    def __init__(self) -> None:
        self._buffers: dict[str, npt.NDArray[Any]] = {}

    def get(self, name: str, shape: tuple[int, ...], dtype: type[np.generic]) -> npt.NDArray[Any]:
        size = math.prod(shape)
        buf = self._buffers.get(name)
        if buf is None or buf.size < size or buf.dtype != dtype:
            buf = np.empty(max(size, int(1.25 * size)), dtype)
            self._buffers[name] = buf
        return buf[:size].reshape(shape)


_FREE_WORKSPACES: list[_Workspace] = []
_WORKSPACE_LOCK = threading.Lock()


@contextmanager
def _workspace() -> Iterator[_Workspace]:
    """A workspace for one job at a time, returned to a shared free list afterwards."""
    with _WORKSPACE_LOCK:
        ws = _FREE_WORKSPACES.pop() if _FREE_WORKSPACES else _Workspace()
    try:
        yield ws
    finally:
        with _WORKSPACE_LOCK:
            _FREE_WORKSPACES.append(ws)


@dataclass(frozen=True)
class _Output:
    disparity: F32
    certainty: F32
    peak: F32
    distinctiveness: F32


@dataclass(frozen=True)
class _Prepared:
    """One image of the pair, prepared for correlation (arrays live in a workspace).

    corr : (H + w - 1, W + w - 1) the values correlated per disparity, padded by the window's
        half side (reflect-101): (I - mu) / max(sd, MIN_STD) * scale, or I itself (exact).
    inv_sd, mu : (H, W) 1 / max(sd, MIN_STD) and the mean of each pixel's window.
    flat : (H, W) windows with std < MIN_STD.
    c_grad : (H, W) the certainty's gradient factor (left image only, else empty).
    """

    window: int
    exact: bool
    corr: F32
    inv_sd: F32
    mu: F32
    flat: npt.NDArray[np.bool_]
    c_grad: F32


def _prepare(
    img: F32,
    window: int,
    exact: bool,
    scale: float,
    ws: _Workspace,
    *,
    gradient_scale: float | None = None,
) -> _Prepared:
    """Window statistics of one whole image (see `_Prepared`), in `ws`'s buffers; with
    ``gradient_scale`` (grey levels / pixel) the certainty's gradient factor too."""
    half = window // 2
    H, W = img.shape
    mu = _box(img, window, ws.get("mu", (H, W), np.float32))
    var = ws.get("var", (H, W), np.float32)
    cv2.sqrBoxFilter(img, cv2.CV_32F, (window, window), dst=var, borderType=cv2.BORDER_REFLECT_101)
    inv_sd = ws.get("inv_sd", (H, W), np.float32)
    cv2.multiply(mu, mu, dst=inv_sd)
    cv2.subtract(var, inv_sd, dst=var)
    flat = var < np.float32(MIN_STD * MIN_STD)
    np.maximum(var, np.float32(MIN_STD * MIN_STD), out=inv_sd)
    cv2.sqrt(inv_sd, dst=inv_sd)
    np.reciprocal(inv_sd, out=inv_sd)
    corr = ws.get("corr", (H + 2 * half, W + 2 * half), np.float32)
    if exact:
        src = img
    else:
        src = var  # the scratch takes the normalised image
        cv2.subtract(img, mu, dst=src)
        cv2.multiply(src, inv_sd, dst=src, scale=scale)
    cv2.copyMakeBorder(src, half, half, half, half, cv2.BORDER_REFLECT_101, dst=corr)
    c_grad = np.empty((0, 0), np.float32)
    if gradient_scale is not None:
        c_grad = _gradient_factor(img, window, ws, gradient_scale)
    return _Prepared(window, exact, corr, inv_sd, mu, flat, c_grad)


def image_noise_sd(img: npt.ArrayLike) -> float:
    """The sd of an image's noise, grey levels: (H, W) array of grey levels (any offset).

    Immerkaer's estimator (1996): the mask N = [[1,-2,1],[-2,4,-2],[1,-2,1]] cancels every
    linear intensity ramp, and white noise of sd sigma gives N * I an sd of 6 sigma (the root
    of the sum of N's squared weights), so sigma = sqrt(pi/2) mean|N * I| / 6. The mean runs
    over the NOISE_FLAT_SHARE of pixels with the least gradient (texture and edges would add
    to it) that are not clipped (within SATURATED_MARGIN of the image's extremes: a blown-out
    sky has no noise left), and the result is at least QUANTISATION_SD. An image without such
    pixels has QUANTISATION_SD.
    """
    a = np.asarray(img, np.float32)
    if a.ndim != 2 or min(a.shape) < 3:
        return QUANTISATION_SD
    mask = np.array([[1, -2, 1], [-2, 4, -2], [1, -2, 1]], np.float32)
    lap = np.abs(cv2.filter2D(a, cv2.CV_32F, mask)[1:-1, 1:-1])
    gx = cv2.Sobel(a, cv2.CV_32F, 1, 0, ksize=3)[1:-1, 1:-1]
    gy = cv2.Sobel(a, cv2.CV_32F, 0, 1, ksize=3)[1:-1, 1:-1]
    grad = cv2.magnitude(gx, gy)
    lo, hi = float(a.min()), float(a.max())
    inner = a[1:-1, 1:-1]
    unclipped = (inner > lo + SATURATED_MARGIN) & (inner < hi - SATURATED_MARGIN)
    if not np.any(unclipped):
        return QUANTISATION_SD
    flat = unclipped & (grad <= np.quantile(grad[unclipped], NOISE_FLAT_SHARE))
    sigma = math.sqrt(math.pi / 2.0) * float(lap[flat].mean()) / 6.0
    return max(sigma, QUANTISATION_SD) if math.isfinite(sigma) else QUANTISATION_SD


def _gradient_factor(img: F32, window: int, ws: _Workspace, scale: float) -> F32:
    """g² / (g² + scale²) (H, W), g the window mean of the gradient magnitude (grey levels per
    pixel), scale in the same unit."""
    H, W = img.shape
    gx = ws.get("gx", (H, W), np.float32)
    gy = ws.get("gy", (H, W), np.float32)
    cv2.Sobel(img, cv2.CV_32F, 1, 0, dst=gx, ksize=3, scale=0.125)
    cv2.Sobel(img, cv2.CV_32F, 0, 1, dst=gy, ksize=3, scale=0.125)
    cv2.magnitude(gx, gy, magnitude=gx)
    g = _box(gx, window, gy)
    cv2.multiply(g, g, dst=g)  # g²
    np.add(g, np.float32(scale**2), out=gx)
    cv2.divide(g, gx, dst=g)
    return g


class _WindowSums:
    """Window sums of corr_L(x) * corr_R(x - d) for one band's output rows y0 .. y0 + h - 1
    and columns d .. W - 1 (exact mode: the zero-mean NCC), from one integral image of the
    band's products per disparity; the scratch arrays are taken once per band."""

    def __init__(self, left: _Prepared, right: _Prepared, y0: int, h: int, ws: _Workspace) -> None:
        w = left.window
        self.left, self.right, self.y0, self.h, self.w = left, right, y0, h, w
        self.Lb = left.corr[y0 : y0 + h + w - 1]
        self.Rb = right.corr[y0 : y0 + h + w - 1]
        wp = self.Lb.shape[1]
        self.prod = ws.get("prod", (h + w - 1, wp), np.float32)
        self.sums = ws.get("integral", (h + w, wp + 1), np.float32)
        self.vert = ws.get("vertical", (h, wp + 1), np.float32)

    def __call__(self, d: int, dst: F32) -> None:
        """Write the sums for disparity d to `dst` (h, W - d)."""
        w, h, n = self.w, self.h, dst.shape[1]
        m = self.Lb.shape[1] - d
        if self.left.exact:
            self._exact(d, dst)
            return
        p = self.prod[:, :m]
        cv2.multiply(self.Lb[:, d:], self.Rb[:, :m], dst=p)
        # float32 integral: the normalised products are ~1/w² each, so that a band's total
        # stays small enough for ~1e-5 absolute accuracy of the scores
        s = self.sums[:, : m + 1]
        cv2.integral(p, sum=s, sdepth=cv2.CV_32F)
        v = self.vert[:, : m + 1]
        cv2.subtract(s[w : w + h], s[0:h], dst=v)
        cv2.subtract(v[:, w : w + n], v[:, 0:n], dst=dst)

    def _exact(self, d: int, dst: F32) -> None:
        # raw products summed in float64, then the means and deviations
        w, h, n = self.w, self.h, dst.shape[1]
        m = self.Lb.shape[1] - d
        p64 = self.Lb[:, d:].astype(np.float64) * self.Rb[:, :m]
        s64 = cv2.integral(p64, sdepth=cv2.CV_64F)
        v64 = s64[w : w + h] - s64[0:h]
        sums = v64[:, w : w + n] - v64[:, 0:n]
        rows = slice(self.y0, self.y0 + h)
        left, right = self.left, self.right
        cov = sums / (w * w) - left.mu[rows, d:] * right.mu[rows, :n]
        dst[:] = cov * left.inv_sd[rows, d:] * right.inv_sd[rows, :n]


def _band(
    left: _Prepared,
    right: _Prepared,
    out: _Output,
    band: tuple[int, int],
    min_disp: int,
    D: int,
    lr_tol: float,
    ws: _Workspace,
) -> None:
    """NCC stereo on the output rows band = (y0, y1), disparities min_disp .. min_disp + D - 1;
    writes the band's rows of `out`.

    The volume holds the scores as float32 with the disparity index written into the lowest
    mantissa bits; the IEEE bits of positive floats order like integers, so an int32 max over
    the disparity axis gives the best positive score and its index at once (a pixel whose
    scores are all <= 0 gets none, as it should). The maxima for the left and the right image
    are taken while each slice is in cache.
    """
    y0, y1 = band
    h = y1 - y0
    W = left.flat.shape[1]
    rows = slice(y0, y1)
    kbits = max(1, math.ceil(math.log2(D)))
    kmask = (1 << kbits) - 1
    not_k = ~kmask

    # slice k + 1 holds disparity index k; slices 0 and D + 1 are empty sentinels, so that the
    # neighbours k - 1 and k + 1 of any peak can be read without bounds checks
    width = W + 1  # a spare column keeps the flat neighbour indices in bounds
    vol = ws.get("volume", (D + 2, h, width), np.float32)
    keys = vol.view(np.int32)
    keys[0] = 0  # key 0 (+0.0) is below the key of every positive score
    keys[D + 1] = 0
    keys[:, :, W:] = 0
    best = ws.get("best", (h, W), np.int32)
    best_r = ws.get("best_r", (h, W), np.int32)  # right image: its pixel xr = x - d
    best.fill(0)
    best_r.fill(0)
    window_sums = _WindowSums(left, right, y0, h, ws)
    clear = _scalar(not_k)
    for k in range(D):
        d = min_disp + k
        n = W - d
        keys[k + 1, :, : min(d, W)] = 0
        if n <= 0:
            continue
        window_sums(d, vol[k + 1, :, d:W])
        ks = keys[k + 1, :, d:W]
        cv2.bitwise_and(ks, clear, dst=ks)
        cv2.bitwise_or(ks, _scalar(k), dst=ks)
        cv2.max(best[:, d:], ks, dst=best[:, d:])
        cv2.max(best_r[:, :n], ks, dst=best_r[:, :n])

    def score(key: npt.NDArray[np.int32]) -> F32:
        return np.asarray(np.bitwise_and(key, not_k).view(np.float32), dtype=np.float32)

    k_best = best & kmask
    peak = score(best)
    # neighbours k - 1 and k + 1 of the peak: flat indices in the (D + 2, h, width) volume
    flat = keys.reshape(-1)
    plane = h * width
    idx = k_best.astype(np.intp)
    idx *= plane
    idx += _base_index(h, width, W)  # slice k_best holds index k_best - 1
    s_m = score(flat.take(idx))
    flat[idx] = 0  # (for the second best, at least two disparities away from the peak)
    idx += 2 * plane
    s_p = score(flat.take(idx))
    flat[idx] = 0
    idx -= plane
    flat[idx] = 0
    second = _max_over(keys[1 : D + 1, :, :W])
    s_2 = score(second)
    s_2 -= second <= kmask  # no positive score two away: -1 for "none" (ok, it is below 0)

    # subpixel: parabola through the peak and its neighbours (NaN/inf only where invalid)
    denom = cv2.scaleAdd(peak, -2.0, cv2.add(s_m, s_p))
    interior = (k_best > 0) & (k_best < D - 1) & (denom < 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        offset = cv2.divide(cv2.subtract(s_m, s_p), denom, scale=0.5)
    np.clip(offset, np.float32(-0.5), np.float32(0.5), out=offset)
    disp = k_best.astype(np.float32)
    disp += offset
    disp += np.float32(min_disp)

    # left-right consistency: the right pixel x - d must point back (no key where it is flat)
    np.multiply(best_r, ~right.flat[rows], out=best_r)
    row_start, right_base = _right_index(h, W, min_disp)
    idx_r = right_base - k_best  # flat index of (y, x - d) in best_r
    x_ok = idx_r >= row_start
    key_r = np.take(best_r.reshape(-1), idx_r, mode="clip")
    consistent = np.abs((key_r & kmask) - k_best) <= lr_tol
    valid = (best > kmask) & (key_r > kmask) & interior & consistent & x_ok & ~left.flat[rows]

    distinct = peak - s_2
    c_peak = peak - np.float32(PEAK_FLOOR)
    c_peak *= np.float32(1.0 / (1.0 - PEAK_FLOOR))
    np.clip(c_peak, np.float32(0.0), np.float32(1.0), out=c_peak)
    c_dist = distinct * np.float32(1.0 / DISTINCT_SCALE)
    np.clip(c_dist, np.float32(0.0), np.float32(1.0), out=c_dist)
    vf = valid.astype(np.float32)
    cv2.multiply(c_peak, c_dist, dst=out.certainty[rows])
    cv2.multiply(out.certainty[rows], left.c_grad[rows], dst=out.certainty[rows])
    cv2.multiply(out.certainty[rows], vf, dst=out.certainty[rows])
    with np.errstate(divide="ignore", invalid="ignore"):
        nan_if_invalid = np.float32(0.0) / vf  # 0 where valid, NaN elsewhere
    np.add(disp, nan_if_invalid, out=out.disparity[rows])
    np.add(peak, nan_if_invalid, out=out.peak[rows])
    np.add(distinct, nan_if_invalid, out=out.distinctiveness[rows])


def _scalar(value: int) -> Any:
    """An int as an OpenCV scalar operand (the cv2 stubs type only arrays there)."""
    return cast(Any, value)


def _max_over(slices: npt.NDArray[np.int32] | list[npt.NDArray[np.int32]]) -> npt.NDArray[np.int32]:
    """Element-wise maximum of equally shaped int32 slices (cv2.max, faster than a strided
    numpy reduction over the first axis)."""
    acc = np.array(slices[0], dtype=np.int32)
    for s in slices[1:]:
        cv2.max(acc, s, dst=acc)
    return acc


@lru_cache(maxsize=16)
def _base_index(h: int, width: int, W: int) -> npt.NDArray[np.intp]:
    """Flat indices of the pixels (h, W) of one (h, width) slice (read-only, cached)."""
    idx = np.arange(h * width, dtype=np.intp).reshape(h, width)[:, :W].copy()
    idx.setflags(write=False)
    return idx


@lru_cache(maxsize=16)
def _right_index(
    h: int, W: int, min_disp: int
) -> tuple[npt.NDArray[np.int32], npt.NDArray[np.int32]]:
    """(h, 1) flat index y·W of each row's start, and (h, W) y·W + x - min_disp (read-only)."""
    row_start = (np.arange(h, dtype=np.int32) * np.int32(W))[:, None]
    base = row_start + (np.arange(W, dtype=np.int32) - np.int32(min_disp))[None, :]
    row_start.setflags(write=False)
    base.setflags(write=False)
    return row_start, base
