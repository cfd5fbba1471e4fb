"""Evidence assembly: a scene directory's stereo views -> `aida_kb.io.evidence.Evidence`.

Per view: rectify, NCC disparity with certainty, depth on the original left image, regions
(labels.png where the scene has one, else regions of equal orientation), a robust certainty-
weighted plane per region (fitted in disparity space, see aida_kb.vision.planes), line segments
attached to the regions they border, region contours, and the cameras.

Frames: view 00's left camera is the world frame. A later view is given in the world frame
when its pose (R_cam_world, t_cam_world of its left camera) is passed in `poses`; otherwise in
its own left camera frame (`frame = "camera"`), to be registered later (paper §5).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any, Literal

import cv2
import numpy as np
import numpy.typing as npt

from aida_kb.errors import VisionError
from aida_kb.geometry.camera import PinholeCamera
from aida_kb.io.evidence import (
    Contour,
    Evidence,
    EvidenceCamera,
    LineSegment,
    Region,
    ViewEvidence,
)
from aida_kb.io.model import Cahv
from aida_kb.io.scene import (
    Scene,
    SceneView,
    StereoCalib,
    read_image,
    read_labels,
    scaled_calib,
    working_size,
)
from aida_kb.vision.depth import DepthMap, depth_map
from aida_kb.vision.disprange import (
    MAX_NUM_DISP,
    RANGE_MARGIN_FRACTION,
    RANGE_MARGIN_PX,
    disparity_range,
    saturation_warnings,
    sparse_disparities,
)
from aida_kb.vision.lines import Segment, attach_segments, detect_segments
from aida_kb.vision.planes import (
    PhotometricPair,
    fit_disparity_plane,
    photometric_pair,
    pixel_areas_m2,
    plane_depth,
    refine_plane_photometric,
)
from aida_kb.vision.rectify import Rectification, remap, stereo_rectification
from aida_kb.vision.segmentation import (
    COMPLETE_GAP_M,
    COMPLETE_GAP_PX,
    COMPLETE_SIGMAS,
    DISPARITY_SIGMA_PX,
    LINE_SIDE_PX,
    OUTLINE_EDGE_PX,
    OUTLINE_REACH_PX,
    absorb_recesses,
    complete_regions,
    extend_to_border,
    line_kinds,
    local_planes,
    merge_coplanar,
    outlined_patches,
    region_contours,
    segment_planes,
)
from aida_kb.vision.sgm import SGM_WINDOW, sgm_disparity
from aida_kb.vision.stereo import DisparityMap, ncc_disparity

F32 = npt.NDArray[np.float32]
F64 = npt.NDArray[np.float64]
I32 = npt.NDArray[np.int32]
Pose = tuple[npt.ArrayLike, npt.ArrayLike]
Stage = Callable[[str], None]
SegmentationMode = Literal["auto", "labels", "orientation"]

STAGES = ("rectify", "disparity", "depth", "segmentation", "planes", "lines", "contours")
MIN_FIT_SAMPLES = 30
# Where the feature matches span more disparities than the matcher searches at once
# (MAX_NUM_DISP: near tractor and far wall of a high-resolution photo), the pair is matched at
# a working size whose span fits, with RANGE_FIT to spare (the margins of disparity_range are
# rounded up) -- rather than losing the far surfaces; but no smaller than MIN_WORKING_SIDE_PX a
# side (below that a facade's windows are a few pixels: the far end is given up instead).
RANGE_FIT = 0.95
MIN_WORKING_SIDE_PX = 480
DEFAULT_WINDOW = 11  # the block matcher's window, pixels (see VisionParams.window)
FALLBACK_NUM_DISP = 128  # disparities searched when neither given nor found from features
# A disparity below this many pixels gives no depth worth the name: stereo noise of ~0.2 px
# changes it by over 10 % (and near the horizon by kilometres). Such samples still shape the
# plane in disparity space but not the metric centroid and RMS of the region.
MIN_METRIC_DISPARITY_PX = 2.0
# A region whose points lie further from its fitted plane (RMS) than this fraction of the
# plane's distance from the camera is not a plane at the accuracy of the stereo: left out of
# the evidence rather than written with an RMS of hundreds of metres (a wall stereo-measured at
# 1:100 noise has an RMS near 0.01 of its distance).
MAX_RMS_DISTANCE_FRACTION = 0.05


@dataclass(frozen=True)
class VisionParams:
    """Parameters of the pipeline (defaults suit 640x480 building pairs)."""

    # disparities min_disp .. min_disp + num_disp - 1 (pixels); num_disp None: the range is
    # found from sparse feature matches (aida_kb.vision.disprange), else 0 .. FALLBACK_NUM_DISP
    num_disp: int | None = None
    min_disp: int = 0
    window: int = DEFAULT_WINDOW  # small enough for narrow faces seen at grazing angles
    # the dense matcher: "ncc" block matching (aida_kb.vision.stereo) or "sgm", semi-global
    # aggregation of the same NCC costs (aida_kb.vision.sgm: fills weak texture, slower);
    # with "sgm" the window is SGM_WINDOW unless `window` is changed from 11
    matcher: Literal["ncc", "sgm"] = "ncc"
    # the NCC of each window with its own mean and deviation (`ncc_disparity`'s exact mode)
    # rather than of the images normalised pixel by pixel: at an outline against a flat area
    # (a roof's verge against the sky, a dark roof's eave) the pixel-wise normalisation
    # blows the flat side's noise up to the edge's contrast, the peak falls to ~0.35 and the
    # outline gets no certain depth (development scene 61618: 9 % of its roof's outline
    # pixels certain, 27 % exact); about twice the matcher's time
    ncc_exact: bool = True
    # regions on the faces without texture that the image's edges outline and the matcher
    # measures all round (`segmentation.outlined_patches`): segmentation by orientation only
    outlined_faces: bool = True
    min_certainty: float = 0.05
    min_line_px: float = 15.0
    min_region_px: int = 200
    # plane fits refined by aligning the images directly (aida_kb.vision.planes): window of
    # the local normalisation, pixels (odd), or 0 for the disparity fits alone
    photometric_window: int = 5


@dataclass(frozen=True)
class ViewProducts:
    """Everything computed for one view (for debug images and tests).

    disparity : on the rectified left image. depth : on the original left image.
    regions : (H, W) int32 region ids on the original left image, 0 = none.
    left_rectified : the rectified left image (8-bit grey).
    """

    evidence: ViewEvidence
    disparity: DisparityMap
    depth: DepthMap
    regions: I32
    segments: list[Segment]
    left: npt.NDArray[np.uint8]
    left_rectified: npt.NDArray[np.uint8]
    disparity_range: tuple[int, int] = (0, 0)  # (min_disp, num_disp) searched, pixels
    warnings: tuple[str, ...] = ()
    rectified: str = ""  # the rectification's size, zoom and share of the left image kept


def _camera(K: F64, D: F64, R: F64, t: F64, size: tuple[int, int]) -> EvidenceCamera:
    cahv = PinholeCamera(K, R, t, size[0], size[1]).to_cahv()
    return EvidenceCamera(
        K=_m3(K),
        D=[float(x) for x in np.asarray(D, float).ravel()],
        R=_m3(R),
        t=_v3(t),
        cahv=Cahv(C=_v3(cahv.C), A=_v3(cahv.A), H=_v3(cahv.H), V=_v3(cahv.V)),
    )


def _v3(v: npt.ArrayLike) -> tuple[float, float, float]:
    a = np.asarray(v, float).ravel()
    return (float(a[0]), float(a[1]), float(a[2]))


def _m3(
    m: npt.ArrayLike,
) -> tuple[tuple[float, float, float], tuple[float, float, float], tuple[float, float, float]]:
    a = np.asarray(m, float).reshape(3, 3)
    return (_v3(a[0]), _v3(a[1]), _v3(a[2]))


def original_rays(calib: StereoCalib) -> F64:
    """Undistorted viewing rays (H, W, 3) (x, y, 1) of the original left image's pixels."""
    W, H = calib.image_size
    ys, xs = np.mgrid[0:H, 0:W].astype(np.float64)
    pts = np.stack([xs.ravel(), ys.ravel()], axis=1).reshape(-1, 1, 2)
    crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 40, 1e-8)
    norm = cv2.undistortPoints(pts, calib.K1, calib.D1, criteria=crit).reshape(H, W, 2)
    return np.dstack([norm, np.ones((H, W))]).astype(np.float64)


