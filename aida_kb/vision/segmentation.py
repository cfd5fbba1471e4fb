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

import warnings
from typing import Literal

import cv2
import numpy as np
import numpy.typing as npt
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components

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


# Merging coplanar regions (window recesses, shallow relief and dropouts split a facade into
# tens of regions that share one plane). Two regions merge when their normals lie within
# COPLANAR_DEG of each other, each one's centroid lies within COPLANAR_REL of its distance from
# the other's plane (2 %: 0.4 m at 20 m, the depth of a window reveal; stereo noise on a wall
# is well below), and they come within MERGE_GAP_PX of each other in the image (across a
# window hole or a dropout).
COPLANAR_DEG = 3.0
COPLANAR_REL = 0.02
MERGE_GAP_PX = 16
_MERGE_STEP_PX = 4  # the label map is sampled on this grid to find neighbours


def _separation(
    regions: I32, index: npt.NDArray[np.int64], R: int, within_px: int = MERGE_GAP_PX
) -> F64:
    """(R, R) symmetric: how close the regions (by `index`, region id -> 0..R-1, -1 none)
    come to each other along an image row or column, pixels (on a grid of _MERGE_STEP_PX;
    inf: not within `within_px`)."""
    grid = index[regions[::_MERGE_STEP_PX, ::_MERGE_STEP_PX]]
    gap = np.full((R, R), np.inf)
    for k in range(max(1, within_px // _MERGE_STEP_PX), 0, -1):  # the closest written last
        for a, b in ((grid[:, :-k], grid[:, k:]), (grid[:-k, :], grid[k:, :])):
            ok = (a >= 0) & (b >= 0) & (a != b)
            gap[a[ok], b[ok]] = k * _MERGE_STEP_PX
            gap[b[ok], a[ok]] = k * _MERGE_STEP_PX
    return gap


def _neighbours(regions: I32, index: npt.NDArray[np.int64], R: int) -> npt.NDArray[np.bool_]:
    """(R, R) symmetric: the regions (by `index`) within MERGE_GAP_PX of each other."""
    return np.isfinite(_separation(regions, index, R))


def merge_coplanar(
    regions: I32,
    ids: npt.NDArray[np.int64],
    normals: F64,
    centroids: F64,
    *,
    points: F32 | None = None,
    focal_px: float | None = None,
) -> I32:
    """The region map (H, W) with coplanar neighbouring regions given one id (the smallest).

    regions : (H, W) int32 ids, 0 = none. ids : (R,) the ids with a plane; normals : (R, 3)
    unit normals and centroids : (R, 3) metres, one frame (the camera's). Regions without a
    plane are left as they are. See COPLANAR_DEG, COPLANAR_REL, MERGE_GAP_PX. With `points`
    ((H, W, 3) float32 metres, that frame, NaN = no depth; the camera's, z its depth) and the
    camera's `focal_px`, the pieces whose points lie on one plane within their own scatter are
    merged too (`merge_fragments`).
    """
    R = len(ids)
    if R < 2:
        return regions
    index = np.full(int(max(int(regions.max()), int(ids.max()))) + 1, -1, np.int64)
    index[ids] = np.arange(R)
    near = _neighbours(regions, index, R)
    cos = np.clip(np.abs(normals @ normals.T), -1.0, 1.0)
    dist = np.abs(np.einsum("ik,ijk->ij", normals, centroids[None, :, :] - centroids[:, None, :]))
    rel = dist / np.linalg.norm(centroids, axis=1)[:, None]
    ok = (
        near
        & (cos >= np.cos(np.radians(COPLANAR_DEG)))
        & (rel <= COPLANAR_REL)
        & (rel.T <= COPLANAR_REL)
    )
    n, comp = connected_components(csr_matrix(ok), directed=False)
    merged = regions
    if n < R:
        first = np.full(n, np.iinfo(np.int64).max)
        np.minimum.at(first, comp, ids)
        lut = np.arange(index.size, dtype=np.int64)
        lut[ids] = first[comp]
        merged = lut[regions].astype(np.int32)
    if points is None or focal_px is None:
        return merged
    return merge_fragments(merged, np.unique(merged[np.isin(merged, ids)]), points, focal_px)


# Merging the fragments of one plane. Narrow or weakly textured faces (a wall between windows,
# seen at 30 m) come out of `segment_planes` as tens of small regions whose own plane fits
# scatter by 5-30 degrees (a few hundred pixels each): COPLANAR_DEG cannot tell them from
# different planes, and a part bound to one of them is a sliver (a wall 0.35 m wide). Whether
# two neighbours are pieces of one plane is asked of their points instead: fit one plane to
# both, and each piece's points must scatter about it by at most FRAGMENT_SIGMAS times their
# scatter about the piece's own plane (RMS: relief and stereo noise as the piece shows them).
# Pieces of one wall pass (development scene 2000: 1.00-1.13); a wall and a roof (tens of
# degrees apart) or a wall and a porch (parallel, a metre out) leave a piece far off the
# joint plane (a wall piece beside a noisier one of a wing at 45 degrees: 3.5). Merging is
# greedy, the best-fitting pair first, and each merged group is tested again as a whole: a
# noisy sliver at an eave may fit the wall or the roof, but wall and roof never fit one plane.
FRAGMENT_SIGMAS = 1.5  # a piece's RMS about the joint plane at most 1.5 times its own
FRAGMENT_MIN_RMS_M = 0.01  # scatter never below 1 cm (exact synthetic depth: no zero divide)
FRAGMENT_MIN_POINTS = 10  # a region needs this many points with depth to be tested
FRAGMENT_GAP_M = 1.5  # pieces this far apart at their depth may be one plane (a window wide),
# and MERGE_GAP_PX more (the rims of a hole, where the matcher's window smears the depth step,
# have no region either: development scene 2000's wall pieces lie 1.9 m apart at 32 m)
FRAGMENT_GAP_PX = 64  # the widest gap in pixels searched (speed)


def _moments(regions: I32, ids: npt.NDArray[np.int64], points: F32) -> tuple[F64, F64, F64, F64]:
    """Per id (R,): the count of its points with depth, their sum (R, 3) and the sum of
    their outer products (R, 3, 3), metres, about `origin` (3,), the mean of all points in
    regions (numerical range)."""
    has = np.isfinite(points).all(axis=-1) & (regions > 0)
    lab = regions[has].astype(np.int64)
    xyz = points[has].astype(np.float64)
    origin = xyz.mean(axis=0) if len(xyz) else np.zeros(3)
    xyz = xyz - origin
    index = np.full(int(max(int(regions.max()), int(ids.max()))) + 1, -1, np.int64)
    index[ids] = np.arange(len(ids))
    k = index[lab]
    sel = k >= 0
    k, xyz = k[sel], xyz[sel]
    R = len(ids)
    count = np.bincount(k, minlength=R).astype(np.float64)
    s1 = np.stack([np.bincount(k, xyz[:, i], minlength=R) for i in range(3)], axis=1)
    s2 = np.stack(
        [np.bincount(k, xyz[:, i] * xyz[:, j], minlength=R) for i in range(3) for j in range(3)],
        axis=1,
    ).reshape(R, 3, 3)
    return count, np.asarray(s1, np.float64), np.asarray(s2, np.float64), origin


def _scatter(count: F64, s1: F64, s2: F64) -> tuple[F64, F64]:
    """The mean (..., 3) and covariance (..., 3, 3) of groups given by their moments."""
    n = np.maximum(count, 1.0)[..., None]
    mean = s1 / n
    cov = s2 / n[..., None] - mean[..., :, None] * mean[..., None, :]
    return mean, cov


def _off_plane(normal: F64, through: F64, mean: F64, cov: F64) -> F64:
    """RMS distance (P,) metres of point groups (means (P, 3), covariances (P, 3, 3)) from
    planes of unit normals (P, 3) through points (P, 3)."""
    spread = np.einsum("pk,pkl,pl->p", normal, cov, normal)
    shift = np.einsum("pk,pk->p", normal, mean - through)
    return np.asarray(np.sqrt(np.maximum(spread, 0.0) + shift**2), np.float64)


def merge_fragments(regions: I32, ids: npt.NDArray[np.int64], points: F32, focal_px: float) -> I32:
    """The region map (H, W) with neighbouring pieces of one plane given one id (the
    smallest): see FRAGMENT_SIGMAS. regions : (H, W) int32 ids, 0 = none; ids : (R,) the
    regions that may merge (others stay); points : (H, W, 3) float32 metres, the camera
    frame (z the depth), NaN = no depth; focal_px : the camera's focal length, pixels (turns
    FRAGMENT_GAP_M into pixels). Neighbours: regions that come within FRAGMENT_GAP_M of each
    other at their depth, along an image row or column."""
    R = len(ids)
    if R < 2:
        return regions
    count, s1, s2, origin = _moments(regions, ids, points)
    index = np.full(int(max(int(regions.max()), int(ids.max()))) + 1, -1, np.int64)
    index[ids] = np.arange(R)
    depth = np.abs(s1[:, 2] / np.maximum(count, 1.0) + origin[2])
    gap_px = focal_px * FRAGMENT_GAP_M / np.maximum(depth, 1e-9) + MERGE_GAP_PX
    sep = _separation(regions, index, R, FRAGMENT_GAP_PX)
    near = sep <= np.minimum(gap_px[:, None], gap_px[None, :])
    near &= (count >= FRAGMENT_MIN_POINTS)[:, None] & (count >= FRAGMENT_MIN_POINTS)[None, :]
    group = np.arange(R)  # each region's group: the index of its group's first member
    while True:
        a, b = np.nonzero(np.triu(near, 1))
        if len(a) == 0:
            break
        mean, cov = _scatter(count, s1, s2)
        own = np.sqrt(np.maximum(np.linalg.eigvalsh(cov)[:, 0], 0.0))
        own = np.maximum(own, FRAGMENT_MIN_RMS_M)
        mean_u, cov_u = _scatter(count[a] + count[b], s1[a] + s1[b], s2[a] + s2[b])
        n_u = np.linalg.eigh(cov_u)[1][:, :, 0]  # (P, 3) the joint plane's normal

        ratio = np.maximum(
            _off_plane(n_u, mean_u, mean[a], cov[a]) / (FRAGMENT_SIGMAS * own[a]),
            _off_plane(n_u, mean_u, mean[b], cov[b]) / (FRAGMENT_SIGMAS * own[b]),
        )
        best = int(np.argmin(ratio))
        if ratio[best] > 1.0:
            break
        i, j = int(a[best]), int(b[best])  # j joins i
        count[i] += count[j]
        s1[i] += s1[j]
        s2[i] += s2[j]
        count[j] = 0.0
        near[i] |= near[j]
        near[:, i] |= near[:, j]
        near[i, i] = False
        near[j, :] = False
        near[:, j] = False
        group[group == j] = i
    if np.all(group == np.arange(R)):
        return regions
    first = np.full(R, np.iinfo(np.int64).max)
    np.minimum.at(first, group, ids)
    lut = np.arange(index.size, dtype=np.int64)
    lut[ids] = first[group]
    merged: I32 = lut[regions].astype(np.int32)
    return merged


# Completing plane regions over the pixels stereo could not measure. A facade's region is only
# where the matcher found depth: plaster, glass and the rims of window recesses leave half of
# a real wall without depth (castle courtyard: 50 %), so its region is a lace of pieces
# although one plane explains all of it. `complete_regions` grows each plane region, largest
# first, over the 3-D points: a free pixel joins when its point lies on the plane within the
# tolerance, or it has no depth and lies in a gap of at most COMPLETE_GAP_M between the
# region's pixels (at the region's distance); then the holes the region encloses (window
# openings, dropouts) join unless their points lie in front of the plane (something else
# stands there: a lamp, a tractor). COMPLETE_GAP_M is metric: in a scene of unknown scale the
# gap is in its units, kept within COMPLETE_GAP_PX.
# The tolerance is in metres, tied to the depth uncertainty: COMPLETE_SIGMAS times the larger
# of the region's own fit RMS (which includes its relief) and the stereo depth noise
# sigma_Z = Z²·DISPARITY_SIGMA_PX / (f·B) at the pixel's depth.
COMPLETE_GAP_M = 1.5  # widest dropout bridged without enclosure: a window's width, metres
COMPLETE_GAP_PX = (2, 64)  # that gap's half in pixels kept within these (speed, tiny regions)
COMPLETE_SIGMAS = 3.0  # a point within 3 sigma of the plane is on it (0.3 % of noise beyond)
DISPARITY_SIGMA_PX = 0.25  # sub-pixel NCC noise on real texture, pixels (1-sigma)
# A pixel is claimed only where a matching window of pixels on the plane holds it
# (an opening of the region with its pixels on the plane). At a depth edge every window that
# straddles it takes the front surface's disparity (the higher contrast rules the exact
# NCC's sums: foreground fattening), so a strip about one window wide beside a silhouette
# carries the front's depth. Where that front stands on the plane's line -- a tower's corner
# rising past a wall's eave, in the wall's plane extended -- the strip lies "on" the plane: the
# real courtyard wall (Strecha castle, exact NCC) grew a strip 10 px wide 60 px up the tower's
# corner above its eave, and the inserted roof, supported by the wall's highest point, rose
# 3 m with it. A real surface joining the region is wider than a window.


def complete_regions(
    regions: I32,
    points: F32,
    ids: npt.NDArray[np.int64],
    normals: F64,
    offsets: F64,
    rms_m: F64,
    distances: F64,
    focal_px: float,
    baseline_m: float,
    window_px: int = 1,
) -> I32:
    """The region map (H, W) with each plane region grown over the pixels its plane explains.

    regions : (H, W) int32 ids, 0 = none. points : (H, W, 3) float32 metres, the camera frame
    of the planes, NaN = no depth. ids : (R,) the regions with a plane; normals : (R, 3) unit,
    towards the camera, and offsets : (R,) metres (n·x = d); rms_m : (R,) each plane fit's RMS,
    metres. focal_px, baseline_m : of the rectified pair (for the depth noise). Only pixels of
    no region are claimed; regions without a plane are left as they are. See COMPLETE_GAP_PX,
    COMPLETE_SIGMAS, DISPARITY_SIGMA_PX. distances : (R,) metres, each region's depth (z of
    its centroid), which turns COMPLETE_GAP_M into pixels. window_px : the matcher's window
    side, pixels of the map: a pixel on the plane is claimed only inside a square of that side
    of the region and its pixels on the plane (1: every one; see DISPARITY_SIGMA_PX's note on
    foreground fattening).
    """
    from scipy.ndimage import binary_fill_holes

    out = regions.copy()
    if len(ids) == 0:
        return out
    has = ~np.isnan(points[..., 2])
    pts = np.where(has[..., None], points, 0.0).astype(np.float64)
    z = pts[..., 2]
    sigma_z = z * z * DISPARITY_SIGMA_PX / max(focal_px * baseline_m, 1e-12)
    size = np.array([np.count_nonzero(regions == i) for i in ids])
    window = np.ones((window_px, window_px), np.uint8)  # the matcher's square window
    for k in np.argsort(-size, kind="stable"):
        rid = int(ids[k])
        mask = out == rid
        if not mask.any():
            continue
        free = out == 0
        signed = pts @ normals[k] - offsets[k]  # > 0: in front of the plane (towards the camera)
        tol = COMPLETE_SIGMAS * np.maximum(rms_m[k], sigma_z)
        on = has & (np.abs(signed) <= tol)
        if window_px > 1:  # no strip narrower than a window out of the region
            whole = cv2.morphologyEx((mask | (free & on)).astype(np.uint8), cv2.MORPH_OPEN, window)
            on &= whole.astype(bool)
        front = has & (signed > tol)
        allowed = mask | (free & (on | ~has))
        half = focal_px * COMPLETE_GAP_M / (2.0 * max(float(distances[k]), 1e-9))
        r = int(np.clip(np.ceil(half), *COMPLETE_GAP_PX))
        disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
        grow = mask | (free & on)
        closed = cv2.morphologyEx(grow.astype(np.uint8), cv2.MORPH_CLOSE, disc).astype(bool)
        n, comp = cv2.connectedComponents((closed & allowed).astype(np.uint8), connectivity=8)
        touching = np.zeros(n, bool)
        touching[comp[mask]] = True
        touching[0] = False
        grown = touching[comp]
        filled = binary_fill_holes(grown) & free & ~front
        out[grown | filled] = rid
    return out


# Recesses counted as the wall they are set in. A facade's openings — window reveals, portals
# with their embrasures, doors and tympana — are seen through the wall: their surfaces lie
# behind its plane, by at most the wall's thickness with its porch, and the wall surrounds them
# in the image. A user takes them as part of the wall (the castle's reference labels do), but
# `complete_regions` only fills what the region encloses completely, and a portal opens onto
# the steps at its foot. `absorb_recesses` gives a plane region what stereo saw behind its
# plane within RECESS_M — pixels of no region, and whole regions whose points lie there
# (RECESS_INLIER_SHARE of them) — where the region encloses it: looking up from the pixel, and
# to its left and right, past pixels without depth and other such recess pixels, the first
# thing met is the region (the image's border may stand for it on one side, not on both: a
# portal cut by the photo's edge). A side wall or a roof behind a front's plane, beyond its
# corner or above its eave, has the sky or its own roof above it, not the wall. The pixels
# without depth between the wall and what joined it then join too (bridged as
# `complete_regions` bridges dropouts), not the sky or the ground (seen in front of the wall)
# a recess opens onto. RECESS_M is metric: in a scene of unknown scale it is in its units.
RECESS_M = 3.0  # deepest recess: the thickest masonry walls with a portal's porch, metres
RECESS_INLIER_SHARE = 0.9  # a region is a recess when this share of its points lies in one
RECESS_ENCLOSED_SHARE = 0.5  # ... and more than this share of its pixels is enclosed


def _first_met(stop: npt.NDArray[np.bool_], axis: int, reverse: bool) -> npt.NDArray[np.intp]:
    """(H, W): for every pixel, the index along `axis` of the nearest `stop` pixel before it
    (after it with `reverse`), the pixel itself included; -1 where there is none (the
    image's border)."""
    n = stop.shape[axis]
    shape = [1, 1]
    shape[axis] = n
    index = np.arange(n).reshape(shape)
    if reverse:
        stop = np.flip(stop, axis)
    marked = np.where(stop, index, -1)
    last = np.maximum.accumulate(marked, axis=axis)
    if reverse:
        last = np.where(last >= 0, n - 1 - last, -1)
        last = np.flip(last, axis)
    return np.asarray(last, np.intp)


def enclosed_by(mask: npt.NDArray[np.bool_], clear: npt.NDArray[np.bool_]) -> npt.NDArray[np.bool_]:
    """(H, W) bool: the `clear` pixels the `mask` encloses from above and on both sides.

    Looking up, left and right from a pixel across `clear` pixels, the first pixel met that is
    not clear must be the mask's — up always, left and right each either the mask's or the
    image's border, not both the border."""
    H, W = mask.shape
    stop = ~clear
    rows = np.arange(H)[:, None].repeat(W, axis=1)
    cols = np.arange(W)[None, :].repeat(H, axis=0)
    up = _first_met(stop, 0, False)
    left = _first_met(stop, 1, False)
    right = _first_met(stop, 1, True)
    up_ok = (up >= 0) & mask[np.maximum(up, 0), cols]
    left_edge, right_edge = left < 0, right < 0
    left_ok = left_edge | mask[rows, np.maximum(left, 0)]
    right_ok = right_edge | mask[rows, np.maximum(right, 0)]
    out: npt.NDArray[np.bool_] = clear & up_ok & left_ok & right_ok & ~(left_edge & right_edge)
    return out


def absorb_recesses(
    regions: I32,
    points: F32,
    ids: npt.NDArray[np.int64],
    gap_px: npt.NDArray[np.int64],
    normals: F64,
    offsets: F64,
    tolerances: F64,
) -> I32:
    """The region map (H, W) with each plane region given the recesses set in it.

    regions : (H, W) int32 ids, 0 = none. points : (H, W, 3) float32 metres, the camera frame
    of the planes, NaN = no depth. ids : (R,) the regions with a plane; gap_px : (R,) the
    widest gap between seen pixels bridged, pixels (COMPLETE_GAP_M at the region's distance,
    half of it, within COMPLETE_GAP_PX); normals : (R, 3) unit, towards the camera, offsets :
    (R,) metres (n·x = d), tolerances : (R,) metres, how far from its plane a point lies on it
    (see `complete_regions`). Regions are served largest first; a region absorbed by another is
    gone. See RECESS_M, RECESS_INLIER_SHARE, RECESS_ENCLOSED_SHARE.
    """
    out = regions.copy()
    if len(ids) == 0:
        return out
    has = ~np.isnan(points[..., 2])
    pts = np.where(has[..., None], points, 0.0).astype(np.float64)
    size = np.bincount(regions.ravel(), minlength=int(max(regions.max(), ids.max())) + 1)[ids]
    for k in np.argsort(-size, kind="stable"):
        rid = int(ids[k])
        mask = out == rid
        if not mask.any():
            continue
        signed = pts @ normals[k] - offsets[k]  # > 0: in front of the plane
        band = has & (signed <= tolerances[k]) & (signed >= -RECESS_M)
        top = int(out.max()) + 1
        with_depth = np.bincount(out[has].ravel(), minlength=top)
        in_band = np.bincount(out[band].ravel(), minlength=top)
        region_ok = (in_band >= RECESS_INLIER_SHARE * with_depth) & (with_depth > 0)
        region_ok[0] = False
        region_ok[rid] = False
        free = out == 0
        seen = (free & band) | region_ok[out]  # what stereo saw in a recess of the plane
        inside = enclosed_by(mask, seen | (free & ~has))
        share = np.bincount(out[inside].ravel(), minlength=top) / np.maximum(
            np.bincount(out.ravel(), minlength=top), 1
        )
        whole = region_ok & (share > RECESS_ENCLOSED_SHARE)
        joined = (free & band & inside) | whole[out]
        if not joined.any():
            continue
        r = int(gap_px[k])
        disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
        hull = cv2.morphologyEx((mask | joined).astype(np.uint8), cv2.MORPH_CLOSE, disc)
        out[joined | (free & ~has & hull.astype(bool))] = rid
    return out


# The strip only the left camera sees. Where a plane lies beyond the right camera's view (a
# disparity's width along the left image's border: 60 px of a facade 15 m away seen with a
# 2.7 m baseline), stereo gives it no depth, so no region grows there however plainly the wall
# goes on to the photo's edge. `extend_to_border` gives a plane region the pixels of no region
# and no depth in that strip (`unseen`, from its plane and the rig: no depth was possible) on
# the image rows where the region reaches the strip and, within STRIP_SUPPORT_PX beyond it,
# stereo measured its plane on at least STRIP_SUPPORT_SHARE of the row (points within its
# tolerance): the wall is seen going on into the strip, extrapolated across it to the border.
# Rows where the region next to the strip is a recess or a dropout, or where something else
# stands (the ground is in front of the wall, the steps of a porch behind it), do not join.
STRIP_SUPPORT_PX = 24  # the band beyond the strip in which the plane must be measured, pixels
STRIP_SUPPORT_SHARE = 0.25  # ... on this share of its pixels (a real wall's density is 0.4-0.6)


def extend_to_border(
    regions: I32,
    unseen: npt.NDArray[np.bool_],
    points: F32,
    *,
    ids: npt.NDArray[np.int64],
    normals: F64,
    offsets: F64,
    tolerances: F64,
) -> I32:
    """The region map (H, W) with each plane region extended to the image's left or right
    border across the strip where its plane can have no depth (see STRIP_SUPPORT_PX).

    regions : (H, W) int32 ids, 0 = none. unseen : (R, H, W) bool, per region with a plane
    the pixels whose point on its plane the other camera cannot see. points : (H, W, 3)
    float32 metres, the camera frame of the planes, NaN = no depth. ids : (R,) the regions
    with a plane; normals : (R, 3) unit, offsets : (R,) metres (n·x = d), tolerances : (R,)
    metres (see `complete_regions`). Largest regions first; only pixels of no region are
    claimed.
    """
    out = regions.copy()
    if len(ids) == 0:
        return out
    H, W = regions.shape
    has = ~np.isnan(points[..., 2])
    pts = np.where(has[..., None], points, 0.0).astype(np.float64)
    rows = np.arange(H)[:, None].repeat(W, axis=1)
    size = np.bincount(regions.ravel(), minlength=int(max(regions.max(), ids.max())) + 1)[ids]
    for k in np.argsort(-size, kind="stable"):
        rid = int(ids[k])
        mask = out == rid
        cand = (out == 0) & ~has & unseen[k]
        if not (mask.any() and cand.any()):
            continue
        on = mask & has & (np.abs(pts @ normals[k] - offsets[k]) <= tolerances[k])
        count = np.concatenate([np.zeros((H, 1)), np.cumsum(on, axis=1)], axis=1)  # (H, W + 1)
        stop = ~cand
        joined = np.zeros((H, W), bool)
        for reverse in (False, True):  # the strip at the left border, then at the right
            border = _first_met(stop, 1, reverse) < 0  # nothing but the strip towards the border
            met = _first_met(stop, 1, not reverse)  # the first pixel beyond the strip
            hit = (met >= 0) & mask[rows, np.maximum(met, 0)]
            if reverse:  # the band lies left of the strip: columns met - band + 1 .. met
                a, b = met - STRIP_SUPPORT_PX + 1, met + 1
            else:
                a, b = met, met + STRIP_SUPPORT_PX
            a, b = np.clip(a, 0, W), np.clip(b, 0, W)
            support = count[rows, b] - count[rows, a]
            joined |= cand & border & hit & (support >= STRIP_SUPPORT_SHARE * STRIP_SUPPORT_PX)
        out[joined] = rid
    return out


# Structural lines told from texture lines. A segment is structural when the surface changes
# across it: its two sides belong to two different regions, or to a region and to nothing (an
# outline), or the 3-D points on its two sides lie apart by more than the plane's tolerance (a
# window frame in front of its recess). It is texture when both sides lie on one plane within
# that tolerance (masonry joints, painted decoration, shadows); unknown (None) when neither
# side has a plane, or a side has no depth to tell by. Sides are sampled LINE_SIDE_PX away
# from the segment (at the working resolution), beyond half the matcher's window (11 px), over
# which it smears depth steps.
LINE_SIDE_PX = 8.0
LINE_SAMPLES = 9  # points per side, spread over the middle 80 % of the segment
LINE_MIN_DEPTH_SAMPLES = 3  # a side needs this many points with depth to say where it lies


def line_kinds(
    segments: F64,
    regions: I32,
    points: F32,
    ids: npt.NDArray[np.int64],
    normals: F64,
    offsets: F64,
    tolerances: F64,
    *,
    side_px: float = LINE_SIDE_PX,
) -> list[Literal["structural", "texture"] | None]:
    """Per segment (N, 4) [x1, y1, x2, y2] pixels: "structural", "texture" or None (unknown).

    regions : (H, W) region ids of the same image, 0 = none; points : (H, W, 3) float32 metres,
    a camera frame, NaN = no depth; ids : (R,) the regions with a plane, normals : (R, 3) unit
    and offsets : (R,) metres (n·x = d) in that frame, tolerances : (R,) metres (see
    `complete_regions`). side_px : how far from the segment its sides are sampled, pixels.
    """
    n = len(segments)
    if n == 0:
        return []
    H, W = regions.shape
    size = int(max(int(regions.max()), int(ids.max()) if len(ids) else 0)) + 1
    has_plane = np.zeros(size, bool)
    has_plane[ids] = True
    nrm = np.zeros((size, 3))
    nrm[ids] = normals
    off = np.zeros(size)
    off[ids] = offsets
    tol = np.zeros(size)
    tol[ids] = tolerances
    p1, p2 = segments[:, :2], segments[:, 2:]
    t = (p2 - p1) / np.maximum(np.linalg.norm(p2 - p1, axis=1, keepdims=True), 1e-9)
    across = np.stack([t[:, 1], -t[:, 0]], axis=1)
    s = np.linspace(0.1, 0.9, LINE_SAMPLES)
    base = p1[:, None, :] + s[None, :, None] * (p2 - p1)[:, None, :]  # (N, S, 2)
    sides = []
    for sign in (1.0, -1.0):
        pts = base + sign * side_px * across[:, None, :]
        xi = np.clip(np.rint(pts[..., 0]).astype(np.intp), 0, W - 1)
        yi = np.clip(np.rint(pts[..., 1]).astype(np.intp), 0, H - 1)
        lab = regions[yi, xi].astype(np.int64)  # (N, S)
        votes = (lab[:, :, None] == lab[:, None, :]).sum(axis=2)  # (N, S)
        k = np.argmax(votes, axis=1)
        major = lab[np.arange(n), k]
        major = np.where(votes[np.arange(n), k] * 2 > LINE_SAMPLES, major, 0)
        sides.append((major, points[yi, xi].astype(np.float64)))  # (N,), (N, S, 3)
    (a, xyz_l), (b, xyz_r) = sides
    two = (a != b) & (has_plane[a] | has_plane[b])
    one = (a == b) & has_plane[a]
    n_a = nrm[a]  # (N, 3)

    def offset(xyz: F64) -> tuple[F64, npt.NDArray[np.int64]]:
        dist = np.einsum("nsk,nk->ns", xyz, n_a) - off[a][:, None]
        good = ~np.isnan(dist)
        with np.errstate(all="ignore"):
            med = np.nanmedian(np.where(good, dist, np.nan), axis=1)
        return med, good.sum(axis=1)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN rows: no depth on a side
        off_l, n_l = offset(xyz_l)
        off_r, n_r = offset(xyz_r)
    measured = (n_l >= LINE_MIN_DEPTH_SAMPLES) & (n_r >= LINE_MIN_DEPTH_SAMPLES)
    step = measured & (np.abs(off_l - off_r) > tol[a])
    out: list[Literal["structural", "texture"] | None] = []
    for i in range(n):
        if two[i] or (one[i] and step[i]):
            out.append("structural")
        elif one[i] and measured[i]:
            out.append("texture")
        else:
            out.append(None)
    return out


# Faces without texture. A roof whose tiles' texture lies below the camera's noise (dark tiles
# in shade) or a blank wall gets no certain disparity inside, so `segment_planes` grows no
# region on it (development scenes 61600-61635 without labels: 30 of 59 roof faces had no
# region, and their houses were taken for flat-roofed ones). Its outline against the sky, the
# walls or a lighter face is an edge that the matcher measures (exact NCC), and the outline of
# a planar face lies on its plane. `outlined_patches` takes the areas of no region that the
# image's edges enclose and whose outline has certain depth within OUTLINE_REACH_PX nearly all
# round (OUTLINE_SUPPORT) -- where it can: an outline along the epipolar lines (within
# EPIPOLAR_DEG of the image's rows: a ridge, an eave) has no disparity for any matcher, and is
# not asked for; the image's border never supports (the sky is cut by it, and so is a face
# whose outline is not seen whole). The evidence fits each patch's plane to the certain
# points along its outline (`aida_kb.vision.evidence`).
# Nor is a patch's left outline (the patch to its right) without certain depth asked for: the
# right camera sees everything shifted left by its disparity, so a face in front covers the
# strip of the background just left of its left outline (a half-occlusion as wide as their
# disparities differ), and every matching window across that outline holds pixels the other
# image does not show. A dark roof in front of the far field loses its whole left verge so
# (development scene 61816: the measurable outline 337 px, 167 of them certain, none on the
# left verge; its right verge and the eave fix the plane to 0.25 deg). Where the left outline
# is measured it counts as any other; the plane's own tests in the evidence (one plane, tilt
# fixed) still judge what the rest of the outline gives.
# The outline counts as measured only by the depth the face's plane is then fitted to: of no
# region, or of a region within OUTLINE_EDGE_PX of an edge (where the face meets it). A
# region's depth away from any edge lies on the region's surface, not on the face's outline:
# where no edge parts them they may be one surface, and a patch held so was fitted to the
# rest of its outline alone (unlabelled development scene 61935 view 00: far ground and a wall
# striped along the rows, 88,000 px, held by the near ground's region and fitted as the wall,
# 90 deg off; 61914 view 01 likewise). On the unlabelled 61902-61935 this leaves out 2 of the
# 10 outlined regions far off their face, and none of the 12 right ones (within 2.2 deg).
EDGE_BLUR_PX = 1.5  # Gaussian sigma before the edge detector: the sensor noise's edges go
EDGE_LOW = 20  # Canny's hysteresis thresholds on the blurred image's Sobel gradient, grey
EDGE_HIGH = 60  # levels per pixel (x 4 of Sobel's kernel): a step of 5 and of 15 grey levels
OUTLINE_REACH_PX = 4  # the edge's dilated width and a pixel: where the outline's depth lies
OUTLINE_SUPPORT = 0.7  # the share of the measurable outline with certain depth within reach
OUTLINE_CERTAINTY = 0.1  # a depth at least this certain measures the outline
EPIPOLAR_DEG = 15.0  # an outline closer than this to the image's rows is not measurable
OUTLINE_EDGE_PX = 2  # 2 px off the eave a wall's point is ~0.1 m off the roof at 50 m


def outlined_patches(
    regions: I32,
    image: npt.NDArray[np.uint8],
    certainty: F32,
    *,
    min_pixels: int,
) -> tuple[I32, npt.NDArray[np.bool_], npt.NDArray[np.bool_]]:
    """The areas of no region enclosed by image edges and measured all round their outline.

    regions : (H, W) int32 ids, 0 = none; image : (H, W) the grey image of the same pixels
    (rows along the epipolar lines); certainty : (H, W) the depth's certainty there (0 = no
    depth). Returns the patches (H, W) int32 ids 1..P, 0 = none, the pixels with certain
    depth and the edges (one pixel wide), both (H, W) bool. Patches of fewer than `min_pixels`
    pixels are left out. See
    EDGE_BLUR_PX, OUTLINE_SUPPORT, OUTLINE_CERTAINTY, EPIPOLAR_DEG.
    """
    H, W = regions.shape
    certain = certainty >= OUTLINE_CERTAINTY
    blurred = cv2.GaussianBlur(image, (0, 0), EDGE_BLUR_PX)
    thin = cv2.Canny(blurred, EDGE_LOW, EDGE_HIGH)
    edges = cv2.dilate(thin, np.ones((3, 3), np.uint8)) > 0
    free = ((regions == 0) & ~edges).astype(np.uint8)
    n, comp, stats, _ = cv2.connectedComponentsWithStats(free, connectivity=4)
    side = 2 * OUTLINE_REACH_PX + 1
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (side, side))
    # the depth the face's plane is fitted to: of no region, or a region's right at an edge
    edge_side = 2 * OUTLINE_EDGE_PX + 1
    at_edge = cv2.dilate(thin, np.ones((edge_side, edge_side), np.uint8)) > 0
    usable = certain & ((regions == 0) | at_edge)
    near = cv2.dilate(usable.astype(np.uint8), disc) > 0
    border = np.ones((H, W), bool)
    border[1:-1, 1:-1] = False
    square = np.ones((3, 3), np.uint8)
    inner = cv2.erode(free, square, borderType=cv2.BORDER_CONSTANT, borderValue=0)
    outline = (free > 0) & (inner == 0)  # a patch's pixels next to an edge, a region, the border
    # the outline's direction from the patches' mask: across a row-wise outline the mask
    # changes along the columns only
    smooth = cv2.GaussianBlur(free.astype(np.float32), (0, 0), 1.5)
    gx = cv2.Sobel(smooth, cv2.CV_32F, 1, 0)
    gy = cv2.Sobel(smooth, cv2.CV_32F, 0, 1)
    measurable = outline & (np.abs(gx) >= np.sin(np.radians(EPIPOLAR_DEG)) * np.hypot(gx, gy))
    measurable |= outline & border
    # the patch's left outline (the mask rising to the right) unmeasured: a half-occlusion
    occluded = outline & ~border & ~near & (gx > 0)
    asked = measurable & ~occluded
    labels = comp[asked]
    total = np.bincount(labels, minlength=n)
    held = np.bincount(labels[near[asked] & ~border[asked]], minlength=n)
    ok = (stats[:, cv2.CC_STAT_AREA] >= min_pixels) & (held >= OUTLINE_SUPPORT * total)
    ok &= total > 0
    ok[0] = False
    lut = np.zeros(n, np.int32)
    lut[ok] = np.arange(1, int(ok.sum()) + 1, dtype=np.int32)
    return lut[comp], certain, thin > 0
