"""The abstract syntax tree of a ``.kb`` file: frozen, slotted dataclasses, each with its span.

The tree says what was *written*, nothing more: names are unresolved, quantities keep their
value and unit as written (``Quantity(90.0, "deg")``), a ``part`` declaration with several
roles stays one node. Resolution, inheritance and unit normalisation are the compiler's work
(``aida_kb.kb``). Every node carries ``span`` (file, 1-based line and column, end exclusive).

Expression nodes: `Path`, `Call`, `Number`, `Quantity`, `String`, `ListExpr`.
Declarations: `Layers`, `Import`, `Template`, `Concept`, `Instance`.
Concept members: `Part`, `ConOf`, `Attribute`, `Adjacency`, `Constraint`, `Measure`, and the
geometry members `Frame`, `Orient`, `Unseen`, `Attach`.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum
from typing import Literal, TypeAlias

from aida_kb.diagnostics.core import Span

#: The units a quantity may carry, as written; the compiler converts (deg -> rad, cm -> m ...).
ANGLE_UNITS: tuple[str, ...] = ("deg", "rad")
LENGTH_UNITS: tuple[str, ...] = ("m", "cm", "mm")
IMAGE_UNITS: tuple[str, ...] = ("px",)
UNITS: tuple[str, ...] = ANGLE_UNITS + LENGTH_UNITS + IMAGE_UNITS


# ---- names and expressions -----------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class Name:
    """An identifier as written: a concept, role, layer, template, parameter or instance name."""

    text: str
    span: Span

    def __str__(self) -> str:
        return self.text


@dataclass(frozen=True, slots=True)
class Path:
    """A name or a dotted role path: ``front``, ``self``, ``roof.front``."""

    parts: tuple[Name, ...]
    span: Span

    @property
    def dotted(self) -> str:
        """The path as written with dots: ``"roof.front"``."""
        return ".".join(p.text for p in self.parts)

    @property
    def is_simple(self) -> bool:
        """True for a single name (no dot)."""
        return len(self.parts) == 1

    def __str__(self) -> str:
        return self.dotted


@dataclass(frozen=True, slots=True)
class Number:
    """A number without a unit: ``2``, ``0.5``, ``-1e-3``."""

    value: float
    text: str
    span: Span

    def __str__(self) -> str:
        return self.text


@dataclass(frozen=True, slots=True)
class Quantity:
    """A number with a unit, both as written: ``90 deg`` is ``Quantity(90.0, "deg", ...)``.

    ``unit`` is one of `UNITS` when the parse reported no error about it.
    """

    value: float
    unit: str
    text: str
    span: Span

    def __str__(self) -> str:
        return self.text


@dataclass(frozen=True, slots=True)
class String:
    """A string literal (unescaped ``value``); in an instance binding, an evidence id."""

    value: str
    span: Span


@dataclass(frozen=True, slots=True)
class Call:
    """A call: a primitive relation or measurement (``angle(a, b)``, ``parallel(a, b)``,
    ``edge(a, b)``, ``position(self)``) or a template use (``perpendicular(front, left)``)."""

    func: Name
    args: tuple[Expr, ...]
    span: Span

    def __str__(self) -> str:
        return f"{self.func.text}({', '.join(str(a) for a in self.args)})"


@dataclass(frozen=True, slots=True)
class ListExpr:
    """A bracketed list of values (instance bindings of a role with several fillers)."""

    items: tuple[Value, ...]
    span: Span

    def __str__(self) -> str:
        shown = (f'"{i.value}"' if isinstance(i, String) else str(i) for i in self.items)
        return "[" + ", ".join(shown) + "]"


#: An expression of a relation, argument or default value.
Expr: TypeAlias = Path | Call | Number | Quantity
#: What an instance binding may bind: an expression, an evidence id, or a list of those.
Value: TypeAlias = Path | Call | Number | Quantity | String | ListExpr


# ---- relations ---------------------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class Comparison:
    """``lhs == rhs``: ``angle(a, b) == 90 deg``; for symmetry ``angle(a, b) == angle(c, d)``."""

    lhs: Expr
    op: Literal["=="]
    rhs: Expr
    span: Span


@dataclass(frozen=True, slots=True)
class Relation:
    """One relation with its qualifiers, as used in templates, ``constraint`` and ``measure``.

    ``body`` is a `Call` (a predicate such as ``parallel(a, b)``, a measurement such as
    ``position(self)``, or a template use) or a `Comparison`. ``tolerance`` is the sigma
    (``+- 0.5 deg``; a quantity, number or parameter name), ``weight`` an explicit weight,
    ``reject`` the rejection threshold (``reject above 3 deg``).
    """

    body: Call | Comparison
    tolerance: Expr | None
    weight: Expr | None
    reject: Expr | None
    span: Span


# ---- concept members ---------------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class Cardinality:
    """``[min..max]``; ``max`` is None for ``*``. ``[n]`` is ``[n..n]``."""

    min: int
    max: int | None
    span: Span

    def __str__(self) -> str:
        return f"[{self.min}..{'*' if self.max is None else self.max}]"


@dataclass(frozen=True, slots=True)
class Range:
    """``[low, high]``, the closed range of an attribute."""

    low: Expr
    high: Expr
    span: Span


@dataclass(frozen=True, slots=True)
class Part:
    """``[optional] part r1, r2: Concept [card]``: one or more roles filled by one concept."""

    roles: tuple[Name, ...]
    concept: Name
    optional: bool
    cardinality: Cardinality | None
    span: Span


@dataclass(frozen=True, slots=True)
class ConOf:
    """``con-of role: Concept [card]``: realised by a concept of the next layer down."""

    role: Name
    concept: Name
    cardinality: Cardinality | None
    span: Span


@dataclass(frozen=True, slots=True)
class AttributeMeasure:
    """``is slope(self) [+- sigma]``: the geometric measure an attribute stands for."""

    call: Call
    tolerance: Expr | None
    span: Span


@dataclass(frozen=True, slots=True)
class Attribute:
    """``attribute name: type [in [low, high]] [= default] [is measure(args) [+- sigma]]``."""

    name: Name
    type: Name
    range: Range | None
    default: Expr | None
    span: Span
    measure: AttributeMeasure | None = None


class AdjacencyKind(StrEnum):
    """How ``adjacent`` lists its parts: a closed ``ring`` or explicit ``pairs``."""

    RING = "ring"
    PAIRS = "pairs"


@dataclass(frozen=True, slots=True)
class Adjacency:
    """``adjacent ring(a, b, c, d)`` or ``adjacent pairs((a, b), (c, d))``.

    ``groups`` holds the ring's parts as one group, or each pair as a group of two.
    """

    kind: AdjacencyKind
    groups: tuple[tuple[Path, ...], ...]
    span: Span
    condition: Condition | None = None

    @property
    def edges(self) -> tuple[tuple[Path, Path], ...]:
        """The adjacent pairs: consecutive parts of the ring (closing it), or the pairs."""
        if self.kind is AdjacencyKind.PAIRS:
            return tuple((g[0], g[1]) for g in self.groups)
        ring = self.groups[0]
        if len(ring) < 2:
            return ()
        return tuple((ring[i], ring[(i + 1) % len(ring)]) for i in range(len(ring)))


@dataclass(frozen=True, slots=True)
class Constraint:
    """``constraint [label:] relation``; the label names it for overriding and reports."""

    label: Name | None
    relation: Relation
    span: Span
    condition: Condition | None = None


@dataclass(frozen=True, slots=True)
class Measure:
    """``measure relation``: a measurement constraint tying the concept to image evidence."""

    relation: Relation
    span: Span
    condition: Condition | None = None


#: The six directions of a composite's frame, as written in ``orient`` and ``attach``.
DIRECTIONS: tuple[str, ...] = ("forward", "backward", "leftward", "rightward", "upward", "downward")


@dataclass(frozen=True, slots=True)
class Frame:
    """``frame from front``: the composite's frame takes its forward axis from a part."""

    anchor: Path
    span: Span


