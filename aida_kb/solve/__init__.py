"""Weighted least squares over parts and cameras, hierarchical refinement, residual report.

>>> from aida_kb.solve import build_problem, solve        # doctest: +SKIP
>>> problem = build_problem(normals, offsets, constraints, centres=centres)
>>> result = solve(problem)                                # or method="cg", levels=[main]
>>> result.report.exceeding                                # constraints over their threshold

From the knowledge base: `problem_from_kb(kb, "HouseBody", assignment, normals, offsets, ...)`.
"""

from __future__ import annotations

from aida_kb.solve.from_kb import KbConstraints, constraints_from_kb, problem_from_kb
from aida_kb.solve.problem import Evaluation, Problem, build_problem
from aida_kb.solve.report import (
    ConstraintResidual,
    ResidualReport,
    residual_report,
    residual_row,
)
from aida_kb.solve.solver import SolveResult, solve

__all__ = [
    "ConstraintResidual",
    "Evaluation",
    "KbConstraints",
    "Problem",
    "ResidualReport",
    "SolveResult",
    "build_problem",
    "constraints_from_kb",
    "problem_from_kb",
    "residual_report",
    "residual_row",
    "solve",
]
