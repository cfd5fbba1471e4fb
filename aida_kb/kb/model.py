"""The compiled knowledge base: immutable pydantic models (frozen), inheritance resolved.

Everything a later phase needs is here, in SI units (radians, metres; image tolerances in
pixels): concepts with their members (each knowing the concept that declared it), templates,
instances, and every constraint expanded into primitive relations (`ConstraintSpec`).
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict

from aida_kb.diagnostics.core import Span
from aida_kb.dsl.ast import PlacementKind
from aida_kb.kb.measures import MeasureKind

__all__ = [
    "AdjacencyModel",
    "AttachmentModel",
    "AttributeModel",
    "BindingModel",
    "ConOfModel",
    "ConceptModel",
    "ConstraintSpec",
    "Direction",
    "FrameModel",
    "InstanceModel",
    "KnowledgeBase",
    "MeasureKind",
    "MeasureModel",
    "OrientationModel",
    "ParamModel",
    "PartModel",
    "PlacementKind",
    "PlacementModel",
    "TemplateModel",
]


class _Frozen(BaseModel):
    model_config = ConfigDict(frozen=True, arbitrary_types_allowed=True)


ConstraintKind = Literal["angle", "parallel", "parallel_edge", "symmetry", "position", "edge"]
ResidualUnit = Literal["rad", "m", "px", ""]
ValueType = Literal["angle", "length", "number"]
ValueUnit = Literal["rad", "m", ""]
#: The directions of a composite's frame (docs/language.md §3.9).
Direction = Literal["forward", "backward", "leftward", "rightward", "upward", "downward"]


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


class MeasureModel(_Frozen):
    """The geometric measure an attribute stands for (``is slope(self) +- 1 deg``).

    ``args`` are role paths relative to the attribute's concept (``"self"``, ``"front"``);
    ``sigma`` the tolerance of the soft prior in SI, None when not given (the range's
    half-width is then taken as `RANGE_SIGMAS` sigma).
    """

    kind: MeasureKind
    args: tuple[str, ...]
    sigma: float | None
    span: Span


#: A measured attribute without a tolerance: its range's half-width counts as this many sigma.
RANGE_SIGMAS = 5.0


class AttributeModel(_Frozen):
    """A typed attribute; ``low``, ``high`` and ``default`` in SI (``unit``).

    ``measure``: the geometric measure of the instance the attribute stands for, if any: the
    range is then checked against the evidence and the model (a soft prior towards the
    default inside it, rejection outside it).
    """

    name: str
    type: ValueType
    unit: ValueUnit
    low: float | None
    high: float | None
    default: float | None
    declared_in: str
    span: Span
    measure: MeasureModel | None = None


class AdjacencyModel(_Frozen):
    """Two planes (role paths) that meet along an edge."""

    a: str
    b: str
    declared_in: str
    span: Span
    requires: Requires = ()


class FrameModel(_Frozen):
    """``frame from ANCHOR``: the concept has its own frame; forward is where the anchor
    part faces (horizontally), up the vertical, rightward completes a right-handed frame."""

    anchor: str
    declared_in: str
    span: Span


class OrientationModel(_Frozen):
    """``orient PART: DIRECTION [tilted by T]``: the direction a planar part faces in the
    frame of the nearest composite (this concept or a whole) that has one.

    ``tilt_rad`` is the angle between the part's plane and the ground: upward faces 0,
    downward pi, a horizontal direction pi/2 unless tilted (a roof plane facing forward
    tilted by its pitch: its normal turned from up towards forward by the pitch). It is
    None when it is read from ``tilt_from`` (a role path of an angle attribute) that has
    no default: the evidence then says.
    """

    part: str
    direction: Direction
    tilt_rad: float | None
    tilt_from: str | None
    declared_in: str
    span: Span
    requires: Requires = ()


class PlacementModel(_Frozen):
    """``unseen PART: ...``: where a part no view shows is put (paths relative to the concept).

    ``mirror``: as far beyond the line ``line`` (an edge, seen from above) as ``ref`` lies
    before it; ``offset``: parallel to ``ref`` at ``value`` metres (or the default of the
    length attribute ``value_attribute``); ``reach``: out to the line ``line``. Every placement
    only moves the part outwards from the seen surface points.
    """

    part: str
    kind: PlacementKind
    ref: str | None
    line: tuple[str, str] | None
    value: float | None
    value_attribute: str | None
    declared_in: str
    span: Span
    requires: Requires = ()


class AttachmentModel(_Frozen):
    """``attach PART: FACE in|against PLANES [as NAME]``: the sub-object filling PART has an
    open face (facing FACE in its own frame) that lies in one of the planar parts PLANES of this
    concept: ``in`` facing the same way as that plane (a wing's bottom in the floor),
    ``against`` facing into it (an oriel's back against a wall). ``name`` names that face in
    the model (default: the direction)."""

    part: str
    face: Direction
    contact: Literal["in", "against"]
    planes: tuple[str, ...]
    name: str
    declared_in: str
    span: Span


class ShareModel(_Frozen):
    """``touching ROLE share PATH``: members of the part role ``role`` (objects of a scene)
    that touch one another are filled alike at ``path`` (relative to the role's concept): the
    same concept along is-a (docs/language.md §3.14)."""

    role: str
    path: str
    declared_in: str
    span: Span


class ConceptModel(_Frozen):
    """A concept with every member resolved: own and inherited, overrides applied.

    The geometry members: ``frame`` (None: the concept uses its whole's frame),
    ``orientations`` and ``placements`` by part path, ``attachments`` by attached part;
    ``shares``: what touching objects of a part role have alike (a scene concept).
    """

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
    frame: FrameModel | None = None
    orientations: dict[str, OrientationModel] = {}
    placements: tuple[PlacementModel, ...] = ()
    attachments: dict[str, AttachmentModel] = {}
    shares: tuple[ShareModel, ...] = ()


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
