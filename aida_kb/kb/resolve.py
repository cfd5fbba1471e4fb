"""Phase 2, resolution: the symbol table, layers, is-a cycles, inheritance with overriding.

One linear pass collects the declarations of every module; a second orders the concepts
parents-first (is-a cycles are reported and cut); a third gives each concept its resolved
members: the parents' members, then its own, which override inherited ones of the same name.
Role paths (``roof.front``) are resolved here too (`Table.resolve_path`), with the rule of
docs/language.md §3.8: a path through a role whose concept lacks the next member may name a
member that some specialisations of that concept have; the path is then *conditional* on the
filler being one of them.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable, Iterator, Sequence
from enum import StrEnum
from typing import Any

from aida_kb.diagnostics import codes
from aida_kb.diagnostics.core import Diagnostic, Span
from aida_kb.dsl import ast

__all__ = [
    "VALUE_TYPES",
    "CInfo",
    "PathRes",
    "Requires",
    "Rule",
    "Slot",
    "SlotKind",
    "Table",
    "diag",
    "did_you_mean",
    "resolve",
]

#: Value types of attributes and template parameters -> the SI unit of their values.
VALUE_TYPES: dict[str, str] = {"angle": "rad", "length": "m", "number": ""}

#: A conditional path's requirements: (role path prefix, the concepts its filler must be one of).
Requires = tuple[tuple[str, tuple[str, ...]], ...]


class SlotKind(StrEnum):
    """What a concept's member is: a part role, a con-of role or an attribute."""

    PART = "part"
    CON_OF = "con-of"
    ATTRIBUTE = "attribute"

    @property
    def words(self) -> str:
        """The kind in a message: "a part", "a con-of role", "an attribute"."""
        return {"part": "a part", "con-of": "a con-of role", "attribute": "an attribute"}[
            self.value
        ]


def diag(
    code: codes.Code,
    message: str,
    span: Span,
    hint: str | None = None,
    related: tuple[tuple[Span, str], ...] = (),
) -> Diagnostic:
    """A diagnostic of a registered code with its default severity."""
    return Diagnostic(code.code, code.severity, message, span, hint, related)


def did_you_mean(word: str, choices: Iterable[str], exclude: Iterable[str] = ()) -> str | None:
    """A "did you mean" hint for ``word`` among ``choices`` (difflib), or None; never one of
    ``exclude`` (a concept is offered no parent that is itself)."""
    left = set(exclude)
    close = difflib.get_close_matches(word, [c for c in choices if c not in left], n=1, cutoff=0.6)
    return f"did you mean '{close[0]}'?" if close else None


#: A cycle of more links than this is written with its first and last links, the middle
#: elided: a 1,500-concept cycle is one line and 8 notes, not 1,500.
MAX_CYCLE_SHOWN = 8


def chain_text(names: Sequence[str], sep: str) -> str:
    """``A sep B sep ... sep A`` of the cycle `names` (closed back to the first), the middle
    elided when it has more than `MAX_CYCLE_SHOWN` links."""
    closed = [*names, names[0]]
    if len(closed) - 1 <= MAX_CYCLE_SHOWN:
        return sep.join(closed)
    keep = MAX_CYCLE_SHOWN // 2
    hidden = len(closed) - 2 * keep
    return sep.join(closed[:keep]) + f"{sep}... {hidden} more ...{sep}" + sep.join(closed[-keep:])


def elide_related(
    related: Sequence[tuple[Span, str]], what: str = "links"
) -> tuple[tuple[Span, str], ...]:
    """The notes of a cycle's links, the middle elided beyond `MAX_CYCLE_SHOWN` (one note
    in its place says how many)."""
    if len(related) <= MAX_CYCLE_SHOWN:
        return tuple(related)
    keep = MAX_CYCLE_SHOWN // 2
    hidden = len(related) - 2 * keep
    return (
        *related[:keep],
        (related[keep][0], f"... {hidden} more {what} of the cycle ..."),
        *related[-keep:],
    )


