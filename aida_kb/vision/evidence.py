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

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
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
    photometric_pair,
)
from aida_kb.vision.rectify import Rectification, remap, stereo_rectification
from aida_kb.vision.regions import (
    ViewStereo,
    completed_regions,
    fit_region_planes,
    lifted_regions,
    merged_regions,
    outlined_regions,
    segment_kinds,
)
from aida_kb.vision.segmentation import (
    local_planes,
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
# Where the feature matches span more disparities than the matcher searches at once
# (MAX_NUM_DISP: near tractor and far wall of a high-resolution photo), the pair is matched at
# a working size whose span fits, with RANGE_FIT to spare (the margins of disparity_range are
# rounded up) -- rather than losing the far surfaces; but no smaller than MIN_WORKING_SIDE_PX a
# side (below that a facade's windows are a few pixels: the far end is given up instead).
RANGE_FIT = 0.95
MIN_WORKING_SIDE_PX = 480
DEFAULT_WINDOW = 11  # the block matcher's window, pixels (see VisionParams.window)
FALLBACK_NUM_DISP = 128  # disparities searched when neither given nor found from features


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
    # measures all round (`outline.outlined_patches`): segmentation by orientation only
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
    stereo = ViewStereo(disp, depth, rect, rays, calib)
    plane_regions = fit_region_planes(
        regions, stereo, p.window, to_frame, used == "labels", photometric
    )
    if used == "orientation" and len(plane_regions) > 1:
        regions, plane_regions = merged_regions(
            regions, plane_regions, (R_w, t_w), stereo, p.window, to_frame, photometric
        )
    kept = {r.id for r in plane_regions}
    regions = np.where(np.isin(regions, list(kept)), regions, 0).astype(np.int32)
    if used == "orientation" and plane_regions:
        regions, plane_regions = completed_regions(
            regions, plane_regions, (R_w, t_w), stereo, p.window, to_frame, photometric
        )
    kept = {r.id for r in plane_regions}
    regions = np.where(np.isin(regions, list(kept)), regions, 0).astype(np.int32)
    if used == "orientation" and p.outlined_faces:
        regions, plane_regions = outlined_regions(
            regions, plane_regions, left_w, stereo, p.window, p.min_region_px, to_frame
        )
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
        plane_regions = lifted_regions(plane_regions, regions, depth)
    tick("lines")
    # on the full image (its pixels are the evidence's); the shortest segment kept is as long
    # at the object as at the working resolution
    min_line = p.min_line_px * full.image_size[0] / calib.image_size[0]
    segments = attach_segments(detect_segments(left, min_length_px=min_line), left, regions)
    kinds = segment_kinds(
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
