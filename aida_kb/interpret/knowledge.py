"""What the interpreter needs from the compiled knowledge base, and the structures it builds.

`Knowledge` wraps a compiled `KnowledgeBase`: concepts with their slots (parts and con-of
realisations with cardinalities), attribute ranges in SI units, expanded constraints and
adjacencies, the is-a hierarchy, and the geometry the language declares (docs/language.md
§3.9-3.12): frames, orientations, measured attributes, placements of unseen parts and
attachments. `structures` unfolds a concept top-down along part-of into every fully
specialised *structure*: the instance skeleton of one alternative, with its planar parts (the
leaves that evidence regions can bind to, each with the direction it faces in the structure's
frame), its is-a choices, its frame's anchor, and which planes meet (adjacency, absolute role
paths). The constraints of a structure are not listed here: `aida_kb.solve.constraints_from_kb`
finds them in the compiled knowledge base (`kb`). No concept, role or attribute name is known
to this module: everything comes from the compiled knowledge base.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any, Literal

from aida_kb.diagnostics.core import Span
from aida_kb.errors import InterpretError
from aida_kb.interpret.hypotheses import HORIZONTAL, PlanarPart
from aida_kb.kb.paths import ROOT, RolePath, Step

if TYPE_CHECKING:
    from aida_kb.kb.model import AttachmentModel, ConceptModel, KnowledgeBase, PlacementModel

Link = Literal["goal", "con-of", "part-of"]
Requires = tuple[tuple[str, tuple[str, ...]], ...]
_RIGHT_ANGLE_DEG = 90.0


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
    """An attribute's range and value in SI units (radians, metres); ``measure`` the geometric
    measure it stands for (``"slope"``, ``"height"`` ...; None: none) and its arguments."""

    name: str
    low: float | None
    high: float | None
    value: float | None
    span: Span | None = None
    measure: str | None = None
    measure_args: tuple[str, ...] = ()
    sigma: float | None = None


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
    frame: str | None = None  # the anchor part of its own frame (None: its whole's frame)
    orientations: Mapping[str, Any] = field(default_factory=dict)  # part -> OrientationModel
    placements: tuple[Any, ...] = ()  # PlacementModel (aida_kb.kb)
    attachments: Mapping[str, Any] = field(default_factory=dict)  # part -> AttachmentModel


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
    anchor: str | None = None  # the role (relative to root) its frame is taken from

    @property
    def anchor_path(self) -> str | None:
        """The absolute role path of the frame's anchor part (None: no frame)."""
        return join(self.root, self.anchor) if self.anchor is not None else None

    def describe(self) -> str:
        """The is-a choices, e.g. 'body.roof=GableRoof' ('' if none)."""
        return ", ".join(f"{r}={c}" for r, c in self.choices)


def join(owner: str, role: str) -> str:
    """The absolute role path of `role` relative to `owner` ('self' is the owner)."""
    return str(RolePath.parse(owner).join(RolePath.parse(role)))


def _plain(role: str) -> str:
    """The role path without filler indices (``wings[1].roof`` -> ``wings.roof``)."""
    return str(RolePath.parse(role).plain)


# the language's directions of a level face (docs/language.md, orient)
_LEVEL_DIRECTIONS = ("upward", "downward")


