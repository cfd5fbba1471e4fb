"""Phase 3, semantic checks: each a small function yielding diagnostics with a code and a span.

The checks read the resolved `Table` and change nothing it says (they fill its caches, and
keep each rule's primitives in ``Table.expansions`` for the build). Per concept: the concepts
its roles name, layers of parts and con-of, cardinalities, attributes (types, units, ranges),
adjacency paths, constraints and measures (through `relations.Analyzer`). Over the whole net:
part-of cycles, templates (parameters, body, use), instances, and the warnings (unused
template, unreachable concept, concept that cannot be verified).
"""

from __future__ import annotations

from collections.abc import Iterator

from aida_kb.diagnostics import codes
from aida_kb.diagnostics.core import Diagnostic
from aida_kb.dsl import ast
from aida_kb.kb.relations import UNIT_KIND, Analyzer, quantity_si
from aida_kb.kb.resolve import (
    VALUE_TYPES,
    CInfo,
    PathRes,
    Slot,
    SlotKind,
    Table,
    chain_text,
    diag,
    did_you_mean,
)
from aida_kb.kb.shape import check_shape

__all__ = ["run_checks"]

_EPS = 1e-12
_KIND_WORDS = {"angle": "an angle", "length": "a length", "image": "in pixels"}
_A_TYPE = {"angle": "an angle", "length": "a length", "number": "a number"}


# ---- per concept ------------------------------------------------------------------------------
def check_role_concepts(table: Table, info: CInfo) -> Iterator[Diagnostic]:
    """``KB100`` for parts and con-of roles typed by unknown concepts; ``KB122``, ``KB123``."""
    cname = info.node.name.text
    for m in info.node.members:
        if not isinstance(m, ast.Part | ast.ConOf):
            continue
        target = m.concept.text
        tinfo = table.concepts.get(target)
        if tinfo is None:
            if target not in table.broken:
                yield diag(
                    codes.UNKNOWN_CONCEPT,
                    f"unknown concept '{target}' for role "
                    f"'{', '.join(r.text for r in _roles(m))}' of {cname}",
                    m.concept.span,
                    did_you_mean(target, table.concepts),
                )
            continue
        if info.layer is None or tinfo.layer is None:
            continue
        here, there = table.layer_index[info.layer], table.layer_index[tinfo.layer]
        if isinstance(m, ast.Part) and here != there:
            yield diag(
                codes.PART_LAYER,
                f"part '{m.roles[0].text}' of {cname} (layer {info.layer}) is a {target}, "
                f"which lies in layer {tinfo.layer}",
                m.concept.span,
                "parts share their whole's layer; link layers with con-of",
            )
        elif isinstance(m, ast.ConOf) and there != here + 1:
            below = table.layers[here + 1] if here + 1 < len(table.layers) else None
            yield diag(
                codes.CONOF_LAYER,
                f"con-of '{m.role.text}' of {cname} (layer {info.layer}) names {target} in layer "
                f"{tinfo.layer}; con-of goes exactly one layer down"
                + (f", to {below}" if below else ""),
                m.concept.span,
                "use 'part' within a layer; a concept of the bottom layer has no con-of"
                if below is None or here == there
                else None,
            )


def _roles(m: ast.Part | ast.ConOf) -> tuple[ast.Name, ...]:
    return m.roles if isinstance(m, ast.Part) else (m.role,)


def check_cardinalities(info: CInfo) -> Iterator[Diagnostic]:
    """``KB124``: ``[min..max]`` with min > max."""
    for m in info.node.members:
        if isinstance(m, ast.Part | ast.ConOf):
            card = m.cardinality
            if card is not None and card.max is not None and card.min > card.max:
                yield diag(
                    codes.CARDINALITY_RANGE,
                    f"cardinality {card}: the minimum {card.min} exceeds the maximum {card.max}",
                    card.span,
                    f"write [{card.max}..{card.min}]",
                )


def _typed_constant(
    expr: ast.Expr, vtype: str, what: str
) -> tuple[float | None, Diagnostic | None]:
    """A constant of the value type in SI, or the ``KB132`` diagnostic saying why not."""
    if isinstance(expr, ast.Quantity):
        kind = UNIT_KIND.get(expr.unit)
        if kind is None:
            return None, None
        if kind == vtype:
            return quantity_si(expr), None
        return None, diag(
            codes.UNIT_MISMATCH,
            f"{what} {expr.text} is {_KIND_WORDS[kind]}, but the type is {vtype}",
            expr.span,
        )
    if isinstance(expr, ast.Number):
        if vtype == "number":
            return expr.value, None
        return None, diag(
            codes.UNIT_MISMATCH,
            f"{what} {expr.text} has no unit, but the type is {vtype}",
            expr.span,
            f"give the unit: {expr.text} {'deg' if vtype == 'angle' else 'm'}",
        )
    return None, diag(
        codes.ARGUMENT_TYPE, f"{what} must be a constant {vtype}, not '{expr}'", expr.span
    )


