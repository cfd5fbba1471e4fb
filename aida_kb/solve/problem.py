"""A weighted least-squares problem over planar parts: parameters, constraint blocks, sparsity.

`Problem` holds the parts' initial frames (`aida_kb.geometry.frames.PartFrames`), the
constraints and which parts are held fixed. `Evaluation` is its compiled form for one set of
free parts and active constraints: it maps the free parameter vector ``x`` (3 per free part:
delta m, alpha rad, beta rad, in part order) to the weighted residual vector and its sparse
analytic Jacobian (scipy CSR), evaluating every constraint kind in one vectorised call.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from aida_kb.constraints import Constraint, ConstraintBlock, compile_blocks
from aida_kb.errors import GeometryError, SolveError
from aida_kb.geometry.camera import PinholeCamera
from aida_kb.geometry.frames import PartFrames
from aida_kb.geometry.rig import Rig

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

Loss = Literal["linear", "soft_l1", "huber"]

_LOSS_BY_CODE: tuple[Loss, ...] = ("linear", "soft_l1", "huber")  # constraints.model.LOSS_CODES


@dataclass(frozen=True)
class Problem:
    """Parts, constraints and the parts held fixed.

    Attributes
    ----------
    frames : the parts' initial local frames (P parts); parameters are relative to them.
    constraints : the constraints, part indices into ``0..P-1``.
    fixed_parts : parts whose planes are not moved.
    names : optional part names (role paths) for messages and reports.
    cameras : the cameras that camera constraints (edge, camera_position) refer to.
    free_cameras : cameras whose poses ``[rvec, C]`` are unknowns (viewpoint registration);
        the others are fixed.
    derived : ``(j, i, rig)``: camera j is the second camera of a stereo rig whose first is
        camera i; its pose follows camera i's (a derived key: free when camera i is).
    """

    frames: PartFrames
    constraints: tuple[Constraint, ...]
    fixed_parts: frozenset[int] = frozenset()
    names: tuple[str, ...] = ()
    blocks: tuple[ConstraintBlock, ...] = field(default=(), repr=False, compare=False)
    cameras: tuple[PinholeCamera, ...] = ()
    free_cameras: frozenset[int] = frozenset()
    derived: tuple[tuple[int, int, Rig], ...] = ()

    @property
    def n_parts(self) -> int:
        """Number of parts P."""
        return self.frames.n_parts

    def part_name(self, i: int) -> str:
        """The name of part ``i`` (its role path if given, else ``part i``)."""
        return self.names[i] if i < len(self.names) else f"part {i}"

    def describe(self, i: int) -> str:
        """Constraint ``i`` for messages: index, label, where it was declared, kind and parts."""
        c = self.constraints[i]
        parts = ", ".join(self.part_name(int(p)) for p in c.parts)
        label = f" '{c.label}'" if c.label else ""
        where = f" at {c.origin.where}" if c.origin is not None and c.origin.span else ""
        return f"constraint {i}{label} ({c.kind} of {parts}){where}"

    def base_camera(self, j: int) -> int:
        """The camera whose pose camera ``j``'s follows (``j`` itself unless derived)."""
        for derived, base, _ in self.derived:
            if derived == j:
                return base
        return j


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
    derived: Sequence[tuple[int, int, Rig]] = (),
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
    derived : ``(j, i, rig)``: camera j is rig's second camera of camera i (its start pose is
        replaced by the one the rig gives; it is free when camera i is).

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
    links = tuple((int(j), int(i), rig) for j, i, rig in derived)
    cam_list = list(cams)
    for j, i, rig in links:
        _check_parts((j, i), len(cams), "derived camera")
        if j == i or j in free_cams or any(i == jj for jj, _, _ in links):
            raise SolveError(
                f"derived camera {j}: must follow another camera ({i}) that is not itself "
                "derived, and cannot be free itself"
            )
        cam_list[j] = rig.right_of(cam_list[i])
    cons = tuple(constraints)
    blocks = compile_blocks(cons, frames.n_parts, len(cams))
    return Problem(frames, cons, fixed, tuple(names), blocks, tuple(cam_list), free_cams, links)


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
    of ``free_cameras``). A derived camera (`Problem.derived`) has no unknowns of its own: its
    constraints' pose Jacobians are chained onto its base camera's columns.

    Parameters
    ----------
    problem : the problem.
    free_parts : (F,) sorted indices of the parts whose parameters are unknowns.
    active : indices of the constraints taken into account (default all).
    free_cameras : (G,) indices of the cameras whose poses are unknowns.
    loss, f_scale : the default robust loss of measurement constraints (those whose own
        ``loss`` is None), applied to each constraint's whitened block norm (``f_scale`` in
        whitened units, i.e. multiples of sigma).
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
        n_cams = len(problem.cameras)
        self.col_of_part = np.full(P, -1, dtype=np.intp)
        self.col_of_part[self.free_parts] = np.arange(self.free_parts.size)
        self.col_of_camera = np.full(n_cams, -1, dtype=np.intp)
        self.col_of_camera[self.free_cameras] = np.arange(self.free_cameras.size)
        for j, i, _ in problem.derived:  # a derived camera moves with its base
            self.col_of_camera[j] = self.col_of_camera[i]
        self.n_part_params = 3 * int(self.free_parts.size)
        self.n_params = self.n_part_params + 6 * int(self.free_cameras.size)
        if active is None:
            blocks = problem.blocks
        else:
            keep = np.zeros(len(problem.constraints), dtype=bool)
            keep[np.asarray(list(active), dtype=np.intp)] = True
            blocks = tuple(b.subset(keep[b.members]) for b in problem.blocks)
            blocks = tuple(b for b in blocks if b.size)
        self.blocks = blocks
        # residual rows and the Jacobian's sparsity pattern, block by block
        rows_all: list[IntArray] = []
        cols_all: list[IntArray] = []
        self._masks: list[npt.NDArray[np.bool_]] = []
        self._cam_masks: list[npt.NDArray[np.bool_] | None] = []
        self._cam_wanted: list[bool] = []
        row = 0
        for b in blocks:
            k = b.kind.residual_size
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
            if b.camera is not None and self.free_cameras.size:
                cam_col = self.col_of_camera[b.camera]  # (M,)
                cshape = (M, k, 6)
                cam_mask = np.broadcast_to(cam_col[:, None, None] >= 0, cshape)
                ccols = self.n_part_params + 6 * cam_col[:, None, None] + np.arange(6)
                rows_all.append(np.broadcast_to(rows[:, :, None], cshape)[cam_mask])
                cols_all.append(np.broadcast_to(ccols, cshape)[cam_mask])
            self._cam_masks.append(cam_mask)
            # the block's Jacobian by the poses is wanted only where it sees a free camera
            self._cam_wanted.append(cam_mask is not None and bool(np.any(cam_mask)))
            row += M * k
        self.n_residuals = row
        # the constraint of each residual row (messages about degenerate geometry)
        self.constraint_of_row = (
            np.concatenate(
                [np.repeat(b.members, b.kind.residual_size).astype(np.intp) for b in blocks]
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
        """All cameras: the free ones at the poses in ``x``, derived ones following their
        base, the others as they are."""
        if not self.free_cameras.size:
            return self.base_cameras
        cams = list(self.base_cameras)
        poses = np.asarray(x[self.n_part_params :], dtype=np.float64).reshape(-1, 6)
        for c, pose in zip(self.free_cameras, poses, strict=True):
            try:
                cams[int(c)] = cams[int(c)].with_pose(pose)
            except GeometryError as exc:
                raise SolveError(f"camera {int(c)}: {exc}") from exc
        for j, i, rig in self.problem.derived:
            cams[j] = rig.right_of(cams[i])
        return tuple(cams)

    def x_from(self, params: FloatArray, cameras: Sequence[PinholeCamera] = ()) -> FloatArray:
        """The unknowns ``x`` of full part parameters (P, 3) and (if any are free) cameras."""
        xp = np.asarray(params, dtype=np.float64)[self.free_parts].reshape(-1)
        if not self.free_cameras.size:
            return xp
        cams = cameras or self.base_cameras
        xc = np.concatenate([cams[int(c)].pose for c in self.free_cameras])
        return np.concatenate([xp, xc])

    def _pose_chain(self, cameras: Sequence[PinholeCamera]) -> FloatArray | None:
        """(n_cameras, 6, 6): d(camera pose)/d(its base's pose) — the identity except for
        derived cameras (`aida_kb.geometry.rig.Rig.pose_jacobian`); None without any."""
        if not self.problem.derived:
            return None
        chain = np.broadcast_to(np.eye(6), (len(cameras), 6, 6)).copy()
        for j, i, rig in self.problem.derived:
            chain[j] = rig.pose_jacobian(cameras[i].pose)[1]
        return chain

    def raw(
        self, params: FloatArray, cameras: Sequence[PinholeCamera], *, jacobian: bool
    ) -> tuple[list[FloatArray], list[FloatArray], list[FloatArray | None]]:
        """Unweighted residuals (M, k) per block and, if asked, Jacobians by the unknowns.

        Returns residuals, Jacobians by the part parameters (M, k, a, 3) and by the pose of
        each constraint's (base) camera (M, k, 6; camera kinds seeing a free camera only, else
        None: a block whose cameras are all held skips that work).
        """
        frames = self.problem.frames
        chain = None
        if jacobian:
            n, d, dn, dd = frames.planes_and_jacobian(params)
            G = np.concatenate([dn, dd[:, None, :]], axis=1)  # (P, 4, 3)
            chain = self._pose_chain(cameras)
        else:
            n, d = frames.planes(params)
        rs: list[FloatArray] = []
        js: list[FloatArray] = []
        jcs: list[FloatArray | None] = []
        for b, wanted in zip(self.blocks, self._cam_wanted, strict=True):
            # degenerate geometry gives non-finite values, which the callers check and name
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                r, J, Jc = b.evaluate(n, d, cameras, camera_jacobian=jacobian and wanted)
            rs.append(r)
            if jacobian:
                js.append(np.einsum("mkaf,mafq->mkaq", J, G[b.idx]))
                if Jc is not None and chain is not None and b.camera is not None:
                    Jc = np.einsum("mkp,mpq->mkq", Jc, chain[b.camera])
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
        for b, r, J, Jc, mask, cmask, wanted in zip(
            self.blocks, rs, js, jcs, self._masks, self._cam_masks, self._cam_wanted, strict=True
        ):
            f, scale = self._weigh(b, r)
            fs.append(f.reshape(-1))
            if scale.ndim == 1:  # a scalar per constraint
                vals.append((J * scale[:, None, None, None])[mask])
            else:
                vals.append(np.einsum("mij,mjaq->miaq", scale, J)[mask])
            if wanted:
                assert cmask is not None
                assert Jc is not None
                if scale.ndim == 1:
                    vals.append((Jc * scale[:, None, None])[cmask])
                else:
                    vals.append(np.einsum("mij,mjq->miq", scale, Jc)[cmask])
        data = np.concatenate(vals) if vals else np.zeros(0)
        return (np.concatenate(fs) if fs else np.zeros(0)), data

    def _weigh(self, b: ConstraintBlock, r: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Whitened, robustified residuals (M, k) and what takes the residuals' Jacobian to
        theirs: a factor (M,) per constraint, or matrices (M, k, k).

        The robust loss acts on each constraint's whitened block ``f``: with ``z = |f|²/s²``,
        ``f~ = ratio·f``, ``ratio = sqrt(rho(z)/z)``, so that ``|f~|² = s²·rho(z)``; its exact
        derivative is ``df~/df = ratio·I + c·f fᵀ`` with ``c = (rho'·z - rho)/(s² z² ratio)``
        (for one component: ``rho'/ratio``).
        """
        f = b.whiten(r)
        W: FloatArray = b.sqrt_weight
        if b.sqrt_information is not None:
            W = b.sqrt_weight[:, None, None] * b.sqrt_information
        code = b.loss.astype(np.intp)
        if b.kind.measurement:
            code = np.where(code < 0, _LOSS_BY_CODE.index(self.loss), code)
        else:
            code = np.where(code < 0, 0, code)
        if not np.any(code):
            return f, W
        fs = np.where(np.isnan(b.loss_scale), self.f_scale, b.loss_scale)
        z = np.sum(f * f, axis=1) / fs**2
        ratio = np.ones(b.size)
        c = np.zeros(b.size)
        for code_k in np.unique(code[code > 0]):
            sel = (code == code_k) & (z > 1e-24)  # below: the loss is the identity
            zs = z[sel]
            rho, drho = _robust(zs, _LOSS_BY_CODE[int(code_k)])
            rt = np.sqrt(rho / zs)
            ratio[sel] = rt
            c[sel] = (drho * zs - rho) / (fs[sel] ** 2 * zs**2 * rt)
        k = f.shape[1]
        D = ratio[:, None, None] * np.eye(k) + c[:, None, None] * np.einsum("mi,mj->mij", f, f)
        if W.ndim == 1:
            return f * ratio[:, None], D * W[:, None, None]
        return f * ratio[:, None], np.einsum("mij,mjl->mil", D, W)
