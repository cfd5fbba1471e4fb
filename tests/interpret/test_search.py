"""Best-first search with a bound on small synthetic spaces."""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable

import numpy as np
import pytest

from aida_kb.errors import InterpretError
from aida_kb.interpret.search import best_first

Assignment = tuple[int, ...]


def _assignment_problem(
    costs: np.ndarray,
) -> tuple[
    Callable[[Assignment], list[tuple[Assignment, float]]],
    Callable[[Assignment], bool],
]:
    n = costs.shape[0]

    def expand(state: Assignment) -> list[tuple[Assignment, float]]:
        row = len(state)
        out = []
        for col in range(n):
            if col in state:
                continue
            nxt = (*state, col)
            g = float(sum(costs[r, c] for r, c in enumerate(nxt)))
            # admissible estimate: each remaining row takes its cheapest column
            h = float(costs[row + 1 :].min(axis=1).sum()) if row + 1 < n else 0.0
            out.append((nxt, g + h))
        return out

    def is_goal(state: Assignment) -> bool:
        return len(state) == n

    return expand, is_goal


def test_assignment_finds_the_optimum_of_brute_force() -> None:
    rng = np.random.default_rng(3)
    costs = rng.uniform(0.0, 10.0, size=(6, 6))
    expand, is_goal = _assignment_problem(costs)
    result = best_first((), expand, is_goal)
    brute = min(
        itertools.permutations(range(6)), key=lambda p: sum(costs[r, c] for r, c in enumerate(p))
    )
    assert result.best == brute
    assert result.cost == pytest.approx(sum(costs[r, c] for r, c in enumerate(brute)))
    # the estimate guides the search: far fewer expansions than the 1957 inner nodes
    assert 0 < result.expanded < 1957
    assert not result.exhausted


def test_search_is_deterministic_with_ties() -> None:
    costs = np.ones((4, 4))
    expand, is_goal = _assignment_problem(costs)
    first = best_first((), expand, is_goal)
    second = best_first((), expand, is_goal)
    assert first == second
    assert first.best == (0, 1, 2, 3)  # ties go to the earliest created alternative


def test_bound_prunes_and_can_leave_no_goal() -> None:
    costs = np.full((3, 3), 5.0)
    expand, is_goal = _assignment_problem(costs)
    result = best_first((), expand, is_goal, bound=12.0)
    assert result.best is None
    assert result.exhausted
    assert result.pruned > 0
    ok = best_first((), expand, is_goal, bound=15.0)
    assert ok.cost == pytest.approx(15.0)


def test_grid_shortest_path_with_walls() -> None:
    walls = {(1, 0), (1, 1), (1, 2), (3, 4), (3, 3), (3, 2)}
    size, target = 5, (4, 0)

    def h(p: tuple[int, int]) -> float:
        return float(abs(p[0] - target[0]) + abs(p[1] - target[1]))

    Cell = tuple[int, int]

    def expand(state: tuple[Cell, int]) -> list[tuple[tuple[Cell, int], float]]:
        (x, y), g = state
        out = []
        for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            q = (x + dx, y + dy)
            if 0 <= q[0] < size and 0 <= q[1] < size and q not in walls:
                out.append(((q, g + 1), g + 1 + h(q)))
        return out

    result = best_first(((0, 0), 0), expand, lambda s: s[0] == target, start_cost=h((0, 0)))
    assert result.best is not None
    # breadth-first search as the reference
    dist = {(0, 0): 0}
    frontier = [(0, 0)]
    while frontier:
        nxt = []
        for cell in frontier:
            for succ, _cost in expand((cell, 0)):
                if succ[0] not in dist:
                    dist[succ[0]] = dist[cell] + 1
                    nxt.append(succ[0])
        frontier = nxt
    assert result.best[1] == dist[target] == 10  # around both walls
    assert result.cost == pytest.approx(10.0)


def test_max_expansions_and_nan_cost() -> None:
    def expand(n: int) -> list[tuple[int, float]]:
        return [(n + 1, float(n + 1))]

    result = best_first(0, expand, lambda n: False, max_expansions=7)
    assert result.best is None
    assert result.expanded == 7
    assert not result.exhausted
    with pytest.raises(InterpretError, match="NaN"):
        best_first(0, lambda n: [(1, math.nan)], lambda n: False)