@dataclass(frozen=True, slots=True)
class Orient:
    """``orient a, b: forward [tilted by pitch]``: the direction planar parts face."""

    parts: tuple[Path, ...]
    direction: Name
    tilt: Expr | None
    span: Span


class PlacementKind(StrEnum):
    """How an unseen part is placed: ``mirror`` about an edge, ``at`` an ``offset``, ``reach``."""

    MIRROR = "mirror"
    OFFSET = "offset"
    REACH = "reach"


@dataclass(frozen=True, slots=True)
class Placement:
    """How an unseen part is placed: ``mirror P about edge(a, b)``, ``at V from P``,
    ``reach edge(a, b)``. ``ref`` is P (mirror, at), ``value`` V (at), ``line`` the edge."""

    kind: PlacementKind
    ref: Path | None
    value: Expr | None
    line: Call | None
    span: Span


@dataclass(frozen=True, slots=True)
class Unseen:
    """``unseen a, b: PLACEMENT``: where parts no view shows are put."""

    parts: tuple[Path, ...]
    placement: Placement
    span: Span
    condition: Condition | None = None


@dataclass(frozen=True, slots=True)
class Attach:
    """``attach oriels: backward against front, left [as back]``: a sub-object's open face lies
    in one of its whole's planes, facing the same way (``in``) or into it (``against``)."""

    part: Path
    face: Name
    contact: Name
    planes: tuple[Path, ...]
    name: Name | None
    span: Span


