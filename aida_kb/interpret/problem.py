"""The verification problem of a hypothesis and the outcome of solving it.

A hypothesis is verified by one weighted least-squares adjustment: the planes of its parts
(seen ones initialised from their regions, inserted ones from the knowledge), the internal
constraints of its concepts, and the measurement constraints that tie it to the evidence
(position of each bound region, eq. 4; edge of each matched line segment, eq. 5). Parts of
an already verified level are passed as fixed (hierarchical refinement, paper §5).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from aida_kb.interpret.edges import EdgeMatch
from aida_kb.interpret.knowledge import OwnedSpec
from aida_kb.interpret.observe import CameraView, RegionView

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class PlaneInit:
    """A part's plane before adjustment: unit outward normal (3,), offset d (n·x = d), metres."""

    role: str
    concept: str
    normal: FloatArray
    offset_m: float
    fixed: bool = False


@dataclass(frozen=True)
class PositionMeasure:
    """Position constraint (eq. 4): the region's plane fit against the part's plane."""

    role: str
    region: RegionView
    camera: CameraView  # the camera that saw the region
    spec: Any  # the Region concept's position ConstraintSpec
    owner: str  # role path of the region instance


@dataclass(frozen=True)
class EdgeMeasure:
    """Edge constraint (eq. 5): the edge of two parts on an image line segment."""

    match: EdgeMatch
    camera: CameraView
    spec: Any  # the edge ConstraintSpec (Contour's, or the owning concept's measure)
    owner: str


@dataclass(frozen=True)
class Problem:
    """Everything one adjustment needs."""

    planes: tuple[PlaneInit, ...]
    internal: tuple[OwnedSpec, ...]
    positions: tuple[PositionMeasure, ...]
    edges: tuple[EdgeMeasure, ...]


@dataclass(frozen=True)
class Residual:
    """One constraint after adjustment (see `aida_kb.interpret.result.ConstraintResidual`)."""

    label: str
    kind: str
    concept: str
    owner: str
    parts: tuple[str, ...]
    residual: float
    unit: str
    sigma: float | None
    normalised: float
    reject_above: float | None
    rejected: bool


@dataclass(frozen=True)
class Outcome:
    """The adjusted planes, the residual of every constraint and the total normalised cost."""

    planes: dict[str, tuple[FloatArray, float]]
    residuals: tuple[Residual, ...]
    cost: float  # mean squared normalised residual over all constraints
    notes: tuple[str, ...] = field(default=())

    def worst_rejected(self) -> Residual | None:
        """The rejected constraint with the highest normalised cost, or None."""
        bad = [r for r in self.residuals if r.rejected]
        return max(bad, key=lambda r: r.normalised) if bad else None


Solve = Callable[[Problem], Outcome]
