"""A view's plane regions: a robust plane per region, regions of one plane merged, regions
completed over the pixels their planes explain, planes for textureless faces fitted along their
outlines, and the image's segments told structural or texture by the planes beside them.

`aida_kb.vision.evidence.process_view` calls these in that order at the working resolution
(`ViewStereo`), then lifts the regions' pixel figures to the full image (`lifted_regions`).
Frames: a region's plane is fitted in the view's rectified left camera, given in its left
camera frame or, with ``to_frame`` = (R_cam_world, t_cam_world), in the world frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Literal

import cv2
import numpy as np
import numpy.typing as npt

from aida_kb.errors import VisionError
from aida_kb.io.evidence import Region
from aida_kb.io.scene import StereoCalib
from aida_kb.vision.complete import (
    COMPLETE_GAP_M,
    COMPLETE_GAP_PX,
    COMPLETE_SIGMAS,
    DISPARITY_SIGMA_PX,
    absorb_recesses,
    complete_regions,
    extend_to_border,
)
from aida_kb.vision.depth import DepthMap
from aida_kb.vision.linekinds import LINE_SIDE_PX, line_kinds
from aida_kb.vision.lines import Segment
from aida_kb.vision.merge import merge_coplanar
from aida_kb.vision.outline import OUTLINE_EDGE_PX, OUTLINE_REACH_PX, outlined_patches
from aida_kb.vision.planes import (
    PhotometricPair,
    fit_disparity_plane,
    pixel_areas_m2,
    plane_depth,
    refine_plane_photometric,
)
from aida_kb.vision.rectify import Rectification, remap
from aida_kb.vision.stereo import DisparityMap

F32 = npt.NDArray[np.float32]
F64 = npt.NDArray[np.float64]
I32 = npt.NDArray[np.int32]

__all__ = [
    "MAX_RMS_DISTANCE_FRACTION",
    "MIN_FIT_SAMPLES",
    "MIN_METRIC_DISPARITY_PX",
    "OUTLINE_INLIER_SHARE",
    "OUTLINE_MAX_TILT_DEG",
    "OUTLINE_RMS_SIGMAS",
    "ViewStereo",
    "completed_regions",
    "fit_region_planes",
    "lifted_regions",
    "merged_regions",
    "outline_tilt_rad",
    "outlined_regions",
    "plane_tolerances",
    "segment_kinds",
    "unseen_by_right",
]

MIN_FIT_SAMPLES = 30
"""A region's plane is fitted to at least this many disparities (inside it, away from its
boundary where it has that many), and kept only when the robust fit keeps this many."""
# A disparity below this many pixels gives no depth worth the name: stereo noise of ~0.2 px
# changes it by over 10 % (and near the horizon by kilometres). Such samples still shape the
# plane in disparity space but not the metric centroid and RMS of the region.
MIN_METRIC_DISPARITY_PX = 2.0
# A region whose points lie further from its fitted plane (RMS) than this fraction of the
# plane's distance from the camera is not a plane at the accuracy of the stereo: left out of
# the evidence rather than written with an RMS of hundreds of metres (a wall stereo-measured at
# 1:100 noise has an RMS near 0.01 of its distance).
MAX_RMS_DISTANCE_FRACTION = 0.05


def _v3(v: npt.ArrayLike) -> tuple[float, float, float]:
    a = np.asarray(v, float).ravel()
    return (float(a[0]), float(a[1]), float(a[2]))


@dataclass(frozen=True)
class ViewStereo:
    """One view's stereo measurements at the working resolution, as this module's functions
    take them: the disparity (rectified), the depth (original image), the rectification, the
    original image's viewing rays (H, W, 3) and the rig."""

    disp: DisparityMap
    depth: DepthMap
    rect: Rectification
    rays: F64
    calib: StereoCalib


