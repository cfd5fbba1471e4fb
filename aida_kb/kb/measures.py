"""The geometric measures an attribute can stand for (``attribute pitch: angle is slope(self)``).

A module of its own, without pydantic, so that the checks (`aida_kb.kb.shape`) and the compiled
model (`aida_kb.kb.model`) share the one enumeration while linting stays light.
"""

from __future__ import annotations

from enum import StrEnum

__all__ = ["MeasureKind"]


class MeasureKind(StrEnum):
    """Geometric measures an attribute can stand for: slope of a plane against the ground, the
    angle at which two planes meet, extents in the frame, distance between two planes, height
    above the ground the evidence shows."""

    SLOPE = "slope"
    ANGLE = "angle"
    HEIGHT = "height"
    WIDTH = "width"
    DEPTH = "depth"
    DISTANCE = "distance"
    ELEVATION = "elevation"
