"""A weighted least-squares problem over planar parts: parameters, constraint blocks, sparsity.

`Problem` holds the parts' initial frames (`aida_kb.geometry.frames.PartFrames`), the
constraints and which parts are held fixed. `Evaluation` is its compiled form for one set of
free parts and active constraints: it maps the free parameter vector ``x`` (3 per free part:
delta m, alpha rad, beta rad, in part order) to the weighted residual vector and its sparse
analytic Jacobian (scipy CSR), evaluating every constraint kind in one vectorised call.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from aida_kb.constraints.model import (
    RESIDUAL_SIZE,
    Constraint,
    ConstraintBlock,
    compile_blocks,
    validate,
)
from aida_kb.errors import GeometryError, SolveError
from aida_kb.geometry.camera import PinholeCamera
from aida_kb.geometry.frames import PartFrames

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

Loss = Literal["linear", "soft_l1", "huber"]

MEASUREMENT_KINDS = frozenset({"position", "edge"})


@dataclass(frozen=True)
class Problem:
    """Parts, constraints and the parts held fixed.

    Attributes
    ----------
    frames : the parts' initial local frames (P parts); parameters are relative to them.
    constraints : the constraints, part indices into ``0..P-1``.
    fixed_parts : parts whose planes are not moved.
    names : optional part names (role paths) for messages and reports.
    cameras : the cameras that edge constraints refer to (by index).
    free_cameras : cameras whose poses ``[rvec, C]`` are unknowns (viewpoint registration);
        the others are fixed.
    """

    frames: PartFrames
    constraints: tuple[Constraint, ...]
    fixed_parts: frozenset[int] = frozenset()
    names: tuple[str, ...] = ()
    blocks: tuple[ConstraintBlock, ...] = field(default=(), repr=False, compare=False)
    cameras: tuple[PinholeCamera, ...] = ()
    free_cameras: frozenset[int] = frozenset()

    @property
    def n_parts(self) -> int:
        """Number of parts P."""
        return self.frames.n_parts

    def part_name(self, i: int) -> str:
        """The name of part ``i`` (its role path if given, else ``part i``)."""
        return self.names[i] if i < len(self.names) else f"part {i}"

    def describe(self, i: int) -> str:
        """Constraint ``i`` for messages: its index, label and kind with its parts' names."""
        c = self.constraints[i]
        parts = ", ".join(self.part_name(int(p)) for p in c.parts)
        label = f" '{c.label}'" if c.label else ""
        return f"constraint {i}{label} ({c.kind} of {parts})"

    def with_frames(self, frames: PartFrames) -> Problem:
        """The same problem relative to new initial frames (e.g. `PartFrames.rebased`)."""
        return replace(self, frames=frames)

    def with_fixed(self, fixed_parts: Iterable[int]) -> Problem:
        """The same problem with another set of fixed parts."""
        return replace(self, fixed_parts=_check_parts(fixed_parts, self.n_parts, "fixed part"))


def _check_parts(parts: Iterable[int], n_parts: int, what: str) -> frozenset[int]:
    out = set()
    things = "cameras" if "camera" in what else "parts"
    for p in parts:
        if not isinstance(p, int | np.integer) or not 0 <= int(p) < n_parts:
            raise SolveError(f"unknown {what} index {p!r} (the problem has {n_parts} {things})")
        out.add(int(p))
    return frozenset(out)


