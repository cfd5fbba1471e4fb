"""Symmetry (paper eq. 3): ``angle(a, b) - angle(c, d)``, radians."""

from __future__ import annotations

from typing import ClassVar

from aida_kb.constraints import kernels
from aida_kb.constraints.kinds.base import NormalsKind


class Symmetry(NormalsKind):
    """Two pairs of planes meeting at the same angle (paper eq. 3)."""

    name: ClassVar[str] = "symmetry"
    arity: ClassVar[int] = 4
    residual_size: ClassVar[int] = 1
    dof: ClassVar[int] = 1
    summary: ClassVar[str] = "angle(a, b) - angle(c, d), rad (eq. 3)"


SYMMETRY = Symmetry(kernels.symmetry_kernel)
