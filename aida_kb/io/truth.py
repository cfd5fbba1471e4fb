"""truth.json: what a synthetic scene really holds (its parts' planes and polygons, the ground,
the views' poses, the generator's parameters), for evaluation only -- the pipeline never reads
it (`aida_kb.io.scene.read_scene` with ``with_truth``; docs/formats.md)."""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
import numpy.typing as npt
from pydantic import Field, field_validator, model_validator

from aida_kb.io.jsonio import (
    FrozenModel,
)
from aida_kb.io.model import Finite, Mat3, Vec3, ViewId, check_camera

FloatArray = npt.NDArray[np.float64]


def _unit(n: Vec3, what: str) -> Vec3:
    norm = math.sqrt(sum(c * c for c in n))
    if abs(norm - 1.0) > 1e-6:
        raise ValueError(f"{what} must have unit length (has {norm:.6g})")
    return n


class PartTruth(FrozenModel):
    """One planar face of the synthetic object, in world coordinates (metres).

    `normal` is the unit normal pointing out of the solid; the plane is normal·x = d.
    `polygon` lists the face's vertices in order, counter-clockwise seen from outside.
    `label` is the id used for this part in views/NN/labels.png.
    """

    role: str = Field(min_length=1)
    concept: str = Field(min_length=1)
    label: int = Field(ge=1, le=65535)
    material: str = ""
    normal: Vec3
    d: Finite
    polygon: list[Vec3] = Field(min_length=3)

    @field_validator("normal")
    @classmethod
    def _unit_normal(cls, n: Vec3) -> Vec3:
        return _unit(n, "normal")


class GroundTruth(FrozenModel):
    """The ground plane (not a part of the object): normal·x = d, normal pointing up (out)."""

    label: int = Field(ge=1, le=65535)
    normal: Vec3
    d: Finite

    @field_validator("normal")
    @classmethod
    def _unit_normal(cls, n: Vec3) -> Vec3:
        return _unit(n, "normal")


class PoseTruth(FrozenModel):
    """The left camera of one view: x_cam = R·x_world + t, pixels = K·x_cam (before distortion)."""

    view: ViewId
    K: Mat3
    R: Mat3
    t: Vec3

    @model_validator(mode="after")
    def _camera(self) -> PoseTruth:
        check_camera(self.K, self.R)
        return self


class SceneTruth(FrozenModel):
    """The content of truth.json (synthetic scenes only)."""

    version: Literal[1] = 1
    object: str = Field(min_length=1, description="scene concept, e.g. House or ReferenceObject")
    parts: list[PartTruth]
    ground: GroundTruth | None = None
    views: list[PoseTruth]
    parameters: dict[str, float | str | bool] = Field(default_factory=dict)
    concepts: dict[str, str] = Field(
        default_factory=dict,
        description="role path -> the concept it must be specialised to (e.g. the roof's kind)",
    )

    def part(self, role: str) -> PartTruth:
        """The part with role path `role` (KeyError if there is none)."""
        for p in self.parts:
            if p.role == role:
                return p
        raise KeyError(role)

    def pose(self, view: str) -> PoseTruth:
        """The left-camera pose of view `view` (KeyError if there is none)."""
        for v in self.views:
            if v.view == view:
                return v
        raise KeyError(view)
