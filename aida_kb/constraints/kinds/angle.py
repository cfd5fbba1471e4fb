"""``angle(a, b) == value`` (paper eq. 1): residual ``angle(a, b) - value``, radians.

``angle(a, b)`` is the angle at which the planes meet inside the solid, ``pi - acos(n_a·n_b)``
(`aida_kb.constraints.kernels.meeting_angle`). A target of 0 or pi is evaluated as the
parallel kind, whose rotation-vector residual has a gradient where the angle's has none.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import ClassVar

import numpy as np

from aida_kb.constraints import kernels
from aida_kb.constraints.factor import Constraint
from aida_kb.constraints.kinds.base import BlockData, Kind, NormalsKind
from aida_kb.constraints.kinds.parallel import PARALLEL
from aida_kb.errors import SolveError

PARALLEL_EPS = 1e-6
"""An angle target this close (rad) to 0 or pi is evaluated as a parallel constraint: the
meeting angle's derivative vanishes there, the rotation vector's does not."""


class Angle(NormalsKind):
    """The angle at which two planes meet (paper eq. 1)."""

    name: ClassVar[str] = "angle"
    arity: ClassVar[int] = 2
    residual_size: ClassVar[int] = 1
    dof: ClassVar[int] = 1
    summary: ClassVar[str] = "angle(a, b) - value, rad (eq. 1)"
    data_keys: ClassVar[tuple[str, ...]] = ("value",)

    def block_kind(self, c: Constraint) -> Kind:
        """Parallel for a target at 0 or pi (see `PARALLEL_EPS`), else the angle kind."""
        assert c.value is not None
        if c.value < PARALLEL_EPS or c.value > math.pi - PARALLEL_EPS:
            return PARALLEL
        return self

    def validate(self, c: Constraint, where: str, n_cameras: int) -> None:
        """The target is a finite angle in [0, pi]."""
        if c.value is None or not math.isfinite(c.value) or not 0.0 <= c.value <= math.pi:
            raise SolveError(
                f"{where}: angle target must be a finite value in [0, pi] rad, got {c.value!r}"
            )

    def pack(self, cs: Sequence[Constraint]) -> BlockData:
        """``value`` (M,) rad."""
        return {"value": np.array([c.value for c in cs], dtype=np.float64)}


ANGLE = Angle(kernels.angle_kernel)
