"""Semi-global aggregation of NCC matching costs (Hirschmüller's SGM on the paper's NCC).

Block NCC (`aida_kb.vision.stereo`) decides each pixel from its own window: on weak texture
the window's best score is often a wrong disparity or too flat to keep, so facades with
plaster, glass or shade get holes. Semi-global matching keeps the same per-pixel cost,
``C(p, d) = 1 - NCC(p, d)`` (0 for a perfect match, 2 for an inverted one), and adds
smoothness along scanlines: along each direction r,

    L_r(p, d) = C(p, d) + min( L_r(p - r, d),
                               L_r(p - r, d ± 1) + P1,
                               min_k L_r(p - r, k) + P2 ) - min_k L_r(p - r, k)

and the disparity minimises ``S(p, d) = sum_r L_r(p, d)``. P1 lets slanted surfaces (a wall
seen at an angle: the disparity changes by a pixel every few pixels) pass cheaply; P2 is the
price of a depth discontinuity. Each direction is one Python loop over the scanlines with
whole (disparities x line) slices per step: vectorised over everything but the scanline
order, which the recursion fixes.

The disparity is the minimum of S refined by a parabola through its neighbours; a pixel
keeps it only if the right image's minimum along its own epipolar line points back (left-right
check) and the minimum lies inside the range. The certainty is the product of the NCC peak at
that disparity (as in block matching), the aggregated cost's uniqueness (how much cheaper the
minimum is than the best disparity at least two away) and the image-gradient factor: a pixel
filled in by the smoothness across a textureless patch keeps its disparity but little
certainty.

Memory: two float32 volumes of H x W x D (the costs and their aggregate): 640x480 with 64
disparities is 157 MB; `sgm_disparity` refuses a volume over the run's memory budget.
"""

from __future__ import annotations

import cv2
import numpy as np
import numpy.typing as npt

from aida_kb.errors import VisionError
from aida_kb.limits import memory_budget
from aida_kb.vision.stereo import (
    DISTINCT_SCALE,
    GRADIENT_SNR,
    PEAK_FLOOR,
    DisparityMap,
    _prepare,
    _WindowSums,
    _Workspace,
    checked_pair,
    image_noise_sd,
)

F32 = npt.NDArray[np.float32]

# Penalties in units of the cost 1 - NCC, and the window. Chosen on the top half of the
# Middlebury Motorcycle pair (scikit-image's copy) among window 5/7/9, P1 0.05/0.1, P2
# 0.4/0.8/1.6 and P2_EDGE_GREY 8/16/constant, with the bottom half held out
# (benchmarks/real.py reports both halves and the whole). P1: a one-pixel disparity step
# between neighbours costs as much as a 0.1 drop of the NCC score (a wall slanted by 60
# degrees changes its disparity every few pixels; it must not be flattened into steps). P2:
# a depth discontinuity inside an evenly shaded patch costs most of the cost range (0..2),
# so that the surface breaks where the image has an edge (P2_EDGE_GREY) and hardly elsewhere.
SGM_P1 = 0.1
SGM_P2 = 1.6
# The correlation window: smaller than block matching's (11-15 px), since the aggregation,
# not the window, supplies the support; 7 px still averages the sensor noise of one pixel.
SGM_WINDOW = 7
# Intensity-adaptive P2: across an image step of this many grey levels P2 is halved (depth
# edges lie on image edges; sensor noise is 1-3 grey levels).
P2_EDGE_GREY = 8.0
# Scanline directions: 4 (rows and columns both ways) or 8 (and the diagonals; about twice
# the time for a smaller gain).
SGM_DIRECTIONS = 4
# Uniqueness at which the certainty's uniqueness factor reaches 1: the best disparity's
# aggregate is 1 - UNIQUE_SCALE times that of the best one at least two disparities away.
UNIQUE_SCALE = DISTINCT_SCALE
# Speckle filter: a connected piece of at most SPECKLE_PX pixels (a 10x10 patch) whose
# disparity jumps by more than SPECKLE_RANGE_PX against everything around it is a wrong
# match in a textureless or repetitive patch, not a surface (OpenCV's SGBM does the same).
SPECKLE_PX = 100
SPECKLE_RANGE_PX = 2.0
# Bytes per pixel and disparity: the cost and the aggregate volumes (float32 each), plus one
# direction's running slice (negligible).
_BYTES_PER_CELL = 8


