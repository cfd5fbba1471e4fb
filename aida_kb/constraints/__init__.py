"""Constraints as factors, compiled to vectorised residuals with analytic Jacobians.

A `Constraint` (`factor.py`) is one factor: a kind of the registry (`registry.KINDS`, one
module per kind in `kinds/`), its keys (parts, a camera), its typed measurement
(`PositionData`, `EdgeData`,
`CameraPositionData`, `TextureData`), a noise model, a robust loss and its
`Origin`. `compile_blocks` groups a list of them by kind into `ConstraintBlock` s evaluated in
one numpy call each (`kernels` for eqs. 1-4, `edge` for eq. 5, `texture` for the texture factor).
"""

from __future__ import annotations

from aida_kb.constraints.factor import (
    CameraPositionData,
    Constraint,
    EdgeData,
    Loss,
    Origin,
    PositionData,
    Rule,
    TextureData,
    TextureImage,
)
from aida_kb.constraints.model import ConstraintBlock, compile_blocks, describe, validate
from aida_kb.constraints.registry import CHI2_999, KINDS, kind_of

__all__ = [
    "CHI2_999",
    "KINDS",
    "CameraPositionData",
    "Constraint",
    "ConstraintBlock",
    "EdgeData",
    "Loss",
    "Origin",
    "PositionData",
    "Rule",
    "TextureData",
    "TextureImage",
    "compile_blocks",
    "describe",
    "kind_of",
    "validate",
]
