"""Solving a `Problem`: sparse trust-region least squares (default) or the paper's CG.

``solve(problem)`` minimises the paper's eq. 6, the sum of all weighted constraint costs, over
the parameters of the free parts. Methods:

* ``"trf"`` (default): ``scipy.optimize.least_squares`` (trust region reflective) with the
  analytic Jacobian. Its trust-region linear solver (``tr_solver``) is chosen by size with
  ``"auto"``: up to `EXACT_MAX_UNKNOWNS` unknowns, ``"exact"`` on the dense Jacobian (an SVD per
  iteration: exact steps, the lowest cost, no iterative-solver overhead on small problems; see
  `INITIAL_RADIUS` and `ANCHOR`); above it, ``"lsmr"`` on the sparse CSR Jacobian (memory and
  time about linear in the problem's size).
* ``"cg"``: the paper's method, ``scipy.optimize.minimize(method="CG")`` on the summed cost
  with numerical (finite-difference) gradients, for comparison.

Hierarchical mode (paper §5): ``levels=[main_parts, smaller_parts, ...]`` solves the first
level with the constraints among its parts, fixes it, then adds the next level, and so on;
parts in no level form a last level. Parts that no active constraint relates are not moved.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
from scipy.optimize import least_squares, minimize

from aida_kb.constraints import kind_of
from aida_kb.errors import SolveError
from aida_kb.geometry.camera import PinholeCamera
from aida_kb.solve.problem import Evaluation, Loss, Problem
from aida_kb.solve.report import ResidualReport, residual_report

FloatArray = npt.NDArray[np.float64]

Method = Literal["trf", "cg"]
TrSolver = Literal["auto", "exact", "lsmr"]

EXACT_MAX_UNKNOWNS = 100
"""``tr_solver="auto"`` uses ``"exact"`` (dense SVD) up to this many unknowns of a level
(about 33 free parts, or a 28-part house and two free cameras), ``"lsmr"`` (sparse) above.
Measured on rows of synthetic houses (one BLAS thread): at 28 parts (84 unknowns) the dense
solve is faster than lsmr and reaches the lower cost; at 56 parts the dense SVD per iteration
(cost ~ residuals x unknowns²) makes it twice as slow, while lsmr's time stays about linear."""


INITIAL_RADIUS = 100.0
"""Dense ("exact") path: size of the first trust region. ``x_scale`` is this over the start's
Jacobian column norms, so that each unknown may at first change the whitened residuals by up
to that much (MINPACK's ``factor``) rather than by 1 (scipy's trf with ``x_scale="jac"``,
which then spends its first iterations growing the region). On the 28-part house it halves
the iterations (7 instead of 14 from 3 degrees / 30 cm off). Unknowns that no residual depends
on get ``x_scale`` 1."""


ANCHOR = 1e-6
"""Dense ("exact") path: the problem gets one more residual per unknown, ``ANCHOR · s_j ·
(x_j - x0_j)`` with ``s_j`` the unknown's column norm at the start (at least their RMS):
directions that the constraints leave undetermined (a roof face that only a symmetry relates;
singular values at rounding level) keep their start instead of drifting on rounding noise or
on a wide trust region (radians of "small" rotation). Determined directions are shifted by
~ANCHOR² of their step: nothing that the costs can show. The reported costs leave these
residuals out. (The sparse path keeps scipy's ``x_scale="jac"``, first trust region and
lsmr's damping.)"""


def choose_tr_solver(n_unknowns: int, tr_solver: TrSolver = "auto") -> Literal["exact", "lsmr"]:
    """The trust-region linear solver for a level with ``n_unknowns`` unknowns.

    ``"auto"`` gives ``"exact"`` up to `EXACT_MAX_UNKNOWNS` unknowns, else ``"lsmr"``; an
    explicit ``"exact"`` or ``"lsmr"`` is returned as it is.
    """
    if tr_solver == "exact" or tr_solver == "lsmr":
        return tr_solver
    return "exact" if n_unknowns <= EXACT_MAX_UNKNOWNS else "lsmr"


@dataclass(frozen=True)
class SolveResult:
    """The outcome of `solve`.

    Attributes
    ----------
    params : (P, 3) part parameters (delta m, alpha rad, beta rad) relative to the problem's
        frames; fixed parts have zeros.
    normals : (P, 3) unit normals, world frame; offsets : (P,) metres; centres : (P, 3) metres.
    report : the residual report at the solution.
    cost : the final eq. 6 cost (sum of the constraint costs, without robust loss).
    cameras : the problem's cameras, the free ones at their solved poses.
    method : "trf" or "cg"; n_evaluations : residual evaluations (all levels; a numerical
        gradient counts its evaluations); time_s : wall time of the solve, seconds.
    success : whether every level converged; message : the optimiser's last message.
    tr_solvers : the trust-region linear solver used by each solved level ("exact" or
        "lsmr"; empty for "cg" or when nothing was free).
    """

    params: FloatArray
    normals: FloatArray
    offsets: FloatArray
    centres: FloatArray
    report: ResidualReport
    cost: float
    cameras: tuple[PinholeCamera, ...]
    method: str
    n_evaluations: int
    time_s: float
    success: bool
    message: str
    tr_solvers: tuple[str, ...] = ()