class Slot:
    """A named member of a concept: a part role, a con-of role or an attribute."""

    __slots__ = ("concept", "kind", "max", "min", "name", "node", "optional", "owner")

    def __init__(
        self,
        kind: SlotKind,
        name: ast.Name,
        node: ast.Part | ast.ConOf | ast.Attribute,
        owner: str,
        concept: str | None,
        min: int,
        max: int | None,
        optional: bool,
    ) -> None:
        self.kind = kind
        self.name = name
        self.node = node
        self.owner = owner
        self.concept = concept
        self.min = min
        self.max = max
        self.optional = optional


class Rule:
    """A constraint or measure as a concept holds it: the declaration and its owner."""

    __slots__ = ("label", "node", "owner")

    def __init__(self, node: ast.Constraint | ast.Measure, owner: str, label: str | None) -> None:
        self.node = node
        self.owner = owner
        self.label = label


class CInfo:
    """What resolution knows of one concept."""

    __slots__ = (
        "adjacency",
        "children",
        "geometry",
        "layer",
        "node",
        "own_slots",
        "parents",
        "rules",
        "slots",
    )

    def __init__(
        self,
        node: ast.Concept,
        parents: list[str],
        layer: str | None = None,
        slots: dict[str, Slot] | None = None,
        adjacency: list[tuple[ast.Adjacency, str]] | None = None,
        rules: list[Rule] | None = None,
        children: list[str] | None = None,
        own_slots: bool = False,
    ) -> None:
        self.node = node
        self.parents = parents
        self.layer = layer
        self.slots: dict[str, Slot] = dict() if slots is None else slots
        self.adjacency: list[tuple[ast.Adjacency, str]] = list() if adjacency is None else adjacency
        self.rules: list[Rule] = list() if rules is None else rules
        self.children: list[str] = list() if children is None else children
        self.own_slots = own_slots
        #: frame, orient, unseen and attach declarations, inherited first: (node, owner)
        self.geometry: list[tuple[ast.Geometry, str]] = []


class PathRes:
    """A resolved role path: the slot it ends on (None for ``self``) and its conditions."""

    __slots__ = ("concept", "dotted", "requires", "slot")

    def __init__(
        self, dotted: str, slot: Slot | None, concept: str | None, requires: Requires
    ) -> None:
        self.dotted = dotted
        self.slot = slot
        self.concept = concept
        self.requires = requires