def fit_region_planes(
    regions: I32,
    stereo: ViewStereo,
    window: int,
    to_frame: tuple[F64, F64] | None,
    labelled: bool,
    photometric: PhotometricPair | None,
    fit_regions: I32 | None = None,
) -> list[Region]:
    """A plane fit per region; regions with too few depth samples are left out.

    fit_regions : where given, the (H, W) map whose pixels the planes are fitted to (the
    regions before `complete_regions` grew them over dropouts and openings); `regions` then
    gives each region's extent (pixel count, area, bounding box).

    The plane comes from a robust fit to the region's disparities (away from its boundary by
    more than a correlation window), then, with `photometric`, is refined by aligning the
    rectified images directly over the region's pixels (away from its boundary by more than
    the normalisation window): unbiased by the matcher's subpixel interpolation, which
    matters on narrow faces. Where the refinement fails, the disparity fit stays.

    regions : (H, W) region ids of the original left image (0: none).
    window : the matcher's window, pixels (the fit keeps this far from a region's boundary).
    to_frame : (R_cam_world, t_cam_world) to give the planes in the world frame, or None (the
    left camera's frame).
    labelled : the regions are the scene's labels (each region keeps its id as its label).
    """
    disp, depth, rect, rays, calib = (
        stereo.disp,
        stereo.depth,
        stereo.rect,
        stereo.rays,
        stereo.calib,
    )
    W, H = rect.rect_size
    fit_map = regions if fit_regions is None else fit_regions
    rect_regions = remap(fit_map.astype(np.float32), rect.map_left, nearest=True, border=0.0)
    rect_regions = np.nan_to_num(rect_regions, nan=0.0).astype(np.int32)
    f, cx, cy, B = rect.focal_px, float(rect.P1[0, 2]), float(rect.P1[1, 2]), rect.baseline_m
    vs, us = np.mgrid[0:H, 0:W].astype(np.float64)
    fx, fy = float(calib.K1[0, 0]), float(calib.K1[1, 1])
    erode = np.ones((window + 2, window + 2), np.uint8)
    if photometric is not None:
        side = photometric.window + 2
        erode_photo = np.ones((side, side), np.uint8)
    us_i, vs_i = us.astype(np.intp), vs.astype(np.intp)
    valid_disp = ~np.isnan(disp.disparity) & (disp.certainty > 0)
    ids, counts = np.unique(regions, return_counts=True)
    inlier_rect = np.zeros((H, W), np.float32)  # region id at each pixel its plane fit kept
    out: list[Region] = []
    for rid, count in zip(ids.tolist(), counts.tolist(), strict=True):
        if rid == 0:
            continue
        mask_r = rect_regions == rid
        inner = cv2.erode(mask_r.astype(np.uint8), erode).astype(bool) & valid_disp
        sel = inner if np.count_nonzero(inner) >= MIN_FIT_SAMPLES else mask_r & valid_disp
        if np.count_nonzero(sel) < MIN_FIT_SAMPLES:
            continue
        u, v = us[sel], vs[sel]
        dd = disp.disparity[sel].astype(np.float64)
        cert = disp.certainty[sel].astype(np.float64)
        try:
            fit = fit_disparity_plane(u, v, dd, cert)
            n_rect, D = fit.plane(f, cx, cy, B)
        except VisionError:
            continue
        if np.count_nonzero(fit.inliers) < MIN_FIT_SAMPLES:
            continue
        if photometric is not None:
            on = cv2.erode(mask_r.astype(np.uint8), erode_photo).astype(bool)
            refined = refine_plane_photometric(photometric, us_i[on], vs_i[on], fit)
            if refined is not None:
                fit = replace(fit, a=refined.a, b=refined.b, g=refined.g)
                n_rect, D = fit.plane(f, cx, cy, B)
        # metric figures only from samples whose disparity gives a depth at all (see
        # MIN_METRIC_DISPARITY_PX): near the horizon 0.1 px of noise is kilometres
        w = np.where(dd >= MIN_METRIC_DISPARITY_PX, fit.weights, 0.0)
        wsum = float(w.sum())
        if wsum <= 0.0:
            continue
        rays_rect = np.stack([(u - cx) / f, (v - cy) / rect.P1[1, 1], np.ones_like(u)], axis=1)
        on_plane = rays_rect * plane_depth(rays_rect, n_rect, D)[:, None]
        measured = rays_rect * (f * B / np.maximum(dd, MIN_METRIC_DISPARITY_PX))[:, None]
        used = w > 0
        c_rect = (on_plane[used] * w[used, None]).sum(axis=0) / wsum
        dist = measured[used] @ n_rect - D
        rms = float(np.sqrt(np.sum(w[used] * dist * dist) / wsum))
        if not rms <= MAX_RMS_DISTANCE_FRACTION * float(np.linalg.norm(c_rect)):
            continue  # not a plane at the accuracy of the stereo (or a fit through the horizon)
        n_cam = rect.R1.T @ n_rect
        c_cam = rect.R1.T @ c_rect
        mask_o = regions == rid
        areas = pixel_areas_m2(rays[mask_o], n_cam, D, fx, fy)
        area = float(np.nansum(np.where(areas > 0, areas, 0.0)))
        w_c = float(depth.certainty[fit_map == rid].sum())
        n_out, d_out, c_out = n_cam, D, c_cam
        if to_frame is not None:  # camera -> world: x_w = R^T (x_cam - t)
            R, t = to_frame
            n_out = R.T @ n_cam
            d_out = D - float(n_cam @ t)
            c_out = R.T @ (c_cam - t)
        ys_o, xs_o = np.nonzero(mask_o)
        values = (n_out, d_out, c_out, area, w_c, rms)
        if not all(np.all(np.isfinite(x)) for x in values):
            raise VisionError(f"region {rid}: the plane fit produced non-finite values")
        ys_s, xs_s = vs_i[sel][fit.inliers], us_i[sel][fit.inliers]
        inlier_rect[ys_s, xs_s] = float(rid)
        out.append(
            Region(
                id=int(rid),
                label=int(rid) if labelled else None,
                pixel_count=int(count),
                depth_pixel_count=int(np.count_nonzero(~np.isnan(depth.depth_m[mask_o]))),
                inlier_count=0,  # counted on the original image below
                area_m2=area,
                n_init=_v3(n_out / np.linalg.norm(n_out)),
                d_init=float(d_out),
                c_init=_v3(c_out),
                w_c=min(w_c, float(count)),
                rms_m=rms,
                mean_certainty=min(1.0, w_c / count),
                bbox=(int(xs_o.min()), int(ys_o.min()), int(xs_o.max()), int(ys_o.max())),
            )
        )
    inliers = _inliers_per_region(inlier_rect, regions, depth, rect)
    return [r.model_copy(update={"inlier_count": inliers.get(r.id, 0)}) for r in out]


