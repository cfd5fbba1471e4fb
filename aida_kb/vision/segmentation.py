"""Segmentation into regions of equal surface orientation (paper §2), and region contours.

Orientation comes from the disparity map of the rectified left image: locally a surface is a
plane d = a·u + b·v + g, whose normal in the rectified camera is parallel to
(a, b, (g + a·cx + b·cy)/f) (see aida_kb.vision.planes). `local_planes` fits that plane in
every pixel's window (box filters of the moments, dropouts excluded); `segment_planes` grows
regions by sequential hypothesise-and-verify: the local planes are the hypotheses, a pixel
joins a plane when its disparity lies on it and its own local orientation agrees, and the
connected components become regions.
"""

from __future__ import annotations

import cv2
import numpy as np
import numpy.typing as npt

from aida_kb.errors import VisionError

F32 = npt.NDArray[np.float32]
F64 = npt.NDArray[np.float64]
I32 = npt.NDArray[np.int32]


def local_planes(
    disparity: F32, certainty: F32, *, window: int = 25, min_valid: float = 0.5
) -> F64:
    """Each pixel's least-squares plane d = a·u + b·v + g over its window: (H, W, 3) (a, b, g).

    Box filters of the moments give all pixels at once. disparity : (H, W) float32 on the
    rectified left image, NaN = none; certainty : (H, W); samples with certainty <= 0.1 are
    left out. NaN where less than `min_valid` of the window has samples.
    """
    H, W = disparity.shape
    ok = ~np.isnan(disparity) & (certainty > 0.1)
    w = ok.astype(np.float64)
    d = np.where(ok, disparity, 0.0).astype(np.float64)
    u = np.arange(W, dtype=np.float64)[None, :].repeat(H, axis=0)
    v = np.arange(H, dtype=np.float64)[:, None].repeat(W, axis=1)
    k = (window, window)

    def box(x: F64) -> F64:
        return np.asarray(
            cv2.boxFilter(x, cv2.CV_64F, k, normalize=False, borderType=cv2.BORDER_CONSTANT),
            np.float64,
        )

    n = box(w)
    enough = n >= min_valid * window * window
    n_safe = np.where(enough, n, 1.0)
    mu, mv, md = box(w * u) / n_safe, box(w * v) / n_safe, box(d) / n_safe
    cuu = box(w * u * u) / n_safe - mu * mu
    cvv = box(w * v * v) / n_safe - mv * mv
    cuv = box(w * u * v) / n_safe - mu * mv
    cud = box(u * d) / n_safe - mu * md
    cvd = box(v * d) / n_safe - mv * md
    det = cuu * cvv - cuv * cuv
    good = enough & (det > 1e-6)
    det = np.where(good, det, 1.0)
    a = (cvv * cud - cuv * cvd) / det
    b = (cuu * cvd - cuv * cud) / det
    g = md - a * mu - b * mv
    return np.where(good[..., None], np.stack([a, b, g], axis=-1), np.nan)


