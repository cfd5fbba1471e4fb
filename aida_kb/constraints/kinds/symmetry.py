"""Symmetry (paper eq. 3): ``angle(a, b) - angle(c, d)``, radians."""

from __future__ import annotations

from collections.abc import Sequence
from typing import ClassVar

from aida_kb.constraints import kernels
from aida_kb.constraints.kinds.base import BlockData, Evaluated, FloatArray, IntArray, Kind
from aida_kb.geometry.camera import PinholeCamera


class Symmetry(Kind):
    """Two pairs of planes meeting at the same angle (paper eq. 3)."""

    name: ClassVar[str] = "symmetry"
    arity: ClassVar[int] = 4
    residual_size: ClassVar[int] = 1
    dof: ClassVar[int] = 1
    summary: ClassVar[str] = "angle(a, b) - angle(c, d), rad (eq. 3)"

    def evaluate(
        self,
        normals: FloatArray,
        offsets: FloatArray,
        cameras: Sequence[PinholeCamera],
        idx: IntArray,
        data: BlockData,
    ) -> Evaluated:
        """r (M, 1) rad, J (M, 1, 4, 4)."""
        r, J = kernels.symmetry_kernel(normals, idx)
        return r, J, None


SYMMETRY = Symmetry()
