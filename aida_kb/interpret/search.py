"""Deterministic best-first search with a bound over partial interpretations (ERNEST control).

The search is generic: a state is any value, `expand` yields the alternatives of a state with
their costs (the cost so far plus an optimistic estimate of what remains, A*-style), and
`is_goal` says when a state is a complete interpretation. The open list is ordered by cost,
ties by creation order, so that equal inputs always give the same search. Successors whose
cost exceeds the bound are pruned. With costs that never decrease along a path (an
admissible, monotone estimate), the first goal taken from the open list is a cheapest one.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Generic, TypeVar

from aida_kb.errors import InterpretError

S = TypeVar("S")


@dataclass(frozen=True)
class SearchResult(Generic[S]):
    """What a search found.

    Attributes
    ----------
    best : the goal state found, or None
    cost : its cost, or None
    expanded : number of states taken from the open list and expanded
    generated : number of successors produced (pruned ones included)
    pruned : number of successors above the bound
    exhausted : True if the search ended because nothing was left to expand
    """

    best: S | None
    cost: float | None
    expanded: int
    generated: int
    pruned: int
    exhausted: bool


@dataclass(order=True)
class _Entry(Generic[S]):
    cost: float
    order: int
    state: S = field(compare=False)


def best_first(
    start: S,
    expand: Callable[[S], Iterable[tuple[S, float]]],
    is_goal: Callable[[S], bool],
    *,
    start_cost: float = 0.0,
    bound: float = math.inf,
    max_expansions: int = 10_000,
) -> SearchResult[S]:
    """Best-first search from `start` for a goal state of least cost.

    Parameters
    ----------
    start : the initial state (e.g. the goal hypothesis with nothing verified)
    expand : yields (successor, cost) pairs; cost is the successor's total estimate, >= 0
    is_goal : True for a complete state
    start_cost : the cost of `start`
    bound : successors costing more than this are pruned (never expanded)
    max_expansions : the search stops (returning nothing) after this many expansions

    Returns
    -------
    SearchResult with the cheapest goal state found, or ``best=None`` if there is none
    within the bound.
    """
    if not math.isfinite(start_cost) and start_cost != math.inf:
        raise InterpretError(f"search: start cost {start_cost!r} is not a number")
    order = 0
    open_list: list[_Entry[S]] = [_Entry(start_cost, order, start)]
    expanded = generated = pruned = 0
    while open_list:
        entry = heapq.heappop(open_list)
        if is_goal(entry.state):
            return SearchResult(entry.state, entry.cost, expanded, generated, pruned, False)
        if expanded >= max_expansions:
            return SearchResult(None, None, expanded, generated, pruned, False)
        expanded += 1
        for successor, cost in expand(entry.state):
            generated += 1
            if math.isnan(cost):
                raise InterpretError("search: an expansion produced a NaN cost")
            if cost > bound:
                pruned += 1
                continue
            order += 1
            heapq.heappush(open_list, _Entry(cost, order, successor))
    return SearchResult(None, None, expanded, generated, pruned, True)
