"""Blame: which constraint of the knowledge felled an alternative, for the trace.

An alternative whose constraints together do not fit (the reduced cost above
`plausibility.MAX_MEAN_COST`) need not have one constraint over its threshold: the
least-squares compromise spreads the contradiction. `blame` finds the culprit by leaving
out each of the likeliest blame groups in turn; it costs solves, so `first_named` evaluates it
only when its reason is the one the trace reports.
"""

from __future__ import annotations

from collections.abc import Callable

from aida_kb.errors import AidaError
from aida_kb.interpret.plausibility import MAX_MEAN_COST, Violation
from aida_kb.interpret.verify import (
    BLAME_EVALUATIONS,
    BlameGroup,
    Outcome,
    Verification,
    blame_group,
    verify,
)
from aida_kb.solve import ConstraintResidual

BLAME_CANDIDATES = 6  # constraints left out in turn to find a contradiction's culprit

# text, and the rejecting constraint's report row or the attribute whose range was left
Reason = tuple[str, ConstraintResidual | Violation | None]


def first_named(reasons: list[Reason | Callable[[], Reason]]) -> Reason:
    """The first reason that names a constraint (evaluating deferred ones in turn), else the
    first reason."""
    first: Reason | None = None
    for entry in reasons:
        reason = entry() if callable(entry) else entry
        if reason[1] is not None:
            return reason
        first = first or reason
    return first or ("no assignment verified", None)


def over(r: ConstraintResidual) -> str:
    """What a constraint over its threshold says, for the trace (with its ``.kb`` line)."""
    limit = f"; reject above {r.reject_above:.3g} {r.unit}" if r.reject_above is not None else ""
    where = f" at {r.where}" if r.where else ""
    return (
        f"{r.label}{where} ({r.kind}) residual {r.residual:.3g} {r.unit}, normalised cost "
        f"{r.normalised_cost:.3g} above its threshold {r.threshold:.3g}{limit} "
        f"(parts {', '.join(r.parts)})"
    )


def blame(outcome: Outcome, full: Verification, worst: ConstraintResidual | None) -> Reason:
    """The constraint that makes an inconsistent adjustment inconsistent.

    No single constraint is over its threshold, but together they do not fit (the
    report's reduced cost is above MAX_MEAN_COST): the least-squares compromise has spread
    the contradiction. Each blame group (`verify.blame_group`: an internal constraint with
    the others of its label and owner, a region's position constraint) is left out in
    turn — the `BLAME_CANDIDATES` that miss most, relative to their thresholds — and the
    one whose removal lowers the reduced cost most is blamed, with its row in the full
    adjustment (`full`, the problem `outcome` solved). ``worst`` (the first constraint over
    its threshold, if any) is named too.
    """
    head = (
        f"its constraints contradict each other (reduced normalised cost "
        f"{outcome.cost:.3g} > {MAX_MEAN_COST:g})"
    )
    tail = f"; {over(worst)}" if worst is not None else ""
    groups: dict[BlameGroup, list[int]] = {}
    for i, c in enumerate(full.constraints):
        g = blame_group(c)
        if g is not None:
            groups.setdefault(g, []).append(i)
    group_of = {i: g for g, members in groups.items() for i in members}
    misses: dict[BlameGroup, float] = {}
    row_of: dict[BlameGroup, ConstraintResidual] = {}
    for row, members in zip(outcome.residuals, outcome.members, strict=True):
        g = group_of.get(members[0])
        if g is None:
            continue
        miss = row.normalised_cost / row.threshold
        if miss >= misses.get(g, -1.0):
            misses[g], row_of[g] = miss, row
    ranked = sorted(groups, key=lambda g: (-misses.get(g, 0.0), g))[:BLAME_CANDIDATES]
    best: tuple[float, BlameGroup] | None = None
    for g in sorted(ranked):
        try:
            trial = full.without(set(groups[g]), outcome.planes)
            cost = verify(trial, BLAME_EVALUATIONS).cost
        except AidaError:
            continue
        if best is None or cost < best[0]:
            best = (cost, g)
    if best is None:
        return head + tail, None
    cost, g = best
    blamed = row_of.get(g)
    if blamed is None:
        return head + tail, None
    owner = ", ".join(blamed.parts) if g[2] else (g[1] or "the goal")
    where = f" ({blamed.where})" if blamed.where else ""
    text = f"{head}; without '{g[0]}' of {owner}{where} it would be {cost:.3g}{tail}"
    return text, blamed