def _range_of(table: Table, info: CInfo, attr: ast.Attribute) -> ast.Range | None:
    if attr.range is not None:
        return attr.range
    for p in info.parents:
        slot = table.concepts[p].slots.get(attr.name.text)
        if slot is not None and isinstance(slot.node, ast.Attribute):
            return slot.node.range
    return None


def check_attributes(table: Table, info: CInfo) -> Iterator[Diagnostic]:
    """Types (``KB105``), units of range and default (``KB132``), empty ranges and defaults
    outside the range (``KB133``), inherited ranges included."""
    for m in info.node.members:
        if not isinstance(m, ast.Attribute):
            continue
        vtype = m.type.text
        if vtype not in VALUE_TYPES:
            yield diag(
                codes.UNKNOWN_TYPE,
                f"unknown attribute type '{vtype}'",
                m.type.span,
                did_you_mean(vtype, VALUE_TYPES) or "the types are angle, length and number",
            )
            continue
        low = high = None
        rng = _range_of(table, info, m)
        if rng is not None:
            low, d1 = _typed_constant(rng.low, vtype, "the lower bound")
            high, d2 = _typed_constant(rng.high, vtype, "the upper bound")
            if rng is m.range:
                yield from (d for d in (d1, d2) if d is not None)
                if low is not None and high is not None and low > high + _EPS:
                    yield diag(
                        codes.OUT_OF_RANGE,
                        f"the range [{rng.low}, {rng.high}] is empty",
                        rng.span,
                        f"write [{rng.high}, {rng.low}]",
                    )
                    continue
        if m.default is None:
            continue
        value, d = _typed_constant(m.default, vtype, "the default")
        if d is not None:
            yield d
        if (
            value is not None
            and rng is not None
            and low is not None
            and high is not None
            and not low - _EPS <= value <= high + _EPS
        ):
            yield diag(
                codes.OUT_OF_RANGE,
                f"the default {m.default} of '{m.name.text}' lies outside its range "
                f"[{rng.low}, {rng.high}]",
                m.default.span,
                related=((rng.span, "the range"),) if rng is not m.range else (),
            )


def check_adjacency(table: Table, info: CInfo) -> Iterator[Diagnostic]:
    """Adjacency entries must be role paths of the concept (``KB102``, ``KB131``).

    Degenerate adjacencies are ``KB139``: a ring of fewer than three parts, a part repeated in
    a ring or paired with itself, a ring entry whose part has several fillers.
    """
    cname = info.node.name.text
    for m in info.node.flat_members:
        if not isinstance(m, ast.Adjacency):
            continue
        for group in m.groups:
            for i, path in enumerate(group):
                res = table.resolve_path(cname, path)
                if isinstance(res, Diagnostic):
                    yield res
                elif isinstance(res, PathRes) and (
                    res.slot is None or res.slot.kind is SlotKind.ATTRIBUTE
                ):
                    yield diag(
                        codes.ARGUMENT_TYPE,
                        f"'{path.dotted}' is no part: only parts can be adjacent",
                        path.span,
                    )
                elif (
                    m.kind is ast.AdjacencyKind.RING
                    and isinstance(res, PathRes)
                    and res.slot is not None
                    and res.slot.max != 1
                ):
                    card = "*" if res.slot.max is None else str(res.slot.max)
                    before, after = group[i - 1].dotted, group[(i + 1) % len(group)].dotted
                    yield diag(
                        codes.DEGENERATE_ADJACENCY,
                        f"'{path.dotted}' has up to {card} fillers: a ring entry must be one plane",
                        path.span,
                        f"declare its edges in pairs, which stand for each filler: "
                        f"adjacent pairs(({before}, {path.dotted}), ({path.dotted}, {after}))",
                    )
        yield from _degenerate_groups(m)