def build_problem(
    normals: npt.ArrayLike,
    offsets: npt.ArrayLike,
    constraints: Sequence[Constraint],
    *,
    centres: npt.ArrayLike | None = None,
    fixed_parts: Iterable[int] = (),
    names: Sequence[str] = (),
    cameras: Sequence[PinholeCamera] = (),
    free_cameras: Iterable[int] = (),
) -> Problem:
    """Build a problem from initial planes ``n·x = d`` and constraints.

    Parameters
    ----------
    normals : (P, 3) world frame (normalised here); offsets : (P,) metres.
    constraints : the constraints (part indices into the P planes).
    centres : (P, 3) metres, world frame: each part's centre (projected onto its plane); the
        default is the foot of the perpendicular from the origin.
    fixed_parts : indices of parts held fixed.
    names : optional part names (P of them).
    cameras : cameras referred to by edge constraints (`aida_kb.geometry.camera`).
    free_cameras : indices of cameras whose poses are solved for (default: all fixed).

    Raises
    ------
    SolveError
        Non-finite planes, an unknown part index, a bad tolerance or missing evidence.
    """
    n = np.asarray(normals, dtype=np.float64)
    d = np.asarray(offsets, dtype=np.float64)
    try:
        frames = PartFrames.from_planes(
            n, d, None if centres is None else np.asarray(centres, dtype=np.float64)
        )
    except GeometryError as exc:
        raise SolveError(f"initial planes: {exc}") from exc
    if names and len(names) != frames.n_parts:
        raise SolveError(f"names: {frames.n_parts} expected, got {len(names)}")
    fixed = _check_parts(fixed_parts, frames.n_parts, "fixed part")
    cams = tuple(cameras)
    for i, cam in enumerate(cams):
        if not isinstance(cam, PinholeCamera):
            raise SolveError(f"camera {i}: a PinholeCamera expected, got {type(cam).__name__}")
    free_cams = _check_parts(free_cameras, len(cams), "free camera")
    cons = tuple(constraints)
    blocks = compile_blocks(cons, frames.n_parts, len(cams))
    return Problem(frames, cons, fixed, tuple(names), blocks, cams, free_cams)


def _robust(z: FloatArray, loss: Loss) -> tuple[FloatArray, FloatArray]:
    """rho(z) and rho'(z) of scipy's losses (z = squared scaled residual)."""
    if loss == "soft_l1":
        t = np.sqrt(1.0 + z)
        return 2.0 * z / (t + 1.0), 1.0 / t
    if loss == "huber":
        big = z > 1.0
        rt = np.sqrt(np.where(big, z, 1.0))
        return np.where(big, 2.0 * rt - 1.0, z), np.where(big, 1.0 / rt, 1.0)
    return z, np.ones_like(z)