@dataclass(frozen=True, slots=True)
class Touching:
    """``touching houses share body.roof, body.height``: members of the scene's part role
    ``role`` that touch one another (a party wall between them) are filled alike at every path
    of ``paths`` (relative to the role's concept): the same concept along is-a."""

    role: Name
    paths: tuple[Path, ...]
    span: Span


Geometry: TypeAlias = Frame | Orient | Unseen | Attach | Touching


@dataclass(frozen=True, slots=True)
class Condition:
    """``when roof is HipRoof, GableRoof``: the relations of a ``when`` block hold only when the
    role at ``role`` is filled by one of ``concepts`` (or a specialisation of one)."""

    role: Path
    concepts: tuple[Name, ...]
    span: Span  # from 'when' to the last concept name


#: The members a ``when`` block may hold: relations, which carry the block's condition.
Conditional: TypeAlias = Adjacency | Constraint | Measure | Unseen


@dataclass(frozen=True, slots=True)
class When:
    """``when ROLE is C1, C2 { members }``: relations that hold only for those fillers.

    ``members`` are as written (any member parses; the compiler accepts only `Conditional`
    ones, ``KB155``); the conditional ones carry ``condition``.
    """

    condition: Condition
    members: tuple[Member, ...]
    span: Span

    @property
    def relations(self) -> tuple[Conditional, ...]:
        """The members that may be conditional, in order."""
        kinds = Adjacency | Constraint | Measure | Unseen
        return tuple(m for m in self.members if isinstance(m, kinds))


Member: TypeAlias = Part | ConOf | Attribute | Adjacency | Constraint | Measure | Geometry | When


# ---- declarations --------------------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class Layers:
    """``layers scene > world > image``: the layers, top to bottom."""

    names: tuple[Name, ...]
    span: Span


@dataclass(frozen=True, slots=True)
class Import:
    """``import "walls.kb"``: the path as written, relative to the importing file."""

    path: String
    span: Span


@dataclass(frozen=True, slots=True)
class Param:
    """A template parameter ``name: type [= default]``."""

    name: Name
    type: Name
    default: Expr | None
    span: Span


@dataclass(frozen=True, slots=True)
class Template:
    """``template name(params) { relations }``: a named, parameterised constraint."""

    name: Name
    params: tuple[Param, ...]
    doc: str | None
    body: tuple[Relation, ...]
    span: Span


