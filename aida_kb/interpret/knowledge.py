"""What the interpreter needs from the compiled knowledge base, and the structures it builds.

`Knowledge` wraps a compiled `KnowledgeBase`: concepts with their slots (parts and con-of
realisations with cardinalities), attribute ranges in SI units, expanded constraints and
adjacencies, and the is-a hierarchy. `structures` unfolds a concept top-down along part-of
into every fully specialised *structure*: the instance skeleton of one alternative, with its
planar parts (the leaves that evidence regions can bind to), its is-a choices, and which
planes meet (adjacency, absolute role paths). The constraints of a structure are not listed
here: `aida_kb.solve.constraints_from_kb` finds them in the compiled knowledge base (`kb`).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

from aida_kb.diagnostics.core import Span
from aida_kb.errors import InterpretError
from aida_kb.interpret.hypotheses import PlanarPart

if TYPE_CHECKING:
    from aida_kb.kb.model import ConceptModel, KnowledgeBase

Link = Literal["goal", "con-of", "part-of"]
Requires = tuple[tuple[str, tuple[str, ...]], ...]
SLOPE_ATTRIBUTES = ("tilt", "pitch")


@dataclass(frozen=True)
class Slot:
    """A part or con-of member of a concept: role, concept, cardinality."""

    role: str
    concept: str
    min: int
    max: int | None  # None: unbounded
    link: Literal["part-of", "con-of"]

    optional: bool = False

    @property
    def obligatory(self) -> bool:
        """True if at least one filler is required."""
        return self.min >= 1 and not self.optional


@dataclass(frozen=True)
class Attribute:
    """An attribute's range and value in SI units (radians, metres)."""

    name: str
    low: float | None
    high: float | None
    value: float | None
    span: Span | None = None


@dataclass(frozen=True)
class Concept:
    """A concept as the interpreter sees it (inherited members resolved)."""

    name: str
    layer: str
    abstract: bool
    parents: tuple[str, ...]
    slots: tuple[Slot, ...]
    attributes: dict[str, Attribute]
    constraints: tuple[Any, ...]  # ConstraintSpec (aida_kb.kb)
    adjacencies: tuple[tuple[str, str, Requires], ...]


@dataclass(frozen=True)
class Node:
    """One instance of a structure: role path, concept, prototype, parent, link."""

    role: str
    concept: str
    instance_of: str
    parent: str | None
    link: Link


@dataclass(frozen=True)
class Structure:
    """A fully specialised instance skeleton for one world-layer concept."""

    root: str  # role path of the composite it describes
    nodes: tuple[Node, ...]
    leaves: tuple[PlanarPart, ...]
    adjacency: tuple[tuple[str, str], ...]
    choices: tuple[tuple[str, str], ...]  # (role path, concept chosen along is-a)

    def describe(self) -> str:
        """The is-a choices, e.g. 'body.roof=GableRoof' ('' if none)."""
        return ", ".join(f"{r}={c}" for r, c in self.choices)


def join(owner: str, role: str) -> str:
    """The absolute role path of `role` relative to `owner` ('self' is the owner)."""
    if role == "self":
        return owner
    return f"{owner}.{role}" if owner else role


