"""The compiled knowledge base: immutable pydantic models (frozen), inheritance resolved.

Everything a later phase needs is here, in SI units (radians, metres; image tolerances in
pixels): concepts with their members (each knowing the concept that declared it), templates,
instances, and every constraint expanded into primitive relations (`ConstraintSpec`).
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict

from aida_kb.diagnostics.core import Span

__all__ = [
    "AdjacencyModel",
    "AttributeModel",
    "BindingModel",
    "ConOfModel",
    "ConceptModel",
    "ConstraintSpec",
    "InstanceModel",
    "KnowledgeBase",
    "ParamModel",
    "PartModel",
    "TemplateModel",
]


class _Frozen(BaseModel):
    model_config = ConfigDict(frozen=True, arbitrary_types_allowed=True)


ConstraintKind = Literal["angle", "parallel", "parallel_edge", "symmetry", "position", "edge"]
ResidualUnit = Literal["rad", "m", "px", ""]
ValueType = Literal["angle", "length", "number"]
ValueUnit = Literal["rad", "m", ""]

#: Conditions on a constraint or adjacency through an abstract role: (role path prefix, the
#: concepts its filler must be (a specialisation of) one of). Empty: unconditional.
Requires = tuple[tuple[str, tuple[str, ...]], ...]


class ConstraintSpec(_Frozen):
    """One primitive relation of a concept, expanded from a constraint or measure, in SI.

    ``args`` are role paths relative to the owning concept (``"front"``, ``"roof.front"``,
    ``"self"``); a path through a role with several fillers (``oriels.front``) stands for each
    filler. Kinds: ``angle`` (a, b): angle(a, b) == value; ``parallel`` (a, b);
    ``parallel_edge`` (a, b, c, d): edge(a, b) || edge(c, d); ``symmetry`` (a, b, c, d):
    angle(a, b) == angle(c, d); ``position`` (p,); ``edge`` (a, b) the edge of a and b, or
    (p,) a contour itself. ``requires`` makes the constraint conditional: it applies only
    when the filler of each named role path is one of the listed concepts (or a specialisation).
    """

    label: str
    kind: ConstraintKind
    args: tuple[str, ...]
    value: float | None
    unit: ResidualUnit
    sigma: float | None
    weight: float
    reject_above: float | None
    measurement: bool
    concept: str
    span: Span
    requires: Requires = ()


class PartModel(_Frozen):
    """A part role: filled by ``min``..``max`` instances of ``concept`` (max None: unbounded)."""

    role: str
    concept: str
    min: int
    max: int | None
    optional: bool
    declared_in: str
    span: Span


class ConOfModel(_Frozen):
    """A con-of role: the concept is realised by ``concept``, one layer down."""

    role: str
    concept: str
    min: int
    max: int | None
    declared_in: str
    span: Span


class AttributeModel(_Frozen):
    """A typed attribute; ``low``, ``high`` and ``default`` in SI (``unit``)."""

    name: str
    type: ValueType
    unit: ValueUnit
    low: float | None
    high: float | None
    default: float | None
    declared_in: str
    span: Span


class AdjacencyModel(_Frozen):
    """Two planes (role paths) that meet along an edge."""

    a: str
    b: str
    declared_in: str
    span: Span
    requires: Requires = ()


class ConceptModel(_Frozen):
    """A concept with every member resolved: own and inherited, overrides applied."""

    name: str
    layer: str
    abstract: bool
    parents: tuple[str, ...]
    specialisations: tuple[str, ...]
    doc: str | None
    parts: dict[str, PartModel]
    con_ofs: dict[str, ConOfModel]
    attributes: dict[str, AttributeModel]
    adjacencies: tuple[AdjacencyModel, ...]
    constraints: tuple[ConstraintSpec, ...]
    span: Span


class ParamModel(_Frozen):
    """A template parameter: a concept (a role argument) or a value type; default in SI."""

    name: str
    type: str
    default: float | None


class TemplateModel(_Frozen):
    """A constraint template (its uses are expanded into the concepts' constraints)."""

    name: str
    params: tuple[ParamModel, ...]
    doc: str | None
    span: Span


class BindingModel(_Frozen):
    """An instance binding: other instances, evidence ids, or an attribute value (SI)."""

    role: str
    instances: tuple[str, ...]
    evidence: tuple[str, ...]
    value: float | None
    span: Span


class InstanceModel(_Frozen):
    """``instance name of Concept { bindings }``."""

    name: str
    concept: str
    doc: str | None
    bindings: dict[str, BindingModel]
    span: Span


class KnowledgeBase(_Frozen):
    """The whole compiled knowledge base."""

    layers: tuple[str, ...]
    concepts: dict[str, ConceptModel]
    templates: dict[str, TemplateModel]
    instances: dict[str, InstanceModel]
    files: tuple[str, ...]

    def is_a(self, concept: str, parent: str) -> bool:
        """True when ``concept`` is ``parent`` or a specialisation of it."""
        todo = [concept]
        seen: set[str] = set()
        while todo:
            c = todo.pop()
            if c == parent:
                return True
            if c in seen or c not in self.concepts:
                continue
            seen.add(c)
            todo.extend(self.concepts[c].parents)
        return False

    def concrete_specialisations(self, concept: str) -> tuple[str, ...]:
        """The non-abstract concepts that are ``concept`` or specialise it, sorted."""
        out: set[str] = set()
        todo = [concept]
        while todo:
            c = todo.pop()
            if c in out or c not in self.concepts:
                continue
            out.add(c)
            todo.extend(self.concepts[c].specialisations)
        return tuple(sorted(c for c in out if not self.concepts[c].abstract))