def plane_normals(planes: F64, focal_px: float, cx: float, cy: float) -> F32:
    """Unit normals (..., 3) facing the camera of disparity planes (..., 3) (a, b, g).

    Rectified left camera frame; NaN where the plane is NaN or degenerate.
    """
    a, b, g = planes[..., 0], planes[..., 1], planes[..., 2]
    m = np.stack([a, b, (g + a * cx + b * cy) / focal_px], axis=-1)
    norm = np.linalg.norm(m, axis=-1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        normals = np.where(norm > 0, -m / norm, np.nan)
    return normals.astype(np.float32)


def segment_planes(
    disparity: F32,
    certainty: F32,
    planes: F64,
    *,
    threshold_px: float = 0.4,
    tolerance_deg: float = 30.0,
    focal_px: float | None = None,
    min_pixels: int = 200,
    max_regions: int = 40,
    hypotheses: int = 128,
    step: int = 2,
    seed: int = 0,
) -> I32:
    """Planar regions of equal orientation: (H, W) int32 ids 1..N on the rectified image.

    Sequential hypothesise-and-verify: each pixel's local plane (`local_planes`) is a
    hypothesis; a random batch of them is scored on a grid of certain pixels (inliers: within
    `threshold_px` of disparity, and — equal orientation — local slopes within the tolerance
    of the plane's), the best is refitted robustly on its inliers (`fit_disparity_plane`), its
    connected inlier components of at least `min_pixels` become regions, and their pixels
    leave the pool. Deterministic for a given `seed`.

    The orientation test compares normals made from the slopes with `focal_px` (default: the
    image width, a plain normal angle for a typical lens); `tolerance_deg` is that angle.
    """
    from aida_kb.vision.planes import fit_disparity_plane

    H, W = disparity.shape
    valid = ~np.isnan(disparity) & (certainty > 0.1)
    regions = np.zeros((H, W), np.int32)
    vs, us = np.mgrid[0:H, 0:W]
    grid = np.zeros((H, W), bool)
    grid[::step, ::step] = True
    rng = np.random.default_rng(seed)
    free = valid.copy()  # pixels not yet in a region nor spent
    has_plane = np.all(np.isfinite(planes), axis=-1)
    d_filled = np.where(valid, disparity, 0.0).astype(np.float64)
    f = float(focal_px) if focal_px is not None else float(W)
    cx, cy = (W - 1) / 2.0, (H - 1) / 2.0
    local_n = plane_normals(planes, f, cx, cy).astype(np.float64)
    unknown = ~np.all(np.isfinite(local_n), axis=-1)  # no local plane: orientation not tested
    local_n = np.where(unknown[..., None], 0.0, local_n)
    cos_tol = float(np.cos(np.radians(tolerance_deg)))
    next_id = 1
    close = np.ones((5, 5), np.uint8)
    for _ in range(4 * max_regions):
        pool = free & grid
        n_pool = int(np.count_nonzero(pool))
        if n_pool * step * step < min_pixels or next_id > max_regions:
            break
        seeds = np.flatnonzero(pool & has_plane)
        if len(seeds) == 0:
            break
        pick = rng.choice(seeds, size=min(hypotheses, len(seeds)), replace=False)
        coef = planes.reshape(-1, 3)[pick]  # (Hy, 3)
        pu, pv, pd = us[pool].astype(np.float64), vs[pool].astype(np.float64), d_filled[pool]
        resid = np.abs(coef[:, :1] * pu + coef[:, 1:2] * pv + coef[:, 2:3] - pd)
        agree = plane_normals(coef, f, cx, cy).astype(np.float64) @ local_n[pool].T > cos_tol
        ok_h = (resid < threshold_px) & agree
        counts = ok_h.sum(axis=1)
        best = int(np.argmax(counts))
        sel = ok_h[best]
        if np.count_nonzero(sel) < 3:
            free.ravel()[pick[best]] = False
            continue
        cert = certainty[pool][sel].astype(np.float64)
        try:
            fit = fit_disparity_plane(pu[sel], pv[sel], pd[sel], cert)
        except VisionError:
            free.ravel()[pick[best]] = False
            continue
        model = fit.a * us + fit.b * vs + fit.g
        n_fit = plane_normals(np.array([fit.a, fit.b, fit.g]), f, cx, cy).astype(np.float64)
        same = (local_n @ n_fit > cos_tol) | unknown
        inl = free & (np.abs(d_filled - model) < threshold_px) & same
        inl_u8 = cv2.morphologyEx(inl.astype(np.uint8), cv2.MORPH_CLOSE, close)
        inl_u8[regions > 0] = 0
        n, comp, stats, _ = cv2.connectedComponentsWithStats(inl_u8, connectivity=4)
        keep = np.nonzero(stats[1:, cv2.CC_STAT_AREA] >= min_pixels)[0] + 1
        if len(keep) == 0:
            free &= ~inl  # these pixels cannot seed a region of their own
            continue
        lut = np.zeros(n, np.int32)
        lut[keep] = np.arange(next_id, next_id + len(keep), dtype=np.int32)
        next_id += len(keep)
        new = lut[comp]
        regions = np.where(new > 0, new, regions)
        free &= new == 0
        free &= ~inl
    return regions


def disparity_normals(
    disparity: F32,
    certainty: F32,
    focal_px: float,
    cx: float,
    cy: float,
    *,
    window: int = 25,
) -> F32:
    """Unit surface normals (H, W, 3) from the local planes, rectified left camera frame."""
    return plane_normals(local_planes(disparity, certainty, window=window), focal_px, cx, cy)


def region_contours(
    regions: npt.NDArray[np.integer], *, tolerance_px: float = 1.0, min_area_px: float = 20.0
) -> list[tuple[int, bool, F64]]:
    """Boundaries of every region: (region id, is_hole, (K, 2) polygon in pixels (x, y)).

    regions : (H, W) integer region map, 0 = none. Polygons are simplified to `tolerance_px`;
    boundaries enclosing less than `min_area_px` are dropped.
    """
    if regions.ndim != 2:
        raise VisionError(f"region map must be 2-D, got shape {regions.shape}")
    out: list[tuple[int, bool, F64]] = []
    for rid in np.unique(regions):
        if rid == 0:
            continue
        mask = (regions == rid).astype(np.uint8)
        found = cv2.findContours(mask, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_SIMPLE)
        contours, hierarchy = found[-2], found[-1]
        if hierarchy is None:
            continue
        for contour, h in zip(contours, hierarchy[0], strict=True):
            if abs(cv2.contourArea(contour)) < min_area_px:
                continue
            poly = cv2.approxPolyDP(contour, tolerance_px, True).reshape(-1, 2)
            if len(poly) < 3:
                continue
            out.append((int(rid), bool(h[3] >= 0), poly.astype(np.float64)))
    return out