@dataclass(frozen=True, slots=True)
class Concept:
    """``[abstract] concept Name in layer | is-a Parents { doc members }``."""

    name: Name
    abstract: bool
    layer: Name | None
    parents: tuple[Name, ...]
    doc: str | None
    members: tuple[Member, ...]
    span: Span

    @property
    def flat_members(self) -> tuple[Member, ...]:
        """The members in order, each ``when`` block replaced by its relations (which carry
        the block's condition); other members inside a block are left out (``KB155``)."""
        out: list[Member] = []
        for m in self.members:
            if isinstance(m, When):
                out.extend(m.relations)
            else:
                out.append(m)
        return tuple(out)

    @property
    def whens(self) -> tuple[When, ...]:
        """The ``when`` blocks, in order."""
        return tuple(m for m in self.members if isinstance(m, When))

    @property
    def parts(self) -> tuple[Part, ...]:
        """The ``part`` declarations, in order."""
        return tuple(m for m in self.members if isinstance(m, Part))

    @property
    def con_ofs(self) -> tuple[ConOf, ...]:
        """The ``con-of`` declarations, in order."""
        return tuple(m for m in self.members if isinstance(m, ConOf))

    @property
    def attributes(self) -> tuple[Attribute, ...]:
        """The ``attribute`` declarations, in order."""
        return tuple(m for m in self.members if isinstance(m, Attribute))

    @property
    def adjacencies(self) -> tuple[Adjacency, ...]:
        """The ``adjacent`` declarations, in order."""
        return tuple(m for m in self.flat_members if isinstance(m, Adjacency))

    @property
    def constraints(self) -> tuple[Constraint, ...]:
        """The ``constraint`` declarations, in order."""
        return tuple(m for m in self.flat_members if isinstance(m, Constraint))

    @property
    def measures(self) -> tuple[Measure, ...]:
        """The ``measure`` declarations, in order."""
        return tuple(m for m in self.flat_members if isinstance(m, Measure))

    @property
    def geometry(self) -> tuple[Geometry, ...]:
        """The ``frame``, ``orient``, ``unseen`` and ``attach`` declarations, in order."""
        return tuple(
            m for m in self.flat_members if isinstance(m, Frame | Orient | Unseen | Attach)
        )


@dataclass(frozen=True, slots=True)
class Binding:
    """``role = value`` in an instance: another instance (a `Path`), an evidence id (a
    `String`), a quantity or number (an attribute value), or a `ListExpr` of those."""

    role: Name
    value: Value
    span: Span


@dataclass(frozen=True, slots=True)
class Instance:
    """``instance name of Concept { bindings }``."""

    name: Name
    concept: Name
    doc: str | None
    bindings: tuple[Binding, ...]
    span: Span


Declaration: TypeAlias = Template | Concept | Instance
Item: TypeAlias = Layers | Import | Template | Concept | Instance


@dataclass(frozen=True, slots=True)
class Module:
    """One parsed file: its top-level items in source order."""

    file: str
    items: tuple[Item, ...]
    span: Span

    @property
    def layers(self) -> tuple[Layers, ...]:
        """The ``layers`` declarations (a well-formed KB has at most one in its root file)."""
        return tuple(i for i in self.items if isinstance(i, Layers))

    @property
    def imports(self) -> tuple[Import, ...]:
        """The ``import`` declarations, in order."""
        return tuple(i for i in self.items if isinstance(i, Import))

    @property
    def declarations(self) -> tuple[Declaration, ...]:
        """Templates, concepts and instances, in order."""
        return tuple(i for i in self.items if isinstance(i, Template | Concept | Instance))

    @property
    def concepts(self) -> tuple[Concept, ...]:
        """The concepts, in order."""
        return tuple(i for i in self.items if isinstance(i, Concept))

    @property
    def templates(self) -> tuple[Template, ...]:
        """The templates, in order."""
        return tuple(i for i in self.items if isinstance(i, Template))

    @property
    def instances(self) -> tuple[Instance, ...]:
        """The instances, in order."""
        return tuple(i for i in self.items if isinstance(i, Instance))