class Table:
    """The symbol table of a knowledge base and the resolved concepts."""

    def __init__(self) -> None:
        self.layers: list[str] = []
        self.layer_index: dict[str, int] = {}
        self.concepts: dict[str, CInfo] = {}
        self.templates: dict[str, ast.Template] = {}
        self.instances: dict[str, ast.Instance] = {}
        self.order: list[str] = []  # concepts, parents first
        self.broken: set[str] = set()
        #: concepts known only in part: a parent is unknown, or a member did not parse. A
        #: member missing from one of them (or from a specialisation) is no new error.
        self.incomplete: set[str] = set()
        self._ancestors: dict[str, frozenset[str]] = {}
        self._descendants: dict[str, list[str]] = {}
        self._adjacent: dict[str, frozenset[tuple[str, str]]] = {}
        self._simple: dict[tuple[str, str], PathRes] = {}
        self._dotted: dict[tuple[str, tuple[str, ...]], PathRes] = {}
        #: template name -> (the template, required arguments, defaults as values): filled and
        #: read by `aida_kb.kb.relations.Analyzer.signature`
        self.signatures: dict[str, tuple[ast.Template, int, tuple[Any, ...]]] = {}
        #: (concept, id of a constraint or measure node) -> its primitives as analysed in that
        #: concept (`aida_kb.kb.relations.Prim`): kept by the checks, reused by the build
        self.expansions: dict[tuple[str, int], list[Any]] = {}
        #: the template cycles reported (each once, however many uses run into it)
        self.template_cycles: set[frozenset[str]] = set()

    # -- is-a queries
    def ancestors(self, name: str) -> frozenset[str]:
        """The concept and all its (acyclic) ancestors."""
        found = self._ancestors.get(name)
        if found is None:
            acc = {name}
            info = self.concepts.get(name)
            if info is not None:
                for p in info.parents:
                    acc |= self.ancestors(p)
            found = frozenset(acc)
            self._ancestors[name] = found
        return found

    def is_incomplete(self, name: str) -> bool:
        """True when the concept or an ancestor is known only in part (`incomplete`)."""
        return bool(self.incomplete) and not self.incomplete.isdisjoint(self.ancestors(name))

    def is_a(self, name: str, parent: str) -> bool:
        """True when ``name`` is ``parent`` or a specialisation of it."""
        return parent in self.ancestors(name)

    def descendants(self, name: str) -> list[str]:
        """All specialisations of the concept, transitively (not the concept itself)."""
        found = self._descendants.get(name)
        if found is None:
            found = []
            seen = {name}
            todo = list(self.concepts[name].children) if name in self.concepts else []
            while todo:
                c = todo.pop()
                if c in seen:
                    continue
                seen.add(c)
                found.append(c)
                todo.extend(self.concepts[c].children)
            found.sort()
            self._descendants[name] = found
        return found

    def adjacent_pairs(self, name: str) -> frozenset[tuple[str, str]]:
        """The adjacent pairs of role paths declared in (or inherited by) the concept."""
        found = self._adjacent.get(name)
        if found is None:
            pairs: set[tuple[str, str]] = set()
            for adj, _owner in self.concepts[name].adjacency:
                for a, b in adj.edges:
                    pairs.add((a.dotted, b.dotted))
                    pairs.add((b.dotted, a.dotted))
            found = frozenset(pairs)
            self._adjacent[name] = found
        return found

    # -- conditions ('when' blocks)
    def condition_requires(self, owner: str, cond: ast.Condition | None) -> Requires | None:
        """The conditions a ``when`` block puts on its relations in concept ``owner``.

        ``()`` without a block; None when the block cannot hold in ``owner``: its role does not
        resolve to a part, or the role's concept there (narrowed by a specialisation) is related
        by is-a to none of the named concepts. Otherwise the role's own conditions (a role
        reached through an abstract role) and ``(role, named concepts related to it)``; the
        latter is left out when the role's concept is itself one of the named (or below one).
        """
        if cond is None:
            return ()
        res = self.resolve_path(owner, cond.role)
        if not isinstance(res, PathRes) or res.slot is None or res.concept is None:
            return None
        if res.slot.kind is SlotKind.ATTRIBUTE or res.concept not in self.concepts:
            return None
        live = tuple(
            n.text
            for n in cond.concepts
            if n.text in self.concepts
            and (self.is_a(n.text, res.concept) or self.is_a(res.concept, n.text))
        )
        if not live:
            return None
        if any(self.is_a(res.concept, n) for n in live):
            return res.requires  # every filler of the (narrowed) role is one of them
        return (*res.requires, (res.dotted, live))

    def never_holds(
        self, requires: Requires
    ) -> tuple[str, tuple[str, ...], tuple[str, ...]] | None:
        """Two conditions on one role path that no concept meets at once (no concept of one is
        related by is-a to a concept of the other): (role path, one, other), else None."""
        by_path: dict[str, tuple[str, ...]] = {}
        for path, allowed in requires:
            prev = by_path.get(path)
            if prev is not None and not any(
                self.is_a(a, b) or self.is_a(b, a) for a in prev for b in allowed
            ):
                return path, prev, allowed
            by_path[path] = allowed if prev is None else prev
        return None

    # -- role paths
    def resolve_path(self, owner: str, path: ast.Path) -> PathRes | Diagnostic | None:
        """Resolve a role path relative to the concept ``owner``.

        Returns the resolution, a ``KB102`` diagnostic when a name is no member, or None when
        the path runs through a concept that is itself unknown (reported elsewhere).
        """
        parts = path.parts
        if len(parts) == 1:  # the common case, cached: a role or attribute of the owner
            key = (owner, parts[0].text)
            hit = self._simple.get(key)
            if hit is not None:
                return hit
            if key[1] == "self":
                hit = PathRes("self", None, owner, ())
            else:
                info = self.concepts.get(owner)
                own = info.slots.get(key[1]) if info is not None else None
                if own is not None:
                    target = None if own.kind is SlotKind.ATTRIBUTE else own.concept
                    hit = PathRes(key[1], own, target, ())
            if hit is not None:
                self._simple[key] = hit
                return hit
        texts = tuple(p.text for p in parts)
        key2 = (owner, texts)
        hit = self._dotted.get(key2)
        if hit is not None:
            return hit
        res = self._resolve_parts(owner, parts)
        if isinstance(res, PathRes):  # diagnostics carry this path's span: not shared
            self._dotted[key2] = res
        return res

    def _resolve_parts(
        self, owner: str, parts: tuple[ast.Name, ...]
    ) -> PathRes | Diagnostic | None:
        cur: str | None = owner
        requires: list[tuple[str, tuple[str, ...]]] = []
        slot: Slot | None = None
        for i, name in enumerate(parts):
            if cur is None or cur not in self.concepts:
                return None
            if slot is not None and slot.kind is SlotKind.ATTRIBUTE:
                return diag(
                    codes.UNKNOWN_ROLE,
                    f"'{parts[i - 1].text}' is an attribute: it has no member '{name.text}'",
                    name.span,
                )
            found = self.concepts[cur].slots.get(name.text)
            if found is None:
                found, cands = self._in_specialisations(cur, name.text)
                if found is None:
                    if self.is_incomplete(cur):
                        return None  # the member may be in what did not resolve or parse
                    return self._unknown_role(cur, name)
                prefix = ".".join(p.text for p in parts[:i])
                requires.append((prefix, cands))
            slot = found
            cur = found.concept
        dotted = ".".join(p.text for p in parts)
        target = None if slot is None or slot.kind is SlotKind.ATTRIBUTE else slot.concept
        return PathRes(dotted, slot, target, tuple(requires))

    def _in_specialisations(self, concept: str, member: str) -> tuple[Slot | None, tuple[str, ...]]:
        """The member as the topmost specialisations of ``concept`` declare it."""
        having = [d for d in self.descendants(concept) if member in self.concepts[d].slots]
        if not having:
            return None, ()
        having_set = set(having)
        top = tuple(
            d for d in having if not (self.ancestors(d) - {d}) & having_set
        )  # drop those that inherit it from another candidate
        return self.concepts[top[0]].slots[member], top

    def _unknown_role(self, concept: str, name: ast.Name) -> Diagnostic:
        members = set(self.concepts[concept].slots)
        for d in self.descendants(concept):
            members |= set(self.concepts[d].slots)
        return diag(
            codes.UNKNOWN_ROLE,
            f"'{name.text}' is no role or attribute of {concept}",
            name.span,
            did_you_mean(name.text, members),
        )