def _read_pair(view: SceneView, calib: StereoCalib) -> tuple[np.ndarray, np.ndarray]:
    left = read_image(view.left, grey=True)
    right = read_image(view.right, grey=True)
    W, H = calib.image_size
    for path, img in ((view.left, left), (view.right, right)):
        if img.shape != (H, W):
            raise VisionError(
                f"{path}: image is {img.shape[1]}x{img.shape[0]}, the calibration says {W}x{H}"
            )
    return left, right


def _region_map(
    view: SceneView,
    mode: SegmentationMode,
    disp: DisparityMap,
    rect: Rectification,
    params: VisionParams,
) -> tuple[I32, Literal["labels", "orientation"]]:
    W, H = rect.size
    if mode != "orientation" and view.labels is not None:
        labels = read_labels(view.labels)
        W0, H0 = view.rig.image_size
        if labels.shape != (H0, W0):
            raise VisionError(
                f"{view.labels}: label image is {labels.shape[1]}x{labels.shape[0]}, "
                f"the calibration says {W0}x{H0}"
            )
        return _resampled(labels.astype(np.int32), (W, H)), "labels"
    if mode == "labels":
        raise VisionError(f"view {view.id}: segmentation 'labels' asked for, but no labels.png")
    planes = local_planes(disp.disparity, disp.certainty)
    seg = segment_planes(disp.disparity, disp.certainty, planes, min_pixels=params.min_region_px)
    back = remap(seg.astype(np.float32), rect.inverse_left, nearest=True, border=0.0)
    return np.nan_to_num(back, nan=0.0).astype(np.int32), "orientation"


