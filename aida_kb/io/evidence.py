"""The evidence file ``evidence.json``: what the vision front end measured, per view.

It is the boundary between vision (aida_kb/vision) and interpretation: per view the stereo
cameras (K, R, t and CAHV), the segmented image regions with their certainty-weighted plane
fits (n_init, c_init and the weight w_c of the paper's position constraint, eq. 4), image line
segments (the edge constraint, eq. 5) and region contours. Documented field by field in
docs/formats.md; the JSON Schema is docs/schemas/evidence.schema.json (`evidence_schema_text`).

Frames: 3-D quantities of a view are given in that view's ``frame``: ``world`` (the left camera
of view 00, or any view whose pose was supplied) or ``camera`` (the view's own left camera,
when its pose is not known yet; registration estimates it). Pixel quantities are in the
ORIGINAL (distorted, unrectified) left image, pixel centres at integer coordinates.
"""

from __future__ import annotations

import json
import math
import os
from typing import Annotated, Literal

from pydantic import BeforeValidator, Field, model_validator

from aida_kb.io.jsonio import FrozenModel, read_json_model, write_json_model
from aida_kb.io.model import (
    Cahv,
    Finite,
    Int,
    Mat3,
    Vec3,
    ViewId,
    camera_centre,
    check_camera,
    number_only,
)

EVIDENCE_FORMAT: Literal["aida-kb-evidence"] = "aida-kb-evidence"
EVIDENCE_VERSION: Literal[1] = 1

Point2 = tuple[Finite, Finite]


def _unit(v: Vec3, what: str) -> None:
    norm = math.sqrt(sum(c * c for c in v))
    if abs(norm - 1.0) > 1e-6:
        raise ValueError(f"{what} must have unit length (has {norm:.6g})")


_Frozen = FrozenModel


class EvidenceCamera(_Frozen):
    """One camera of a view's stereo pair, in the view's frame.

    x_cam = R·x + t (R_cam_frame, t_cam_frame in metres); pixels = K·x_cam, then distortion D.
    """

    K: Mat3 = Field(description="intrinsic matrix, pixels")
    D: list[Finite] = Field(
        default_factory=list, description="OpenCV distortion k1 k2 p1 p2 k3 ...; [] for none"
    )
    R: Mat3 = Field(description="rotation frame -> camera")
    t: Vec3 = Field(description="translation frame -> camera, metres")
    cahv: Cahv = Field(description="the same pinhole camera as CAHV (distortion not included)")

    @model_validator(mode="after")
    def _check(self) -> EvidenceCamera:
        if len(self.D) not in (0, 4, 5, 8, 12, 14):
            raise ValueError(f"D has {len(self.D)} coefficients; expected 0, 4, 5, 8, 12 or 14")
        check_camera(self.K, self.R)
        _unit(self.cahv.A, "cahv.A")
        centre = camera_centre(self.R, self.t)
        scale = max(1.0, math.sqrt(sum(c * c for c in centre)))
        if max(abs(a - b) for a, b in zip(self.cahv.C, centre, strict=True)) > 1e-6 * scale:
            raise ValueError("cahv.C is not the centre -Rᵀ·t of the camera given by R and t")
        if max(abs(a - b) for a, b in zip(self.cahv.A, self.R[2], strict=True)) > 1e-6:
            raise ValueError("cahv.A is not the optical axis (third row of R)")
        return self