# ---- the passes -------------------------------------------------------------------------------
def _collect(
    table: Table, modules: list[ast.Module], *, library: bool = False
) -> Iterator[Diagnostic]:
    """Symbols of every module; duplicates (``KB110``) and the layers declaration (``KB112``).

    A file that declares the same layers as the first declaration (a knowledge base that is
    both run on its own and imported) repeats them harmlessly; different layers are ``KB112``.
    """
    layer_decls: list[ast.Layers] = []
    first: dict[tuple[str, str], ast.Name] = {}
    for module in modules:
        for item in module.items:
            if isinstance(item, ast.Layers):
                layer_decls.append(item)
                continue
            if isinstance(item, ast.Import):
                continue
            kind = (
                "concept"
                if isinstance(item, ast.Concept)
                else "template"
                if isinstance(item, ast.Template)
                else "instance"
            )
            name = item.name
            prev = first.get((kind, name.text))
            if prev is not None:
                yield diag(
                    codes.DUPLICATE_DEFINITION,
                    f"{kind} '{name.text}' is defined twice",
                    name.span,
                    "rename one of them or delete the repetition",
                    ((prev.span, "first defined here"),),
                )
                continue
            first[(kind, name.text)] = name
            if isinstance(item, ast.Concept):
                table.concepts[name.text] = CInfo(item, [])
            elif isinstance(item, ast.Template):
                table.templates[name.text] = item
            else:
                table.instances[name.text] = item
    if not layer_decls:
        if modules and not library:
            yield diag(
                codes.LAYERS_DECLARATION,
                "the knowledge base has no layers declaration",
                Span.point(modules[0].file, 1, 1),
                "declare the layers top to bottom: layers scene > world > image",
            )
        return
    first_names = [n.text for n in layer_decls[0].names]
    for extra in layer_decls[1:]:
        if [n.text for n in extra.names] == first_names:
            continue
        yield diag(
            codes.LAYERS_DECLARATION,
            "a second, different layers declaration",
            extra.span,
            "declare the layers once per knowledge base (an imported file may repeat them exactly)",
            ((layer_decls[0].span, "the first layers declaration"),),
        )
    for name in layer_decls[0].names:
        if name.text in table.layer_index:
            yield diag(
                codes.DUPLICATE_MEMBER,
                f"layer '{name.text}' is listed twice",
                name.span,
            )
            continue
        table.layer_index[name.text] = len(table.layers)
        table.layers.append(name.text)


