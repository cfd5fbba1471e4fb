"""A view's evidence as registration measurements, and registration of an evidence view.

Segments are undistorted with the left camera's D (evidence pixels are those of the original
image); region plane fits are carried into the view's own left camera frame.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aida_kb.errors import FormatError, SolveError
from aida_kb.geometry.camera import PinholeCamera
from aida_kb.geometry.rig import Rig
from aida_kb.io.evidence import ViewEvidence
from aida_kb.io.model import ModelCamera
from aida_kb.io.scene import Scene, read_image
from aida_kb.register.model import RigidModel
from aida_kb.register.register import (
    RegionMeasurements,
    Registration,
    RegistrationOptions,
    StereoSegments,
    register_view,
)
from aida_kb.register.twins import PhotometricJudge
from aida_kb.vision.rectify import undistort_pixels

FloatArray = npt.NDArray[np.float64]

__all__ = [
    "ViewMeasurements",
    "camera_of",
    "measurements_of",
    "region_outlines",
    "register_evidence_view",
    "right_segments",
]


@dataclass(frozen=True)
class ViewMeasurements:
    """What registration uses of a view.

    K : (3, 3) left camera matrix; width, height : image size, pixels; p1, p2 : (S, 2)
    undistorted segment end points, pixels; regions : plane fits in the left camera frame;
    sigma_px : (S,) the segments' edge-point sigmas from their edge fits (pixels) when they
    were fitted to the image, else None; bounding : (S,) whether a segment bounds a region
    (its two sides are not one region: a region's border, not a texture line inside it), None
    when not known.
    """

    view: str
    K: FloatArray
    width: int
    height: int
    p1: FloatArray
    p2: FloatArray
    regions: RegionMeasurements
    sigma_px: FloatArray | None = None
    bounding: npt.NDArray[np.bool_] | None = None


def measurements_of(
    view: ViewEvidence, image: npt.NDArray[np.uint8] | None = None
) -> ViewMeasurements:
    """Segments and region plane fits of an evidence view, in its left camera's terms.

    With the view's left `image` (8-bit grey, as taken: the evidence's pixels), its segments
    are first moved onto their edges (`aida_kb.vision.lines.fit_segments`), which gives each
    its edge-point sigma too.
    """
    K = np.array(view.left.K, dtype=np.float64)
    D = np.array(view.left.D, dtype=np.float64)
    ends = np.array([[s.p1, s.p2] for s in view.lines], dtype=np.float64).reshape(-1, 2, 2)
    sigma = None
    if image is not None:
        from aida_kb.vision.lines import fit_segments

        fits = fit_segments(image, ends.reshape(-1, 4))
        ends, sigma = fits.segments.reshape(-1, 2, 2), fits.sigma_px
    flat = undistort_pixels(ends.reshape(-1, 2), K, D).reshape(-1, 2, 2)
    R = np.array(view.left.R, dtype=np.float64)
    t = np.array(view.left.t, dtype=np.float64)
    n = np.array([r.n_init for r in view.regions], dtype=np.float64).reshape(-1, 3)
    c = np.array([r.c_init for r in view.regions], dtype=np.float64).reshape(-1, 3)
    rms = np.array([r.rms_m for r in view.regions], dtype=np.float64)
    inliers = np.array([r.inlier_count for r in view.regions], dtype=np.float64)
    area = np.array([r.area_m2 for r in view.regions], dtype=np.float64)
    regions = RegionMeasurements(n @ R.T, c @ R.T + t, rms, inliers, area)
    inside = np.array(
        [s.left_region is not None and s.left_region == s.right_region for s in view.lines],
        dtype=bool,
    )
    return ViewMeasurements(
        view.id,
        K,
        view.image_width,
        view.image_height,
        flat[:, 0],
        flat[:, 1],
        regions,
        sigma,
        ~inside,
    )


def region_outlines(view: ViewEvidence) -> list[FloatArray | None]:
    """Per region of the view (the order of its ``regions``, as `measurements_of`'s), its
    outer outline (K, 2) in the pinhole camera's (undistorted) pixels, or None where the
    evidence holds none (its contours' holes are not outlines)."""
    K = np.array(view.left.K, dtype=np.float64)
    D = np.array(view.left.D, dtype=np.float64)
    outer = {c.region: c.points for c in view.contours if not c.hole}
    out: list[FloatArray | None] = []
    for r in view.regions:
        pts = outer.get(r.id)
        out.append(
            None
            if pts is None
            else undistort_pixels(np.array(pts, dtype=np.float64).reshape(-1, 2), K, D)
        )
    return out


def right_segments(scene: Scene, view_id: str) -> StereoSegments:
    """The line segments of a view's right image (undistorted with D2) and the rig's camera.

    The evidence file holds the left image's segments only; the right image's are detected
    here with the same detector (`aida_kb.vision.lines.detect_segments`), each moved onto its
    edge with its edge-point sigma (`aida_kb.vision.lines.fit_segments`).
    """
    from aida_kb.vision.lines import detect_segments, fit_segments

    calib = scene.view(view_id).rig
    grey = read_image(scene.view(view_id).right, grey=True)
    fits = fit_segments(grey, detect_segments(grey))
    seg = fits.segments
    K2 = np.asarray(calib.K2, dtype=np.float64)
    D2 = np.asarray(calib.D2, dtype=np.float64).ravel()
    ends = undistort_pixels(seg.reshape(-1, 2), K2, D2).reshape(-1, 2, 2)
    w, h = calib.image_size
    rig = Rig(K2, np.asarray(calib.R, dtype=np.float64), np.asarray(calib.T).ravel(), w, h)
    pinhole = undistorted_image(grey, K2, D2)
    return StereoSegments(rig, ends[:, 0], ends[:, 1], fits.sigma_px, pinhole)


def undistorted_image(
    grey: npt.NDArray[np.uint8], K: FloatArray, D: FloatArray
) -> npt.NDArray[np.uint8]:
    """The image as pinhole camera K sees it (its pixels those of `undistort_pixels`); the
    image itself when D is empty or zero."""
    if D.size == 0 or not np.any(D):
        return grey
    import cv2

    out: npt.NDArray[np.uint8] = np.asarray(cv2.undistort(grey, K, D), dtype=np.uint8)
    return out


def camera_of(camera: ModelCamera) -> PinholeCamera:
    """The pinhole camera of a model file's camera entry."""
    return PinholeCamera(
        np.array(camera.K, dtype=np.float64),
        np.array(camera.R, dtype=np.float64),
        np.array(camera.t, dtype=np.float64),
        camera.image_width,
        camera.image_height,
    )


MAX_IMAGE_SIDE_PX = 100_000
"""An image side longer than this (pixels) is taken for a mistake in the model file."""

MIN_INSIDE_FRACTION = 0.5
"""At least this share of the model's vertices must project into the reference image."""


def check_reference_camera(
    model: RigidModel, camera: ModelCamera, where: str, index: int = 0
) -> None:
    """Refuse (FormatError) a reference camera whose image cannot hold the model's projection.

    Parameters
    ----------
    model : the rigid model; its vertices (V, 3), world frame, metres, are projected.
    camera : the model file's camera entry the registration starts from.
    where : the model file, named in the message; index : the entry's place in ``cameras``.

    The image must be at most `MAX_IMAGE_SIDE_PX` a side, and at least
    `MIN_INSIDE_FRACTION` of the vertices in front of the camera must fall inside it
    (a 1x1 image, or one that is not this camera's, holds none of them).
    """
    field = f"field cameras[{index}] (view {camera.view!r})"
    w, h = camera.image_width, camera.image_height
    if max(w, h) > MAX_IMAGE_SIDE_PX:
        raise FormatError(
            f"{where}: {field}: image_width x image_height {w}x{h} is absurd "
            f"(at most {MAX_IMAGE_SIDE_PX} pixels a side)"
        )
    cam = camera_of(camera)
    points = cam.to_camera(model.vertices)
    front = points[points[:, 2] > 1e-9]
    if len(front) == 0:
        raise FormatError(f"{where}: {field}: the model lies behind the camera")
    q = front @ cam.K.T
    uv = q[:, :2] / q[:, 2:3]
    inside = (uv[:, 0] >= -0.5) & (uv[:, 0] <= w - 0.5) & (uv[:, 1] >= -0.5) & (uv[:, 1] <= h - 0.5)
    if inside.mean() < MIN_INSIDE_FRACTION:
        lo, hi = uv.min(axis=0), uv.max(axis=0)
        raise FormatError(
            f"{where}: {field}: image_width x image_height {w}x{h} cannot hold the model's "
            f"projection ({int(inside.sum())} of {len(front)} vertices inside; they span "
            f"u {lo[0]:.0f}..{hi[0]:.0f}, v {lo[1]:.0f}..{hi[1]:.0f} px)"
        )


def register_evidence_view(
    model: RigidModel,
    reference: PinholeCamera,
    view: ViewEvidence,
    *,
    init_angle_deg: float | None = None,
    expected_turn_deg: float | None = None,
    use_regions: bool = True,
    stereo: StereoSegments | None = None,
    options: RegistrationOptions | None = None,
    image: npt.NDArray[np.uint8] | None = None,
    photometric: PhotometricJudge | None = None,
    region_sigma: Callable[[RegionMeasurements], FloatArray | None] | None = None,
) -> Registration:
    """Register an evidence view (its segments and, if asked, its regions) against `model`.

    `stereo`: the segments of the view's right image (`right_segments`), used as well.
    `image`: the view's left image (8-bit grey): its segments are moved onto their edges
    first (`measurements_of`). `photometric`: the images' support of a candidate pose
    (`aida_kb.register.twins`), which decides between poses the segments cannot.
    `region_sigma`: the caller's noise model of the regions' normals (their (R,) 1-σ tilts,
    radians, or None), with which `register_view` also starts from the rotation they give.

    Raises SolveError naming the view when it cannot be registered.
    """
    m = measurements_of(view, image)
    D = np.array(view.left.D, dtype=np.float64).ravel()
    regions = m.regions if use_regions and m.regions.size else None
    sigma = None if regions is None or region_sigma is None else region_sigma(regions)
    try:
        return register_view(
            model,
            reference,
            m.p1,
            m.p2,
            regions=regions,
            intrinsics=(m.K, m.width, m.height),
            init_angle_deg=init_angle_deg,
            expected_turn_deg=expected_turn_deg,
            stereo=stereo,
            options=options,
            sigma_px=m.sigma_px,
            image=None if image is None else undistorted_image(image, m.K, D),
            photometric=photometric,
            region_sigma_rad=sigma,
        )
    except SolveError as exc:
        raise SolveError(f"view {view.id}: {exc}") from exc