def _cost_volume(L: F32, R: F32, min_disp: int, D: int, window: int) -> tuple[F32, F32, F32]:
    """(D, H, W) costs 1 - NCC (2 where x - d leaves the image, 1 where a window is flat),
    the left image's flat mask as float (H, W), and its gradient factor (H, W)."""
    H, W = L.shape
    wl, wr, ws = _Workspace(), _Workspace(), _Workspace()
    g_scale = GRADIENT_SNR * max(image_noise_sd(L), image_noise_sd(R))
    left = _prepare(L, window, False, 1.0 / (window * window), wl, gradient_scale=g_scale)
    right = _prepare(R, window, False, 1.0, wr)
    sums = _WindowSums(left, right, 0, H, ws)
    cost = np.full((D, H, W), 2.0, np.float32)
    scores = np.empty((H, W), np.float32)
    for k in range(D):
        d = min_disp + k
        if d >= W:
            continue
        sums(d, scores[:, : W - d])
        np.subtract(np.float32(1.0), scores[:, : W - d], out=cost[k, :, d:])
        flat_right = right.flat[:, : W - d]
        cost[k, :, d:][flat_right] = 1.0  # a flat right window says nothing either way
    cost[:, left.flat] = 1.0
    return cost, left.flat.astype(np.float32), np.array(left.c_grad, np.float32)


def _p2_map(image: F32, p1: float, p2: float, dy: int, dx: int) -> F32:
    """P2 for the step from p - r to p, r = (dy, dx), (H, W): p2 / (1 + |I(p) - I(p - r)| /
    P2_EDGE_GREY), at least p1 (intensity-adaptive P2: a disparity jump is cheaper across an
    image edge, where depth edges are; 0 steps at the image border are never used)."""
    H, W = image.shape
    prev = np.empty_like(image)
    ys = slice(max(dy, 0), H + min(dy, 0))
    xs = slice(max(dx, 0), W + min(dx, 0))
    ys_from = slice(max(-dy, 0), H + min(-dy, 0))
    xs_from = slice(max(-dx, 0), W + min(-dx, 0))
    prev[...] = image
    prev[ys, xs] = image[ys_from, xs_from]
    step = np.abs(image - prev)
    out = np.float32(p2) / (1.0 + step / np.float32(P2_EDGE_GREY))
    return np.asarray(np.maximum(out, np.float32(p1)), dtype=np.float32)


def _along(cost: F32, total: F32, axis: int, reverse: bool, p1: float, p2_map: F32) -> None:
    """Add one direction's L_r to `total`; the direction runs along `axis` (1: down the
    columns, 2: along the rows) of the (D, H, W) volumes, backwards if `reverse`; p2_map
    (H, W) is P2 of the step into each pixel along this direction."""
    c = np.moveaxis(cost, axis, 0)  # (N, D, M) views
    t = np.moveaxis(total, axis, 0)
    p2s = np.moveaxis(p2_map, axis - 1, 0)  # (N, M)
    n = c.shape[0]
    order = range(n - 1, -1, -1) if reverse else range(n)
    prev: F32 | None = None
    cand = np.empty(c.shape[1:], np.float32)
    shifted = np.empty(c.shape[1:], np.float32)
    for i in order:
        if prev is None:
            prev = c[i].copy()
        else:
            _step(prev, c[i], cand, shifted, p1, p2s[i])
            prev, cand = cand, prev
        t[i] += prev


