"""The geometry members of concepts: frames, orientations, measured attributes, unseen parts,
attachments (docs/language.md §3.9-3.12). Checked here (codes ``KB150``-``KB154`` and the
shared ones: unknown roles ``KB102``, wrong kinds ``KB131``/``KB132``, edges of parts not
adjacent ``KB134``) and turned into the compiled models for the build.

Each check walks the concept's *own* declarations; inherited ones were checked where they were
declared, and the build drops those whose paths a narrowed role no longer resolves (as it does
for constraints).
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

from aida_kb.diagnostics import codes
from aida_kb.diagnostics.core import Diagnostic
from aida_kb.dsl import ast
from aida_kb.kb.measures import MeasureKind
from aida_kb.kb.relations import (
    MIN_TOLERANCE,
    TOLERANCE_UNDERFLOW,
    UNIT_KIND,
    Analyzer,
    Dimension,
    quantity_si,
)
from aida_kb.kb.resolve import CInfo, PathRes, Requires, SlotKind, Table, diag, did_you_mean

__all__ = ["HORIZONTAL", "MEASURES", "attribute_measure", "build_shape", "check_shape"]

#: measure name -> (number of role arguments, the attribute type it gives)
MEASURES: dict[str, tuple[int, Dimension]] = {
    "slope": (1, Dimension.ANGLE),
    "angle": (2, Dimension.ANGLE),
    "height": (1, Dimension.LENGTH),
    "width": (1, Dimension.LENGTH),
    "depth": (1, Dimension.LENGTH),
    "distance": (2, Dimension.LENGTH),
    "elevation": (1, Dimension.LENGTH),
}
#: the directions that face a side (a tilt applies to them only)
HORIZONTAL = ("forward", "backward", "leftward", "rightward")
_RIGHT_ANGLE = 1.5707963267948966


def is_planar(table: Table, concept: str | None) -> bool:
    """True for a concept known to the table that, like all its specialisations, has no parts
    (a plane; an abstract roof whose specialisations have planes is no plane)."""
    if concept is None or concept not in table.concepts:
        return False
    return not any(
        s.kind is SlotKind.PART
        for c in (concept, *table.descendants(concept))
        for s in table.concepts[c].slots.values()
    )


def _part(
    table: Table, owner: str, path: ast.Path, *, allow_self: bool = False
) -> tuple[PathRes | None, Diagnostic | None]:
    """A role path that must name a part (or ``self``): its resolution, or why not."""
    res = table.resolve_path(owner, path)
    if res is None:
        return None, None
    if isinstance(res, Diagnostic):
        return None, res
    if res.slot is None and not allow_self:
        return None, diag(codes.ARGUMENT_TYPE, "'self' is no part here", path.span)
    if res.slot is not None and res.slot.kind is not SlotKind.PART:
        what = "an attribute" if res.slot.kind is SlotKind.ATTRIBUTE else "a con-of role"
        return None, diag(
            codes.ARGUMENT_TYPE, f"'{path.dotted}' is {what}; a part is due here", path.span
        )
    return res, None


def _planar(
    table: Table, owner: str, path: ast.Path, code: codes.Code, what: str
) -> tuple[PathRes | None, Diagnostic | None]:
    res, d = _part(table, owner, path)
    if res is None:
        return None, d
    if not is_planar(table, res.concept):
        return None, diag(
            code,
            f"'{path.dotted}' is a {res.concept}, which has parts: {what} a planar part",
            path.span,
            "name one of its planes, or declare this inside the concept that has them",
        )
    return res, None


def _angle_source(
    table: Table, owner: str, expr: ast.Expr
) -> tuple[float | None, str | None, Requires, Diagnostic | None]:
    """A tilt: a constant angle, or an angle attribute path (its default, maybe None)."""
    if isinstance(expr, ast.Quantity):
        kind = UNIT_KIND.get(expr.unit)
        if kind is None:
            return None, None, (), None
        if kind is not Dimension.ANGLE:
            return (
                None,
                None,
                (),
                diag(codes.UNIT_MISMATCH, f"a tilt is an angle, not {expr.text}", expr.span),
            )
        return quantity_si(expr), None, (), None
    if isinstance(expr, ast.Path):
        res = table.resolve_path(owner, expr)
        if res is None:
            return None, None, (), None
        if isinstance(res, Diagnostic):
            return None, None, (), res
        slot = res.slot
        if slot is None or slot.kind is not SlotKind.ATTRIBUTE:
            return (
                None,
                None,
                (),
                diag(
                    codes.ARGUMENT_TYPE,
                    f"'{expr.dotted}' is a role; a tilt is an angle or an angle attribute",
                    expr.span,
                ),
            )
        node = slot.node
        assert isinstance(node, ast.Attribute)
        if node.type.text != "angle":
            return (
                None,
                None,
                (),
                diag(
                    codes.UNIT_MISMATCH,
                    f"attribute '{expr.dotted}' is of type {node.type.text}; a tilt is an angle",
                    expr.span,
                ),
            )
        value = _si(node.default)
        return value, expr.dotted, res.requires, None
    return (
        None,
        None,
        (),
        diag(codes.UNIT_MISMATCH, f"a tilt is an angle such as 30 deg, not '{expr}'", expr.span),
    )


def _si(expr: ast.Expr | None) -> float | None:
    if isinstance(expr, ast.Quantity) and expr.unit in UNIT_KIND:
        return quantity_si(expr)
    return None


def _edge_line(
    table: Table, owner: str, call: ast.Call, code: codes.Code
) -> tuple[tuple[PathRes, PathRes] | None, list[Diagnostic]]:
    """``edge(a, b)`` of two adjacent planar parts."""
    if call.func.text != "edge" or len(call.args) != 2:
        return None, [
            diag(code, f"'{call}' is no edge: write edge(a, b) of two adjacent parts", call.span)
        ]
    out: list[PathRes] = []
    diags: list[Diagnostic] = []
    for a in call.args:
        if not isinstance(a, ast.Path):
            diags.append(diag(codes.ARGUMENT_TYPE, f"a part is due here, not '{a}'", a.span))
            continue
        res, d = _planar(table, owner, a, code, "an edge joins")
        if d is not None:
            diags.append(d)
        if res is not None:
            out.append(res)
    if len(out) != 2 or diags:
        return None, diags
    az = Analyzer(table, owner)
    if not az.adjacent(owner, out[0].dotted, out[1].dotted):
        pa, pb = out[0].dotted, out[1].dotted
        diags.append(
            diag(
                codes.EDGE_NOT_ADJACENT,
                f"edge({pa}, {pb}): {pa} and {pb} are not declared adjacent in {owner}",
                call.span,
                f"declare them: adjacent pairs(({pa}, {pb}))",
            )
        )
        return None, diags
    return (out[0], out[1]), diags


# ---- checks -------------------------------------------------------------------------------
def check_shape(table: Table, info: CInfo) -> Iterator[Diagnostic]:
    """The concept's own geometry members and attribute measures."""
    cname = info.node.name.text
    own = [g for g, owner in info.geometry if owner == cname]
    frames = [g for g in own if isinstance(g, ast.Frame)]
    oriented: dict[str, ast.Orient] = {}
    for g in own:
        if isinstance(g, ast.Orient):
            yield from _check_orient(table, cname, g, oriented)
        elif isinstance(g, ast.Unseen):
            yield from _check_unseen(table, cname, g)
        elif isinstance(g, ast.Attach):
            yield from _check_attach(table, cname, g)
        elif isinstance(g, ast.Touching):
            yield from _check_touching(table, cname, g)
    for i, f in enumerate(frames):
        if i > 0:
            yield diag(
                codes.BAD_FRAME,
                f"concept {cname} declares its frame twice",
                f.span,
                "a composite has one frame: keep one 'frame from ...'",
                ((frames[0].span, "the first frame"),),
            )
            continue
        res, d = _planar(table, cname, f.anchor, codes.BAD_FRAME, "a frame is taken from")
        if d is not None:
            yield d
            continue
        if res is None:
            continue
        o = oriented.get(res.dotted) or _inherited_orient(table, info, res.dotted)
        if o is not None and (o.direction.text != "forward" or o.tilt is not None):
            yield diag(
                codes.BAD_FRAME,
                f"the frame's anchor '{res.dotted}' faces {o.direction.text}"
                + (" tilted" if o.tilt is not None else "")
                + ": a frame is taken from a vertical part facing forward",
                f.anchor.span,
                f"orient {res.dotted}: forward, or take the frame from the part that faces forward",
                ((o.span, "oriented here"),),
            )
    for m in info.node.members:
        if isinstance(m, ast.Attribute) and m.measure is not None:
            yield from _check_measure(table, cname, m)