def _inliers_per_region(
    inlier_rect: F32, regions: I32, depth: DepthMap, rect: Rectification
) -> dict[int, int]:
    """Per region id, the pixels of the ORIGINAL left image kept by its plane fit.

    inlier_rect : (H, W) region id at each rectified pixel the fit kept (0 elsewhere).
    regions : (H, W) region ids on the original image. A pixel counts when it has a depth,
    lies in the region, and its rectified position (nearest) is one of the region's inliers:
    the same pixels as `depth_pixel_count` counts, so inlier_count <= depth_pixel_count.
    """
    back = remap(inlier_rect, rect.inverse_left, nearest=True, border=0.0)
    back = np.nan_to_num(back, nan=0.0).astype(np.int32)
    kept = (back == regions) & (regions > 0) & ~np.isnan(depth.depth_m)
    counts = np.bincount(regions[kept].ravel(), minlength=int(regions.max()) + 1)
    return {int(i): int(c) for i, c in enumerate(counts.tolist()) if c > 0}


def _in_camera(
    plane_regions: list[Region], pose: tuple[F64, F64]
) -> tuple[npt.NDArray[np.int64], F64, F64]:
    """The regions' ids (R,), unit normals (R, 3) and centroids (R, 3, metres) in the camera
    frame, from their planes given in the frame of pose = (R_cam_world, t_cam_world)."""
    R_w, t_w = pose
    ids = np.array([r.id for r in plane_regions], np.int64)
    normals = np.array([np.array(r.n_init) for r in plane_regions], np.float64).reshape(-1, 3)
    centroids = np.array([np.array(r.c_init) for r in plane_regions], np.float64).reshape(-1, 3)
    return ids, normals @ R_w.T, centroids @ R_w.T + t_w


def merged_regions(
    regions: I32,
    plane_regions: list[Region],
    pose: tuple[F64, F64],
    stereo: ViewStereo,
    window: int,
    to_frame: tuple[F64, F64] | None,
    photometric: PhotometricPair | None,
) -> tuple[I32, list[Region]]:
    """Regions of one plane merged (`merge.merge_coplanar`) and their planes refitted.

    pose : (R_cam_world, t_cam_world) of the frame the regions' planes are given in.
    """
    ids, normals, centroids = _in_camera(plane_regions, pose)
    merged = merge_coplanar(
        regions,
        ids,
        normals,
        centroids,
        points=stereo.depth.points,
        focal_px=float(stereo.calib.K1[0, 0]),
    )
    if np.array_equal(merged, regions):
        return regions, plane_regions
    refit = fit_region_planes(merged, stereo, window, to_frame, False, photometric)
    return merged, refit


