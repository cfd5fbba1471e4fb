"""The residual report: every constraint's final cost, normalised cost and rejection flag.

For constraint i with unweighted residual vector ``e_i`` (its unit), multiplicity ``m_i``
(``w_c`` for a position constraint, else 1) and whitening ``S_i`` (``I/sigma_i``, or its
``sqrt_information``; a weight ``W_i`` given instead of sigma counts as ``sigma_i =
1/sqrt(W_i)`` for the normalisation):

* ``residual = |e_i|`` (for angle kinds: the angle error in rad),
* ``cost = m_i · W_i · |e_i|²`` (its term of the paper's eq. 6; ``m_i · |S_i e_i|²`` with a
  square-root information),
* ``normalised_cost = m_i · |S_i e_i|²`` (chi-square-like, the kind's ``dof`` degrees of
  freedom),
* ``threshold``: ``m_i · (reject_above / sigma_i)²`` when the constraint has ``reject_above``
  (then ``rejected`` is exactly ``residual > reject_above``; sigma is 1 — whitened units —
  with a square-root information), else the 99.9 % chi-square quantile,
* ``rejected = normalised_cost > threshold``: what the interpreter rejects hypotheses by.

`ConstraintResidual` is the one row type from the solver to ``interpretation.json``: it carries
the constraint's origin (label, concept, owner, rule and the ``span`` of its ``.kb`` line).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from pydantic import BaseModel, ConfigDict, Field, field_validator

from aida_kb.constraints import CHI2_999, Constraint, kind_of
from aida_kb.diagnostics.core import Span
from aida_kb.errors import SolveError
from aida_kb.geometry.camera import PinholeCamera
from aida_kb.solve.problem import Evaluation, Problem

FloatArray = npt.NDArray[np.float64]


class ConstraintResidual(BaseModel):
    """One constraint's row of the report (see the module docstring for the definitions)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    label: str = Field(description="the constraint's label (from the knowledge base)")
    kind: str = Field(description="its kind (aida_kb.constraints.registry)")
    concept: str = Field(default="", description="the concept that declared it")
    owner: str = Field(default="", description="role path of the instance that introduced it")
    rule: str = Field(
        default="code",
        description="why it exists: knowledge, evidence, attribute, prior or code",
    )
    span: Span | None = Field(
        default=None, description="its .kb declaration (file, line, column, end); None if none"
    )
    parts: tuple[str, ...] = Field(description="the parts it relates (role paths)")
    residual: float = Field(description="the residual, in `unit` (length of its components)")
    unit: str = Field(description="'rad', 'm', 'px' or ''")
    sigma: float | None = Field(description="the tolerance, in `unit`")
    cost: float = Field(default=0.0, description="its term of the paper's eq. 6")
    normalised_cost: float = Field(description="multiplicity · |whitened residual|²")
    threshold: float = Field(description="the normalised cost above which it rejects")
    reject_above: float | None = Field(description="residuals above this reject, in `unit`")
    rejected: bool = Field(description="True if the normalised cost is above the threshold")
    fragments: int = Field(
        default=1, ge=1, description="constraints pooled in this row (an edge's image fragments)"
    )

    @property
    def where(self) -> str:
        """``file:line:column`` of its ``.kb`` declaration, or '' when it has none."""
        return str(self.span) if self.span is not None else ""

    @field_validator(
        "residual", "sigma", "cost", "normalised_cost", "threshold", "reject_above", mode="before"
    )
    @classmethod
    def _finite(cls, value: object) -> object:
        if value is None:
            return value
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ValueError("must be a number")
        if not math.isfinite(value):
            raise ValueError("must be a finite number")
        return value


@dataclass(frozen=True)
class ResidualReport:
    """The report of all constraints of a problem, in the problem's constraint order.

    ``dof`` holds each row's degrees of freedom (its kind's).
    """

    rows: tuple[ConstraintResidual, ...]
    dof: tuple[int, ...] = ()

    @property
    def total_cost(self) -> float:
        """Sum of all constraint costs (the paper's eq. 6, without robust loss)."""
        return float(sum(r.cost for r in self.rows))

    @property
    def reduced_cost(self) -> float:
        """Sum of the normalised costs over their degrees of freedom (a reduced chi-square).

        About 1 when every constraint misses by about its sigma; 0 for an empty report.
        """
        dof = sum(self.dof)
        return float(sum(r.normalised_cost for r in self.rows) / dof) if dof else 0.0

    @property
    def exceeding(self) -> tuple[ConstraintResidual, ...]:
        """The constraints whose normalised cost exceeds their threshold."""
        return tuple(r for r in self.rows if r.rejected)

    def by_label(self, label: str) -> ConstraintResidual:
        """The row of the constraint labelled ``label`` (SolveError if none or several)."""
        found = [r for r in self.rows if r.label == label]
        if len(found) != 1:
            raise SolveError(f"report: {len(found)} constraints labelled {label!r}")
        return found[0]

    def format(self) -> str:
        """A plain-text table, one line per constraint, with its ``.kb`` location."""
        lines = [f"{'label':30} {'kind':13} {'residual':>12} {'norm. cost':>11} {'thresh':>9}  "]
        for r in self.rows:
            flag = "REJECT" if r.rejected else ""
            lines.append(
                f"{r.label[:30]:30} {r.kind:13} {r.residual:12.4g} {r.normalised_cost:11.4g} "
                f"{r.threshold:9.4g}  {flag:6} {r.where}".rstrip()
            )
        return "\n".join(lines)


def residual_row(
    c: Constraint,
    e: FloatArray,
    parts: tuple[str, ...],
) -> ConstraintResidual:
    """The report row of constraint ``c`` with unweighted residual vector ``e`` (k,)."""
    kind = kind_of(c.kind)
    mult = kind.multiplicity(c)
    sigma = c.effective_sigma
    if c.sqrt_information is not None:
        w = np.asarray(c.sqrt_information, dtype=np.float64) @ e
        normalised = mult * float(w @ w)
        cost = normalised
    else:
        normalised = mult * float(e @ e) / (sigma * sigma)
        cost = mult * c.effective_weight * float(e @ e)
    if c.reject_above is not None:
        threshold = mult * (c.reject_above / sigma) ** 2
    else:
        threshold = CHI2_999[kind.dof]
    o = c.source
    return ConstraintResidual(
        label=c.label or o.label,
        kind=c.kind,
        concept=o.concept,
        owner=str(o.owner),
        rule=o.rule,
        span=o.span,
        parts=parts,
        residual=float(np.linalg.norm(e)),
        unit=c.unit,
        sigma=c.sigma if c.sqrt_information is None else None,
        cost=cost,
        normalised_cost=normalised,
        threshold=threshold,
        reject_above=c.reject_above,
        rejected=normalised > threshold,
    )


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
    residuals: list[FloatArray | None] = [None] * len(problem.constraints)
    for b, r in zip(ev.blocks, rs, strict=True):
        for m, row in zip(b.members, r, strict=True):
            residuals[int(m)] = row
    rows = []
    for i, c in enumerate(problem.constraints):
        e = residuals[i]
        if e is None or not np.all(np.isfinite(e)):
            raise SolveError(f"{problem.describe(i)}: residual is not finite (degenerate geometry)")
        names = tuple(problem.part_name(int(p)) for p in c.parts)
        rows.append(residual_row(c, e, names))
    return ResidualReport(tuple(rows), tuple(kind_of(c.kind).dof for c in problem.constraints))
