"""Solving a `Problem`: sparse trust-region least squares (default) or the paper's CG.

``solve(problem)`` minimises the paper's eq. 6, the sum of all weighted constraint costs, over
the parameters of the free parts. Methods:

* ``"trf"`` (default): ``scipy.optimize.least_squares`` (trust region reflective) with the
  analytic sparse Jacobian and ``tr_solver="lsmr"``.
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
from scipy.optimize import least_squares, minimize

from aida_kb.errors import SolveError
from aida_kb.geometry.camera import PinholeCamera
from aida_kb.solve.problem import Evaluation, Loss, Problem
from aida_kb.solve.report import ResidualReport, residual_report

FloatArray = npt.NDArray[np.float64]

Method = Literal["trf", "cg"]


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


def _check_options(method: str, loss: str, f_scale: float) -> None:
    if method not in ("trf", "cg"):
        raise SolveError(f"unknown method {method!r} (trf or cg)")
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
) -> SolveResult:
    """Minimise the weighted sum of constraint costs (paper eq. 6) over the free parts.

    Parameters
    ----------
    problem : the problem (`aida_kb.solve.build_problem`).
    method : "trf" (sparse least squares, default) or "cg" (the paper's conjugate gradients
        with numerical gradients).
    loss : "linear", "soft_l1" or "huber": robust loss on measurement constraints only.
    f_scale : the robust loss's soft threshold, in whitened units (multiples of sigma).
    levels : hierarchical mode: lists of part indices, solved level by level, each fixed
        before the next is added.
    max_iterations : cap on function evaluations (trf) or iterations (cg); default scipy's.
    tolerance : ftol, xtol and gtol of least_squares; gtol of CG is ``1e-5`` (scipy's default).

    Raises
    ------
    SolveError
        Bad options or a non-finite residual at the start or the end.
    """
    _check_options(method, loss, f_scale)
    start = time.perf_counter()
    stages = _levels(problem, levels)
    params = np.zeros((problem.n_parts, 3))
    cameras = problem.cameras
    fixed = set(problem.fixed_parts)
    allowed: set[int] = set(fixed)
    n_eval = 0
    success = True
    message = "no free parts"
    constraint_parts = [frozenset(int(p) for p in c.parts) for c in problem.constraints]
    for level in stages:
        allowed |= level
        active = [i for i, ps in enumerate(constraint_parts) if ps <= allowed]
        involved = {p for i in active for p in constraint_parts[i]}
        free = np.array(sorted((involved & level) - fixed), dtype=np.intp)
        seen_by = {
            int(problem.constraints[i].edge.camera)  # type: ignore[union-attr]
            for i in active
            if problem.constraints[i].kind == "edge"
        }
        free_cams = np.array(sorted(seen_by & problem.free_cameras), dtype=np.intp)
        if (free.size or free_cams.size) and active:
            ev = Evaluation(
                problem, free, active, free_cameras=free_cams, loss=loss, f_scale=f_scale
            )
            ev.base_params = params
            ev.base_cameras = cameras
            x0 = ev.x_from(params, cameras)
            f0 = ev.residuals(x0)
            if not np.all(np.isfinite(f0)):
                bad = int(np.argmax(~np.isfinite(f0)))
                raise SolveError(f"residual {bad} is not finite at the start (degenerate planes?)")
            x, nfev, ok, message = _run(ev, x0, method, max_iterations, tolerance)
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
    )


def _run(
    ev: Evaluation, x0: FloatArray, method: str, max_iterations: int | None, tolerance: float
) -> tuple[FloatArray, int, bool, str]:
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

    cache: dict[str, object] = {}
    n_res = ev.n_residuals

    def fun(x: FloatArray) -> FloatArray:
        try:
            f, J = ev.residuals_and_jacobian(x)
        except SolveError:
            # a trial step with no residual (an edge behind a free camera, degenerate planes):
            # a cost far above the start's makes the trust region reject it and shrink
            return np.full(n_res, 1e8)
        cache["x"] = x.copy()
        cache["J"] = J
        return f

    def jac(x: FloatArray) -> object:
        cx = cache.get("x")
        if isinstance(cx, np.ndarray) and np.array_equal(cx, x):
            return cache["J"]
        return ev.jacobian(x)

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
