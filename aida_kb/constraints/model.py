"""Constraints as records, and their compilation into vectorised blocks, one per kind.

A `Constraint` mirrors the compiler's ``ConstraintSpec`` (DOMAIN.md, "Session 2 contracts")
with role paths resolved to part indices, plus the evidence a measurement needs
(`PositionData` for eq. 4, `EdgeData` for eq. 5). `compile_blocks` validates a list of them
and groups them by kind into `ConstraintBlock` s whose `evaluate` computes all residuals of the
kind in one numpy call.

Weighting: the least-squares residual of constraint i is ``sqrt(m_i · W_i) · e_i`` where
``e_i`` is the unweighted residual vector in the constraint's unit, ``W_i`` its weight
(explicit, or ``1/sigma²``) and ``m_i`` its multiplicity (``w_c``, the summed certainty of the
region, for a position constraint; 1 otherwise). Its cost is ``m_i · W_i · |e_i|²`` (paper eq. 6
term).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import numpy.typing as npt

from aida_kb.constraints import kernels
from aida_kb.constraints.edge import edge_kernel
from aida_kb.errors import SolveError
from aida_kb.geometry.camera import PinholeCamera

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

Kind = Literal["angle", "parallel", "parallel_edge", "symmetry", "position", "edge"]

#: Number of planes each kind relates.
ARITY: dict[str, int] = {
    "angle": 2,
    "parallel": 2,
    "parallel_edge": 4,
    "symmetry": 4,
    "position": 1,
    "edge": 2,
}

#: Degrees of freedom of each kind's residual (its chi-square degrees of freedom).
DOF: dict[str, int] = {
    "angle": 1,
    "parallel": 2,
    "parallel_edge": 2,
    "symmetry": 1,
    "position": 3,
    "edge": 2,
}

#: Number of residual components of each kind's kernel.
RESIDUAL_SIZE: dict[str, int] = {
    "angle": 1,
    "parallel": 3,
    "parallel_edge": 3,
    "symmetry": 1,
    "position": 4,
    "edge": 2,
}

#: 99.9 % quantiles of chi-square with 1, 2, 3 degrees of freedom: the default rejection
#: thresholds of the normalised cost when a constraint has no ``reject_above``.
CHI2_999 = {1: 10.828, 2: 13.816, 3: 16.266}

_PARALLEL_EPS = 1e-6  # an angle target this close to 0 or pi is compiled as a parallel constraint


@dataclass(frozen=True)
class PositionData:
    """Region evidence of a position constraint (paper eq. 4).

    Attributes
    ----------
    n_init : (3,) unit normal of the region's plane fit, world frame.
    c_init : (3,) metres, world frame: the region's centre of gravity on that plane.
    w_c : summed certainty over the region (the constraint's multiplicity), > 0.
    w_n : relative weight of the centre shift against the normal angle (1/m²), > 0.
    px_per_m : pixels per metre at the region's depth (focal length / depth); needed only when
        the constraint's unit is "px".
    radius_m : the region's radius in metres (a tilt by theta moves its rim by
        ``radius_m · theta``); needed only when the unit is "px".
    shift_px_per_m : unit "px" only: pixels per metre of shift along the normal, in place of
        ``px_per_m`` (e.g. the change of stereo disparity, ``f·B/z²`` per metre of depth).
    tilt_px_per_rad : unit "px" only: pixels per radian of tilt, in place of
        ``px_per_m · radius_m``.
    """

    n_init: tuple[float, float, float]
    c_init: tuple[float, float, float]
    w_c: float = 1.0
    w_n: float = 1.0
    px_per_m: float | None = None
    radius_m: float | None = None
    shift_px_per_m: float | None = None
    tilt_px_per_rad: float | None = None


@dataclass(frozen=True)
class EdgeData:
    """Image evidence of an edge constraint (paper eq. 5).

    Attributes
    ----------
    camera : index of the camera that saw the segment.
    p1_px, p2_px : the segment's end points, pixels (x right, y down).
    """

    camera: int
    p1_px: tuple[float, float]
    p2_px: tuple[float, float]


@dataclass(frozen=True)
class Constraint:
    """One constraint between parts (indices into the problem's parts).

    Attributes
    ----------
    kind : "angle" (value: rad), "parallel", "parallel_edge" (parts a, b, c, d: edge(a, b) is
        parallel to edge(c, d)), "symmetry" (angle(a, b) == angle(c, d)), "position" (one
        part, with `position` evidence) or "edge" (parts a, b, with `edge` evidence).
    parts : part indices, ``ARITY[kind]`` of them.
    value : the target angle (rad) of an "angle" constraint; None for the others.
    sigma : tolerance in `unit`; the weight is ``1/sigma²`` unless `weight` is given.
    weight : explicit weight (overrides sigma for the objective; sigma still normalises).
    reject_above : |residual| above this (in `unit`) flags the constraint in the report.
    unit : "rad", "m", "px" or "" (the unit of the residual, sigma and reject_above).
    measurement : True for measurement constraints (position, edge): robust loss applies.
    label : a name for reports and messages.
    sign : "parallel" only: +1 the normals face the same way, -1 opposite ways, 0 either.
    """

    kind: Kind
    parts: tuple[int, ...]
    value: float | None = None
    sigma: float | None = None
    weight: float | None = None
    reject_above: float | None = None
    unit: str = ""
    measurement: bool = False
    label: str = ""
    position: PositionData | None = None
    edge: EdgeData | None = None
    sign: int = 0

    @property
    def effective_weight(self) -> float:
        """The weight W: explicit, else ``1/sigma²`` (validated by `compile_blocks`)."""
        if self.weight is not None:
            return float(self.weight)
        if self.sigma is None:
            return 1.0
        return 1.0 / float(self.sigma) ** 2


@dataclass(frozen=True)
class ConstraintBlock:
    """All constraints of one kind, as arrays.

    Attributes
    ----------
    kind : the kernel's kind ("angle" targets at 0 or pi are compiled as "parallel").
    members : (M,) positions of the constraints in the list given to `compile_blocks`.
    idx : (M, a) part indices.
    sqrt_weight : (M,) ``sqrt(m · W)`` per constraint.
    data : per-kind arrays (value, sign, n_init, c_init, scales, camera, end points).
    """

    kind: str
    members: IntArray
    idx: IntArray
    sqrt_weight: FloatArray
    data: dict[str, FloatArray] = field(default_factory=dict)

    @property
    def size(self) -> int:
        """Number of constraints M in the block."""
        return int(self.members.shape[0])

    def evaluate(
        self,
        normals: FloatArray,
        offsets: FloatArray,
        cameras: Sequence[PinholeCamera] = (),
    ) -> tuple[FloatArray, FloatArray, FloatArray | None]:
        """Unweighted residuals and Jacobians of the block.

        Parameters
        ----------
        normals : (P, 3) unit normals, offsets : (P,) metres: the planes of all parts.
        cameras : the problem's cameras (for "edge" blocks).

        Returns
        -------
        r : (M, k) in the constraints' unit; J : (M, k, a, 4) by each plane's (n, d);
        J_camera : (M, k, 6) by the pose of the constraint's camera, or None.
        """
        if self.kind == "angle":
            r, J = kernels.angle_kernel(normals, self.idx, self.data["value"])
        elif self.kind == "parallel":
            r, J = kernels.parallel_kernel(normals, self.idx, self.data["sign"])
        elif self.kind == "parallel_edge":
            r, J = kernels.parallel_edge_kernel(normals, self.idx)
        elif self.kind == "symmetry":
            r, J = kernels.symmetry_kernel(normals, self.idx)
        elif self.kind == "position":
            r, J = kernels.position_kernel(
                normals,
                offsets,
                self.idx,
                self.data["n_init"],
                self.data["c_init"],
                self.data["scale_angle"],
                self.data["scale_shift"],
            )
        elif self.kind == "edge":
            return edge_kernel(
                normals,
                offsets,
                self.idx,
                cameras,
                self.data["camera"].astype(np.intp),
                self.data["p1"],
                self.data["p2"],
                self.data["px"] > 0.5,
            )
        else:  # pragma: no cover - compile_blocks only makes the kinds above
            raise SolveError(f"unknown constraint kind {self.kind!r}")
        return r, J, None


def _name(i: int, c: Constraint) -> str:
    return f"constraint {i} ({c.label})" if c.label else f"constraint {i} ({c.kind})"


def _finite_positive(where: str, what: str, x: float | None, *, optional: bool = True) -> None:
    if x is None:
        if not optional:
            raise SolveError(f"{where}: {what} is missing")
        return
    if not math.isfinite(x) or x <= 0.0:
        raise SolveError(f"{where}: {what} must be a finite number > 0, got {x!r}")


def _vector(where: str, what: str, x: Sequence[float], size: int) -> FloatArray:
    a = np.asarray(x, dtype=np.float64)
    if a.shape != (size,):
        raise SolveError(f"{where}: {what} must have {size} components, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise SolveError(f"{where}: {what} is not finite ({a.tolist()})")
    return a


def validate(constraints: Sequence[Constraint], n_parts: int, n_cameras: int = 0) -> None:
    """Check every constraint; raise `SolveError` naming the first bad one and why."""
    for i, c in enumerate(constraints):
        where = _name(i, c)
        if c.kind not in ARITY:
            raise SolveError(f"{where}: unknown kind {c.kind!r} (one of {', '.join(ARITY)})")
        if len(c.parts) != ARITY[c.kind]:
            raise SolveError(f"{where}: {c.kind} relates {ARITY[c.kind]} parts, got {len(c.parts)}")
        for p in c.parts:
            if not isinstance(p, int | np.integer) or not 0 <= int(p) < n_parts:
                raise SolveError(
                    f"{where}: unknown part index {p!r} (the problem has {n_parts} parts)"
                )
        _finite_positive(where, "sigma", c.sigma)
        _finite_positive(where, "weight", c.weight)
        _finite_positive(where, "reject_above", c.reject_above)
        if c.sigma is None and c.weight is None:
            raise SolveError(f"{where}: needs a tolerance (sigma) or an explicit weight")
        if c.kind == "angle" and (
            c.value is None or not math.isfinite(c.value) or not 0.0 <= c.value <= math.pi
        ):
            raise SolveError(
                f"{where}: angle target must be a finite value in [0, pi] rad, got {c.value!r}"
            )
        pairs = [c.parts[j : j + 2] for j in range(0, len(c.parts), 2)] if len(c.parts) > 1 else []
        if any(int(a) == int(b) for a, b in pairs):
            raise SolveError(f"{where}: a plane cannot be related to itself: parts {c.parts}")
        if c.kind == "parallel" and c.sign not in (-1, 0, 1):
            raise SolveError(f"{where}: sign must be -1, 0 or 1, got {c.sign!r}")
        if c.kind == "position":
            pos = c.position
            if pos is None:
                raise SolveError(f"{where}: a position constraint needs its region evidence")
            n = _vector(where, "n_init", pos.n_init, 3)
            if abs(float(np.linalg.norm(n)) - 1.0) > 1e-6:
                raise SolveError(f"{where}: n_init must be a unit vector")
            _vector(where, "c_init", pos.c_init, 3)
            _finite_positive(where, "w_c", pos.w_c, optional=False)
            _finite_positive(where, "w_n", pos.w_n, optional=False)
            _finite_positive(where, "shift_px_per_m", pos.shift_px_per_m)
            _finite_positive(where, "tilt_px_per_rad", pos.tilt_px_per_rad)
            if c.unit == "px":
                if pos.shift_px_per_m is None or pos.tilt_px_per_rad is None:
                    _finite_positive(where, "px_per_m (unit px)", pos.px_per_m, optional=False)
                if pos.tilt_px_per_rad is None:
                    _finite_positive(where, "radius_m (unit px)", pos.radius_m, optional=False)
        if c.kind == "edge":
            e = c.edge
            if e is None:
                raise SolveError(f"{where}: an edge constraint needs its image segment")
            if not 0 <= e.camera < n_cameras:
                raise SolveError(
                    f"{where}: unknown camera index {e.camera} (the problem has "
                    f"{n_cameras} cameras)"
                )
            p1 = _vector(where, "p1_px", e.p1_px, 2)
            p2 = _vector(where, "p2_px", e.p2_px, 2)
            if float(np.linalg.norm(p2 - p1)) < 1e-6:
                raise SolveError(f"{where}: the image segment has zero length")


def compile_blocks(
    constraints: Sequence[Constraint], n_parts: int, n_cameras: int = 0
) -> tuple[ConstraintBlock, ...]:
    """Validate ``constraints`` and group them by kind into vectorised blocks.

    Raises
    ------
    SolveError
        NaN or non-positive tolerance, unknown part or camera index, wrong number of parts,
        missing evidence; the message names the constraint.
    """
    validate(constraints, n_parts, n_cameras)
    groups: dict[str, list[int]] = {}
    for i, c in enumerate(constraints):
        kind: str = c.kind
        if kind == "angle":
            assert c.value is not None
            if c.value < _PARALLEL_EPS or c.value > math.pi - _PARALLEL_EPS:
                kind = "parallel"
        groups.setdefault(kind, []).append(i)
    blocks = []
    for kind, members in groups.items():
        cs = [constraints[i] for i in members]
        idx = np.array([c.parts for c in cs], dtype=np.intp).reshape(len(cs), -1)
        mult = np.array([c.position.w_c if c.position else 1.0 for c in cs])
        sqrt_w = np.sqrt(mult * np.array([c.effective_weight for c in cs]))
        data: dict[str, FloatArray] = {}
        if kind == "angle":
            data["value"] = np.array([c.value for c in cs], dtype=np.float64)
        elif kind == "parallel":
            data["sign"] = np.array([_parallel_sign(c) for c in cs], dtype=np.float64)
        elif kind == "position":
            pos = [c.position for c in cs]
            assert all(p is not None for p in pos)
            data["n_init"] = np.array([p.n_init for p in pos if p], dtype=np.float64)
            data["c_init"] = np.array([p.c_init for p in pos if p], dtype=np.float64)
            px = np.array([c.unit == "px" for c in cs])
            ppm = np.array([p.px_per_m or 1.0 for p in pos if p])
            rad = np.array([p.radius_m or 1.0 for p in pos if p])
            shift = np.array([p.shift_px_per_m or q for p, q in zip(pos, ppm, strict=True) if p])
            tilt = np.array(
                [p.tilt_px_per_rad or q * r for p, q, r in zip(pos, ppm, rad, strict=True) if p]
            )
            w_n = np.array([p.w_n for p in pos if p])
            data["scale_angle"] = np.where(px, tilt, 1.0)
            data["scale_shift"] = np.where(px, shift, np.sqrt(w_n))
        elif kind == "edge":
            eds = [c.edge for c in cs]
            data["camera"] = np.array([e.camera for e in eds if e], dtype=np.float64)
            data["p1"] = np.array([e.p1_px for e in eds if e], dtype=np.float64)
            data["p2"] = np.array([e.p2_px for e in eds if e], dtype=np.float64)
            data["px"] = np.array([c.unit == "px" for c in cs], dtype=np.float64)
        blocks.append(
            ConstraintBlock(
                kind=kind,
                members=np.array(members, dtype=np.intp),
                idx=idx,
                sqrt_weight=sqrt_w,
                data=data,
            )
        )
    return tuple(blocks)


def _parallel_sign(c: Constraint) -> int:
    if c.kind == "angle":
        assert c.value is not None
        return 1 if c.value > math.pi / 2 else -1  # meeting at pi: the normals agree
    return c.sign
