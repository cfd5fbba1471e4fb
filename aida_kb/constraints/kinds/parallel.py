"""Parallel planes (paper eq. 2): the rotation vector from ``n_a`` to ``s·n_b``, radians.

``|r|`` is the angle between the planes; the sign ``s`` is +1 (same facing), -1 (opposite) or
chosen so that the normals agree (0). An angle constraint with a target of 0 or pi is
evaluated as this kind: meeting at pi means the normals agree (s = +1), at 0 opposite.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import ClassVar

import numpy as np

from aida_kb.constraints import kernels
from aida_kb.constraints.factor import Constraint
from aida_kb.constraints.kinds.base import BlockData, NormalsKind
from aida_kb.errors import SolveError


class Parallel(NormalsKind):
    """Two parallel planes (paper eq. 2)."""

    name: ClassVar[str] = "parallel"
    arity: ClassVar[int] = 2
    residual_size: ClassVar[int] = 3
    dof: ClassVar[int] = 2
    summary: ClassVar[str] = "rotation vector from n_a to ±n_b, rad (eq. 2)"
    data_keys: ClassVar[tuple[str, ...]] = ("sign",)

    def validate(self, c: Constraint, where: str, n_cameras: int) -> None:
        """The sign is -1, 0 or 1."""
        if c.sign not in (-1, 0, 1):
            raise SolveError(f"{where}: sign must be -1, 0 or 1, got {c.sign!r}")

    def pack(self, cs: Sequence[Constraint]) -> BlockData:
        """``sign`` (M,): +-1 fixed, 0 free (an angle's target of pi gives +1, of 0 gives -1)."""
        signs = [c.sign if c.value is None else (1 if c.value > math.pi / 2 else -1) for c in cs]
        return {"sign": np.array(signs, dtype=np.float64)}


PARALLEL = Parallel(kernels.parallel_kernel)
