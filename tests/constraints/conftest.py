"""Shared helpers of the constraint tests."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

Residual = Callable[[np.ndarray, np.ndarray], np.ndarray]
Derivative = Callable[[Residual, np.ndarray, np.ndarray, int, int, float], np.ndarray]


def _plane_derivative(
    fn: Residual, n: np.ndarray, d: np.ndarray, part: int, comp: int, eps: float
) -> np.ndarray:
    """Central difference of ``fn(n, d)`` by component ``comp`` of part ``part``'s plane
    (0-2: the normal's coordinates, 3: the offset)."""
    n_p, n_m, d_p, d_m = n.copy(), n.copy(), d.copy(), d.copy()
    if comp < 3:
        n_p[part, comp] += eps
        n_m[part, comp] -= eps
    else:
        d_p[part] += eps
        d_m[part] -= eps
    out: np.ndarray = (fn(n_p, d_p) - fn(n_m, d_m)) / (2 * eps)
    return out


@pytest.fixture
def plane_derivative() -> Derivative:
    """The central difference of a residual function by one plane coordinate."""
    return _plane_derivative
