"""One plane of two parts: the rotation vector from ``n_a`` to ``s·n_b`` (rad, as `parallel`)
and the offset ``d_a - s·d_b`` (m).

Two parts are one plane where two objects touch: a terrace's party wall is a wall of each
house, each house's copy facing into it (``s = -1``: opposite normals, ``n_a·x = d_a`` and
``-n_a·x = -d_a``). Its four residual components mix units (three rad, one m): a constraint
of this kind carries a ``sqrt_information`` that whitens them (its sigma would be one unit for
both).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import ClassVar

import numpy as np

from aida_kb.constraints import kernels
from aida_kb.constraints.factor import Constraint
from aida_kb.constraints.kinds.base import BlockData, Evaluated, FloatArray, IntArray, Kind
from aida_kb.errors import SolveError
from aida_kb.geometry.camera import PinholeCamera


class Coincident(Kind):
    """Two parts on one plane, facing alike (sign 1) or opposite (sign -1)."""

    name: ClassVar[str] = "coincident"
    arity: ClassVar[int] = 2
    residual_size: ClassVar[int] = 4
    dof: ClassVar[int] = 3
    summary: ClassVar[str] = "rotation vector from n_a to ±n_b, rad, and d_a ∓ d_b, m (one plane)"

    def validate(self, c: Constraint, where: str, n_cameras: int) -> None:
        """The sign is fixed (-1 or 1): which way the second part faces decides its offset's
        sign."""
        if c.sign not in (-1, 1):
            raise SolveError(f"{where}: a coincident constraint's sign must be -1 or 1")

    def pack(self, cs: Sequence[Constraint]) -> BlockData:
        """``sign`` (M,): +-1."""
        return {"sign": np.array([c.sign for c in cs], dtype=np.float64)}

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
        """r (M, 4): the parallel kernel's rotation vector (rad) and ``d_a - s·d_b`` (m);
        J (M, 4, 2, 4)."""
        sign = data["sign"]
        turn, J_turn = kernels.parallel_kernel(normals, idx, sign)
        shift = offsets[idx[:, 0]] - sign * offsets[idx[:, 1]]
        J = np.zeros((len(idx), 4, 2, 4))
        J[:, :3] = J_turn
        J[:, 3, 0, 3] = 1.0
        J[:, 3, 1, 3] = -sign
        r: FloatArray = np.concatenate([turn, shift[:, None]], axis=1)
        return r, J, None


COINCIDENT = Coincident()