class Knowledge:
    """The compiled knowledge base seen through the interpreter's needs."""

    def __init__(self, concepts: dict[str, Concept], kb: KnowledgeBase) -> None:
        self.concepts = concepts
        self.kb = kb
        self._children: dict[str, list[str]] = {name: [] for name in concepts}
        # filled by `structures`: role path (no filler indices) -> direction / composite concept
        self._directions: dict[str, str] = {}
        self._composites: dict[str, str] = {}
        self._planes: dict[str, str] = {}
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

    def slope_attribute(self, concept: str) -> Attribute | None:
        """The attribute of a planar concept that measures its own slope (``is slope(self)``)."""
        for a in self.concept(concept).attributes.values():
            if a.measure == "slope" and a.measure_args == ("self",):
                return a
        return None

    def slope_range_deg(self, concept: str) -> tuple[float, float] | None:
        """The range of a planar concept's slope attribute, degrees (None if none)."""
        a = self.slope_attribute(concept)
        if a is not None and a.low is not None and a.high is not None:
            return (math.degrees(a.low), math.degrees(a.high))
        return None

    def is_planar(self, concept: str) -> bool:
        """True for a leaf of the world layer: a concept without part-of slots."""
        return not any(s.link == "part-of" for s in self.concept(concept).slots)

    def orients_level(self) -> bool:
        """True if some concept orients a part level (``orient ROLE: upward`` or
        ``downward``: a floor on the ground, a flat roof): regions may then be taken for level
        (`observe.estimate_up`)."""
        return any(
            o.direction in _LEVEL_DIRECTIONS
            for c in self.concepts.values()
            for o in c.orientations.values()
        )

    def direction(self, role: str) -> str | None:
        """The direction a planar part (absolute role path) faces, once its structure has been
        unfolded by `structures` (None: not oriented, or not unfolded)."""
        return self._directions.get(_plain(role))

    def concept_at(self, role: str) -> str:
        """The concept of the planar part at an absolute role path, once unfolded ('' if none
        is known; alternatives of one path share their concept's meaning, not always its name:
        the first unfolded is given)."""
        return self._planes.get(_plain(role), "")

    def attachment(self, root: str) -> AttachmentModel | None:
        """How the sub-object at role path ``root`` (``body.wings[0]``) attaches to its whole."""
        path = RolePath.parse(root)
        if len(path) < 2:
            return None
        concept = self._composites.get(str(path.parent.plain))
        if concept is None:
            return None
        found: AttachmentModel | None = self.concept(concept).attachments.get(path.last.role)
        return found

    def placements(
        self, role: str, fillers: Mapping[str, str]
    ) -> list[tuple[PlacementModel, str, Mapping[str, str]]]:
        """The placements that apply to the unseen planar part at ``role`` (absolute path).

        Each comes with the role path of the composite that declares it and a map from the
        placement's paths (relative to that composite) to absolute role paths (a path through a
        role with several fillers takes the index of ``role``'s filler). Declared by every
        composite above the part; those whose ``requires`` the ``fillers`` (role path ->
        concept) do not meet are left out.
        """
        out: list[tuple[PlacementModel, str, Mapping[str, str]]] = []
        steps = RolePath.parse(role).steps
        for i in range(len(steps) - 1, -1, -1):
            owner, rel = RolePath(steps[:i]), RolePath(steps[i:])
            concept = self._composites.get(str(owner.plain))
            if concept is None:
                continue
            plain = str(rel.plain)
            for p in self.concept(concept).placements:
                if p.part != plain:
                    continue
                paths = {
                    x: str(_indexed(owner, x, rel))
                    for x in (p.ref, *(p.line or ()))
                    if x is not None
                }
                if self.holds(str(owner), _indexed_requires(p.requires, rel), fillers):
                    out.append((p, str(owner), paths))
        return out

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
                slope = self.slope_attribute(special)
                path = RolePath.parse(role)
                leaf = PlanarPart(
                    role,
                    str(path.last) if path else "",
                    special,
                    self.slope_range_deg(special),
                    False,
                    default_tilt_deg=(
                        math.degrees(slope.value)
                        if slope is not None and slope.value is not None
                        else None
                    ),
                )
                self._planes.setdefault(str(path.plain), special)
                yield Structure(role, (node,), (leaf,), (), choice)
                continue
            self._composites[_plain(role)] = special
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
                leaves = tuple(
                    self._oriented(leaf, role, c, fillers) for sub in combo for leaf in sub.leaves
                )
                yield Structure(
                    role,
                    nodes,
                    leaves,
                    adjacency + tuple(a for sub in combo for a in sub.adjacency),
                    choice + tuple(ch for sub in combo for ch in sub.choices),
                    c.frame,
                )

    def _oriented(
        self, leaf: PlanarPart, owner: str, c: Concept, fillers: dict[str, str]
    ) -> PlanarPart:
        """The leaf with the orientation ``c`` (at role path ``owner``) declares for it, if any:
        a whole's declaration overrides its parts' own (it is applied later, going up)."""
        rel = RolePath.parse(leaf.role).relative_to(RolePath.parse(owner))
        o = c.orientations.get(str(rel.plain))
        if o is None or not self.holds(owner, o.requires, fillers):
            return leaf
        tilt: float | None = o.tilt_rad
        tilted = o.direction in HORIZONTAL and (
            o.tilt_from is not None
            or (tilt is not None and abs(math.degrees(tilt) - _RIGHT_ANGLE_DEG) > 1e-9)
        )
        self._directions[_plain(leaf.role)] = o.direction
        return replace(
            leaf,
            direction=o.direction,
            pitched=tilted,
            tilt_deg=math.degrees(tilt) if tilt is not None else None,
            orient_span=o.span,
        )

    def asserted(self, structure: Structure) -> frozenset[tuple[object, ...]]:
        """What the knowledge asserts of `structure`'s planes: every constraint and measure
        that holds for its fillers, as (kind, absolute role paths, value, measurement) — the
        same relation declared for two specialisations is one."""
        fillers = {n.role: n.concept for n in structure.nodes}
        out: set[tuple[object, ...]] = set()
        for node in structure.nodes:
            for spec in self.concept(node.concept).constraints:
                if self.holds(node.role, spec.requires, fillers):
                    args = tuple(join(node.role, a) for a in spec.args)
                    out.add((spec.kind, args, spec.value, spec.measurement))
        return frozenset(out)

    def weaker(self, a: Structure, b: Structure) -> bool:
        """True if `a` asserts strictly less than `b` of the same planes: the same planar
        parts facing the same ways, meeting alike, and `a`'s constraints a proper subset of
        `b`'s (a gable whose slopes may differ, against the symmetric one). Where both fit the
        evidence, `b` says more and is preferred (`generate.WEAKER_PENALTY`)."""
        if a.root != b.root or set(a.adjacency) != set(b.adjacency):
            return False
        if {_leaf_key(x) for x in a.leaves} != {_leaf_key(x) for x in b.leaves}:
            return False
        return self.asserted(a) < self.asserted(b)

    def beyond_weaker(self, structure: Structure, others: Sequence[Structure]) -> frozenset[str]:
        """The role paths of `structure`'s planar parts that a relation it asserts beyond a
        weaker structure of `others` (`weaker`) names: what only the stronger one says of
        them (the symmetry of a gable's slopes names both slopes and the eaves walls)."""
        mine = self.asserted(structure)
        leaves = {leaf.role for leaf in structure.leaves}
        out: set[str] = set()
        for other in others:
            if other is structure or not self.weaker(other, structure):
                continue
            for relation in mine - self.asserted(other):
                args = relation[1]
                if isinstance(args, tuple):
                    out.update(a for a in args if isinstance(a, str) and a in leaves)
        return frozenset(out)

    def weaker_choices(self, concept: str, role: str) -> frozenset[tuple[str, str]]:
        """Pairs of choices along is-a (``ROLE=CONCEPT``) of `concept` at `role` whose
        structures differ by that choice only, the first's `weaker` than the second's
        (``('body.roof=AsymmetricGableRoof', 'body.roof=GableRoof')`` in kb/buildings.kb)."""
        found = self.structures(concept, role, "" if role else None, "con-of")
        out: set[tuple[str, str]] = set()
        for a in found:
            for b in found:
                diff_a, diff_b = set(a.choices) - set(b.choices), set(b.choices) - set(a.choices)
                if len(diff_a) == 1 and len(diff_b) == 1 and self.weaker(a, b):
                    ((ra, ca),), ((rb, cb),) = diff_a, diff_b
                    out.add((f"{ra}={ca}", f"{rb}={cb}"))
        return frozenset(out)

    def holds(self, owner: str, requires: Requires, fillers: Mapping[str, str]) -> bool:
        """True if every conditional role path is filled by one of the required concepts."""
        for path, allowed in requires:
            filler = fillers.get(join(owner, path))
            if filler is None or not any(self.is_a(filler, a) for a in allowed):
                return False
        return True

    def measurement(self, concept: str, kind: str) -> Any | None:
        """The first measurement spec of `kind` ('position', 'edge') declared by `concept`."""
        for s in self.concept(concept).constraints:
            if s.measurement and s.kind == kind:
                return s
        return None

    def contour_path(self, concept: str) -> str | None:
        """The role path, relative to a planar concept, of the contours of its evidence: its
        con-of realisation, then the part of the realising concept whose concept measures an
        edge of itself (``measure edge(self)``); None when the knowledge has none."""
        real = self.realisation(concept) if concept in self.concepts else None
        if real is None:
            return None
        for s in self.concept(real.concept).slots:
            if s.link == "part-of" and self.measurement(s.concept, "edge") is not None:
                return f"{real.role}.{s.role}"
        return None

    def realisation(self, concept: str) -> Slot | None:
        """The con-of slot of `concept` (its realisation one layer down), if any."""
        for s in self.concept(concept).slots:
            if s.link == "con-of":
                return s
        return None