def _inherited_orient(table: Table, info: CInfo, part: str) -> ast.Orient | None:
    for g, _owner in reversed(info.geometry):
        if isinstance(g, ast.Orient) and any(p.dotted == part for p in g.parts):
            return g
    return None


def _check_orient(
    table: Table, cname: str, g: ast.Orient, oriented: dict[str, ast.Orient]
) -> Iterator[Diagnostic]:
    for path in g.parts:
        res, d = _planar(table, cname, path, codes.BAD_ORIENTATION, "only planes face; orient")
        if d is not None:
            yield d
        if res is None:
            continue
        prev = oriented.get(res.dotted)
        if prev is not None:
            yield diag(
                codes.BAD_ORIENTATION,
                f"'{res.dotted}' is oriented twice in {cname}",
                path.span,
                "a part faces one direction: remove one of the orientations",
                ((prev.span, "first oriented here"),),
            )
            continue
        oriented[res.dotted] = g
    if g.tilt is None:
        return
    if g.direction.text not in HORIZONTAL:
        yield diag(
            codes.BAD_ORIENTATION,
            f"a part facing {g.direction.text} cannot be tilted",
            g.tilt.span,
            "tilt a part that faces a side (forward, backward, leftward, rightward) "
            "towards up: orient top: forward tilted by pitch",
        )
        return
    _, _, _, d = _angle_source(table, cname, g.tilt)
    if d is not None:
        yield d