def _degenerate_groups(m: ast.Adjacency) -> Iterator[Diagnostic]:
    """``KB139`` for repeated entries and rings too short to enclose anything."""
    for group in m.groups:
        seen: set[str] = set()
        repeated = False
        for path in group:
            if path.dotted in seen:
                repeated = True
                what = (
                    "paired with itself: a plane is not adjacent to itself"
                    if m.kind is ast.AdjacencyKind.PAIRS
                    else "repeated in the ring: a ring passes each plane once"
                )
                yield diag(
                    codes.DEGENERATE_ADJACENCY,
                    f"'{path.dotted}' is {what}",
                    path.span,
                    "remove the repetition"
                    if m.kind is ast.AdjacencyKind.RING
                    else f"remove the pair ({path.dotted}, {path.dotted})",
                )
            seen.add(path.dotted)
        if m.kind is ast.AdjacencyKind.RING and not repeated and len(group) < 3:
            names = ", ".join(p.dotted for p in group)
            if len(group) == 1:
                problem, hint = "declares no edge", "name at least three parts in a ring"
            else:
                problem = "declares one edge twice"
                hint = f"write adjacent pairs(({names}))"
            yield diag(
                codes.DEGENERATE_ADJACENCY,
                f"ring({names}) {problem}: a ring needs at least three parts",
                m.span,
                hint,
            )


def check_rules(table: Table, info: CInfo, used: set[str]) -> Iterator[Diagnostic]:
    """Constraints and measures: relations, templates, units, adjacency of edges."""
    cname = info.node.name.text
    az = Analyzer(table, cname)
    expansions = table.expansions
    for rule in info.rules:
        if rule.owner == cname or info.own_slots:
            prims = az.rule(rule.node, inherited=rule.owner != cname)
            expansions[(cname, id(rule.node))] = prims
    used |= az.used
    yield from az.diagnostics


def check_conditions(table: Table, info: CInfo) -> Iterator[Diagnostic]:
    """``when`` blocks (``KB155``): the role is a part, each concept named a specialisation of
    its concept (or the concept itself), the block holds only relations, and no relation in it
    names a member that the named concepts cannot have (it would never hold).

    Runs after `check_rules` (reads the rules' primitives from ``Table.expansions``).
    """
    cname = info.node.name.text
    for w in info.node.whens:
        cond = w.condition
        yield from _condition_head(table, cname, cond)
        for m in w.members:
            if not isinstance(m, ast.Adjacency | ast.Constraint | ast.Measure | ast.Unseen):
                word = _MEMBER_WORDS.get(type(m).__name__, "this member")
                yield diag(
                    codes.BAD_CONDITION,
                    f"a 'when' block holds relations (adjacent, constraint, measure, unseen), "
                    f"not {word}",
                    m.span,
                    "declare it in the concept (a part or attribute in the specialisation "
                    "that has it)",
                )
        when = table.condition_requires(cname, cond)
        if not when:
            continue
        for m in w.relations:
            requires = list(when)
            if isinstance(m, ast.Adjacency):
                paths = [p for g in m.groups for p in g]
            elif isinstance(m, ast.Unseen):
                pl = m.placement
                paths = [*m.parts, *([pl.ref] if pl.ref is not None else [])]
                if pl.line is not None:
                    paths += [a for a in pl.line.args if isinstance(a, ast.Path)]
            else:
                paths = []
                for prim in table.expansions.get((cname, id(m)), []):
                    requires += prim.requires
            for path in paths:
                res = table.resolve_path(cname, path)
                if isinstance(res, PathRes):
                    requires += res.requires
            clash = table.never_holds(tuple(requires))
            if clash is not None:
                role, block, members = clash
                yield diag(
                    codes.BAD_CONDITION,
                    f"this relation never holds: it names members of '{role}' that only "
                    f"{' and '.join(members)} declare{'s' if len(members) == 1 else ''}, but its "
                    f"block is for "
                    f"{' or '.join(block)}",
                    m.span,
                    "move it to the 'when' block of the concepts that have those members",
                    ((cond.span, "the block's condition"),),
                )


_MEMBER_WORDS = {
    "Part": "a part",
    "ConOf": "a con-of",
    "Attribute": "an attribute",
    "Frame": "a frame",
    "Orient": "an orientation",
    "Attach": "an attachment",
    "When": "another 'when' block",
}


