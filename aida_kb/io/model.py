"""The reconstructed model on disk: ``model.json`` (pydantic) and ``model.obj`` (a closed mesh).

Coordinates are world coordinates in metres: the frame of the left camera of view 00 in
OpenCV's convention (x right, y down, z forward). A plane is ``n·x = d`` with the unit
normal ``n`` pointing out of the solid.
"""

from __future__ import annotations

import math
import os
from typing import Annotated, Literal

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, model_validator

from aida_kb.io.atomic import write_text_atomic
from aida_kb.io.jsonio import read_json_model, write_json_model


def _finite(value: float) -> float:
    if not math.isfinite(value):
        raise ValueError("must be a finite number (NaN and infinity are not allowed)")
    return value


Finite = Annotated[float, AfterValidator(_finite)]
Vec3 = tuple[Finite, Finite, Finite]
Mat3 = tuple[Vec3, Vec3, Vec3]


class _Frozen(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


class Cahv(_Frozen):
    """A CAHV camera: centre C (m), unit axis A, H and V (pixels per unit tangent)."""

    C: Vec3
    A: Vec3
    H: Vec3
    V: Vec3


class ModelCamera(_Frozen):
    """One view's left camera: x_cam = R·x_world + t (R_cam_world, t_cam_world in metres)."""

    view: str = Field(description="view id, e.g. '00'")
    K: Mat3 = Field(description="intrinsic matrix, pixels")
    R: Mat3 = Field(description="rotation world -> camera")
    t: Vec3 = Field(description="translation world -> camera, metres")
    image_width: int = Field(gt=0)
    image_height: int = Field(gt=0)
    cahv: Cahv | None = None


class ModelPart(_Frozen):
    """One planar part: its role path, concept, plane and closed polygon (world, metres)."""

    role: str = Field(description="role path from the scene object, e.g. 'body.roof.front'")
    concept: str = Field(description="the knowledge-base concept, e.g. 'RoofPlane'")
    normal: Vec3 = Field(description="unit normal, out of the solid")
    offset_m: Finite = Field(description="d in n·x = d, metres")
    polygon: list[Vec3] = Field(min_length=3, description="vertices in order, world frame, m")

    @model_validator(mode="after")
    def _unit_normal(self) -> ModelPart:
        norm = math.sqrt(sum(c * c for c in self.normal))
        if abs(norm - 1.0) > 1e-6:
            raise ValueError(f"normal of part {self.role!r} has length {norm:.6g}, not 1")
        return self


class ReconstructedModel(_Frozen):
    """A reconstructed scene: parts (a closed polyhedron per object) and the view cameras."""

    format: Literal["aida-kb/model"] = "aida-kb/model"
    version: Literal[1] = 1
    units: Literal["m"] = "m"
    frame: str = "world = left camera of view 00; OpenCV axes (x right, y down, z forward)"
    parts: list[ModelPart]
    cameras: list[ModelCamera] = Field(default_factory=list)


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
