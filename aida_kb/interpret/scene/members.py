"""The role of a scene goal that holds objects, and choices decided for one of its objects."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from aida_kb.interpret.knowledge import Knowledge

if TYPE_CHECKING:
    pass


@dataclass(frozen=True)
class Members:
    """The role of a scene-layer goal that holds scene objects: role, concept, cardinality."""

    role: str
    concept: str
    min: int
    max: int | None


def members(knowledge: Knowledge, goal: str) -> Members | None:
    """The goal's first part-of role filled by a concept of its own layer (None: there is none,
    the goal is one object)."""
    concept = knowledge.concept(goal)
    for slot in concept.slots:
        if slot.link != "part-of":
            continue
        if knowledge.concept(slot.concept).layer == concept.layer:
            return Members(slot.role, slot.concept, 0 if slot.optional else slot.min, slot.max)
    return None


@dataclass(frozen=True)
class Preference:
    """Choices along is-a (``ROLE=CONCEPT``, roles relative to the object) that views other
    than the interpreted one, or the knowledge (`reason`), decided for the object explaining
    `regions` ('VIEW/REGION')."""

    regions: frozenset[str]
    choices: frozenset[str]
    # why, when the knowledge decided them (`shared_choices`; empty: the other views did)
    reason: str = ""