def _step(prev: F32, c: F32, out: F32, shifted: F32, p1: float, p2: F32) -> None:
    """out = c + min(prev, prev(d ± 1) + p1, min prev + p2) - min prev; (D, M) slices,
    p2 (M,)."""
    m = prev.min(axis=0)
    np.copyto(out, prev)
    np.add(prev[:-1], np.float32(p1), out=shifted[1:])
    np.minimum(out[1:], shifted[1:], out=out[1:])
    np.add(prev[1:], np.float32(p1), out=shifted[:-1])
    np.minimum(out[:-1], shifted[:-1], out=out[:-1])
    np.minimum(out, m + np.float32(p2), out=out)
    out += c
    out -= m


def _diagonal(cost: F32, total: F32, dy: int, dx: int, p1: float, p2_map: F32) -> None:
    """Add the L_r of the diagonal direction (dy, dx) (each ±1): row by row, the previous
    row's aggregate shifted by one column; a path entering at the image's side restarts."""
    D, H, W = cost.shape
    rows = range(H) if dy > 0 else range(H - 1, -1, -1)
    prev: F32 | None = None
    moved = np.empty((D, W), np.float32)
    cand = np.empty((D, W), np.float32)
    shifted = np.empty((D, W), np.float32)
    entry = 0 if dx > 0 else W - 1
    for y in rows:
        c = cost[:, y, :]
        if prev is None:
            prev = c.copy()
        else:
            if dx > 0:
                moved[:, 1:] = prev[:, :-1]
            else:
                moved[:, :-1] = prev[:, 1:]
            moved[:, entry] = c[:, entry]
            _step(moved, c, cand, shifted, p1, p2_map[y])
            cand[:, entry] = c[:, entry]
            prev, cand = cand, prev
        total[:, y, :] += prev


def aggregate(
    cost: F32,
    image: F32,
    *,
    p1: float = SGM_P1,
    p2: float = SGM_P2,
    directions: int = SGM_DIRECTIONS,
) -> F32:
    """S(p, d): the costs (D, H, W) aggregated along `directions` (4 or 8) scanline
    directions (see the module docstring), P2 adapted to the steps of `image` (H, W, grey
    levels); float32 (D, H, W)."""
    if directions not in (4, 8):
        raise VisionError(f"SGM directions must be 4 or 8, got {directions}")
    if not 0 <= p1 <= p2:
        raise VisionError(f"SGM penalties need 0 <= P1 <= P2, got {p1}, {p2}")
    total = np.zeros_like(cost)
    for axis in (1, 2):
        for reverse in (False, True):
            sign = -1 if reverse else 1
            dy, dx = (sign, 0) if axis == 1 else (0, sign)
            _along(cost, total, axis, reverse, p1, _p2_map(image, p1, p2, dy, dx))
    if directions == 8:
        for dy in (1, -1):
            for dx in (1, -1):
                _diagonal(cost, total, dy, dx, p1, _p2_map(image, p1, p2, dy, dx))
    return total


def _take(volume: F32, k: npt.NDArray[np.intp]) -> F32:
    """volume[k[y, x], y, x] for an index map k (H, W)."""
    return np.asarray(np.take_along_axis(volume, k[None], axis=0)[0], dtype=np.float32)


