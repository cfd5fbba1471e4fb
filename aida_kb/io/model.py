"""The reconstructed model on disk: ``model.json`` (pydantic) and ``model.obj`` (a closed mesh).

Coordinates are world coordinates in metres: the frame of the left camera of view 00 in
OpenCV's convention (x right, y down, z forward). A plane is ``n·x = d`` with the unit
normal ``n`` pointing out of the solid.
"""

from __future__ import annotations

import math
import os
from typing import TYPE_CHECKING, Annotated, Literal

from pydantic import AfterValidator, BeforeValidator, Field, model_validator

from aida_kb.io.atomic import write_text_atomic
from aida_kb.io.jsonio import FrozenModel, read_json_model, write_json_model

if TYPE_CHECKING:
    import numpy as np
    import numpy.typing as npt

# Larger magnitudes are certainly wrong (metres, pixels, counts) and would overflow when squared.
MAX_MAGNITUDE = 1e12


def number_only(value: object) -> object:
    """Refuse JSON strings and booleans where a number is wanted (pydantic would convert them)."""
    if isinstance(value, (str, bool)):
        raise ValueError(f"expected a number, got {type(value).__name__} {value!r}")
    return value


def _finite_any(value: float) -> float:
    if not math.isfinite(value):
        raise ValueError("must be a finite number (NaN and infinity are not allowed)")
    return value


def _finite(value: float) -> float:
    _finite_any(value)
    if abs(value) > MAX_MAGNITUDE:
        raise ValueError(f"magnitude {value:.3g} is beyond {MAX_MAGNITUDE:.0e}")
    return value


ViewId = Annotated[
    str,
    Field(
        pattern=r"^[A-Za-z0-9][A-Za-z0-9_.-]*$",
        max_length=64,
        description="view id: letters, digits, '_', '.', '-' (it names output files)",
    ),
]
"""A view id such as ``00``; safe as a part of a file name (no path separators)."""

# A part's vertices lie on its plane to this (metres per metre of distance from the origin):
# a vertex is where planes meet, so only rounding separates it from the plane.
ON_PLANE_TOLERANCE_M = 1e-4

Finite = Annotated[float, BeforeValidator(number_only), AfterValidator(_finite)]
"""A finite number (not NaN, not infinite, not absurdly large; not a string or boolean)."""
FiniteCost = Annotated[float, BeforeValidator(number_only), AfterValidator(_finite_any)]
"""A finite number of any size (a normalised cost of a far-off hypothesis can be huge)."""
Int = Annotated[int, BeforeValidator(number_only)]
"""A whole number (not a string or boolean)."""
Vec3 = tuple[Finite, Finite, Finite]
Mat3 = tuple[Vec3, Vec3, Vec3]


def check_camera(K: Mat3, R: Mat3) -> None:
    """Raise ValueError unless K is a camera matrix and R a rotation (orthonormal, det +1)."""
    if K[0][0] <= 0 or K[1][1] <= 0 or K[1][0] != 0 or tuple(K[2]) != (0.0, 0.0, 1.0):
        raise ValueError("K must be [[fx, s, cx], [0, fy, cy], [0, 0, 1]] with fx, fy > 0")
    for i in range(3):
        for j in range(3):
            dot = sum(R[i][k] * R[j][k] for k in range(3))
            if abs(dot - (1.0 if i == j else 0.0)) > 1e-6:
                raise ValueError("R must be a rotation matrix (orthonormal)")
    det = (
        R[0][0] * (R[1][1] * R[2][2] - R[1][2] * R[2][1])
        - R[0][1] * (R[1][0] * R[2][2] - R[1][2] * R[2][0])
        + R[0][2] * (R[1][0] * R[2][1] - R[1][1] * R[2][0])
    )
    if det < 0:
        raise ValueError("R must be a rotation matrix (determinant +1, not a reflection)")


def camera_centre(R: Mat3, t: Vec3) -> Vec3:
    """The camera centre C = -Rᵀ·t (metres, frame of R and t) of x_cam = R·x + t."""
    return (
        -(R[0][0] * t[0] + R[1][0] * t[1] + R[2][0] * t[2]),
        -(R[0][1] * t[0] + R[1][1] * t[1] + R[2][1] * t[2]),
        -(R[0][2] * t[0] + R[1][2] * t[1] + R[2][2] * t[2]),
    )


_Frozen = FrozenModel


class Cahv(_Frozen):
    """A CAHV camera: centre C (m), unit axis A, H and V (pixels per unit tangent)."""

    C: Vec3
    A: Vec3
    H: Vec3
    V: Vec3