def _condition_head(table: Table, cname: str, cond: ast.Condition) -> Iterator[Diagnostic]:
    """The role of a ``when`` block and the concepts it names."""
    res = table.resolve_path(cname, cond.role)
    if isinstance(res, Diagnostic):
        yield res
        return
    if res is None:
        return
    if res.slot is None or res.slot.kind is SlotKind.ATTRIBUTE or res.concept is None:
        what = "an attribute" if res.slot is not None else "the concept itself"
        yield diag(
            codes.BAD_CONDITION,
            f"'{cond.role.dotted}' is {what}: a 'when' block is conditional on the concept "
            "filling a part",
            cond.role.span,
        )
        return
    role_concept = res.concept
    seen: dict[str, ast.Name] = {}
    for name in cond.concepts:
        if name.text in seen:
            yield diag(
                codes.DUPLICATE_MEMBER,
                f"'{name.text}' is named twice in this condition",
                name.span,
                related=((seen[name.text].span, "first named here"),),
            )
            continue
        seen[name.text] = name
        if name.text not in table.concepts:
            if name.text not in table.broken:
                yield diag(
                    codes.UNKNOWN_CONCEPT,
                    f"unknown concept '{name.text}' in the condition on '{cond.role.dotted}'",
                    name.span,
                    did_you_mean(name.text, [role_concept, *table.descendants(role_concept)]),
                )
            continue
        if role_concept not in table.concepts:
            continue
        if not (table.is_a(name.text, role_concept) or table.is_a(role_concept, name.text)):
            kinds = table.descendants(role_concept)
            yield diag(
                codes.BAD_CONDITION,
                f"{name.text} is no specialisation of {role_concept}, the concept of "
                f"'{cond.role.dotted}': the condition can never hold",
                name.span,
                f"name one of {', '.join([role_concept, *kinds])}" if kinds else None,
            )


# ---- over the net -----------------------------------------------------------------------------
def check_part_cycles(table: Table) -> Iterator[Diagnostic]:
    """``KB121``: concepts that contain each other, shown as the whole cycle."""
    state: dict[str, int] = {}
    for root in table.concepts:
        if root in state:
            continue
        state[root] = 1
        stack: list[tuple[str, list[Slot], int]] = [(root, _part_slots(table, root), 0)]
        path = [root]
        while stack:
            cname, slots, i = stack[-1]
            if i == len(slots):
                stack.pop()
                path.pop()
                state[cname] = 2
                continue
            stack[-1] = (cname, slots, i + 1)
            target = slots[i].concept
            assert target is not None
            st = state.get(target)
            if st is None:
                state[target] = 1
                stack.append((target, _part_slots(table, target), 0))
                path.append(target)
            elif st == 1:
                cyc = path[path.index(target) :]
                text = chain_text([cyc[0], *reversed(cyc[1:])], " part-of ")
                slot = slots[i]
                yield diag(
                    codes.PART_CYCLE,
                    f"part-of cycle: {text}",
                    slot.name.span,
                    "a concept cannot contain itself, directly or through its parts",
                )


def _part_slots(table: Table, cname: str) -> list[Slot]:
    return [
        s
        for s in table.concepts[cname].slots.values()
        if s.kind is SlotKind.PART and s.concept in table.concepts
    ]


def check_template(table: Table, t: ast.Template) -> Iterator[Diagnostic]:
    """Parameters (``KB111``, ``KB105``, ``KB132``) and the body of a template."""
    seen: dict[str, ast.Name] = {}
    for p in t.params:
        if p.name.text in seen:
            yield diag(
                codes.DUPLICATE_MEMBER,
                f"parameter '{p.name.text}' of template {t.name.text} is declared twice",
                p.name.span,
                related=((seen[p.name.text].span, "first declared here"),),
            )
        seen[p.name.text] = p.name
        ptype = p.type.text
        if ptype not in VALUE_TYPES and ptype not in table.concepts:
            if ptype not in table.broken:
                yield diag(
                    codes.UNKNOWN_TYPE,
                    f"unknown parameter type '{ptype}'",
                    p.type.span,
                    did_you_mean(ptype, [*VALUE_TYPES, *table.concepts]),
                )
            continue
        if p.default is not None:
            if ptype not in VALUE_TYPES:
                yield diag(
                    codes.ARGUMENT_TYPE,
                    f"parameter '{p.name.text}' is a role ({ptype}); it cannot have a default",
                    p.default.span,
                )
            else:
                _, d = _typed_constant(p.default, ptype, "the default")
                if d is not None:
                    yield d
    az = Analyzer(table, None, t)
    az.template_body(t)
    yield from az.diagnostics


