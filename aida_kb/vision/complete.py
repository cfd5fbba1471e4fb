"""Completing a view's plane regions over the pixels stereo could not measure
(`complete_regions`), absorbing window recesses (`absorb_recesses`) and extending regions to
the image border (`extend_to_border`)."""

from __future__ import annotations

import cv2
import numpy as np
import numpy.typing as npt

F32 = npt.NDArray[np.float32]
F64 = npt.NDArray[np.float64]
I32 = npt.NDArray[np.int32]


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