def _non_negative(value: float) -> float:
    if value < 0:
        raise ValueError("a standard deviation cannot be negative")
    return value


Deviation = Annotated[
    float, BeforeValidator(number_only), AfterValidator(_finite), AfterValidator(_non_negative)
]
"""One standard deviation: finite and not negative."""


class PartSd(_Frozen):
    """How well the adjustment fixes a part: one standard deviation of its plane, from the
    adjustment's covariance at the scatter of its measurements (`interpret.uncertainty`);
    null where the evidence and the knowledge leave it open."""

    normal_deg: Deviation | None = Field(description="the normal's direction, degrees")
    offset_m: Deviation | None = Field(
        description="the plane's offset at the part's centre, metres (the model's units)"
    )


class CameraSd(_Frozen):
    """How well the adjustment fixes a view's camera (one standard deviation; null: open)."""

    rotation_deg: Deviation | None = Field(description="its rotation, degrees")
    centre_m: Deviation | None = Field(description="its centre, metres (the model's units)")
    measurements: Literal["segments", "image edges", "ground texture"] = Field(
        default="segments",
        description="whose covariance: the line detector's segments on the model's edges (the "
        "verdict's adjustment), the model's edges fitted along the images (the "
        "reconstruction's last adjustment, `interpret.multiview.IMAGE_ROUNDS`) or those and "
        "the ground's texture seen again by the view (`interpret.groundtexture`)",
    )


class ModelCamera(_Frozen):
    """One view's left camera: x_cam = R·x_world + t (R_cam_world, t_cam_world in metres)."""

    view: ViewId
    K: Mat3 = Field(description="intrinsic matrix, pixels")
    R: Mat3 = Field(description="rotation world -> camera")
    t: Vec3 = Field(description="translation world -> camera, metres")
    image_width: Int = Field(gt=0)
    image_height: Int = Field(gt=0)
    cahv: Cahv | None = None
    sd: CameraSd | None = Field(
        default=None,
        description="how well the adjustment fixes this camera; null for the first view "
        "(it sets the world frame) or a result not judged",
    )
    undecided_turns_deg: tuple[float, ...] = Field(
        default=(),
        description="turns about the vertical (degrees from the camera the view was registered "
        "against) that nothing in the view's evidence rules out as well as the pose taken: "
        "poses whose edges fit about as well and which the images do not correlate clearly "
        "worse (a symmetric model's twins); non-empty: the registration did not decide the "
        "pose, and the verdict doubts the view",
    )

    @model_validator(mode="after")
    def _check(self) -> ModelCamera:
        try:
            check_camera(self.K, self.R)
        except ValueError as exc:
            raise ValueError(f"camera of view {self.view!r}: {exc}") from None
        return self


class ModelPart(_Frozen):
    """One planar part: its role path, concept, plane and closed polygon (world, metres)."""

    role: str = Field(description="role path from the scene object, e.g. 'body.roof.front'")
    concept: str = Field(description="the knowledge-base concept, e.g. 'RoofPlane'")
    normal: Vec3 = Field(description="unit normal, out of the solid")
    offset_m: Finite = Field(description="d in n·x = d, metres")
    polygon: list[Vec3] = Field(min_length=3, description="vertices in order, world frame, m")
    sd: PartSd | None = Field(default=None, description="how well the adjustment fixes it")

    @model_validator(mode="after")
    def _unit_normal(self) -> ModelPart:
        n = self.normal
        norm = math.sqrt(sum(c * c for c in n))
        if abs(norm - 1.0) > 1e-6:
            raise ValueError(f"normal of part {self.role!r} has length {norm:.6g}, not 1")
        for k, v in enumerate(self.polygon):
            off = n[0] * v[0] + n[1] * v[1] + n[2] * v[2] - self.offset_m
            if abs(off) > ON_PLANE_TOLERANCE_M * max(1.0, math.sqrt(sum(c * c for c in v))):
                raise ValueError(
                    f"part {self.role!r}: polygon vertex {k} lies {off:.3g} m off the part's plane"
                )
        # Newell's vector: twice the area vector of the (planar) polygon
        area2 = [0.0, 0.0, 0.0]
        for a, b in zip(self.polygon, self.polygon[1:] + self.polygon[:1], strict=True):
            area2[0] += (a[1] - b[1]) * (a[2] + b[2])
            area2[1] += (a[2] - b[2]) * (a[0] + b[0])
            area2[2] += (a[0] - b[0]) * (a[1] + b[1])
        if math.sqrt(sum(c * c for c in area2)) <= 2e-12:
            raise ValueError(f"part {self.role!r}: polygon has zero area")
        return self