def check_unused_templates(table: Table, used: set[str]) -> Iterator[Diagnostic]:
    """``KB300`` (warning): a template nobody uses."""
    for name, t in table.templates.items():
        if name not in used:
            yield diag(
                codes.UNUSED_TEMPLATE,
                f"template '{name}' is never used",
                t.name.span,
                "use it in a constraint, or delete it",
            )


def check_instance(table: Table, inst: ast.Instance) -> Iterator[Diagnostic]:
    """``KB100``/``KB140`` for the concept, ``KB102``/``KB111``/``KB104``/``KB142`` for the
    bindings, ``KB141`` for obligatory roles left unbound."""
    cname = inst.concept.text
    info = table.concepts.get(cname)
    if info is None:
        if cname not in table.broken:
            yield diag(
                codes.UNKNOWN_CONCEPT,
                f"unknown concept '{cname}' for instance {inst.name.text}",
                inst.concept.span,
                did_you_mean(cname, table.concepts),
            )
        return
    if info.node.abstract:
        concrete = [d for d in table.descendants(cname) if not table.concepts[d].node.abstract]
        yield diag(
            codes.ABSTRACT_INSTANCE,
            f"{cname} is abstract: it cannot have instances",
            inst.concept.span,
            f"instantiate a specialisation: {', '.join(concrete)}" if concrete else None,
        )
    bound: dict[str, ast.Binding] = {}
    for b in inst.bindings:
        role = b.role.text
        if role in bound:
            yield diag(
                codes.DUPLICATE_MEMBER,
                f"role '{role}' is bound twice in instance {inst.name.text}",
                b.role.span,
                "bind several fillers as a list: role = [a, b]",
                ((bound[role].role.span, "first bound here"),),
            )
            continue
        bound[role] = b
        slot = info.slots.get(role)
        if slot is None and table.is_incomplete(cname):
            continue  # the role may be in what did not resolve or parse
        if slot is None:
            yield diag(
                codes.UNKNOWN_ROLE,
                f"'{role}' is no role or attribute of {cname}",
                b.role.span,
                did_you_mean(role, info.slots),
            )
            continue
        yield from _check_binding(table, slot, b)
    for key, slot in info.slots.items():
        if slot.kind is not SlotKind.ATTRIBUTE and slot.min >= 1 and key not in bound:
            yield diag(
                codes.MISSING_ROLE,
                f"instance {inst.name.text} leaves the obligatory role '{key}' "
                f"({slot.concept}) unbound",
                inst.name.span,
                f"bind it: {key} = ...",
                ((slot.name.span, f"declared in {slot.owner}"),),
            )


def _check_binding(table: Table, slot: Slot, b: ast.Binding) -> Iterator[Diagnostic]:
    value = b.value
    if slot.kind is SlotKind.ATTRIBUTE:
        node = slot.node
        assert isinstance(node, ast.Attribute)
        if node.type.text not in VALUE_TYPES:
            return
        if not isinstance(value, ast.Quantity | ast.Number):
            yield diag(
                codes.BAD_BINDING,
                f"attribute '{slot.name.text}' takes {_A_TYPE[node.type.text]} value, "
                f"not '{value}'",
                value.span,
            )
            return
        v, d = _typed_constant(value, node.type.text, "the value")
        if d is not None:
            yield d
        rng = node.range
        if v is not None and rng is not None:
            low, _ = _typed_constant(rng.low, node.type.text, "")
            high, _ = _typed_constant(rng.high, node.type.text, "")
            if low is not None and high is not None and not low - _EPS <= v <= high + _EPS:
                yield diag(
                    codes.OUT_OF_RANGE,
                    f"{value.text} lies outside the range [{rng.low}, {rng.high}] of "
                    f"'{slot.name.text}'",
                    value.span,
                    related=((rng.span, f"the range, declared in {slot.owner}"),),
                )
        return
    items = value.items if isinstance(value, ast.ListExpr) else (value,)
    if slot.max is not None and len(items) > slot.max:
        yield diag(
            codes.BAD_BINDING,
            f"role '{slot.name.text}' takes at most {slot.max} filler"
            f"{'s' if slot.max != 1 else ''}, given {len(items)}",
            value.span,
        )
    for item in items:
        if isinstance(item, ast.String):
            continue  # an evidence id
        if isinstance(item, ast.Path) and item.is_simple:
            other = table.instances.get(item.dotted)
            if other is None:
                yield diag(
                    codes.UNKNOWN_INSTANCE,
                    f"unknown instance '{item.dotted}'",
                    item.span,
                    did_you_mean(item.dotted, table.instances),
                )
            elif (
                slot.concept is not None
                and slot.concept in table.concepts  # an unknown one is reported at the role
                and other.concept.text in table.concepts
                and not table.is_a(other.concept.text, slot.concept)
            ):
                yield diag(
                    codes.BAD_BINDING,
                    f"'{item.dotted}' is a {other.concept.text}, but role '{slot.name.text}' "
                    f"takes a {slot.concept}",
                    item.span,
                    related=((other.concept.span, f"{item.dotted} is declared here"),),
                )
            continue
        yield diag(
            codes.BAD_BINDING,
            f"role '{slot.name.text}' takes instances or evidence ids (\"v00/r17\"), not '{item}'",
            item.span,
        )


