"""Constraint templates compiled to vectorised residuals with analytic Jacobians.

`Constraint` (with `PositionData` / `EdgeData` evidence) is one constraint between parts;
`compile_blocks` groups a list of them by kind into `ConstraintBlock` s evaluated in one
numpy call each (`kernels` for eqs. 1-4, `edge` for eq. 5).
"""

from __future__ import annotations

from aida_kb.constraints.model import (
    ARITY,
    DOF,
    Constraint,
    ConstraintBlock,
    EdgeData,
    PositionData,
    compile_blocks,
)

__all__ = [
    "ARITY",
    "DOF",
    "Constraint",
    "ConstraintBlock",
    "EdgeData",
    "PositionData",
    "compile_blocks",
]