def moved_part(
    part: ModelPart, R: npt.NDArray[np.float64], t: npt.NDArray[np.float64]
) -> ModelPart:
    """`part` in the frame ``x' = R x + t`` (R (3, 3) a rotation, t (3,) metres): its normal
    turned, its polygon moved and its offset ``d' = d + n'·t``; its deviations kept (a rigid
    motion does not change them)."""
    import numpy as np  # not at import: `aida-kb lint` starts without numpy

    n = R @ np.asarray(part.normal, dtype=np.float64)
    n = n / float(np.linalg.norm(n))
    polygon = np.asarray(part.polygon, dtype=np.float64) @ R.T + t
    return part.model_copy(
        update={
            "normal": (float(n[0]), float(n[1]), float(n[2])),
            "offset_m": float(part.offset_m + n @ t),
            "polygon": [(float(v[0]), float(v[1]), float(v[2])) for v in polygon],
        }
    )


class ModelObject(_Frozen):
    """One object of a scene of several (``houses[0]``): its parts are those under its role."""

    role: str = Field(min_length=1, description="its role path in the scene object")
    concept: str = Field(description="its scene-layer concept")
    verdict: Literal["verified", "doubtful"] = Field(description="its own verdict")


class ReconstructedModel(_Frozen):
    """A reconstructed scene: parts (a closed polyhedron per object) and the view cameras."""

    format: Literal["aida-kb/model"] = "aida-kb/model"
    version: Literal[1] = 1
    units: Literal["m", "unknown"] = Field(
        default="m",
        description="'m': metres; 'unknown': the scene's scale is unknown (structure from "
        "motion) and every length is in its calibration's arbitrary units (up to scale)",
    )
    frame: str = "world = left camera of view 00; OpenCV axes (x right, y down, z forward)"
    parts: list[ModelPart]
    cameras: list[ModelCamera] = Field(default_factory=list)
    up: Vec3 | None = Field(
        default=None,
        description="the estimated vertical (unit, world frame, pointing up); None: unknown",
    )
    objects: list[ModelObject] = Field(
        default_factory=list,
        description="a scene of several objects: each object, its parts those under its role; "
        "empty: the model is one object",
    )

    @model_validator(mode="after")
    def _unique(self) -> ReconstructedModel:
        if self.up is not None and abs(math.sqrt(sum(c * c for c in self.up)) - 1.0) > 1e-6:
            raise ValueError("up must be a unit vector")
        for what, keys in (
            ("part roles", [p.role for p in self.parts]),
            ("camera views", [c.view for c in self.cameras]),
        ):
            repeated = sorted({k for k in keys if keys.count(k) > 1})
            if repeated:
                raise ValueError(f"{what} must be unique; repeated: {', '.join(repeated)}")
        return self


def read_model(path: str | os.PathLike[str]) -> ReconstructedModel:
    """Load ``model.json``; FormatError names the file and field on bad input."""
    return read_json_model(path, ReconstructedModel)


def write_model(path: str | os.PathLike[str], model: ReconstructedModel) -> None:
    """Write ``model.json`` atomically."""
    write_json_model(path, model)


def obj_text(model: ReconstructedModel, weld_tolerance_m: float = 1e-6) -> str:
    """The model as Wavefront OBJ text: one group per part, vertices welded across parts.

    Vertices closer than `weld_tolerance_m` are merged, so that faces of a closed
    polyhedron share their edges in the mesh. Polygons are written as n-gons.
    """
    vertices: list[Vec3] = []
    index: dict[tuple[int, int, int], int] = {}
    lines = ["# aida-kb reconstructed model; units: metres; " + model.frame]
    faces: list[str] = []
    for part in model.parts:
        ids: list[int] = []
        for vertex in part.polygon:
            key = (
                round(vertex[0] / weld_tolerance_m),
                round(vertex[1] / weld_tolerance_m),
                round(vertex[2] / weld_tolerance_m),
            )
            if key not in index:
                vertices.append(vertex)
                index[key] = len(vertices)
            ids.append(index[key])
        faces.append(f"g {part.role.replace(' ', '_')}")
        faces.append("f " + " ".join(str(i) for i in ids))
    lines.extend(f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in vertices)
    lines.extend(faces)
    return "\n".join(lines) + "\n"


def write_obj(path: str | os.PathLike[str], model: ReconstructedModel) -> None:
    """Write the model's mesh as ``model.obj`` atomically."""
    write_text_atomic(path, obj_text(model))