def _leaf_key(leaf: PlanarPart) -> tuple[object, ...]:
    """A planar part as the knowledge declares it, not where (its ``orient`` span left out)."""
    return (
        leaf.role,
        leaf.concept,
        leaf.slope_range_deg,
        leaf.pitched,
        leaf.direction,
        leaf.tilt_deg,
        leaf.default_tilt_deg,
    )


def _concept_of(name: str, model: ConceptModel) -> Concept:
    """Translate the compiler's `ConceptModel` into a `Concept`."""
    slots = [
        Slot(p.role, p.concept, p.min, p.max, "part-of", p.optional) for p in model.parts.values()
    ]
    slots += [Slot(c.role, c.concept, c.min, c.max, "con-of") for c in model.con_ofs.values()]
    attributes = {
        a.name: Attribute(
            a.name,
            a.low,
            a.high,
            a.default,
            a.span,
            a.measure.kind if a.measure is not None else None,
            a.measure.args if a.measure is not None else (),
            a.measure.sigma if a.measure is not None else None,
        )
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
        frame=model.frame.anchor if model.frame is not None else None,
        orientations=dict(model.orientations),
        placements=tuple(model.placements),
        attachments=dict(model.attachments),
    )


def _indexed(owner: RolePath, path: str, like: RolePath) -> RolePath:
    """``path`` (relative to ``owner``) as an absolute path, taking the filler indices of the
    relative path ``like`` where they share roles (``wings.roof.front`` like ``wings[1].left``
    is ``wings[1].roof.front``)."""
    given = like.steps
    out = []
    for i, step in enumerate(RolePath.parse(path).steps):
        if i < len(given) and Step(given[i].role) == step:
            out.append(given[i])
        else:
            out.append(step)
            given = ()
    return owner.join(RolePath(tuple(out)))


def _indexed_requires(requires: Requires, like: RolePath) -> Requires:
    """Conditions whose role paths take the filler indices of ``like``."""
    return tuple((str(_indexed(ROOT, path, like)), allowed) for path, allowed in requires)