def completed_regions(
    regions: I32,
    plane_regions: list[Region],
    pose: tuple[F64, F64],
    stereo: ViewStereo,
    window: int,
    to_frame: tuple[F64, F64] | None,
    photometric: PhotometricPair | None,
) -> tuple[I32, list[Region]]:
    """Regions grown over the pixels their planes explain (`complete.complete_regions`);
    the planes stay fitted to the measured pixels, the extents (pixel count, area, box) grow.

    pose : (R_cam_world, t_cam_world) of the frame the regions' planes are given in.
    """
    depth, rect = stereo.depth, stereo.rect
    ids, normals, centroids = _in_camera(plane_regions, pose)
    offsets = np.einsum("ij,ij->i", normals, centroids)
    rms = np.array([r.rms_m for r in plane_regions])
    grown = complete_regions(
        regions,
        depth.points,
        ids,
        normals,
        offsets,
        rms,
        np.abs(centroids[:, 2]),
        rect.focal_px,
        rect.baseline_m,
        window,
    )
    _, _, _, tolerances = plane_tolerances(plane_regions, pose, rect)
    half = rect.focal_px * COMPLETE_GAP_M / (2.0 * np.maximum(np.abs(centroids[:, 2]), 1e-9))
    gap_px = np.clip(np.ceil(half), *COMPLETE_GAP_PX).astype(np.int64)
    grown = absorb_recesses(grown, depth.points, ids, gap_px, normals, offsets, tolerances)
    unseen = unseen_by_right(stereo.rays, normals, offsets, stereo.calib, window // 2 + 1)
    grown = extend_to_border(
        grown,
        unseen,
        depth.points,
        ids=ids,
        normals=normals,
        offsets=offsets,
        tolerances=tolerances,
    )
    if np.array_equal(grown, regions):
        return regions, plane_regions
    refit = fit_region_planes(grown, stereo, window, to_frame, False, photometric, regions)
    return grown, refit


# A textureless face's plane (`outline.outlined_patches`) is fitted to the certain
# points along its outline (within OUTLINE_REACH_PX of it, either side: the edge's depth is the
# face's where the face is in front or meets its neighbour there), but of a neighbouring
# region only its pixels within OUTLINE_EDGE_PX of the edge (a wall's pixels a few rows below
# the eave lie on the wall, off the roof's plane, and a wall's texture gives many more of them
# than the roof's outline) -- and accepted when the outline is one plane:
# OUTLINE_INLIER_SHARE of those points kept by the robust fit, their RMS within
# OUTLINE_RMS_SIGMAS of the depth noise at the face's distance, and the plane's tilt fixed by
# them to OUTLINE_MAX_TILT_DEG (a single verge is a line: any plane through it fits). Two
# faces under one patch (the hips of a dark roof with no edge between them) leave a whole side
# of the outline off the fit.
OUTLINE_INLIER_SHARE = 0.8
OUTLINE_RMS_SIGMAS = COMPLETE_SIGMAS
# The outline's points fix the plane's tilt to rms / (sqrt(n / (window - 2)²) · g): g their
# lesser spread on the plane (metres; a single verge is a line, g ~ 0: any plane through it
# fits), n / (window - 2)² the independent ones among them (a matching window's pixels share
# their error, as `aida_kb.interpret.observe.FIT_CORRELATED_PX` counts them). A fit whose tilt
# is not fixed to OUTLINE_MAX_TILT_DEG is left out (a far roof's outline with ~0.3 m of depth
# noise: development scene 61615 at 90 m); the region's inlier_count is cut so that the
# interpreter's sigma, which spreads the inliers over a square of the region's area, is no
# smaller than this one.
OUTLINE_MAX_TILT_DEG = 2.0


def outline_tilt_rad(points: F64, n: F64, rms_m: float, inliers: int, window: int) -> float:
    """The 1-sigma tilt (radians) of a plane of unit normal n (3,) fitted to the outline's
    points (N, 3) (metres) with `inliers` of them kept at `rms_m`: see OUTLINE_MAX_TILT_DEG."""
    if len(points) < 3 or inliers < 1:
        return math.inf
    on = points - points.mean(axis=0)
    on = on - np.outer(on @ n, n)  # projected onto the plane
    spread = np.sort(np.linalg.eigvalsh(on.T @ on / len(on)))[1]  # the lesser in-plane axis
    if spread <= 0.0:
        return math.inf
    samples = inliers / float((window - 2) ** 2)
    return float(rms_m / (math.sqrt(max(samples, 1.0)) * math.sqrt(spread)))


def outlined_regions(
    regions: I32,
    plane_regions: list[Region],
    image: npt.NDArray[np.uint8],
    stereo: ViewStereo,
    window: int,
    min_region_px: int,
    to_frame: tuple[F64, F64] | None,
) -> tuple[I32, list[Region]]:
    """Regions added on the textureless faces (`outline.outlined_patches`): each patch
    with the certain pixels of no region along its outline, its plane fitted to the certain
    pixels along the outline (no photometric refinement: they straddle the outline). Pixel
    figures are the patch's; inlier_count at most its pixels with depth. See
    OUTLINE_INLIER_SHARE.

    image : (H, W) the left image, grey; window : the matcher's window, pixels;
    min_region_px : the smallest patch taken, pixels.
    """
    depth, rect, rays, calib = stereo.depth, stereo.rect, stereo.rays, stereo.calib
    patches, certain, edges = outlined_patches(
        regions, image, depth.certainty, min_pixels=min_region_px
    )
    count = int(patches.max())
    if count == 0:
        return regions, plane_regions
    next_id = int(max([int(regions.max()), *(r.id for r in plane_regions)])) + 1
    side = 2 * OUTLINE_REACH_PX + 1
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (side, side))
    has = ~np.isnan(depth.depth_m)
    fx, fy = float(calib.K1[0, 0]), float(calib.K1[1, 1])
    side = 2 * OUTLINE_EDGE_PX + 1
    at_edge = cv2.dilate(edges.astype(np.uint8), np.ones((side, side), np.uint8)) > 0
    out = regions.copy()
    added: list[Region] = []
    for k in range(1, count + 1):
        mask = (patches == k).astype(np.uint8)
        inside = cv2.erode(mask, disc, borderType=cv2.BORDER_CONSTANT, borderValue=0) > 0
        along = (cv2.dilate(mask, disc) > 0) & ~inside & certain & has & ((out == 0) | at_edge)
        band = np.where(along, next_id, 0).astype(np.int32)
        found = fit_region_planes(band, stereo, window, to_frame, False, None)
        if not found:
            continue
        r = found[0]
        n_out, d_out, c_out = np.array(r.n_init), r.d_init, np.array(r.c_init)
        n_cam, d_cam, c_cam = n_out, d_out, c_out
        if to_frame is not None:  # world -> camera: x_cam = R x_w + t
            R, t = to_frame
            n_cam = R @ n_out
            d_cam = d_out + float(n_cam @ t)
            c_cam = R @ c_out + t
        z = abs(float(c_cam[2]))
        sigma_z = z * z * DISPARITY_SIGMA_PX / max(rect.focal_px * rect.baseline_m, 1e-12)
        tilt = outline_tilt_rad(
            depth.points[along].astype(np.float64), n_cam, r.rms_m, r.inlier_count, window
        )
        if not (
            r.inlier_count >= OUTLINE_INLIER_SHARE * int(along.sum())
            and r.rms_m <= OUTLINE_RMS_SIGMAS * sigma_z
            and tilt <= math.radians(OUTLINE_MAX_TILT_DEG)
        ):
            continue
        extent = (mask > 0) | (along & (out == 0))
        ys, xs = np.nonzero(extent)
        pixels = int(extent.sum())
        areas = pixel_areas_m2(rays[extent], n_cam, d_cam, fx, fy)
        w_c = min(float(depth.certainty[extent].sum()), float(pixels))
        with_depth = int(np.count_nonzero(has & extent))
        area = float(np.nansum(np.where(areas > 0, areas, 0.0)))
        # inliers that give a square of the region's area no smaller a tilt than the outline
        honest = (
            float((window - 2) ** 2)
            * (r.rms_m / max(tilt * math.sqrt(max(area, 1e-12) / 12.0), 1e-12)) ** 2
        )
        added.append(
            r.model_copy(
                update={
                    "pixel_count": pixels,
                    "depth_pixel_count": with_depth,
                    "inlier_count": min(r.inlier_count, with_depth, int(honest)),
                    "area_m2": area,
                    "w_c": w_c,
                    "mean_certainty": min(1.0, w_c / pixels),
                    "bbox": (int(xs.min()), int(ys.min()), int(xs.max()), int(ys.max())),
                }
            )
        )
        out[extent] = next_id
        next_id += 1
    return out, plane_regions + added