def sgm_disparity(
    left: npt.NDArray[np.generic],
    right: npt.NDArray[np.generic],
    *,
    min_disp: int = 0,
    num_disp: int = 64,
    window: int = SGM_WINDOW,
    p1: float = SGM_P1,
    p2: float = SGM_P2,
    directions: int = SGM_DIRECTIONS,
    lr_tolerance_px: float = 1.0,
    speckle_px: int = SPECKLE_PX,
) -> DisparityMap:
    """Dense disparity of a rectified pair by semi-global aggregation of NCC costs.

    Parameters
    ----------
    left, right : (H, W) grey or (H, W, 3) BGR images of a rectified pair (same size).
    min_disp, num_disp : disparities min_disp .. min_disp + num_disp - 1 (pixels,
        x_left - x_right); min_disp >= 0, 3 <= num_disp <= 256.
    window : odd side of the NCC window, pixels. p1, p2 : the smoothness penalties (cost
        units, see SGM_P1 / SGM_P2). directions : 4 or 8 scanline directions.
    lr_tolerance_px : the right image's best disparity at x - d must be within this of d.
    speckle_px : connected pieces of fewer pixels whose disparities differ from their
        neighbours' by more than SPECKLE_RANGE_PX are dropped (0: none).

    Returns
    -------
    DisparityMap
        (H, W) float32 maps on the rectified left image, as `ncc_disparity`'s: disparity
        (NaN where none: left-right check failed, minimum on an end of the range, or x - d
        outside the right image), certainty = clip((peak - PEAK_FLOOR) / (1 - PEAK_FLOOR))
        * clip(uniqueness / UNIQUE_SCALE) * gradient factor, peak (the NCC at the disparity)
        and distinctiveness (the aggregate's uniqueness, 0..1).
    """
    L, R = checked_pair(left, right, min_disp, num_disp, window)
    H, W = L.shape
    need = _BYTES_PER_CELL * H * W * num_disp
    if need > memory_budget():
        raise VisionError(
            f"semi-global matching of {W}x{H} pixels over {num_disp} disparities needs "
            f"{need / 2**30:.1f} GiB, more than the memory budget of "
            f"{memory_budget() / 2**30:.1f} GiB: match at a lower resolution"
        )
    D = num_disp
    cost, _, c_grad = _cost_volume(L, R, min_disp, D, window)
    total = aggregate(cost, L, p1=p1, p2=p2, directions=directions)

    k = total.argmin(axis=0)
    best = _take(total, k)
    s_m = _take(total, np.maximum(k - 1, 0))
    s_p = _take(total, np.minimum(k + 1, D - 1))
    denom = s_m + s_p - 2.0 * best
    with np.errstate(divide="ignore", invalid="ignore"):
        offset = np.where(denom > 0, 0.5 * (s_m - s_p) / denom, 0.0)
    disp = (k + np.clip(offset, -0.5, 0.5) + min_disp).astype(np.float32)

    # uniqueness: the best aggregate at least two disparities away from the minimum
    d_index = np.arange(D)[:, None, None]
    near = np.abs(d_index - k[None]) <= 1
    second = np.where(near, np.inf, total).min(axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        unique = np.where(second > 0, (second - best) / second, 0.0).astype(np.float32)
    unique[~np.isfinite(unique)] = 0.0

    # left-right check: the right pixel xr = x - d takes its minimum over d of S(xr + d, d)
    right_total = np.full((D, H, W), np.inf, np.float32)
    for j in range(D):
        d = min_disp + j
        if d < W:
            right_total[j, :, : W - d] = total[j, :, d:]
    k_right = right_total.argmin(axis=0)
    x_right = np.arange(W)[None, :] - (k + min_disp)
    inside = x_right >= 0
    k_back = np.take_along_axis(k_right, np.clip(x_right, 0, W - 1), axis=1)
    valid = inside & (np.abs(k_back - k) <= lr_tolerance_px) & (k > 0) & (k < D - 1)

    if speckle_px > 0:
        # small islands of disparity unlike their surroundings are wrong matches (cv2's
        # speckle filter, as SGBM's own post-processing): drop them
        fixed = np.where(valid, np.round(disp * 16.0), -16).astype(np.int16)
        cv2.filterSpeckles(fixed, -16, speckle_px, int(SPECKLE_RANGE_PX * 16))
        valid &= fixed >= 0

    peak = 1.0 - _take(cost, k)
    c_peak = np.clip((peak - PEAK_FLOOR) / (1.0 - PEAK_FLOOR), 0.0, 1.0)
    c_unique = np.clip(unique / UNIQUE_SCALE, 0.0, 1.0)
    certainty = (c_peak * c_unique * c_grad).astype(np.float32)
    certainty[~valid] = 0.0
    nan = np.float32(np.nan)
    return DisparityMap(
        disparity=np.where(valid, disp, nan).astype(np.float32),
        certainty=certainty,
        peak=np.where(valid, peak, nan).astype(np.float32),
        distinctiveness=np.where(valid, unique, nan).astype(np.float32),
    )
