"""Benchmark of the constraint solver (not a test). Prints ONE line of JSON at the end.

1. The paper-sized problem (28 surface elements, 51 constraints; `aida_kb.testing.houses`),
   started 3 degrees / 30 cm off: the default solver (trust-region least squares with the
   analytic Jacobian; ``tr_solver="auto"``, here "exact" on the dense Jacobian) against the
   paper's method (conjugate gradients with numerical gradients, scipy's defaults): wall time
   and final cost of each. The costs and their ratio are printed unrounded, so that
   ``cost_ratio_vs_cg <= 1`` means that our final cost is not above CG's (a rounded ratio of
   1.0 could hide a cost slightly above it); ``cost_diff_vs_cg`` is ours minus CG's.
2. The default solver on rows of such houses with about 100, 1,000 and 5,000 parts ("lsmr" on
   the sparse Jacobian at these sizes), and the growth exponent fitted to time ~ parts^k.

``speedup_vs_cg`` is the ratio of wall times (best of 5 for ours, before and after CG's single
run); ``speedup_vs_cg_cpu`` the ratio of this process's CPU times, which other processes'
load affects less. BLAS is limited to one thread (set before numpy loads): the problems are
sparse and their vectors small, and on a shared machine multithreaded BLAS calls on short
vectors cost milliseconds each. ``load_average_1min`` is the machine's load at the end.
Run: ``.venv/bin/python benchmarks/solver.py``.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import json  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from aida_kb.geometry.polygon import intersect_planes  # noqa: E402
from aida_kb.solve.problem import build_problem  # noqa: E402
from aida_kb.solve.solver import solve  # noqa: E402
from aida_kb.testing.houses import house_row, perturbed  # noqa: E402


def _problem(n_houses: int):  # type: ignore[no-untyped-def]
    scene = house_row(n_houses, seed=0)
    n0, d0 = perturbed(scene, seed=1, angle_deg=3.0, offset_m=0.3)
    return scene, build_problem(n0, d0, scene.constraints, centres=scene.centres)


def _best_of(runs: int, fn):  # type: ignore[no-untyped-def]
    """Best wall time, best CPU time (this process) and the last result of ``runs`` calls."""
    best, best_cpu, out = math.inf, math.inf, None
    for _ in range(runs):
        t, c = time.perf_counter(), time.process_time()
        out = fn()
        best = min(best, time.perf_counter() - t)
        best_cpu = min(best_cpu, time.process_time() - c)
    return best, best_cpu, out


def main() -> int:
    scene, problem = _problem(1)
    t_trf, c_trf, trf = _best_of(5, lambda: solve(problem))
    print(
        f"28 parts, trf ({'+'.join(trf.tr_solvers)}): {t_trf:.4f} s, cost {trf.cost!r}, "
        f"{trf.n_evaluations} evaluations",
        file=sys.stderr,
    )
    t_cg, c_cg, cg = _best_of(1, lambda: solve(problem, method="cg"))
    t_again, c_again, _ = _best_of(5, lambda: solve(problem))  # the load may have changed
    t_trf, c_trf = min(t_trf, t_again), min(c_trf, c_again)
    print(
        f"28 parts, cg: {t_cg:.2f} s, cost {cg.cost!r}, {cg.n_evaluations} evaluations "
        f"({cg.message})",
        file=sys.stderr,
    )
    v = intersect_planes(trf.normals[scene.vertex_planes], trf.offsets[scene.vertex_planes])
    vertex_err = float(np.max(np.linalg.norm(v - scene.vertices, axis=1)) / scene.size)

    sizes, times = [], []
    for target in (100, 1000, 5000):
        houses = math.ceil(target / 28)
        _, big = _problem(houses)
        runs = 3 if target < 5000 else 1
        t, _, res = _best_of(runs, lambda big=big: solve(big))
        sizes.append(big.n_parts)
        times.append(t)
        print(
            f"{big.n_parts} parts ({'+'.join(res.tr_solvers)}): {t:.3f} s, "
            f"{res.n_evaluations} evaluations, success {res.success}",
            file=sys.stderr,
        )
    slope = float(np.polyfit(np.log(sizes), np.log(times), 1)[0])
    out = {
        "benchmark": "solver",
        "parts": 28,
        "constraints": len(scene.constraints),
        "trf_tr_solver": "+".join(trf.tr_solvers),
        "trf_time_s": round(t_trf, 5),
        "trf_evaluations": trf.n_evaluations,
        "trf_cost": trf.cost,
        "cg_time_s": round(t_cg, 3),
        "cg_cost": cg.cost,
        "cg_evaluations": cg.n_evaluations,
        "cg_converged": cg.success,
        "speedup_vs_cg": round(t_cg / t_trf, 1),
        "speedup_vs_cg_cpu": round(c_cg / c_trf, 1),
        "cost_ratio_vs_cg": trf.cost / cg.cost,
        "cost_diff_vs_cg": trf.cost - cg.cost,
        "vertex_error_rel": round(vertex_err, 5),
        "parts_sizes": sizes,
        "t_100_s": round(times[0], 4),
        "t_1000_s": round(times[1], 4),
        "t_5000_s": round(times[2], 4),
        "growth_exponent": round(slope, 3),
        "blas_threads": os.environ.get("OPENBLAS_NUM_THREADS"),
        "load_average_1min": round(os.getloadavg()[0], 2),
    }
    print(json.dumps(out))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