def _check_measure(table: Table, cname: str, m: ast.Attribute) -> Iterator[Diagnostic]:
    measure = m.measure
    assert measure is not None
    call = measure.call
    name = call.func.text
    sig = MEASURES.get(name)
    if sig is None:
        yield diag(
            codes.BAD_ATTRIBUTE_MEASURE,
            f"unknown measure '{name}'",
            call.func.span,
            did_you_mean(name, MEASURES) or f"the measures are {', '.join(MEASURES)}",
        )
        return
    arity, kind = sig
    if len(call.args) != arity:
        yield diag(
            codes.BAD_ATTRIBUTE_MEASURE,
            f"{name}(...) takes {arity} part{'s' if arity > 1 else ''}, given {len(call.args)}",
            call.span,
        )
        return
    if m.type.text != kind:
        yield diag(
            codes.BAD_ATTRIBUTE_MEASURE,
            f"{name}(...) is {kind.words}, but attribute '{m.name.text}' is of type {m.type.text}",
            call.func.span,
            f"declare 'attribute {m.name.text}: {kind}'",
        )
        return
    for a in call.args:
        if not isinstance(a, ast.Path):
            yield diag(codes.ARGUMENT_TYPE, f"a part or self is due here, not '{a}'", a.span)
            continue
        res, d = _part(table, cname, a, allow_self=True)
        if d is not None:
            yield d
        elif res is not None and name in ("slope", "angle", "distance"):
            concept = res.concept if res.slot is not None else cname
            if not is_planar(table, concept):
                yield diag(
                    codes.BAD_ATTRIBUTE_MEASURE,
                    f"{name}(...) measures planes, but '{a.dotted}' is a {concept}, which has "
                    "parts",
                    a.span,
                    "name one of its planes",
                )
    tol = measure.tolerance
    if tol is not None:
        if not isinstance(tol, ast.Quantity) or UNIT_KIND.get(tol.unit) != kind:
            yield diag(
                codes.UNIT_MISMATCH,
                f"the tolerance of '{m.name.text}' must be " + kind.words,
                tol.span,
            )
        elif tol.value <= 0:
            yield diag(codes.BAD_QUALIFIER, "a tolerance must be positive", tol.span)
        elif quantity_si(tol) < MIN_TOLERANCE:  # as a relation's (`Analyzer.tolerance`)
            yield diag(codes.BAD_QUALIFIER, TOLERANCE_UNDERFLOW, tol.span)