def unseen_by_right(
    rays: F64, normals: F64, offsets: F64, calib: StereoCalib, margin_px: float
) -> npt.NDArray[np.bool_]:
    """(R, H, W) bool: the left image's pixels whose ray meets each plane (normals (R, 3),
    offsets (R,) metres, n·x = d, the left camera's frame) in front of the camera at a point
    the right camera does not see at least `margin_px` inside its image (no depth is possible
    there). rays : (H, W, 3) the left image's viewing rays (x, y, 1)."""
    W, H = calib.image_size
    out = np.zeros((len(normals), *rays.shape[:2]), bool)
    for k, (n, d) in enumerate(zip(normals, offsets, strict=True)):
        along = rays @ n
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(np.abs(along) > 1e-12, d / along, -1.0)
        right = (rays * t[..., None]) @ calib.R.T + calib.T.ravel()
        z = right[..., 2]
        pix = right @ calib.K2.T
        with np.errstate(divide="ignore", invalid="ignore"):
            x, y = pix[..., 0] / z, pix[..., 1] / z
        seen = (
            (z > 0)
            & (x >= margin_px)
            & (x <= W - 1 - margin_px)
            & (y >= margin_px)
            & (y <= H - 1 - margin_px)
        )
        out[k] = (t > 0) & ~seen
    return out