class Region(_Frozen):
    """A segmented image region and the plane fitted to its depth (paper §4.5)."""

    id: Int = Field(ge=1, description="region id, unique in the view (the value in segmentation)")
    label: Annotated[int, Field(ge=1), BeforeValidator(number_only)] | None = Field(
        default=None, description="the labels.png id it came from; null if segmented"
    )
    pixel_count: Int = Field(ge=1, description="pixels of the region in the left image")
    depth_pixel_count: Int = Field(ge=0, description="region pixels with a depth value")
    inlier_count: Int = Field(ge=0, description="pixels the robust plane fit kept")
    area_m2: Finite = Field(ge=0, description="area of the region on the fitted plane, m²")
    n_init: Vec3 = Field(description="unit plane normal, pointing towards the camera")
    d_init: Finite = Field(description="plane offset: n_init·x = d_init, metres")
    c_init: Vec3 = Field(description="certainty-weighted centre of gravity on the plane, metres")
    w_c: Finite = Field(ge=0, description="sum of the certainty map over the region (eq. 4)")
    rms_m: Finite = Field(ge=0, description="weighted RMS distance of the inliers to the plane")
    mean_certainty: Finite = Field(ge=0, le=1, description="w_c / pixel_count")
    bbox: tuple[Int, Int, Int, Int] = Field(description="x0 y0 x1 y1, pixels, inclusive")

    @model_validator(mode="after")
    def _check(self) -> Region:
        _unit(self.n_init, f"region {self.id}: n_init")
        x0, y0, x1, y1 = self.bbox
        if not (0 <= x0 <= x1 and 0 <= y0 <= y1):
            raise ValueError(f"region {self.id}: bbox must be x0 y0 x1 y1, 0 <= x0 <= x1, y0 <= y1")
        if self.pixel_count > (x1 - x0 + 1) * (y1 - y0 + 1):
            raise ValueError(f"region {self.id}: pixel_count exceeds the area of its bbox")
        if self.depth_pixel_count > self.pixel_count or self.inlier_count > self.depth_pixel_count:
            raise ValueError(
                f"region {self.id}: need inlier_count <= depth_pixel_count <= pixel_count"
            )
        if self.w_c > self.pixel_count * (1.0 + 1e-9):
            raise ValueError(f"region {self.id}: w_c exceeds pixel_count (certainty is <= 1)")
        return self


class LineSegment(_Frozen):
    """A straight image edge with subpixel end points (paper §4.6, p1 and p2)."""

    id: Int = Field(ge=1)
    p1: Point2 = Field(description="first end point, pixels (x, y)")
    p2: Point2 = Field(description="second end point, pixels (x, y)")
    length_px: Finite = Field(gt=0)
    contrast: Finite = Field(ge=0, description="mean grey-level step across the edge")
    regions: list[Int] = Field(
        default_factory=list, description="ids of the regions it borders (0, 1 or 2)"
    )
    left_region: Int | None = Field(
        default=None, description="region on the left of p1->p2 (image axes), if any"
    )
    right_region: Int | None = Field(default=None, description="region on the right, if any")
    kind: Literal["structural", "texture"] | None = Field(
        default=None,
        description="structural: the surface changes across it (two regions, an outline, or "
        "a depth step beyond the plane's tolerance); texture: both sides on one plane "
        "(masonry, paint, shadow); null: not known (no plane or no depth on a side)",
    )

    @model_validator(mode="after")
    def _check(self) -> LineSegment:
        length = math.dist(self.p1, self.p2)
        if length == 0.0:
            raise ValueError(f"line {self.id}: p1 and p2 are the same point (zero length)")
        if abs(self.length_px - length) > 0.05 + 1e-6 * length:  # rounded to 0.1 px is fine
            raise ValueError(
                f"line {self.id}: length_px {self.length_px:.6g} is not the distance "
                f"{length:.6g} from p1 to p2"
            )
        return self


class Contour(_Frozen):
    """A closed region boundary as a polygon in pixels (simplified, ~1 px tolerance)."""

    id: Int = Field(ge=1)
    region: Int = Field(ge=1, description="the region it bounds")
    hole: bool = Field(default=False, description="True for an inner boundary")
    points: list[Point2] = Field(min_length=3, description="vertices (x, y), pixels")