def _check_unseen(table: Table, cname: str, g: ast.Unseen) -> Iterator[Diagnostic]:
    for path in g.parts:
        _, d = _planar(table, cname, path, codes.BAD_PLACEMENT, "only planes are placed; name")
        if d is not None:
            yield d
    p = g.placement
    if p.ref is not None:
        _, d = _planar(table, cname, p.ref, codes.BAD_PLACEMENT, "a placement refers to")
        if d is not None:
            yield d
    if p.line is not None:
        _, diags = _edge_line(table, cname, p.line, codes.BAD_PLACEMENT)
        yield from diags
    if p.value is not None:
        az = Analyzer(table, cname)
        v = az.value(p.value, Dimension.LENGTH, {})
        yield from az.diagnostics
        if v is not None and any(x <= 0 for x, _ in v.alts):
            yield diag(codes.BAD_PLACEMENT, "a distance must be positive", p.value.span)


def _check_attach(table: Table, cname: str, g: ast.Attach) -> Iterator[Diagnostic]:
    res, d = _part(table, cname, g.part)
    if d is not None:
        yield d
    elif res is not None and is_planar(table, res.concept):
        yield diag(
            codes.BAD_ATTACHMENT,
            f"'{g.part.dotted}' is a {res.concept}, a plane: only a composite part is attached",
            g.part.span,
            "attach a part that has parts of its own (an oriel, a wing)",
        )
    elif res is not None and g.name is not None and res.concept in table.concepts:
        clash = table.concepts[res.concept].slots.get(g.name.text)
        if clash is not None:
            yield diag(
                codes.BAD_ATTACHMENT,
                f"the open face cannot be called '{g.name.text}': {res.concept} has a member "
                "of that name",
                g.name.span,
                related=((clash.name.span, "declared here"),),
            )
    for path in g.planes:
        _, d = _planar(table, cname, path, codes.BAD_ATTACHMENT, "a face lies in")
        if d is not None:
            yield d


def _check_touching(table: Table, cname: str, g: ast.Touching) -> Iterator[Diagnostic]:
    res, d = _part(table, cname, ast.Path((g.role,), g.role.span))
    if d is not None:
        yield d
        return
    if res is None or res.slot is None:
        return
    if res.slot.max is not None and res.slot.max < 2:
        yield diag(
            codes.BAD_SHARE,
            f"'{g.role.text}' holds at most one {res.concept}: no two of them can touch",
            g.role.span,
            "name a part role of several objects, such as 'part houses: House [1..*]'",
        )
        return
    for path in g.paths:
        if res.concept is None or res.concept not in table.concepts:
            return
        inner, d = _part(table, res.concept, path)
        if d is not None:
            yield d
        elif inner is not None and not table.concepts.get(inner.concept or "", None):
            continue
        elif inner is not None and not table.concepts[inner.concept or ""].children:
            yield diag(
                codes.BAD_SHARE,
                f"'{path.dotted}' of {res.concept} is a {inner.concept}, which has no "
                "specialisation: there is no choice to share",
                path.span,
                "share a part whose concept has specialisations (a roof of several kinds)",
            )


# ---- build -------------------------------------------------------------------------------
def attribute_measure(node: ast.Attribute) -> dict[str, Any] | None:
    """The fields of an attribute's `MeasureModel` (None without a measure)."""
    m = node.measure
    if m is None:
        return None
    return {
        "kind": MeasureKind(m.call.func.text),
        "args": tuple(a.dotted for a in m.call.args if isinstance(a, ast.Path)),
        "sigma": _si(m.tolerance),
        "span": m.span,
    }