class Knowledge:
    """The compiled knowledge base seen through the interpreter's needs."""

    def __init__(self, concepts: dict[str, Concept], kb: KnowledgeBase) -> None:
        self.concepts = concepts
        self.kb = kb
        self._children: dict[str, list[str]] = {name: [] for name in concepts}
        for c in concepts.values():
            for p in c.parents:
                self._children.setdefault(p, []).append(c.name)

    @classmethod
    def from_kb(cls, kb: KnowledgeBase) -> Knowledge:
        """Wrap a compiled `aida_kb.kb.KnowledgeBase`."""
        return cls({name: _concept_of(name, model) for name, model in kb.concepts.items()}, kb)

    def concept(self, name: str) -> Concept:
        """The concept called `name` (InterpretError if unknown)."""
        try:
            return self.concepts[name]
        except KeyError:
            known = ", ".join(sorted(self.concepts))
            raise InterpretError(
                f"unknown concept {name!r}; the knowledge base has {known}"
            ) from None

    def specialisations(self, name: str) -> list[str]:
        """`name` itself if concrete, else its concrete descendants along is-a, in order."""
        out: list[str] = []
        stack = [name]
        while stack:
            current = stack.pop(0)
            if not self.concept(current).abstract:
                out.append(current)
            stack.extend(self._children.get(current, []))
        return out

    def is_a(self, name: str, ancestor: str) -> bool:
        """True if `name` is `ancestor` or inherits from it."""
        if name == ancestor:
            return True
        return any(self.is_a(p, ancestor) for p in self.concept(name).parents)

    def slope_range_deg(self, concept: str) -> tuple[float, float] | None:
        """The range of a planar concept's tilt or pitch attribute, degrees (None if none)."""
        attrs = self.concept(concept).attributes
        for name in SLOPE_ATTRIBUTES:
            a = attrs.get(name)
            if a is not None and a.low is not None and a.high is not None:
                return (math.degrees(a.low), math.degrees(a.high))
        return None

    def is_planar(self, concept: str) -> bool:
        """True for a leaf of the world layer: a concept without part-of slots."""
        return not any(s.link == "part-of" for s in self.concept(concept).slots)

    def structures(
        self, concept: str, role: str, parent: str | None, link: Link
    ) -> list[Structure]:
        """Every fully specialised structure of `concept` at `role` (its obligatory parts)."""
        return list(self._structures(concept, role, parent, link))

    def _structures(
        self, concept: str, role: str, parent: str | None, link: Link
    ) -> Iterator[Structure]:
        for special in self.specialisations(concept):
            c = self.concept(special)
            node = Node(role, special, special, parent, link)
            choice = ((role, special),) if special != concept else ()
            if self.is_planar(special):
                leaf = PlanarPart(
                    role,
                    role.rsplit(".", 1)[-1],
                    special,
                    self.slope_range_deg(special),
                    self.is_a(special, "RoofPlane") or "pitch" in c.attributes,
                )
                yield Structure(role, (node,), (leaf,), (), choice)
                continue
            parts = [s for s in c.slots if s.link == "part-of" and s.obligatory]
            options = [
                self.structures(s.concept, join(role, s.role), role, "part-of") for s in parts
            ]
            for combo in itertools.product(*options):
                nodes = (node, *(n for sub in combo for n in sub.nodes))
                fillers = {n.role: n.concept for n in nodes}
                adjacency = tuple(
                    (join(role, a), join(role, b))
                    for a, b, req in c.adjacencies
                    if self.holds(role, req, fillers)
                )
                yield Structure(
                    role,
                    nodes,
                    tuple(leaf for sub in combo for leaf in sub.leaves),
                    adjacency + tuple(a for sub in combo for a in sub.adjacency),
                    choice + tuple(ch for sub in combo for ch in sub.choices),
                )

    def holds(self, owner: str, requires: Requires, fillers: dict[str, str]) -> bool:
        """True if every conditional role path is filled by one of the required concepts."""
        for path, allowed in requires:
            filler = fillers.get(join(owner, path))
            if filler is None or not any(self.is_a(filler, a) for a in allowed):
                return False
        return True

    def realisation(self, concept: str) -> Slot | None:
        """The con-of slot of `concept` (its realisation one layer down), if any."""
        for s in self.concept(concept).slots:
            if s.link == "con-of":
                return s
        return None


def _concept_of(name: str, model: ConceptModel) -> Concept:
    """Translate the compiler's `ConceptModel` into a `Concept`."""
    slots = [
        Slot(p.role, p.concept, p.min, p.max, "part-of", p.optional) for p in model.parts.values()
    ]
    slots += [Slot(c.role, c.concept, c.min, c.max, "con-of") for c in model.con_ofs.values()]
    attributes = {
        a.name: Attribute(a.name, a.low, a.high, a.default, a.span)
        for a in model.attributes.values()
    }
    return Concept(
        name=name,
        layer=model.layer,
        abstract=model.abstract,
        parents=tuple(model.parents),
        slots=tuple(slots),
        attributes=attributes,
        constraints=tuple(model.constraints),
        adjacencies=tuple((a.a, a.b, tuple(a.requires)) for a in model.adjacencies),
    )
