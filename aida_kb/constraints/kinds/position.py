"""Position of a plane against its region (paper eq. 4), world frame.

Four residual components: the rotation vector from the region's fitted normal to the plane's
(scaled to the constraint's unit) and the move of the region's centre along its normal when
projected onto the plane (`aida_kb.constraints.kernels.position_kernel`). In unit "px" the
angle counts ``tilt_px_per_rad`` pixels per radian and the shift ``shift_px_per_m`` pixels per
metre; otherwise radians and ``sqrt(w_n)`` times metres. The multiplicity is the region's
certainty ``w_c``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import ClassVar

import numpy as np

from aida_kb.constraints import kernels
from aida_kb.constraints.factor import Constraint, PositionData
from aida_kb.constraints.kinds.base import (
    BlockData,
    Evaluated,
    Evidence,
    FloatArray,
    IntArray,
    Kind,
    finite_positive,
    unit_vector,
    vector,
)
from aida_kb.errors import SolveError
from aida_kb.geometry.camera import PinholeCamera


def _data(c: Constraint) -> PositionData:
    assert c.position is not None
    return c.position


class Position(Kind):
    """A plane against its region's plane fit (paper eq. 4)."""

    name: ClassVar[str] = "position"
    arity: ClassVar[int] = 1
    residual_size: ClassVar[int] = 4
    dof: ClassVar[int] = 3
    measurement: ClassVar[bool] = True
    evidence: ClassVar[Evidence] = "plane_fit"
    summary: ClassVar[str] = "tilt and shift of a plane from its region's fit, rad+m or px (eq. 4)"

    def multiplicity(self, c: Constraint) -> float:
        """The region's summed certainty ``w_c``."""
        return float(_data(c).w_c)

    def validate(self, c: Constraint, where: str, n_cameras: int) -> None:
        """The region evidence is there, finite, and has the scales its unit needs."""
        pos = c.position
        if pos is None:
            raise SolveError(f"{where}: a position constraint needs its region evidence")
        unit_vector(where, "n_init", pos.n_init)
        vector(where, "c_init", pos.c_init, 3)
        finite_positive(where, "w_c", pos.w_c, optional=False)
        finite_positive(where, "w_n", pos.w_n, optional=False)
        finite_positive(where, "shift_px_per_m", pos.shift_px_per_m)
        finite_positive(where, "tilt_px_per_rad", pos.tilt_px_per_rad)
        if c.unit == "px":
            if pos.shift_px_per_m is None or pos.tilt_px_per_rad is None:
                finite_positive(where, "px_per_m (unit px)", pos.px_per_m, optional=False)
            if pos.tilt_px_per_rad is None:
                finite_positive(where, "radius_m (unit px)", pos.radius_m, optional=False)

    def pack(self, cs: Sequence[Constraint]) -> BlockData:
        """``n_init``, ``c_init`` (M, 3); ``scale_angle``, ``scale_shift`` (M,)."""
        pos = [_data(c) for c in cs]
        px = np.array([c.unit == "px" for c in cs], dtype=bool)
        ppm = np.array([p.px_per_m or 1.0 for p in pos])
        rad = np.array([p.radius_m or 1.0 for p in pos])
        shift = np.array([p.shift_px_per_m or q for p, q in zip(pos, ppm, strict=True)])
        tilt = np.array([p.tilt_px_per_rad or q * r for p, q, r in zip(pos, ppm, rad, strict=True)])
        w_n = np.array([p.w_n for p in pos])
        return {
            "n_init": np.array([p.n_init for p in pos], dtype=np.float64).reshape(-1, 3),
            "c_init": np.array([p.c_init for p in pos], dtype=np.float64).reshape(-1, 3),
            "scale_angle": np.where(px, tilt, 1.0),
            "scale_shift": np.where(px, shift, np.sqrt(w_n)),
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
        """r (M, 4), J (M, 4, 1, 4)."""
        r, J = kernels.position_kernel(
            normals,
            offsets,
            idx,
            data["n_init"],
            data["c_init"],
            data["scale_angle"],
            data["scale_shift"],
        )
        return r, J, None


POSITION = Position()