def build_shape(table: Table, cname: str, info: CInfo) -> dict[str, Any]:
    """The geometry fields of a concept's model, as plain values (the build makes the models):
    ``frame`` (anchor, owner, span) or None; ``orientations`` part -> dict; ``placements``
    list of dicts; ``attachments`` part -> dict; ``shares`` list of dicts. Later declarations
    override earlier ones (a concept's own over inherited)."""
    frame: dict[str, Any] | None = None
    orientations: dict[str, dict[str, Any]] = {}
    placements: list[dict[str, Any]] = []
    attachments: dict[str, dict[str, Any]] = {}
    shares: dict[tuple[str, str], dict[str, Any]] = {}
    for g, owner in info.geometry:
        if isinstance(g, ast.Frame):
            res = table.resolve_path(cname, g.anchor)
            if isinstance(res, PathRes):
                frame = {"anchor": res.dotted, "declared_in": owner, "span": g.span}
        elif isinstance(g, ast.Orient):
            tilt = attr = None
            treq: Requires = ()
            if g.tilt is not None:
                tilt, attr, treq, _ = _angle_source(table, cname, g.tilt)
            elif g.direction.text in HORIZONTAL:
                tilt = _RIGHT_ANGLE
            elif g.direction.text == "upward":
                tilt = 0.0
            else:
                tilt = 2.0 * _RIGHT_ANGLE
            for path in g.parts:
                res = table.resolve_path(cname, path)
                if not isinstance(res, PathRes):
                    continue
                orientations[res.dotted] = {
                    "part": res.dotted,
                    "direction": g.direction.text,
                    "tilt_rad": tilt,
                    "tilt_from": attr,
                    "declared_in": owner,
                    "span": g.span,
                    "requires": res.requires + treq,
                }
        elif isinstance(g, ast.Unseen):
            placements.extend(_placements(table, cname, g, owner))
        elif isinstance(g, ast.Touching):
            role = table.resolve_path(cname, ast.Path((g.role,), g.role.span))
            if not isinstance(role, PathRes) or role.concept is None:
                continue
            for path in g.paths:
                res = table.resolve_path(role.concept, path)
                if isinstance(res, PathRes):
                    shares[(role.dotted, res.dotted)] = {
                        "role": role.dotted,
                        "path": res.dotted,
                        "declared_in": owner,
                        "span": g.span,
                    }
        else:
            res = table.resolve_path(cname, g.part)
            planes = [table.resolve_path(cname, p) for p in g.planes]
            if isinstance(res, PathRes) and all(isinstance(p, PathRes) for p in planes):
                attachments[res.dotted] = {
                    "part": res.dotted,
                    "face": g.face.text,
                    "contact": g.contact.text,
                    "planes": tuple(p.dotted for p in planes if isinstance(p, PathRes)),
                    "name": g.name.text if g.name is not None else g.face.text,
                    "declared_in": owner,
                    "span": g.span,
                }
    return {
        "frame": frame,
        "orientations": orientations,
        "placements": placements,
        "attachments": attachments,
        "shares": list(shares.values()),
    }


def _placements(table: Table, cname: str, g: ast.Unseen, owner: str) -> list[dict[str, Any]]:
    p = g.placement
    ref = line = None
    when = table.condition_requires(cname, g.condition)
    if when is None:
        return []  # a 'when' block that cannot hold here (or did not resolve)
    requires: Requires = when
    if p.ref is not None:
        r = table.resolve_path(cname, p.ref)
        if not isinstance(r, PathRes):
            return []
        # the ref's own conditions add to the block's (they replaced them: a 'when' block's
        # mirror placement held for every concept having the line's parts)
        ref, requires = r.dotted, requires + r.requires
    if p.line is not None:
        ends = [table.resolve_path(cname, a) for a in p.line.args if isinstance(a, ast.Path)]
        if len(ends) != 2 or not all(isinstance(e, PathRes) for e in ends):
            return []
        a, b = ends
        assert isinstance(a, PathRes)
        assert isinstance(b, PathRes)
        line = (a.dotted, b.dotted)
        requires = tuple(dict.fromkeys(requires + a.requires + b.requires))
    value = attr = None
    if p.value is not None:
        if isinstance(p.value, ast.Path):
            r = table.resolve_path(cname, p.value)
            if not isinstance(r, PathRes) or r.slot is None:
                return []
            node = r.slot.node
            assert isinstance(node, ast.Attribute)
            value, attr = _si(node.default), r.dotted
        else:
            value = _si(p.value)
    out: list[dict[str, Any]] = []
    for path in g.parts:
        res = table.resolve_path(cname, path)
        if not isinstance(res, PathRes):
            continue
        out.append(
            {
                "part": res.dotted,
                "kind": p.kind,
                "ref": ref,
                "line": line,
                "value": value,
                "value_attribute": attr,
                "declared_in": owner,
                "span": g.span,
                "requires": _dedupe(res.requires + requires),
            }
        )
    return out


def _dedupe(requires: Requires) -> Requires:
    return tuple(dict.fromkeys(requires))