def _plane_regions(
    regions: I32,
    disp: DisparityMap,
    depth: DepthMap,
    rect: Rectification,
    rays: F64,
    calib: StereoCalib,
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
    """
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


def _merge_coplanar(
    regions: I32,
    plane_regions: list[Region],
    pose: tuple[F64, F64],
    disp: DisparityMap,
    depth: DepthMap,
    rect: Rectification,
    rays: F64,
    calib: StereoCalib,
    p: VisionParams,
    to_frame: tuple[F64, F64] | None,
    photometric: PhotometricPair | None,
) -> tuple[I32, list[Region]]:
    """Regions of one plane merged (`segmentation.merge_coplanar`) and their planes refitted.

    pose : (R_cam_world, t_cam_world) of the frame the regions' planes are given in.
    """
    R_w, t_w = pose
    ids = np.array([r.id for r in plane_regions], np.int64)
    normals = np.array([R_w @ np.array(r.n_init) for r in plane_regions])
    centroids = np.array([R_w @ np.array(r.c_init) + t_w for r in plane_regions])
    merged = merge_coplanar(
        regions, ids, normals, centroids, points=depth.points, focal_px=float(calib.K1[0, 0])
    )
    if np.array_equal(merged, regions):
        return regions, plane_regions
    refit = _plane_regions(
        merged, disp, depth, rect, rays, calib, p.window, to_frame, False, photometric
    )
    return merged, refit


def _complete(
    regions: I32,
    plane_regions: list[Region],
    pose: tuple[F64, F64],
    disp: DisparityMap,
    depth: DepthMap,
    rect: Rectification,
    rays: F64,
    calib: StereoCalib,
    p: VisionParams,
    to_frame: tuple[F64, F64] | None,
    photometric: PhotometricPair | None,
) -> tuple[I32, list[Region]]:
    """Regions grown over the pixels their planes explain (`segmentation.complete_regions`);
    the planes stay fitted to the measured pixels, the extents (pixel count, area, box) grow.

    pose : (R_cam_world, t_cam_world) of the frame the regions' planes are given in.
    """
    R_w, t_w = pose
    ids = np.array([r.id for r in plane_regions], np.int64)
    normals = np.array([R_w @ np.array(r.n_init) for r in plane_regions])
    centroids = np.array([R_w @ np.array(r.c_init) + t_w for r in plane_regions])
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
        p.window,
    )
    _, _, _, tolerances = _plane_tolerances(plane_regions, pose, rect)
    half = rect.focal_px * COMPLETE_GAP_M / (2.0 * np.maximum(np.abs(centroids[:, 2]), 1e-9))
    gap_px = np.clip(np.ceil(half), *COMPLETE_GAP_PX).astype(np.int64)
    grown = absorb_recesses(grown, depth.points, ids, gap_px, normals, offsets, tolerances)
    unseen = _unseen_by_right(rays, normals, offsets, calib, p.window // 2 + 1)
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
    refit = _plane_regions(
        grown, disp, depth, rect, rays, calib, p.window, to_frame, False, photometric, regions
    )
    return grown, refit


# A textureless face's plane (`segmentation.outlined_patches`) is fitted to the certain
# points along its outline (within OUTLINE_REACH_PX of it, either side: the edge's depth is the
# face's where the face is in front or meets its neighbour there), but of a neighbouring
# region only its pixels within OUTLINE_EDGE_PX of the edge (a wall's pixels a few rows below
# the eave lie on the wall, off the roof's plane, and a wall's texture gives many more of them
# than the roof's outline) -- and accepted when the outline
# is one plane: OUTLINE_INLIER_SHARE of those points kept by the robust fit, their RMS within
# OUTLINE_RMS_SIGMAS of the depth noise at the face's distance, and spread across their main
# line by OUTLINE_SPREAD of the patch's own spread (a single verge is a line: any plane through
# it fits). Two faces under one patch (the hips of a dark roof with no edge between them)
# leave a whole side of the outline off the fit.
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


def _outline_tilt_rad(points: F64, n: F64, rms_m: float, inliers: int, window: int) -> float:
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


@dataclass(frozen=True)
class _Stereo:
    """One view's stereo measurements at the working resolution, as `_plane_regions` takes
    them: the disparity (rectified), the depth (original image), the rectification, the
    original image's viewing rays (H, W, 3) and the rig."""

    disp: DisparityMap
    depth: DepthMap
    rect: Rectification
    rays: F64
    calib: StereoCalib


def _outlined(
    regions: I32,
    plane_regions: list[Region],
    image: npt.NDArray[np.uint8],
    stereo: _Stereo,
    p: VisionParams,
    to_frame: tuple[F64, F64] | None,
) -> tuple[I32, list[Region]]:
    """Regions added on the textureless faces (`segmentation.outlined_patches`): each patch
    with the certain pixels of no region along its outline, its plane fitted to the certain
    pixels along the outline (no photometric refinement: they straddle the outline). Pixel
    figures are the patch's; inlier_count at most its pixels with depth. See
    OUTLINE_INLIER_SHARE."""
    disp, depth, rect, rays, calib = (
        stereo.disp,
        stereo.depth,
        stereo.rect,
        stereo.rays,
        stereo.calib,
    )
    patches, certain, edges = outlined_patches(
        regions, image, depth.certainty, min_pixels=p.min_region_px
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
        window = p.window
        found = _plane_regions(band, disp, depth, rect, rays, calib, window, to_frame, False, None)
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
        tilt = _outline_tilt_rad(
            depth.points[along].astype(np.float64), n_cam, r.rms_m, r.inlier_count, p.window
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
            float((p.window - 2) ** 2)
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


def _unseen_by_right(
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


def _plane_tolerances(
    plane_regions: list[Region], pose: tuple[F64, F64], rect: Rectification
) -> tuple[npt.NDArray[np.int64], F64, F64, F64]:
    """(ids, normals, offsets, tolerances) of the regions' planes in the camera frame: unit
    normals (R, 3), offsets (R,) metres (n·x = d), and the distance from the plane within
    which a point lies on it, metres (COMPLETE_SIGMAS times the larger of the fit's RMS and
    the depth noise at the region's distance, as `complete_regions` uses it)."""
    R_w, t_w = pose
    ids = np.array([r.id for r in plane_regions], np.int64)
    normals = np.array([R_w @ np.array(r.n_init) for r in plane_regions]).reshape(-1, 3)
    centroids = np.array([R_w @ np.array(r.c_init) + t_w for r in plane_regions]).reshape(-1, 3)
    offsets = np.einsum("ij,ij->i", normals, centroids)
    z = np.abs(centroids[:, 2])
    sigma_z = z * z * DISPARITY_SIGMA_PX / max(rect.focal_px * rect.baseline_m, 1e-12)
    rms = np.array([r.rms_m for r in plane_regions])
    return ids, normals, offsets, COMPLETE_SIGMAS * np.maximum(rms, sigma_z)


def _line_kinds(
    segments: list[Segment],
    regions: I32,
    depth: DepthMap,
    plane_regions: list[Region],
    pose: tuple[F64, F64],
    rect: Rectification,
    scale: float,
) -> list[Literal["structural", "texture"] | None]:
    """Each segment structural, texture or unknown (`segmentation.line_kinds`); `scale`: the
    image's pixels per working pixel (the sides are sampled as far at the object)."""
    if not segments:
        return []
    if not plane_regions:
        return [None] * len(segments)
    ids, normals, offsets, tolerances = _plane_tolerances(plane_regions, pose, rect)
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


def working_rig(calib: StereoCalib) -> StereoCalib:
    """`calib` itself, or for images above WORKING_MAX_PIXELS (aida_kb.io.calib) the same rig
    at the working resolution: the pair is matched, segmented and fitted there, the evidence is
    given in the full images' pixels."""
    size = working_size(*calib.image_size)
    return calib if size == calib.image_size else scaled_calib(calib, size)


def _resampled(values: npt.NDArray[Any], size: tuple[int, int]) -> npt.NDArray[Any]:
    """A per-pixel map (H, W) or (H, W, C) resampled to `size` (width, height) by the nearest
    pixel centre (no value invented: ids and NaN dropouts stay as they are)."""
    H, W = values.shape[:2]
    W2, H2 = size
    rows = np.minimum(((np.arange(H2) + 0.5) * (H / H2)).astype(np.intp), H - 1)
    cols = np.minimum(((np.arange(W2) + 0.5) * (W / W2)).astype(np.intp), W - 1)
    return np.ascontiguousarray(values[rows][:, cols])


def _lifted(regions: list[Region], region_map: I32, depth: DepthMap) -> list[Region]:
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


def process_view(
    scene: Scene,
    view_id: str,
    *,
    params: VisionParams | None = None,
    segmentation: SegmentationMode = "auto",
    pose: Pose | None = None,
    rect: Rectification | None = None,
    rays: F64 | None = None,
    stage: Stage | None = None,
) -> ViewProducts:
    """Run the vision pipeline on one view of `scene`.

    pose : (R_cam_world, t_cam_world) of the view's left camera, if known; view 00 always has
    the identity (world = its left camera). Without a pose, other views are given in their own
    camera frame. segmentation : "auto" uses labels.png where the view has one, "labels"
    requires it, "orientation" always segments by surface orientation. stage : called with
    each stage's name (see STAGES) as it starts.
    """
    p = params or VisionParams()
    try:
        view = scene.view(view_id)
    except KeyError:
        raise VisionError(f"{scene.root}: no view {view_id!r}") from None
    tick: Stage = stage or (lambda _name: None)
    full = view.rig  # the images' own calibration: the evidence is given in its pixels
    calib = working_rig(full)  # the calibration of the working resolution (see working_rig)
    if pose is None and view.pose is not None:  # the scene gives the view's pose
        pose = view.pose
    tick("rectify")
    left, right = _read_pair(view, full)
    left_w, right_w = left, right
    if calib is not full:
        left_w = cv2.resize(left, calib.image_size, interpolation=cv2.INTER_AREA)
        right_w = cv2.resize(right, calib.image_size, interpolation=cv2.INTER_AREA)
    rect = rect or stereo_rectification(calib)
    rays = rays if rays is not None else original_rays(calib)
    left_r, right_r = rect.rectify(left_w, right_w)
    if p.num_disp is None:  # a span the matcher cannot search at once: a coarser working size
        found = disparity_range(left_r, right_r)
        if found is not None and found.clipped:
            need = (1.0 + 2.0 * RANGE_MARGIN_FRACTION) * (found.high_px - found.low_px)
            shrink = RANGE_FIT * MAX_NUM_DISP / (need + 2.0 * RANGE_MARGIN_PX)
            W_w, H_w = calib.image_size
            size = (max(1, round(W_w * shrink)), max(1, round(H_w * shrink)))
            if min(size) >= MIN_WORKING_SIDE_PX:
                calib = scaled_calib(full, size)
                left_w = np.asarray(cv2.resize(left, size, interpolation=cv2.INTER_AREA), np.uint8)
                right_w = np.asarray(
                    cv2.resize(right, size, interpolation=cv2.INTER_AREA), np.uint8
                )
                rect = stereo_rectification(calib)
                rays = original_rays(calib)
                left_r, right_r = rect.rectify(left_w, right_w)
    tick("disparity")
    min_disp, num_disp, warnings = _search_range(left_r, right_r, p)
    if p.matcher == "sgm":
        window = SGM_WINDOW if p.window == DEFAULT_WINDOW else p.window
        disp = sgm_disparity(left_r, right_r, min_disp=min_disp, num_disp=num_disp, window=window)
    else:
        disp = ncc_disparity(
            left_r,
            right_r,
            min_disp=min_disp,
            num_disp=num_disp,
            window=p.window,
            exact=p.ncc_exact,
        )
    sparse = sparse_disparities(left_r, right_r) if p.num_disp is not None else None
    warnings += saturation_warnings(disp, min_disp, num_disp, sparse)
    tick("depth")
    depth = depth_map(disp, rect, min_certainty=p.min_certainty)
    tick("segmentation")
    regions, used = _region_map(view, segmentation, disp, rect, p)
    if view_id == scene.views[0].id:
        frame: Literal["world", "camera"] = "world"
        R_w, t_w = np.eye(3), np.zeros(3)
        to_frame = None
    elif pose is not None:
        frame = "world"
        R_w, t_w = np.asarray(pose[0], float), np.asarray(pose[1], float).ravel()
        to_frame = (R_w, t_w)
    else:
        frame = "camera"
        R_w, t_w = np.eye(3), np.zeros(3)
        to_frame = None
    tick("planes")
    photometric = None
    if p.photometric_window:
        photometric = photometric_pair(left_r, right_r, p.photometric_window)
    plane_regions = _plane_regions(
        regions,
        disp,
        depth,
        rect,
        rays,
        calib,
        p.window,
        to_frame,
        used == "labels",
        photometric,
    )
    if used == "orientation" and len(plane_regions) > 1:
        regions, plane_regions = _merge_coplanar(
            regions,
            plane_regions,
            (R_w, t_w),
            disp,
            depth,
            rect,
            rays,
            calib,
            p,
            to_frame,
            photometric,
        )
    kept = {r.id for r in plane_regions}
    regions = np.where(np.isin(regions, list(kept)), regions, 0).astype(np.int32)
    if used == "orientation" and plane_regions:
        regions, plane_regions = _complete(
            regions,
            plane_regions,
            (R_w, t_w),
            disp,
            depth,
            rect,
            rays,
            calib,
            p,
            to_frame,
            photometric,
        )
    kept = {r.id for r in plane_regions}
    regions = np.where(np.isin(regions, list(kept)), regions, 0).astype(np.int32)
    if used == "orientation" and p.outlined_faces:
        stereo = _Stereo(disp, depth, rect, rays, calib)
        regions, plane_regions = _outlined(regions, plane_regions, left_w, stereo, p, to_frame)
    work_size = calib.image_size
    if calib is not full:  # back to the images' own pixels
        W0, H0 = full.image_size
        if used == "labels":
            assert view.labels is not None
            labels = read_labels(view.labels).astype(np.int32)
            regions = np.where(np.isin(labels, list(kept)), labels, 0).astype(np.int32)
        else:
            regions = _resampled(regions, (W0, H0))
        depth = DepthMap(
            depth_m=_resampled(depth.depth_m, (W0, H0)),
            points=_resampled(depth.points, (W0, H0)),
            certainty=_resampled(depth.certainty, (W0, H0)),
        )
        plane_regions = _lifted(plane_regions, regions, depth)
    tick("lines")
    # on the full image (its pixels are the evidence's); the shortest segment kept is as long
    # at the object as at the working resolution
    min_line = p.min_line_px * full.image_size[0] / calib.image_size[0]
    segments = attach_segments(detect_segments(left, min_length_px=min_line), left, regions)
    kinds = _line_kinds(
        segments, regions, depth, plane_regions, (R_w, t_w), rect, full.image_size[0] / work_size[0]
    )
    lines = [
        LineSegment(
            id=i + 1,
            p1=s.p1,
            p2=s.p2,
            length_px=s.length_px,
            contrast=s.contrast,
            regions=s.regions,
            left_region=s.left_region,
            right_region=s.right_region,
            kind=kind,
        )
        for i, (s, kind) in enumerate(zip(segments, kinds, strict=True))
    ]
    tick("contours")
    contours = [
        Contour(
            id=i + 1,
            region=rid,
            hole=hole,
            points=[(float(x), float(y)) for x, y in poly],
        )
        for i, (rid, hole, poly) in enumerate(region_contours(regions))
    ]
    working_note = ""
    if work_size != full.image_size:
        working_note = (
            f"; matched at {work_size[0]}x{work_size[1]} (working resolution) of "
            f"{full.image_size[0]}x{full.image_size[1]}"
        )
    calib = full
    R_r = calib.R @ R_w
    t_r = calib.R @ t_w + calib.T
    evidence = ViewEvidence(
        id=view.id,
        frame=frame,
        image_width=calib.image_size[0],
        image_height=calib.image_size[1],
        left=_camera(calib.K1, calib.D1, R_w, t_w, calib.image_size),
        right=_camera(calib.K2, calib.D2, R_r, t_r, calib.image_size),
        segmentation=used,
        disparity_density=depth.density,
        regions=plane_regions,
        lines=lines,
        contours=contours,
    )
    return ViewProducts(
        evidence=evidence,
        disparity=disp,
        depth=depth,
        regions=regions,
        segments=segments,
        left=left,
        left_rectified=left_r,
        disparity_range=(min_disp, num_disp),
        rectified=rect.summary() + working_note,
        warnings=tuple(f"view {view.id}: {w}" for w in warnings),
    )


def _search_range(
    left_r: npt.NDArray[np.uint8], right_r: npt.NDArray[np.uint8], p: VisionParams
) -> tuple[int, int, list[str]]:
    """(min_disp, num_disp) to search on a rectified pair, and warnings about the choice."""
    if p.num_disp is not None:
        return p.min_disp, p.num_disp, []
    found = disparity_range(left_r, right_r)
    if found is None:
        return (
            p.min_disp,
            FALLBACK_NUM_DISP,
            [
                f"too few feature matches to find the disparity range; searching "
                f"{p.min_disp}..{p.min_disp + FALLBACK_NUM_DISP - 1} px (set --max-disp)"
            ],
        )
    notes = []
    if found.clipped:
        notes.append(
            f"the feature matches span {found.low_px:.0f}..{found.high_px:.0f} px, more than "
            f"{found.num_disp} disparities: searching {found.min_disp}.."
            f"{found.min_disp + found.num_disp - 1} px, the farthest surfaces get no depth"
        )
    return found.min_disp, found.num_disp, notes


def scene_evidence(
    scene: Scene,
    *,
    views: Sequence[str] | None = None,
    params: VisionParams | None = None,
    segmentation: SegmentationMode = "auto",
    poses: Mapping[str, Pose] | None = None,
    stage: Callable[[str, str], None] | None = None,
) -> tuple[Evidence, list[ViewProducts]]:
    """Evidence of the given views (default: all) of `scene`, and each view's products.

    poses : view id -> (R_cam_world, t_cam_world) for views whose pose is known.
    stage : called with (view id, stage name) as each stage starts.
    """
    ids = list(views) if views is not None else [v.id for v in scene.views]
    known = {v.id for v in scene.views}
    if len(set(ids)) != len(ids):
        raise VisionError(f"views {', '.join(ids)}: a view is given more than once")
    missing = [i for i in ids if i not in known]
    if missing:
        raise VisionError(f"{scene.root}: no view(s) {', '.join(missing)}")
    rigs: dict[int, tuple[Rectification, F64]] = {}  # one rectification per distinct rig
    products = []
    for vid in ids:
        rig = scene.view(vid).rig
        if id(rig) not in rigs:
            work = working_rig(rig)
            rigs[id(rig)] = (stereo_rectification(work), original_rays(work))
        rect, rays = rigs[id(rig)]

        def tick(name: str, vid: str = vid) -> None:
            if stage is not None:
                stage(vid, name)

        products.append(
            process_view(
                scene,
                vid,
                params=params,
                segmentation=segmentation,
                pose=(poses or {}).get(vid),
                rect=rect,
                rays=rays,
                stage=tick,
            )
        )
    evidence = Evidence(
        scene=scene.name,
        units="m" if scene.metric else "unknown",
        views=[p.evidence for p in products],
    )
    return evidence, products