class ViewEvidence(_Frozen):
    """The evidence of one stereo view."""

    id: ViewId
    frame: Literal["world", "camera"] = Field(
        description="frame of 3-D quantities: world, or this view's own left camera"
    )
    image_width: Int = Field(gt=0)
    image_height: Int = Field(gt=0)
    left: EvidenceCamera
    right: EvidenceCamera
    segmentation: Literal["labels", "orientation"] = Field(
        description="labels.png was used, or regions of equal orientation were segmented"
    )
    disparity_density: Finite = Field(
        ge=0, le=1, description="fraction of left-image pixels with a depth value"
    )
    regions: list[Region] = Field(default_factory=list)
    lines: list[LineSegment] = Field(default_factory=list)
    contours: list[Contour] = Field(default_factory=list)

    @model_validator(mode="after")
    def _references(self) -> ViewEvidence:
        self._check_geometry()
        ids = [r.id for r in self.regions]
        if len(set(ids)) != len(ids):
            raise ValueError(f"view {self.id}: region ids must be unique")
        known = set(ids)
        for kind, items in (("line", self.lines), ("contour", self.contours)):
            item_ids = [it.id for it in items]
            if len(set(item_ids)) != len(item_ids):
                raise ValueError(f"view {self.id}: {kind} ids must be unique")
        for line in self.lines:
            refs = [*line.regions, line.left_region, line.right_region]
            bad = sorted({r for r in refs if r is not None and r not in known})
            if bad:
                raise ValueError(f"view {self.id}: line {line.id} names unknown regions {bad}")
        for contour in self.contours:
            if contour.region not in known:
                raise ValueError(
                    f"view {self.id}: contour {contour.id} names unknown region {contour.region}"
                )
        return self

    def _check_geometry(self) -> None:
        """The stereo pair has a baseline; regions lie in the image, points near it."""
        left_c = camera_centre(self.left.R, self.left.t)
        right_c = camera_centre(self.right.R, self.right.t)
        if math.dist(left_c, right_c) <= 1e-9:
            raise ValueError(
                f"view {self.id}: left and right cameras have the same centre (zero baseline)"
            )
        w, h = self.image_width, self.image_height
        for r in self.regions:
            if r.bbox[2] >= w or r.bbox[3] >= h:
                raise ValueError(
                    f"view {self.id}: region {r.id}: bbox {list(r.bbox)} exceeds the {w}x{h} image"
                )

        def far(p: Point2) -> bool:  # a margin of one image size: lines may be extrapolated
            return not (-w <= p[0] <= 2 * w and -h <= p[1] <= 2 * h)

        for line in self.lines:
            if far(line.p1) or far(line.p2):
                raise ValueError(
                    f"view {self.id}: line {line.id}: an end point lies far outside the "
                    f"{w}x{h} image"
                )
        for contour in self.contours:
            if any(far(p) for p in contour.points):
                raise ValueError(
                    f"view {self.id}: contour {contour.id}: a point lies far outside the "
                    f"{w}x{h} image"
                )

    def region(self, region_id: int) -> Region:
        """The region with id `region_id` (KeyError if there is none)."""
        for r in self.regions:
            if r.id == region_id:
                return r
        raise KeyError(region_id)


class Evidence(_Frozen):
    """The content of evidence.json: the measurements of every processed view."""

    format: Literal["aida-kb-evidence"] = EVIDENCE_FORMAT
    version: Literal[1] = EVIDENCE_VERSION
    units: Literal["m", "unknown"] = Field(
        default="m",
        description="m: lengths are metres; unknown: the scene's scale is unknown (structure "
        "from motion) and every length is in its calibration's arbitrary units (up to scale): "
        "a knowledge range in metres does not apply to them",
    )
    scene: str = Field(default="", description="scene name (scene.yaml), free text")
    world: str = "left camera of view 00; OpenCV axes (x right, y down, z forward)"
    views: list[ViewEvidence] = Field(min_length=1)

    @model_validator(mode="after")
    def _unique_views(self) -> Evidence:
        ids = [v.id for v in self.views]
        if len(set(ids)) != len(ids):
            raise ValueError("view ids must be unique")
        return self

    def view(self, view_id: str) -> ViewEvidence:
        """The view with id `view_id` (KeyError if there is none)."""
        for v in self.views:
            if v.id == view_id:
                return v
        raise KeyError(view_id)


def read_evidence(path: str | os.PathLike[str]) -> Evidence:
    """Load and validate evidence.json; FormatError names the file and the field."""
    return read_json_model(path, Evidence)


def write_evidence(path: str | os.PathLike[str], evidence: Evidence) -> None:
    """Write evidence.json atomically."""
    write_json_model(path, evidence)


def evidence_schema_text() -> str:
    """The JSON Schema of evidence.json, as stored in docs/schemas/evidence.schema.json."""
    schema = Evidence.model_json_schema()
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["$id"] = "https://aida-kb.invalid/schemas/evidence.schema.json"
    return json.dumps(schema, indent=2, sort_keys=True) + "\n"