def _unknown_concept(
    table: Table, name: ast.Name, what: str, exclude: Iterable[str] = ()
) -> Diagnostic | None:
    """``KB100`` for a name that is no concept (None when it is, or its declaration broke)."""
    if name.text in table.concepts or name.text in table.broken:
        return None
    return diag(
        codes.UNKNOWN_CONCEPT,
        f"unknown concept '{name.text}' {what}",
        name.span,
        did_you_mean(name.text, table.concepts, exclude),
    )


def _parents(table: Table) -> Iterator[Diagnostic]:
    """Known parents of each concept (``KB100`` for unknown ones); children lists."""
    for cname, info in table.concepts.items():
        node = info.node
        if node.layer is not None and node.layer.text not in table.layer_index and table.layers:
            yield diag(
                codes.UNKNOWN_LAYER,
                f"unknown layer '{node.layer.text}'",
                node.layer.span,
                did_you_mean(node.layer.text, table.layers)
                or f"the layers are: {', '.join(table.layers)}",
            )
        for p in node.parents:
            d = _unknown_concept(table, p, f"as the parent of {cname}", (cname,))
            if p.text not in table.concepts:
                table.incomplete.add(cname)
            if d is not None:
                yield d
            elif p.text in table.concepts and p.text not in info.parents:
                info.parents.append(p.text)


def _cycles(table: Table) -> Iterator[Diagnostic]:
    """Report is-a cycles (``KB120``) and cut them; fill ``table.order`` parents first."""
    state: dict[str, int] = {}  # 1 on the stack, 2 done
    order = table.order
    for root in table.concepts:
        if root in state:
            continue
        stack: list[tuple[str, int]] = [(root, 0)]
        path: list[str] = [root]
        state[root] = 1
        while stack:
            cname, i = stack[-1]
            info = table.concepts[cname]
            if i < len(info.parents):
                stack[-1] = (cname, i + 1)
                p = info.parents[i]
                st = state.get(p)
                if st is None:
                    state[p] = 1
                    stack.append((p, 0))
                    path.append(p)
                elif st == 1:
                    cyc = path[path.index(p) :]
                    yield _cycle_diag(table, cyc)
                    info.parents.remove(p)
                    stack[-1] = (cname, i)
                continue
            stack.pop()
            path.pop()
            state[cname] = 2
            order.append(cname)
    for cname in order:
        for p in table.concepts[cname].parents:
            table.concepts[p].children.append(cname)


def _parent_name(table: Table, child: str, parent: str) -> ast.Name:
    return next(n for n in table.concepts[child].node.parents if n.text == parent)


def _cycle_diag(table: Table, cyc: list[str]) -> Diagnostic:
    """``A is-a B is-a C is-a A``, at the is-a link that closes the cycle."""
    last = cyc[-1]
    text = chain_text(cyc, " is-a ")
    related = elide_related(
        [
            (_parent_name(table, a, b).span, f"{a} is-a {b}")
            for a, b in zip(cyc, [*cyc[1:], cyc[0]], strict=True)
        ]
    )
    return diag(
        codes.ISA_CYCLE,
        f"is-a cycle: {text}",
        _parent_name(table, last, cyc[0]).span,
        "a concept cannot specialise itself; remove one of the is-a links",
        related,
    )


def _slot_of(member: ast.Part | ast.ConOf | ast.Attribute, name: ast.Name, owner: str) -> Slot:
    if isinstance(member, ast.Attribute):
        return Slot(SlotKind.ATTRIBUTE, name, member, owner, None, 1, 1, False)
    card = member.cardinality
    low, high = (card.min, card.max) if card is not None else (1, 1)
    optional = isinstance(member, ast.Part) and member.optional
    if optional:
        low = 0
    kind = SlotKind.PART if isinstance(member, ast.Part) else SlotKind.CON_OF
    return Slot(kind, name, member, owner, member.concept.text, low, high, optional)


