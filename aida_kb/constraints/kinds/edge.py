"""The edge constraint (paper eq. 5): the edge of two planes against an image segment.

Residuals per end point of the segment: its distance from the plane of sight in metres (unit
"m" or ""), or the image distance of the edge's projection from the segment's line in pixels
(unit "px") — `aida_kb.constraints.edge.edge_kernel`, with Jacobians by both planes and the
camera pose. A segment's two end-point residuals are correlated when the segment is a fitted
line; a ``sqrt_information`` (2, 2) whitens them (`segment_sqrt_information`). A measurement
with a one-sided bias (`EdgeData.lean`) has the residuals of the biased side scaled down before
whitening (a split normal per end point).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import ClassVar

import numpy as np

from aida_kb.constraints.edge import edge_kernel
from aida_kb.constraints.factor import Constraint, EdgeData
from aida_kb.constraints.kinds.base import (
    BlockData,
    Evaluated,
    Evidence,
    FloatArray,
    IntArray,
    Kind,
    check_camera,
    vector,
)
from aida_kb.errors import SolveError
from aida_kb.geometry.camera import PinholeCamera

MIN_FIT_POINTS = 4.0
"""A segment shorter than this many pixels still counts as a line fitted to this many edge
points (`segment_sqrt_information`): a 1-pixel segment is not known to a tenth of a pixel."""


def _data(c: Constraint) -> EdgeData:
    assert c.edge is not None
    return c.edge


def segment_sqrt_information(
    p1_px: tuple[float, float], p2_px: tuple[float, float], point_sigma_px: float
) -> tuple[tuple[float, float], tuple[float, float]]:
    """The (2, 2) square-root information of a fitted segment's two end-point residuals.

    A line fitted to n edge points (one per pixel of its length) of noise ``point_sigma_px``
    across it has its centre known to ``sigma/sqrt(n)`` and its end points' mean and half
    difference uncorrelated with standard deviations ``sigma/sqrt(n)`` and
    ``sigma·sqrt(3/n)``: the residuals (r1, r2) map to ``((r1 + r2)/2 / sd_mean,
    (r1 - r2)/2 / sd_diff)``.
    """
    n = max(float(np.hypot(p2_px[0] - p1_px[0], p2_px[1] - p1_px[1])), MIN_FIT_POINTS)
    sd_mean = point_sigma_px / np.sqrt(n)
    sd_diff = point_sigma_px * np.sqrt(3.0 / n)
    a, b = float(0.5 / sd_mean), float(0.5 / sd_diff)
    return ((a, a), (b, -b))


class Edge(Kind):
    """A model edge against an image segment (paper eq. 5)."""

    name: ClassVar[str] = "edge"
    arity: ClassVar[int] = 2
    residual_size: ClassVar[int] = 2
    dof: ClassVar[int] = 2
    measurement: ClassVar[bool] = True
    uses_camera: ClassVar[bool] = True
    evidence: ClassVar[Evidence] = "segment"
    summary: ClassVar[str] = "end points' distance from the edge, m or px (eq. 5)"

    def camera(self, c: Constraint) -> int | None:
        """The camera that saw the segment."""
        return int(_data(c).camera)

    def validate(self, c: Constraint, where: str, n_cameras: int) -> None:
        """The segment is there, finite, of non-zero length, seen by a known camera."""
        e = c.edge
        if e is None:
            raise SolveError(f"{where}: an edge constraint needs its image segment")
        check_camera(where, e.camera, n_cameras)
        if e.lean not in (-1, 0, 1):
            raise SolveError(f"{where}: an edge's lean must be -1, 0 or 1, not {e.lean!r}")
        if not 0.0 < e.lean_scale <= 1.0:
            raise SolveError(f"{where}: an edge's lean scale must lie in (0, 1]: {e.lean_scale}")
        p1 = vector(where, "p1_px", e.p1_px, 2)
        p2 = vector(where, "p2_px", e.p2_px, 2)
        if float(np.linalg.norm(p2 - p1)) < 1e-6:
            raise SolveError(f"{where}: the image segment has zero length")

    def pack(self, cs: Sequence[Constraint]) -> BlockData:
        """``camera`` (M,) int; ``p1``, ``p2`` (M, 2) px; ``px`` (M,) bool; ``lean`` (M,)
        -1, 0 or 1 and ``lean_scale`` (M,) (`EdgeData`)."""
        eds = [_data(c) for c in cs]
        return {
            "camera": np.array([e.camera for e in eds], dtype=np.intp),
            "p1": np.array([e.p1_px for e in eds], dtype=np.float64).reshape(-1, 2),
            "p2": np.array([e.p2_px for e in eds], dtype=np.float64).reshape(-1, 2),
            "px": np.array([c.unit == "px" for c in cs], dtype=bool),
            "lean": np.array([e.lean for e in eds], dtype=np.float64),
            "lean_scale": np.array([e.lean_scale for e in eds], dtype=np.float64),
        }

    def evaluate(
        self,
        normals: FloatArray,
        offsets: FloatArray,
        cameras: Sequence[PinholeCamera],
        idx: IntArray,
        data: BlockData,
        *,
        camera_jacobian: bool = True,
    ) -> Evaluated:
        """r (M, 2), J (M, 2, 2, 4), J_camera (M, 2, 6) (None unless ``camera_jacobian``);
        the end-point residuals whose sign is a constraint's ``lean`` scaled by its
        ``lean_scale``, with their Jacobians."""
        r, J, Jc = edge_kernel(
            normals,
            offsets,
            idx,
            cameras,
            data["camera"],
            data["p1"],
            data["p2"],
            data["px"],
            camera_jacobian=camera_jacobian,
        )
        lean = data["lean"][:, None]
        if not np.any(lean):
            return r, J, Jc
        scale = np.where(lean * r > 0.0, data["lean_scale"][:, None], 1.0)  # (M, 2)
        return (
            r * scale,
            J * scale[:, :, None, None],
            None if Jc is None else Jc * scale[:, :, None],
        )


EDGE = Edge()
