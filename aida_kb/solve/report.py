"""The residual report: every constraint's final cost, normalised cost and rejection flag.

For constraint i with unweighted residual vector ``e_i`` (its unit), weight ``W_i``,
multiplicity ``m_i`` (``w_c`` for a position constraint, else 1) and tolerance ``sigma_i``
(``1/sqrt(W_i)`` when only a weight is given):

* ``residual = |e_i|`` (for angle kinds: the angle error in rad),
* ``cost = m_i · W_i · |e_i|²`` (its term of the paper's eq. 6),
* ``normalised_cost = m_i · |e_i|² / sigma_i²`` (chi-square-like, ``DOF[kind]`` degrees of
  freedom),
* ``threshold``: ``m_i · (reject_above / sigma_i)²`` when the constraint has ``reject_above``
  (then ``exceeds`` is exactly ``residual > reject_above``), else the 99.9 % chi-square quantile,
* ``exceeds = normalised_cost > threshold``: what the interpreter rejects hypotheses by.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from aida_kb.constraints.model import CHI2_999, DOF
from aida_kb.errors import SolveError
from aida_kb.geometry.camera import PinholeCamera
from aida_kb.solve.problem import Evaluation, Problem

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class ConstraintResidual:
    """One constraint's line of the report (see the module docstring for the definitions)."""

    index: int
    label: str
    kind: str
    parts: tuple[int, ...]
    unit: str
    measurement: bool
    residual: float
    cost: float
    normalised_cost: float
    threshold: float
    exceeds: bool


@dataclass(frozen=True)
class ResidualReport:
    """The report of all constraints of a problem, in the problem's constraint order."""

    rows: tuple[ConstraintResidual, ...]

    @property
    def total_cost(self) -> float:
        """Sum of all constraint costs (the paper's eq. 6, without robust loss)."""
        return float(sum(r.cost for r in self.rows))

    @property
    def reduced_cost(self) -> float:
        """Sum of the normalised costs over their degrees of freedom (a reduced chi-square).

        About 1 when every constraint misses by about its sigma; 0 for an empty report.
        """
        dof = sum(DOF[r.kind] for r in self.rows)
        return float(sum(r.normalised_cost for r in self.rows) / dof) if dof else 0.0

    @property
    def exceeding(self) -> tuple[ConstraintResidual, ...]:
        """The constraints whose normalised cost exceeds their threshold."""
        return tuple(r for r in self.rows if r.exceeds)

    def by_label(self, label: str) -> ConstraintResidual:
        """The row of the constraint labelled ``label`` (SolveError if none or several)."""
        found = [r for r in self.rows if r.label == label]
        if len(found) != 1:
            raise SolveError(f"report: {len(found)} constraints labelled {label!r}")
        return found[0]

    def format(self) -> str:
        """A plain-text table, one line per constraint."""
        lines = [f"{'label':30} {'kind':13} {'residual':>12} {'norm. cost':>11} {'thresh':>9}  "]
        for r in self.rows:
            flag = "REJECT" if r.exceeds else ""
            lines.append(
                f"{r.label[:30]:30} {r.kind:13} {r.residual:12.4g} {r.normalised_cost:11.4g} "
                f"{r.threshold:9.4g}  {flag}"
            )
        return "\n".join(lines)


def residual_report(
    problem: Problem, params: FloatArray, cameras: Sequence[PinholeCamera] | None = None
) -> ResidualReport:
    """The report of ``problem`` at part parameters ``params`` (P, 3) and ``cameras``
    (default: the problem's cameras).

    Raises
    ------
    SolveError
        If a residual is not finite (degenerate geometry).
    """
    ev = Evaluation(problem, np.zeros(0, dtype=np.intp))
    cams = problem.cameras if cameras is None else tuple(cameras)
    rs, _, _ = ev.raw(np.asarray(params, dtype=np.float64), cams, jacobian=False)
    norms = np.zeros(len(problem.constraints))
    for b, r in zip(ev.blocks, rs, strict=True):
        norms[b.members] = np.linalg.norm(r, axis=1)
    rows = []
    for i, c in enumerate(problem.constraints):
        e = float(norms[i])
        if not math.isfinite(e):
            raise SolveError(f"{problem.describe(i)}: residual is not finite (degenerate geometry)")
        weight = c.effective_weight
        mult = c.position.w_c if c.position is not None else 1.0
        sigma = c.sigma if c.sigma is not None else 1.0 / math.sqrt(weight)
        normalised = mult * e * e / (sigma * sigma)
        if c.reject_above is not None:
            threshold = mult * (c.reject_above / sigma) ** 2
        else:
            threshold = CHI2_999[DOF[c.kind]]
        rows.append(
            ConstraintResidual(
                index=i,
                label=c.label,
                kind=c.kind,
                parts=tuple(int(p) for p in c.parts),
                unit=c.unit,
                measurement=c.measurement,
                residual=e,
                cost=mult * weight * e * e,
                normalised_cost=normalised,
                threshold=threshold,
                exceeds=normalised > threshold,
            )
        )
    return ResidualReport(tuple(rows))