def _check_options(method: str, loss: str, f_scale: float, tr_solver: str) -> None:
    if method not in ("trf", "cg"):
        raise SolveError(f"unknown method {method!r} (trf or cg)")
    if tr_solver not in ("auto", "exact", "lsmr"):
        raise SolveError(f"unknown tr_solver {tr_solver!r} (auto, exact or lsmr)")
    if loss not in ("linear", "soft_l1", "huber"):
        raise SolveError(f"unknown loss {loss!r} (linear, soft_l1 or huber)")
    if not np.isfinite(f_scale) or f_scale <= 0:
        raise SolveError(f"f_scale must be a finite number > 0, got {f_scale!r}")


def _levels(problem: Problem, levels: Sequence[Sequence[int]] | None) -> list[frozenset[int]]:
    P = problem.n_parts
    if not levels:
        return [frozenset(range(P))]
    out: list[frozenset[int]] = []
    seen: set[int] = set()
    for k, level in enumerate(levels):
        lv = set()
        for p in level:
            if not isinstance(p, int | np.integer) or not 0 <= int(p) < P:
                raise SolveError(f"level {k}: unknown part index {p!r} (the problem has {P} parts)")
            if int(p) in seen:
                raise SolveError(f"level {k}: part {problem.part_name(int(p))} is in two levels")
            lv.add(int(p))
        seen |= lv
        out.append(frozenset(lv))
    rest = frozenset(range(P)) - seen
    if rest:
        out.append(rest)
    return out


def solve(
    problem: Problem,
    *,
    method: Method = "trf",
    loss: Loss = "linear",
    f_scale: float = 1.0,
    levels: Sequence[Sequence[int]] | None = None,
    max_iterations: int | None = None,
    tolerance: float = 1e-10,
    tr_solver: TrSolver = "auto",
) -> SolveResult:
    """Minimise the weighted sum of constraint costs (paper eq. 6) over the free parts.

    Parameters
    ----------
    problem : the problem (`aida_kb.solve.build_problem`).
    method : "trf" (sparse least squares, default) or "cg" (the paper's conjugate gradients
        with numerical gradients).
    loss : "linear", "soft_l1" or "huber": the default robust loss of measurement
        constraints (a constraint's own ``loss`` overrides it), on its whitened block norm.
    f_scale : the default loss's soft threshold, in whitened units (multiples of sigma).
    levels : hierarchical mode: lists of part indices, solved level by level, each fixed
        before the next is added.
    max_iterations : cap on function evaluations (trf) or iterations (cg); default scipy's.
    tolerance : ftol, xtol and gtol of least_squares; gtol of CG is ``1e-5`` (scipy's default).
    tr_solver : "auto" (default: "exact" on the dense Jacobian up to `EXACT_MAX_UNKNOWNS`
        unknowns per level, else "lsmr" on the sparse one), "exact" or "lsmr" (trf only).

    Raises
    ------
    SolveError
        Bad options or a non-finite residual at the start or the end.
    """
    _check_options(method, loss, f_scale, tr_solver)
    start = time.perf_counter()
    stages = _levels(problem, levels)
    params = np.zeros((problem.n_parts, 3))
    cameras = problem.cameras
    fixed = set(problem.fixed_parts)
    allowed: set[int] = set(fixed)
    n_eval = 0
    success = True
    message = "no free parts"
    used: list[str] = []
    constraint_parts = [frozenset(int(p) for p in c.parts) for c in problem.constraints]
    cameras_of = [kind_of(c.kind).camera(c) for c in problem.constraints]
    for level in stages:
        allowed |= level
        active = [i for i, ps in enumerate(constraint_parts) if ps <= allowed]
        involved = {p for i in active for p in constraint_parts[i]}
        free = np.array(sorted((involved & level) - fixed), dtype=np.intp)
        seen_by = {problem.base_camera(cam) for i in active if (cam := cameras_of[i]) is not None}
        free_cams = np.array(sorted(seen_by & problem.free_cameras), dtype=np.intp)
        if (free.size or free_cams.size) and active:
            ev = Evaluation(
                problem, free, active, free_cameras=free_cams, loss=loss, f_scale=f_scale
            )
            ev.base_params = params
            ev.base_cameras = cameras
            x0 = ev.x_from(params, cameras)
            linear = choose_tr_solver(ev.n_params, tr_solver)
            dense = method == "trf" and linear == "exact"
            start_eval = (
                ev.residuals_and_dense_jacobian(x0) if dense else ev.residuals_and_jacobian(x0)
            )
            f0 = start_eval[0]
            if not np.all(np.isfinite(f0)):
                bad = int(ev.constraint_of_row[int(np.argmax(~np.isfinite(f0)))])
                raise SolveError(
                    f"{problem.describe(bad)}: no finite residual at the start: degenerate "
                    "geometry (e.g. parallel planes where an edge is needed, opposite normals "
                    "where a parallel constraint wants them alike)"
                )
            x, nfev, ok, message = _run(
                ev, x0, method, max_iterations, tolerance, linear, start_eval
            )
            if method == "trf":
                used.append(linear)
            params = ev.params(x)
            cameras = ev.cameras(x)
            n_eval += nfev
            success = success and ok
        fixed |= level
    n, d = problem.frames.planes(params)
    report = residual_report(problem, params, cameras)
    return SolveResult(
        params=params,
        normals=n,
        offsets=d,
        centres=problem.frames.centres(params),
        report=report,
        cost=report.total_cost,
        cameras=cameras,
        method=method,
        n_evaluations=n_eval,
        time_s=time.perf_counter() - start,
        success=success,
        message=message,
        tr_solvers=tuple(used),
    )


