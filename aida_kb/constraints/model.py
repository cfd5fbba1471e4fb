"""Constraints compiled into vectorised blocks, one per kind (`compile_blocks`).

`validate` checks a list of constraints (`aida_kb.constraints.factor.Constraint`) against the
problem's parts and cameras; `compile_blocks` groups them by the kind that evaluates them
(`aida_kb.constraints.registry`) into `ConstraintBlock` s whose `evaluate` computes all
residuals of the kind in one numpy call, and whose `whiten` applies each member's noise model.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from aida_kb.constraints.factor import Constraint
from aida_kb.constraints.kinds.base import (
    BlockData,
    Evaluated,
    FloatArray,
    IntArray,
    Kind,
    finite_positive,
)
from aida_kb.constraints.registry import kind_of
from aida_kb.errors import SolveError
from aida_kb.geometry.camera import PinholeCamera

LOSS_CODES = {"linear": 0, "soft_l1": 1, "huber": 2}
"""Robust losses by code in a block's ``loss`` array; -1 takes the solve's default."""


@dataclass(frozen=True)
class ConstraintBlock:
    """All constraints evaluated by one kind, as arrays.

    Attributes
    ----------
    kind : the kind that evaluates the block (an angle at 0 or pi is evaluated as parallel).
    members : (M,) positions of the constraints in the list given to `compile_blocks`.
    idx : (M, a) part indices.
    sqrt_weight : (M,) ``sqrt(m · W)`` per constraint (the multiplicity and scalar weight).
    sqrt_information : (M, k, k) whitening of each member's residual (identity for members
        with a scalar noise model), or None when every member has one.
    camera : (M,) the camera of each member (camera kinds), or None.
    loss : (M,) robust loss codes (`LOSS_CODES`; -1: the solve's default for measurements,
        linear for the others); loss_scale : (M,) its threshold in sigmas (NaN: the default).
    data : the kind's packed measurement (`Kind.pack`).
    """

    kind: Kind
    members: IntArray
    idx: IntArray
    sqrt_weight: FloatArray
    sqrt_information: FloatArray | None
    camera: IntArray | None
    loss: npt.NDArray[np.int8]
    loss_scale: FloatArray
    data: BlockData = field(default_factory=dict)

    @property
    def size(self) -> int:
        """Number of constraints M in the block."""
        return int(self.members.shape[0])

    def evaluate(
        self,
        normals: FloatArray,
        offsets: FloatArray,
        cameras: Sequence[PinholeCamera] = (),
        *,
        camera_jacobian: bool = True,
    ) -> Evaluated:
        """Unweighted residuals (M, k) and Jacobians by the planes (M, k, a, 4) and, for
        camera kinds, by the camera pose (M, k, 6; None without ``camera_jacobian``) — see
        `Kind.evaluate`."""
        return self.kind.evaluate(
            normals, offsets, cameras, self.idx, self.data, camera_jacobian=camera_jacobian
        )

    def whiten(self, r: FloatArray) -> FloatArray:
        """Whitened residuals (M, k): ``sqrt_weight · S · r``."""
        if self.sqrt_information is not None:
            r = np.einsum("mij,mj->mi", self.sqrt_information, r)
        out: FloatArray = self.sqrt_weight[:, None] * r
        return out

    def subset(self, keep: npt.NDArray[np.bool_]) -> ConstraintBlock:
        """The block of the members where ``keep`` (M,) is True."""
        return ConstraintBlock(
            kind=self.kind,
            members=self.members[keep],
            idx=self.idx[keep],
            sqrt_weight=self.sqrt_weight[keep],
            sqrt_information=None if self.sqrt_information is None else self.sqrt_information[keep],
            camera=None if self.camera is None else self.camera[keep],
            loss=self.loss[keep],
            loss_scale=self.loss_scale[keep],
            data={k: v[keep] for k, v in self.data.items()},
        )


def describe(i: int, c: Constraint) -> str:
    """Constraint ``i`` for messages: its index and label (or kind), and where it came from."""
    label = c.label or (c.origin.label if c.origin is not None else "") or c.kind
    where = f", {c.origin.where}" if c.origin is not None and c.origin.span is not None else ""
    return f"constraint {i} ({label}{where})"


def validate(constraints: Sequence[Constraint], n_parts: int, n_cameras: int = 0) -> None:
    """Check every constraint; raise `SolveError` naming the first bad one and why."""
    for i, c in enumerate(constraints):
        where = describe(i, c)
        kind = kind_of(c.kind, where)
        if len(c.parts) != kind.arity:
            raise SolveError(f"{where}: {c.kind} relates {kind.arity} parts, got {len(c.parts)}")
        for p in c.parts:
            if not isinstance(p, int | np.integer) or not 0 <= int(p) < n_parts:
                raise SolveError(
                    f"{where}: unknown part index {p!r} (the problem has {n_parts} parts)"
                )
        finite_positive(where, "sigma", c.sigma)
        finite_positive(where, "weight", c.weight)
        finite_positive(where, "reject_above", c.reject_above)
        finite_positive(where, "loss_scale", c.loss_scale)
        if c.loss is not None and c.loss not in LOSS_CODES:
            raise SolveError(f"{where}: unknown loss {c.loss!r} ({', '.join(LOSS_CODES)})")
        if c.sqrt_information is not None:
            S = np.asarray(c.sqrt_information, dtype=np.float64)
            k = kind.residual_size
            if S.shape != (k, k) or not np.all(np.isfinite(S)):
                raise SolveError(
                    f"{where}: sqrt_information must be a finite {k}x{k} matrix, got {S.shape}"
                )
            if abs(float(np.linalg.det(S))) < 1e-300:
                raise SolveError(f"{where}: sqrt_information is singular")
        elif c.sigma is None and c.weight is None:
            raise SolveError(f"{where}: needs a tolerance (sigma) or an explicit weight")
        pairs = [c.parts[j : j + 2] for j in range(0, len(c.parts), 2)] if len(c.parts) > 1 else []
        if any(int(a) == int(b) for a, b in pairs):
            raise SolveError(f"{where}: a plane cannot be related to itself: parts {c.parts}")
        kind.validate(c, where, n_cameras)


def compile_blocks(
    constraints: Sequence[Constraint], n_parts: int, n_cameras: int = 0
) -> tuple[ConstraintBlock, ...]:
    """Validate ``constraints`` and group them by the kind that evaluates them.

    Raises
    ------
    SolveError
        NaN or non-positive tolerance, unknown kind, part or camera index, wrong number of
        parts, missing evidence; the message names the constraint.
    """
    validate(constraints, n_parts, n_cameras)
    groups: dict[str, tuple[Kind, list[int]]] = {}
    for i, c in enumerate(constraints):
        kind = kind_of(c.kind).block_kind(c)
        groups.setdefault(kind.name, (kind, []))[1].append(i)
    blocks = []
    for kind, members in groups.values():
        cs = [constraints[i] for i in members]
        declared = [kind_of(c.kind) for c in cs]
        idx = np.array([c.parts for c in cs], dtype=np.intp).reshape(len(cs), -1)
        mult = np.array([k.multiplicity(c) for k, c in zip(declared, cs, strict=True)])
        sqrt_w = np.sqrt(mult * np.array([c.effective_weight for c in cs]))
        info = None
        if any(c.sqrt_information is not None for c in cs):
            eye = np.eye(kind.residual_size)
            info = np.array(
                [eye if c.sqrt_information is None else c.sqrt_information for c in cs],
                dtype=np.float64,
            )
        camera = None
        if kind.uses_camera:
            camera = np.array([kind.camera(c) for c in cs], dtype=np.intp)
        loss = np.array([LOSS_CODES[c.loss] if c.loss else -1 for c in cs], dtype=np.int8)
        scale = np.array([c.loss_scale if c.loss_scale else math.nan for c in cs])
        blocks.append(
            ConstraintBlock(
                kind=kind,
                members=np.array(members, dtype=np.intp),
                idx=idx,
                sqrt_weight=sqrt_w,
                sqrt_information=info,
                camera=camera,
                loss=loss,
                loss_scale=scale,
                data=kind.pack(cs),
            )
        )
    return tuple(blocks)