def _merge_parents(table: Table, cname: str, info: CInfo) -> dict[str, list[Slot]]:
    """Inherit slots, rules and adjacency; returns the keys on which parents disagree."""
    parents = info.parents
    if not parents:
        return {}
    if len(parents) == 1:
        p = table.concepts[parents[0]]
        info.slots = dict(p.slots)
        info.rules = list(p.rules)
        info.adjacency = list(p.adjacency)
        info.geometry = list(p.geometry)
        return {}
    clashes: dict[str, list[Slot]] = {}
    seen_rules: set[int] = set()
    labels: dict[str, Rule] = {}
    seen_adj: set[int] = set()
    for pname in parents:
        p = table.concepts[pname]
        for key, s in p.slots.items():
            prev = info.slots.get(key)
            if prev is None:
                info.slots[key] = s
            elif prev.node is not s.node:
                clashes.setdefault(key, [prev]).append(s)
        for r in p.rules:
            if id(r.node) in seen_rules:
                continue
            seen_rules.add(id(r.node))
            if r.label is not None:
                first = labels.get(r.label)
                if first is not None:
                    clashes.setdefault("#" + r.label, [])
                    continue
                labels[r.label] = r
            info.rules.append(r)
        for adj in p.adjacency:
            if id(adj[0]) not in seen_adj:
                seen_adj.add(id(adj[0]))
                info.adjacency.append(adj)
        for geo in p.geometry:
            if all(geo[0] is not g[0] for g in info.geometry):
                info.geometry.append(geo)
    return clashes


def _own_members(table: Table, cname: str, info: CInfo) -> Iterator[Diagnostic]:
    """Add the concept's own members, overriding inherited ones (``KB111``, ``KB126``)."""
    own: dict[str, ast.Name] = {}
    own_labels: dict[str, ast.Name] = {}
    inherited = info.slots
    for m in info.node.flat_members:
        if isinstance(m, ast.Part | ast.ConOf | ast.Attribute):
            names = (
                m.roles
                if isinstance(m, ast.Part)
                else (m.name,)
                if isinstance(m, ast.Attribute)
                else (m.role,)
            )
            for name in names:
                prev_own = own.get(name.text)
                if prev_own is not None:
                    yield diag(
                        codes.DUPLICATE_MEMBER,
                        f"'{name.text}' is declared twice in concept {cname}",
                        name.span,
                        "parts, con-of roles and attributes of a concept share one namespace",
                        ((prev_own.span, "first declared here"),),
                    )
                    continue
                own[name.text] = name
                slot = _slot_of(m, name, cname)
                for base in _bases(table, info, name.text):
                    bad = _override_problem(table, base, slot)
                    if bad is not None:
                        yield diag(
                            codes.BAD_OVERRIDE,
                            bad,
                            name.span,
                            "an override may only narrow a role to a specialisation of its "
                            "concept, or restate an attribute of the same type",
                            ((base.name.span, f"inherited from {base.owner}"),),
                        )
                        break
                inherited[name.text] = slot
                info.own_slots = True
        elif isinstance(m, ast.Adjacency):
            info.adjacency.append((m, cname))
        elif isinstance(m, ast.Frame | ast.Orient | ast.Unseen | ast.Attach | ast.Touching):
            info.geometry.append((m, cname))
        elif isinstance(m, ast.Constraint) and m.label is not None:
            label = m.label.text
            prev = own_labels.get(label)
            if prev is not None:
                yield diag(
                    codes.DUPLICATE_MEMBER,
                    f"constraint label '{label}' is used twice in concept {cname}",
                    m.label.span,
                    related=((prev.span, "first used here"),),
                )
                continue
            own_labels[label] = m.label
            info.rules = [r for r in info.rules if r.label != label]
            info.rules.append(Rule(m, cname, label))
        elif isinstance(m, ast.Constraint | ast.Measure):
            info.rules.append(Rule(m, cname, None))


def _bases(table: Table, info: CInfo, key: str) -> list[Slot]:
    """The distinct declarations of ``key`` that the parents pass on."""
    out: list[Slot] = []
    for p in info.parents:
        s = table.concepts[p].slots.get(key)
        if s is not None and all(s.node is not o.node for o in out):
            out.append(s)
    return out


