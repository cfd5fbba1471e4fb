"""Parallel edges (paper §4.3): the rotation vector between edge(a, b) and edge(c, d), rad.

An edge's direction is ``n_a × n_b``; its sign is irrelevant (lines).
"""

from __future__ import annotations

from typing import ClassVar

from aida_kb.constraints import kernels
from aida_kb.constraints.kinds.base import NormalsKind


class ParallelEdge(NormalsKind):
    """The edge of two planes parallel to the edge of two others."""

    name: ClassVar[str] = "parallel_edge"
    arity: ClassVar[int] = 4
    residual_size: ClassVar[int] = 3
    dof: ClassVar[int] = 2
    summary: ClassVar[str] = "rotation vector between edge(a, b) and edge(c, d), rad (§4.3)"


PARALLEL_EDGE = ParallelEdge(kernels.parallel_edge_kernel)
