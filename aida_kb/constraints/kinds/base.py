"""What a constraint kind is: the interface every kind of the registry implements.

A kind (Ceres' ``CostFunction`` with its parameter-block sizes) knows

* ``arity`` — how many planes it relates, and ``uses_camera`` — whether it looks through one
  camera (whose pose may be an unknown);
* ``residual_size`` — the number of residual components k of its kernel, and ``dof`` — the
  degrees of freedom of its normalised cost (its chi-square quantile is the default threshold);
* ``measurement`` — whether it measures evidence (then the solve's robust loss applies);
* ``validate`` — the checks of one constraint of the kind (a `SolveError` naming it);
* ``pack`` — the typed arrays of a block of constraints of the kind;
* ``evaluate`` — all residuals of a block in one vectorised call, with the analytic Jacobian
  by each plane's ``(n, d)`` and, for camera kinds, by the camera's pose ``[rvec, C]``.

Adding a kind is one module in this package and one line in
`aida_kb.constraints.registry`; `tests/constraints/test_registry.py` checks that every kind
has a finite-difference Jacobian test and documentation.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any, ClassVar, Literal

import numpy as np
import numpy.typing as npt

from aida_kb.constraints.factor import Constraint
from aida_kb.errors import SolveError
from aida_kb.geometry.camera import PinholeCamera

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
BlockData = dict[str, npt.NDArray[Any]]
"""A block's packed measurement: named arrays with a first axis of M (one row per member)."""

Evidence = Literal["plane_fit", "segment"] | None
"""What a knowledge-base measure of a kind is fed with (`Kind.evidence`)."""

Evaluated = tuple[FloatArray, FloatArray, FloatArray | None]
"""``(r, J, J_camera)``: residuals (M, k) in the constraints' unit, Jacobian (M, k, a, 4) by
each plane's ``(n, d)``, and (M, k, 6) by the camera pose ``[rvec, C]`` (camera kinds only)."""


class Kind:
    """The interface of a constraint kind (see the module docstring); one instance per kind."""

    name: ClassVar[str]
    arity: ClassVar[int]
    residual_size: ClassVar[int]
    dof: ClassVar[int]
    measurement: ClassVar[bool] = False
    uses_camera: ClassVar[bool] = False
    evidence: ClassVar[Evidence] = None
    """What a knowledge-base measure of this kind is fed with: a region's plane fit
    (`PositionData`), an image segment (`EdgeData`), or nothing (an internal constraint)."""
    summary: ClassVar[str]
    """One line for the documentation: what the residual measures, in which unit."""

    def block_kind(self, c: Constraint) -> Kind:
        """The kind that evaluates ``c`` (an angle of 0 or pi is evaluated as parallel)."""
        return self

    def multiplicity(self, c: Constraint) -> float:
        """The constraint's multiplicity m (its cost is m times its whitened square)."""
        return 1.0

    def camera(self, c: Constraint) -> int | None:
        """The index of the camera the constraint looks through, or None."""
        return None

    def validate(self, c: Constraint, where: str, n_cameras: int) -> None:
        """Kind-specific checks of one constraint (`SolveError` naming ``where``)."""

    def pack(self, cs: Sequence[Constraint]) -> BlockData:
        """The typed measurement arrays of a block (M rows)."""
        return {}

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
        """Residuals and Jacobians of a block: ``normals`` (P, 3) unit and ``offsets`` (P,)
        metres are all planes (world frame), ``idx`` (M, arity) the block's part indices.

        ``camera_jacobian``: whether the caller needs the Jacobian by the camera poses (a
        problem whose cameras are all held does not); without it a camera kind may return
        None in its place and skip that work (as Ceres skips the Jacobian of a constant
        parameter block)."""
        raise NotImplementedError


NormalsKernel = Callable[..., tuple[FloatArray, FloatArray]]
"""A kernel of `aida_kb.constraints.kernels` over the normals alone: ``(normals, idx, *data)``
-> ``(r (M, k), J (M, k, a, 4))``."""


class NormalsKind(Kind):
    """A kind whose residual depends on its planes' normals alone: ``evaluate`` calls its
    kernel with the block's ``data`` arrays named by ``data_keys``, in that order."""

    data_keys: ClassVar[tuple[str, ...]] = ()

    def __init__(self, kernel: NormalsKernel) -> None:
        self._kernel = kernel

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
        """r (M, k) rad and J (M, k, arity, 4) from the kernel; no camera."""
        r, J = self._kernel(normals, idx, *(data[k] for k in self.data_keys))
        return r, J, None


def finite_positive(where: str, what: str, x: float | None, *, optional: bool = True) -> None:
    """`SolveError` unless ``x`` is a finite number > 0 (or None when ``optional``)."""
    if x is None:
        if not optional:
            raise SolveError(f"{where}: {what} is missing")
        return
    if not math.isfinite(x) or x <= 0.0:
        raise SolveError(f"{where}: {what} must be a finite number > 0, got {x!r}")


def vector(where: str, what: str, x: Sequence[float], size: int) -> FloatArray:
    """``x`` as a finite (size,) array, else `SolveError` naming ``where``."""
    a = np.asarray(x, dtype=np.float64)
    if a.shape != (size,):
        raise SolveError(f"{where}: {what} must have {size} components, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise SolveError(f"{where}: {what} is not finite ({a.tolist()})")
    return a


def unit_vector(where: str, what: str, x: Sequence[float]) -> FloatArray:
    """``x`` as a finite unit (3,) vector, else `SolveError` naming ``where``."""
    a = vector(where, what, x, 3)
    if abs(float(np.linalg.norm(a)) - 1.0) > 1e-6:
        raise SolveError(f"{where}: {what} must be a unit vector")
    return a


def check_camera(where: str, camera: int, n_cameras: int) -> None:
    """`SolveError` unless ``camera`` indexes one of the problem's ``n_cameras`` cameras."""
    if not isinstance(camera, int | np.integer) or not 0 <= int(camera) < n_cameras:
        raise SolveError(
            f"{where}: unknown camera index {camera} (the problem has {n_cameras} cameras)"
        )


def normal_block(dr_dn: FloatArray) -> FloatArray:
    """(M, k, 3) derivative by a normal -> (M, k, 4) with zero derivative by the offset."""
    out = np.zeros((*dr_dn.shape[:-1], 4))
    out[..., :3] = dr_dn
    return out