def _override_problem(table: Table, base: Slot, new: Slot) -> str | None:
    if base.kind != new.kind:
        return f"'{new.name.text}' is {new.kind.words} here but {base.kind.words} in {base.owner}"
    if new.kind is SlotKind.ATTRIBUTE:
        a, b = base.node, new.node
        assert isinstance(a, ast.Attribute)
        assert isinstance(b, ast.Attribute)
        if a.type.text != b.type.text:
            return (
                f"attribute '{new.name.text}' is of type {b.type.text} here but "
                f"{a.type.text} in {base.owner}"
            )
        return None
    if (
        base.concept is not None
        and new.concept is not None
        and base.concept in table.concepts
        and new.concept in table.concepts
        and not table.is_a(new.concept, base.concept)
    ):
        return (
            f"role '{new.name.text}' is filled by {new.concept} here, which is no "
            f"specialisation of {base.concept} (the concept in {base.owner})"
        )
    return None


def _clash_diags(cname: str, info: CInfo, clashes: dict[str, list[Slot]]) -> Iterator[Diagnostic]:
    own = {
        n.text
        for m in info.node.members
        if isinstance(m, ast.Part | ast.ConOf | ast.Attribute)
        for n in (
            m.roles
            if isinstance(m, ast.Part)
            else (m.name,)
            if isinstance(m, ast.Attribute)
            else (m.role,)
        )
    }
    own_labels = {
        m.label.text for m in info.node.members if isinstance(m, ast.Constraint) and m.label
    }
    for key, slots in clashes.items():
        if key.startswith("#"):
            if key[1:] in own_labels:
                continue
            yield diag(
                codes.INHERITED_CONFLICT,
                f"{cname} inherits two different constraints labelled '{key[1:]}'",
                info.node.name.span,
                f"declare 'constraint {key[1:]}: ...' in {cname} to decide",
            )
            continue
        if key in own:
            continue
        owners = " and ".join(sorted({s.owner for s in slots}))
        yield diag(
            codes.INHERITED_CONFLICT,
            f"{cname} inherits '{key}' from {owners} with different declarations",
            info.node.name.span,
            f"declare '{key}' in {cname} to decide which one holds",
            tuple((s.name.span, f"declared in {s.owner}") for s in slots),
        )


def _layers_and_members(table: Table) -> Iterator[Diagnostic]:
    """Each concept's layer (``KB113``) and resolved members, parents first."""
    for cname in table.order:
        info = table.concepts[cname]
        node = info.node
        parent_layers = {
            table.concepts[p].layer for p in info.parents if table.concepts[p].layer is not None
        }
        own = node.layer.text if node.layer is not None else None
        if own is not None and own not in table.layer_index:
            own = None
            info.layer = None
        elif own is not None:
            info.layer = own
        elif len(parent_layers) == 1:
            info.layer = next(iter(parent_layers))
        if len(parent_layers | ({own} if own else set())) > 1:
            where = ", ".join(
                f"{p} in {table.concepts[p].layer}"
                for p in info.parents
                if table.concepts[p].layer is not None
            )
            yield diag(
                codes.LAYER_CONFLICT,
                f"{cname} is in layer {own or '?'}, but its parents are not all there ({where})",
                (node.layer or node.name).span,
                "a specialisation lives in the layer of its parents",
            )
        clashes = _merge_parents(table, cname, info)
        if node.members:
            yield from _own_members(table, cname, info)
        if clashes:
            yield from _clash_diags(cname, info, clashes)


def resolve(
    modules: list[ast.Module],
    broken: set[str],
    *,
    library: bool = False,
    incomplete: Iterable[str] = (),
) -> tuple[Table, list[Diagnostic]]:
    """Run the resolution passes over the loaded modules.

    ``library`` accepts a knowledge base without a layers declaration (a library file checked
    on its own, docs/language.md §2.3): no ``KB112`` for the missing declaration.
    ``incomplete`` names the concepts kept without a member that did not parse.
    """
    table = Table()
    table.broken = broken
    table.incomplete = set(incomplete)
    diags: list[Diagnostic] = []
    diags.extend(_collect(table, modules, library=library))
    diags.extend(_parents(table))
    diags.extend(_cycles(table))
    diags.extend(_layers_and_members(table))
    return table, diags
