"""Four planes through one point: the fourth plane's signed distance from the point where the
first three meet, metres.

Where more than three faces of a solid meet (the eaves corner of a hip roof: two walls and two
slopes; a pyramid's apex), their planes must pass through one point, or the faces do not close
the solid (`aida_kb.interpret.closure.check_concurrent`). Three planes always meet in a point
``X = A⁻¹ d`` (``A`` the rows ``n_a, n_b, n_c``); the residual is ``n_d·X - d_d``. Its
derivatives: by ``(n_d, d_d)`` ``(X, -1)``; by ``(n_i, d_i)``, i one of the first three,
``(-w_i X, w_i)`` with ``w = A⁻ᵀ n_d``. The first three planes must not share a line: the
caller takes the best-conditioned three of a vertex's four (`aida_kb.interpret.joint`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import ClassVar

import numpy as np

from aida_kb.constraints.kinds.base import BlockData, Evaluated, FloatArray, IntArray, Kind
from aida_kb.geometry.camera import PinholeCamera


class Concurrent(Kind):
    """The fourth plane through the point of the first three."""

    name: ClassVar[str] = "concurrent"
    arity: ClassVar[int] = 4
    residual_size: ClassVar[int] = 1
    dof: ClassVar[int] = 1
    summary: ClassVar[str] = "distance of plane d from the point of planes a, b, c, m"

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
        """r (M, 1) metres; J (M, 1, 4, 4) by each plane's ``(n, d)``; no camera."""
        n = normals[idx]  # (M, 4, 3)
        d = offsets[idx]  # (M, 4)
        A = n[:, :3]
        X = np.linalg.solve(A, d[:, :3, None])[..., 0]  # (M, 3): the first three's point
        w = np.linalg.solve(np.transpose(A, (0, 2, 1)), n[:, 3, :, None])[..., 0]  # A^T w = n_d
        r = np.einsum("mi,mi->m", n[:, 3], X) - d[:, 3]
        J = np.zeros((len(idx), 1, 4, 4))
        J[:, 0, :3, :3] = -w[:, :, None] * X[:, None, :]
        J[:, 0, :3, 3] = w
        J[:, 0, 3, :3] = X
        J[:, 0, 3, 3] = -1.0
        return r[:, None], J, None


CONCURRENT = Concurrent()