def _run(
    ev: Evaluation,
    x0: FloatArray,
    method: str,
    max_iterations: int | None,
    tolerance: float,
    tr_solver: Literal["exact", "lsmr"],
    start: tuple[FloatArray, FloatArray | sp.csr_matrix],
) -> tuple[FloatArray, int, bool, str]:
    """Minimise from ``x0``; ``start`` is the evaluation at ``x0`` (residuals and the Jacobian,
    dense for the exact path)."""
    if method == "cg":
        calls = [0]

        def total(x: FloatArray) -> float:
            calls[0] += 1
            f = ev.residuals(x)
            return float(f @ f)

        options: dict[str, float | int] = {}
        if max_iterations is not None:
            options["maxiter"] = max_iterations
        res = minimize(total, x0, method="CG", options=options)
        return np.asarray(res.x), calls[0], bool(res.success), str(res.message)

    # the kernels give residuals and Jacobian in one pass: keep the last evaluation for
    # least_squares' calls at the same x (its first call; jac after an accepted step)
    dense = tr_solver == "exact"
    evaluate = ev.residuals_and_dense_jacobian if dense else ev.residuals_and_jacobian
    f0, J0 = start
    cache: dict[str, object] = {"x": x0.copy(), "f": f0, "J": J0}
    n_res = ev.n_residuals

    def fun(x: FloatArray) -> FloatArray:
        cx = cache["x"]
        if not (isinstance(cx, np.ndarray) and np.array_equal(cx, x)):
            try:
                f, J = evaluate(x)
            except SolveError:
                # a trial step with no residual (an edge behind a free camera, degenerate
                # planes): a cost far above the start's makes the trust region reject it
                return np.full(n_res, 1e8)
            cache.update(x=x.copy(), f=f, J=J)
        return np.asarray(cache["f"])

    def jac(x: FloatArray) -> object:
        # least_squares asks at accepted points only, which have residuals
        cx = cache["x"]
        if not (isinstance(cx, np.ndarray) and np.array_equal(cx, x)):
            f, J = evaluate(x)
            cache.update(x=x.copy(), f=f, J=J)
        return cache["J"]

    if not dense:
        # sparse: scipy's column scaling and first trust region, lsmr's own damping
        res = least_squares(
            fun,
            x0,
            jac=jac,
            method="trf",
            tr_solver="lsmr",
            x_scale="jac",
            ftol=tolerance,
            xtol=tolerance,
            gtol=tolerance,
            max_nfev=max_iterations,
        )
        return np.asarray(res.x), int(res.nfev), bool(res.status > 0), str(res.message)

    # dense: a MINPACK-sized first trust region and the anchor rows (see ANCHOR)
    norms = _column_norms(np.asarray(J0))
    anchor = ANCHOR * np.maximum(norms, np.sqrt(np.mean(norms**2)))
    anchor_rows = np.diag(anchor)
    scale = np.where(norms > 1e-12, INITIAL_RADIUS / np.where(norms > 1e-12, norms, 1.0), 1.0)

    def fun_anchored(x: FloatArray) -> FloatArray:
        return np.concatenate([fun(x), anchor * (x - x0)])

    def jac_anchored(x: FloatArray) -> FloatArray:
        return np.vstack([np.asarray(jac(x)), anchor_rows])

    res = least_squares(
        fun_anchored,
        x0,
        jac=jac_anchored,
        method="trf",
        tr_solver="exact",
        x_scale=scale,
        ftol=tolerance,
        xtol=tolerance,
        gtol=tolerance,
        max_nfev=max_iterations,
    )
    return np.asarray(res.x), int(res.nfev), bool(res.status > 0), str(res.message)


def _column_norms(J: FloatArray) -> FloatArray:
    """Euclidean norms of a dense Jacobian's columns (n_params,)."""
    out: FloatArray = np.sqrt(np.einsum("ij,ij->j", J, J))
    return out