def check_reachability(table: Table) -> Iterator[Diagnostic]:
    """``KB301`` (warning): concepts no top-layer concept leads to (by part-of, con-of, is-a)."""
    if not table.layers:
        return
    top = table.layers[0]
    seen = {c for c, info in table.concepts.items() if info.layer == top}
    todo = list(seen)
    while todo:
        c = todo.pop()
        info = table.concepts[c]
        nxt = [s.concept for s in info.slots.values() if s.concept is not None]
        nxt += info.parents
        nxt += info.children
        for n in nxt:
            if n not in seen and n in table.concepts:
                seen.add(n)
                todo.append(n)
    for c, info in table.concepts.items():
        if c not in seen and info.layer is not None and not table.is_incomplete(c):
            yield diag(
                codes.UNREACHABLE_CONCEPT,
                f"concept {c} cannot be reached from any concept of layer {top}",
                info.node.name.span,
                "link it by part, con-of or is-a, or delete it",
            )


def check_verifiable(table: Table) -> Iterator[Diagnostic]:
    """``KB302`` (warning): no part-of/con-of path down to a measured image-layer concept.

    A concept is verifiable when it is an image-layer concept with a measure, when one of its
    roles is filled by a verifiable concept, or when all its specialisations are verifiable.
    """
    if not table.layers:
        return
    bottom = table.layers[-1]
    users: dict[str, list[str]] = {}
    for c, info in table.concepts.items():
        for s in info.slots.values():
            if s.concept is not None and s.kind is not SlotKind.ATTRIBUTE:
                users.setdefault(s.concept, []).append(c)
    ok: set[str] = set()
    todo = [
        c
        for c, info in table.concepts.items()
        if info.layer == bottom and any(isinstance(r.node, ast.Measure) for r in info.rules)
    ]
    pending = {c: len(info.children) for c, info in table.concepts.items() if info.children}
    while todo:
        c = todo.pop()
        if c in ok:
            continue
        ok.add(c)
        todo.extend(users.get(c, ()))
        for p in table.concepts[c].parents:
            pending[p] -= 1
            if pending[p] == 0:
                todo.append(p)
    for c, info in table.concepts.items():
        if c not in ok and info.layer is not None and not table.is_incomplete(c):
            yield diag(
                codes.UNVERIFIABLE_CONCEPT,
                f"concept {c} cannot be verified: no part-of/con-of path leads from it to an "
                f"image-layer ({bottom}) concept with a measure",
                info.node.name.span,
                "give it a measure, as in 'measure position(self)'"
                if info.layer == bottom
                else "give it (or a part) a con-of to an image concept such as a Region",
            )


def run_checks(table: Table) -> list[Diagnostic]:
    """Run every check; the diagnostics in the order found (the caller sorts)."""
    out: list[Diagnostic] = []
    used: set[str] = set()
    for info in table.concepts.values():
        out.extend(check_role_concepts(table, info))
        out.extend(check_cardinalities(info))
        if info.node.members:
            out.extend(check_attributes(table, info))
            out.extend(check_adjacency(table, info))
            out.extend(check_shape(table, info))
        if info.rules:
            out.extend(check_rules(table, info, used))
        if info.node.whens:
            out.extend(check_conditions(table, info))
    out.extend(check_part_cycles(table))
    for t in table.templates.values():
        t_az = list(check_template(table, t))
        out.extend(t_az)
    for t in table.templates.values():
        for rel in t.body:
            if isinstance(rel.body, ast.Call) and rel.body.func.text in table.templates:
                used.add(rel.body.func.text)
    for inst in table.instances.values():
        out.extend(check_instance(table, inst))
    out.extend(check_unused_templates(table, used))
    out.extend(check_reachability(table))
    out.extend(check_verifiable(table))
    return out