class Evaluation:
    """Residuals and sparse Jacobian of a problem for given free parts and active constraints.

    The unknowns ``x`` are 3 parameters per free part (delta m, alpha rad, beta rad; in the
    order of ``free_parts``) followed by 6 per free camera (its pose ``[rvec, C]``, in the order
    of ``free_cameras``).

    Parameters
    ----------
    problem : the problem.
    free_parts : (F,) sorted indices of the parts whose parameters are unknowns.
    active : indices of the constraints taken into account (default all).
    free_cameras : (G,) indices of the cameras whose poses are unknowns.
    loss, f_scale : robust loss applied to the whitened residuals of measurement constraints
        (``f_scale`` in whitened units, i.e. multiples of sigma).
    """

    def __init__(
        self,
        problem: Problem,
        free_parts: IntArray,
        active: Sequence[int] | None = None,
        *,
        free_cameras: IntArray | None = None,
        loss: Loss = "linear",
        f_scale: float = 1.0,
    ) -> None:
        self.problem = problem
        self.free_parts = np.asarray(free_parts, dtype=np.intp)
        self.free_cameras = np.asarray([] if free_cameras is None else free_cameras, dtype=np.intp)
        self.loss: Loss = loss
        self.f_scale = float(f_scale)
        P = problem.n_parts
        self.col_of_part = np.full(P, -1, dtype=np.intp)
        self.col_of_part[self.free_parts] = np.arange(self.free_parts.size)
        self.col_of_camera = np.full(len(problem.cameras), -1, dtype=np.intp)
        self.col_of_camera[self.free_cameras] = np.arange(self.free_cameras.size)
        self.n_part_params = 3 * int(self.free_parts.size)
        self.n_params = self.n_part_params + 6 * int(self.free_cameras.size)
        if active is None:
            blocks = problem.blocks
        else:
            keep = np.zeros(len(problem.constraints), dtype=bool)
            keep[np.asarray(list(active), dtype=np.intp)] = True
            blocks = tuple(_sub_block(b, keep[b.members]) for b in problem.blocks)
            blocks = tuple(b for b in blocks if b.size)
        self.blocks = blocks
        # residual rows and the Jacobian's sparsity pattern, block by block
        rows_all: list[IntArray] = []
        cols_all: list[IntArray] = []
        self._masks: list[npt.NDArray[np.bool_]] = []
        self._cam_masks: list[npt.NDArray[np.bool_] | None] = []
        row = 0
        for b in blocks:
            k = RESIDUAL_SIZE[b.kind]
            M, a = b.idx.shape
            rows = row + np.arange(M * k, dtype=np.intp).reshape(M, k)
            cols_part = self.col_of_part[b.idx]  # (M, a)
            shape = (M, k, a, 3)
            rows_b = np.broadcast_to(rows[:, :, None, None], shape)
            cols_b = np.broadcast_to(
                3 * cols_part[:, None, :, None] + np.arange(3)[None, None, None, :], shape
            )
            mask = np.broadcast_to(cols_part[:, None, :, None] >= 0, shape)
            rows_all.append(rows_b[mask])
            cols_all.append(cols_b[mask])
            self._masks.append(mask)
            cam_mask = None
            if b.kind == "edge" and self.free_cameras.size:
                cam_col = self.col_of_camera[b.data["camera"].astype(np.intp)]  # (M,)
                cshape = (M, k, 6)
                cam_mask = np.broadcast_to(cam_col[:, None, None] >= 0, cshape)
                ccols = self.n_part_params + 6 * cam_col[:, None, None] + np.arange(6)
                rows_all.append(np.broadcast_to(rows[:, :, None], cshape)[cam_mask])
                cols_all.append(np.broadcast_to(ccols, cshape)[cam_mask])
            self._cam_masks.append(cam_mask)
            row += M * k
        self.n_residuals = row
        # the constraint of each residual row (messages about degenerate geometry)
        self.constraint_of_row = (
            np.concatenate(
                [np.repeat(b.members, RESIDUAL_SIZE[b.kind]).astype(np.intp) for b in blocks]
            )
            if blocks
            else np.zeros(0, dtype=np.intp)
        )
        self.rows = np.concatenate(rows_all) if rows_all else np.zeros(0, dtype=np.intp)
        self.cols = np.concatenate(cols_all) if cols_all else np.zeros(0, dtype=np.intp)
        # the CSR structure once: entries sorted by (row, col), duplicates (a plane occurring
        # twice in one constraint) summed into one slot by `_slot`
        width = max(self.n_params, 1)
        self._flat = self.rows * width + self.cols
        uniq, slot = np.unique(self._flat, return_inverse=True)
        self._slot = slot.reshape(-1)
        self._csr_indices = (uniq % width).astype(np.int32)
        counts = np.bincount(uniq // width, minlength=self.n_residuals)
        self._csr_indptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int32)
        self.base_params = np.zeros((P, 3))
        self.base_cameras: tuple[PinholeCamera, ...] = problem.cameras

    def params(self, x: FloatArray) -> FloatArray:
        """All parts' parameters (P, 3): ``x`` for the free parts, the base values elsewhere."""
        p = self.base_params.copy()
        p[self.free_parts] = np.asarray(x[: self.n_part_params], dtype=np.float64).reshape(-1, 3)
        return p

    def cameras(self, x: FloatArray) -> tuple[PinholeCamera, ...]:
        """All cameras: the free ones at the poses in ``x``, the others as they are."""
        if not self.free_cameras.size:
            return self.base_cameras
        cams = list(self.base_cameras)
        poses = np.asarray(x[self.n_part_params :], dtype=np.float64).reshape(-1, 6)
        for c, pose in zip(self.free_cameras, poses, strict=True):
            try:
                cams[int(c)] = cams[int(c)].with_pose(pose)
            except GeometryError as exc:
                raise SolveError(f"camera {int(c)}: {exc}") from exc
        return tuple(cams)

    def x_from(self, params: FloatArray, cameras: Sequence[PinholeCamera] = ()) -> FloatArray:
        """The unknowns ``x`` of full part parameters (P, 3) and (if any are free) cameras."""
        xp = np.asarray(params, dtype=np.float64)[self.free_parts].reshape(-1)
        if not self.free_cameras.size:
            return xp
        cams = cameras or self.base_cameras
        xc = np.concatenate([cams[int(c)].pose for c in self.free_cameras])
        return np.concatenate([xp, xc])

    def raw(
        self, params: FloatArray, cameras: Sequence[PinholeCamera], *, jacobian: bool
    ) -> tuple[list[FloatArray], list[FloatArray], list[FloatArray | None]]:
        """Unweighted residuals (M, k) per block and, if asked, Jacobians by the unknowns.

        Returns residuals, Jacobians by the part parameters (M, k, a, 3) and by the camera
        pose (M, k, 6; edge blocks only, else None).
        """
        frames = self.problem.frames
        if jacobian:
            n, d, dn, dd = frames.planes_and_jacobian(params)
            G = np.concatenate([dn, dd[:, None, :]], axis=1)  # (P, 4, 3)
        else:
            n, d = frames.planes(params)
        rs: list[FloatArray] = []
        js: list[FloatArray] = []
        jcs: list[FloatArray | None] = []
        for b in self.blocks:
            # degenerate geometry gives non-finite values, which the callers check and name
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                r, J, Jc = b.evaluate(n, d, cameras)
            rs.append(r)
            if jacobian:
                js.append(np.einsum("mkaf,mafq->mkaq", J, G[b.idx]))
                jcs.append(Jc)
        return rs, js, jcs

    def residuals(self, x: FloatArray) -> FloatArray:
        """Weighted (and robustified) residual vector, (n_residuals,)."""
        rs, _, _ = self.raw(self.params(x), self.cameras(x), jacobian=False)
        out = [self._weigh(b, r)[0].reshape(-1) for b, r in zip(self.blocks, rs, strict=True)]
        return np.concatenate(out) if out else np.zeros(0)

    def residuals_and_jacobian(self, x: FloatArray) -> tuple[FloatArray, sp.csr_matrix]:
        """Weighted residual vector and its sparse Jacobian (n_residuals, n_params), CSR."""
        f, data = self._residuals_and_entries(x)
        values = np.bincount(self._slot, weights=data, minlength=self._csr_indices.size)
        jac = sp.csr_matrix(
            (values, self._csr_indices, self._csr_indptr), shape=(self.n_residuals, self.n_params)
        )
        return f, jac

    def residuals_and_dense_jacobian(self, x: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Weighted residual vector and its Jacobian as a dense (n_residuals, n_params) array
        (for small problems, where a dense factorisation beats an iterative solver)."""
        f, data = self._residuals_and_entries(x)
        size = self.n_residuals * self.n_params
        dense: FloatArray = np.bincount(self._flat, weights=data, minlength=size).astype(
            np.float64, copy=False
        )
        return f, dense.reshape(self.n_residuals, self.n_params)

    def jacobian(self, x: FloatArray) -> sp.csr_matrix:
        """The sparse Jacobian alone (CSR)."""
        return self.residuals_and_jacobian(x)[1]

    def _residuals_and_entries(self, x: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Weighted residuals and the Jacobian's entries in the order of ``rows``/``cols``."""
        rs, js, jcs = self.raw(self.params(x), self.cameras(x), jacobian=True)
        fs, vals = [], []
        for b, r, J, Jc, mask, cmask in zip(
            self.blocks, rs, js, jcs, self._masks, self._cam_masks, strict=True
        ):
            f, scale = self._weigh(b, r)
            fs.append(f.reshape(-1))
            vals.append((J * scale[:, :, None, None])[mask])
            if cmask is not None:
                assert Jc is not None
                vals.append((Jc * scale[:, :, None])[cmask])
        data = np.concatenate(vals) if vals else np.zeros(0)
        return (np.concatenate(fs) if fs else np.zeros(0)), data

    def _weigh(self, b: ConstraintBlock, r: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Weighted, robustified residuals (M, k) and the factor (M, k) for their Jacobian."""
        sw = np.broadcast_to(b.sqrt_weight[:, None], r.shape)
        f = sw * r
        if self.loss == "linear" or b.kind not in MEASUREMENT_KINDS:
            return f, sw
        fs = self.f_scale
        z = (f / fs) ** 2
        rho, drho = _robust(z, self.loss)
        small = z < 1e-24
        ratio = np.where(small, 1.0, np.sqrt(rho) / np.sqrt(np.where(small, 1.0, z)))
        # f~ = sign(f)·fs·sqrt(rho(z)) = f·ratio; df~/df = rho'(z)/ratio
        deriv = np.where(small, 1.0, drho / ratio)
        return f * ratio, sw * deriv


def _sub_block(b: ConstraintBlock, keep: npt.NDArray[np.bool_]) -> ConstraintBlock:
    return ConstraintBlock(
        kind=b.kind,
        members=b.members[keep],
        idx=b.idx[keep],
        sqrt_weight=b.sqrt_weight[keep],
        data={k: v[keep] for k, v in b.data.items()},
    )


def involved_parts(problem: Problem, active: Iterable[int]) -> frozenset[int]:
    """The parts that the constraints ``active`` relate."""
    return frozenset(int(p) for i in active for p in problem.constraints[i].parts)


def revalidate(problem: Problem) -> None:
    """Re-check a problem's constraints against its parts (after hand-made changes)."""
    validate(problem.constraints, problem.n_parts)