def plane_tolerances(
    plane_regions: list[Region], pose: tuple[F64, F64], rect: Rectification
) -> tuple[npt.NDArray[np.int64], F64, F64, F64]:
    """(ids, normals, offsets, tolerances) of the regions' planes in the camera frame: unit
    normals (R, 3), offsets (R,) metres (n·x = d), and the distance from the plane within
    which a point lies on it, metres (COMPLETE_SIGMAS times the larger of the fit's RMS and
    the depth noise at the region's distance, as `complete_regions` uses it)."""
    ids, normals, centroids = _in_camera(plane_regions, pose)
    offsets = np.einsum("ij,ij->i", normals, centroids)
    z = np.abs(centroids[:, 2])
    sigma_z = z * z * DISPARITY_SIGMA_PX / max(rect.focal_px * rect.baseline_m, 1e-12)
    rms = np.array([r.rms_m for r in plane_regions])
    return ids, normals, offsets, COMPLETE_SIGMAS * np.maximum(rms, sigma_z)


def segment_kinds(
    segments: list[Segment],
    regions: I32,
    depth: DepthMap,
    plane_regions: list[Region],
    pose: tuple[F64, F64],
    rect: Rectification,
    scale: float,
) -> list[Literal["structural", "texture"] | None]:
    """Each segment structural, texture or unknown (`linekinds.line_kinds`); `scale`: the
    image's pixels per working pixel (the sides are sampled as far at the object)."""
    if not segments:
        return []
    if not plane_regions:
        return [None] * len(segments)
    ids, normals, offsets, tolerances = plane_tolerances(plane_regions, pose, rect)
    segs = np.array([[*s.p1, *s.p2] for s in segments], np.float64)
    return line_kinds(
        segs,
        regions,
        depth.points,
        ids,
        normals,
        offsets,
        tolerances,
        side_px=LINE_SIDE_PX * scale,
    )


def lifted_regions(regions: list[Region], region_map: I32, depth: DepthMap) -> list[Region]:
    """Regions measured at the working resolution, their pixel figures counted again on the
    full image's `region_map` and `depth` (the plane, area and RMS are the same)."""
    size = int(max([int(region_map.max()), *(r.id for r in regions)])) + 1
    counts = np.bincount(region_map.ravel(), minlength=size)
    has = ~np.isnan(depth.depth_m)
    with_depth = np.bincount(region_map[has].ravel(), minlength=size)
    ys, xs = np.nonzero(region_map)
    ids = region_map[ys, xs]
    big = np.iinfo(np.int64).max
    x0, y0 = np.full(size, big), np.full(size, big)
    x1, y1 = np.full(size, -1), np.full(size, -1)
    np.minimum.at(x0, ids, xs)
    np.minimum.at(y0, ids, ys)
    np.maximum.at(x1, ids, xs)
    np.maximum.at(y1, ids, ys)
    out = []
    for r in regions:
        n = int(counts[r.id])
        if n == 0:
            continue
        ratio = n / r.pixel_count
        n_depth = int(with_depth[r.id])
        w_c = min(float(n), r.w_c * ratio)
        out.append(
            r.model_copy(
                update={
                    "pixel_count": n,
                    "depth_pixel_count": n_depth,
                    "inlier_count": min(n_depth, round(r.inlier_count * ratio)),
                    "w_c": w_c,
                    "mean_certainty": min(1.0, w_c / n),
                    "bbox": (int(x0[r.id]), int(y0[r.id]), int(x1[r.id]), int(y1[r.id])),
                }
            )
        )
    return out
