"""Relations: analyse a constraint, measure or template body into primitive relations.

The same walk serves the checks (arity, argument types, units, adjacency of edges, measurement
kinds) and the build (`Prim` records, later turned into `ConstraintSpec`): a template use
binds its parameters (defaults applied) and expands its body; quantities are converted to SI
(radians, metres; pixels stay pixels); a tolerance becomes sigma, a plain-number threshold is
read as a multiple of sigma. A value given by an attribute path (``wings.meeting``) takes the
attribute's value in each concrete specialisation; where those differ, one primitive is made
per value, conditional on the filler's concept (`Prim.requires`).
"""

from __future__ import annotations

import math
from enum import StrEnum

from aida_kb.diagnostics import codes
from aida_kb.diagnostics.core import Diagnostic, Span
from aida_kb.dsl import ast
from aida_kb.kb.resolve import (
    VALUE_TYPES,
    PathRes,
    Requires,
    SlotKind,
    Table,
    chain_text,
    diag,
    did_you_mean,
)

__all__ = [
    "PRIMITIVES",
    "SCALE",
    "UNIT_KIND",
    "Analyzer",
    "Dimension",
    "Prim",
    "quantity_si",
]


class Dimension(StrEnum):
    """What a value measures: an angle, a length, an image distance (px) or a plain number."""

    ANGLE = "angle"
    LENGTH = "length"
    IMAGE = "image"
    NUMBER = "number"

    @property
    def words(self) -> str:
        """The dimension in a message: "an angle", "a length", ..."""
        return _KIND_WORDS[self]


#: Unit -> its dimension; IMAGE is pixels (measurement tolerances only).
UNIT_KIND: dict[str, Dimension] = {
    "deg": Dimension.ANGLE,
    "rad": Dimension.ANGLE,
    "m": Dimension.LENGTH,
    "cm": Dimension.LENGTH,
    "mm": Dimension.LENGTH,
    "px": Dimension.IMAGE,
}
#: Unit -> factor to its SI unit (rad, m; px stays px).
SCALE: dict[str, float] = {
    "deg": math.pi / 180.0,
    "rad": 1.0,
    "m": 1.0,
    "cm": 0.01,
    "mm": 0.001,
    "px": 1.0,
}
_SI = {Dimension.ANGLE: "rad", Dimension.LENGTH: "m", Dimension.IMAGE: "px", Dimension.NUMBER: ""}
_KIND_WORDS = {
    Dimension.ANGLE: "an angle",
    Dimension.LENGTH: "a length",
    Dimension.IMAGE: "an image distance (px)",
    Dimension.NUMBER: "a number",
}
_EXAMPLE = {
    Dimension.ANGLE: "90 deg",
    Dimension.LENGTH: "2 m",
    Dimension.IMAGE: "1 px",
    Dimension.NUMBER: "2",
}
PRIMITIVES = ("angle", "parallel", "edge", "position")
_MEASUREMENTS = ("position", "edge")
#: The smallest tolerance (SI: rad, m, px). Below it the weight 1/sigma² leaves float64's
#: normal range (sigma = 1e-300 deg squares to 0); 1e-12 already means "exactly".
MIN_TOLERANCE = 1e-12
#: KB137's message for a tolerance under MIN_TOLERANCE (a relation's or an attribute's).
TOLERANCE_UNDERFLOW = (
    f"a tolerance must be at least {MIN_TOLERANCE:g} (SI units): its weight 1/sigma² would not "
    "be a finite number"
)


def quantity_si(q: ast.Quantity) -> float:
    """The quantity in its SI unit (radians, metres, pixels)."""
    return q.value * SCALE.get(q.unit, 1.0)


class Ref:
    """A role path argument: ``front``, ``roof.front``, ``self``."""

    __slots__ = ("concept", "dotted", "requires")

    def __init__(self, dotted: str, concept: str | None, requires: Requires) -> None:
        self.dotted = dotted
        self.concept = concept
        self.requires = requires


class Val:
    """A value argument: its alternatives (SI value, conditions) and its kind."""

    __slots__ = ("alts", "kind")

    def __init__(self, alts: tuple[tuple[float, Requires], ...], kind: Dimension) -> None:
        self.alts = alts
        self.kind = kind


Arg = Ref | Val


class Prim:
    """One primitive relation, expanded and in SI units."""

    __slots__ = (
        "args",
        "kind",
        "measurement",
        "reject_above",
        "requires",
        "sigma",
        "span",
        "unit",
        "value",
        "weight",
    )

    def __init__(
        self,
        kind: str,
        args: tuple[str, ...],
        value: float | None,
        unit: str,
        sigma: float | None,
        weight: float,
        reject_above: float | None,
        measurement: bool,
        requires: Requires,
        span: Span,
    ) -> None:
        self.kind = kind
        self.args = args
        self.value = value
        self.unit = unit
        self.sigma = sigma
        self.weight = weight
        self.reject_above = reject_above
        self.measurement = measurement
        self.requires = requires
        self.span = span


#: A rejection threshold: (value, whether it is a multiple of sigma, its kind, where written).
_Threshold = tuple[float, bool, Dimension, Span]


class _Quals:
    __slots__ = ("reject", "tolerance", "weight")

    def __init__(
        self, tolerance: Val | None, weight: float | None, reject: _Threshold | None
    ) -> None:
        self.tolerance = tolerance
        self.weight = weight
        self.reject = reject


#: Enclosing template uses, innermost first: (the use, its scope, where to report).
_Outer = tuple[tuple[ast.Relation, dict[str, "Arg"], Span | None], ...]


def _merge_requires(*groups: Requires) -> Requires:
    if not any(groups):  # the common case: nothing is conditional
        return ()
    out: dict[str, tuple[str, ...]] = {}
    for group in groups:
        for prefix, concepts in group:
            prev = out.get(prefix)
            out[prefix] = concepts if prev is None else tuple(c for c in prev if c in concepts)
    return tuple(out.items())


class Analyzer:
    """Analyse relations in the scope of one concept (``owner``) or one template's body.

    Diagnostics go to ``self.diagnostics``; ``analyse`` returns the primitives.
    """

    def __init__(self, table: Table, owner: str | None, template: ast.Template | None = None):
        self.table = table
        self.owner = owner
        self.template = template
        self.diagnostics: list[Diagnostic] = []
        self._site: Span | None = None  # a template use being expanded: report only here
        self._expanding: list[str] = []  # the templates being expanded, outermost first
        self.used: set[str] = set()  # the templates used

    def report(self, d: Diagnostic, *, use_dependent: bool = False) -> None:
        """Record a diagnostic; inside an expansion only use-dependent ones, at the use."""
        if self._site is None:
            self.diagnostics.append(d)
        elif use_dependent:
            self.diagnostics.append(
                Diagnostic(d.code, d.severity, d.message, self._site, d.hint, d.related)
            )

    # -- entry points
    def rule(self, node: ast.Constraint | ast.Measure, *, inherited: bool = False) -> list[Prim]:
        """The primitives of a ``constraint`` or ``measure``; checks the measurement kind.

        An ``inherited`` rule whose path no longer resolves (a conditional path such as
        ``roof.front`` in a specialisation that narrows ``roof`` to a ``FlatRoof``) does not
        apply to this concept: it gives no primitive and no error.
        """
        assert self.owner is not None
        when = self.table.condition_requires(self.owner, node.condition)
        if when is None and inherited:
            return []  # a 'when' block that cannot hold in this specialisation
        mark = len(self.diagnostics)
        prims = self.relation(node.relation, {})
        if inherited and any(d.code == codes.UNKNOWN_ROLE.code for d in self.diagnostics[mark:]):
            del self.diagnostics[mark:]
            return []
        if when is None:
            return []  # its condition is in error (reported by the checks): no primitive
        if when:
            for p in prims:
                p.requires = tuple(dict.fromkeys(p.requires + when))
        measuring = isinstance(node, ast.Measure)
        for p in prims:
            if p.measurement != measuring:
                if measuring:
                    msg = f"'measure' needs a measurement (position or edge), not {p.kind}"
                    hint = "write 'constraint' for relations between parts"
                else:
                    msg = f"{p.kind}(...) is a measurement: declare it with 'measure'"
                    hint = f"measure {p.kind}(...)"
                self.report(diag(codes.MEASUREMENT_MISUSE, msg, node.relation.body.span, hint))
                return []
        return prims

    def template_body(self, template: ast.Template) -> None:
        """Check a template's body once, its parameters standing for themselves."""
        self._expanding = [template.name.text]
        env: dict[str, Arg] = {}
        for p in template.params:
            ptype = p.type.text
            if ptype in VALUE_TYPES:
                env[p.name.text] = Val(((0.0, ()),), Dimension(ptype))
            else:
                known = ptype if ptype in self.table.concepts else None
                env[p.name.text] = Ref(p.name.text, known, ())
        for rel in template.body:
            self.relation(rel, env)

    # -- relations
    def relation(self, rel: ast.Relation, env: dict[str, Arg], outer: _Outer = ()) -> list[Prim]:
        """Expand one relation; ``outer`` are the enclosing template uses, innermost first:
        their qualifiers override the relation's own (the outermost wins)."""
        body = rel.body
        if isinstance(body, ast.Call) and body.func.text not in PRIMITIVES:
            template = self.table.templates.get(body.func.text)
            if template is None:
                self.report(
                    diag(
                        codes.UNKNOWN_RELATION,
                        f"unknown relation or template '{body.func.text}'",
                        body.func.span,
                        did_you_mean(body.func.text, [*PRIMITIVES, *self.table.templates]),
                    )
                )
                return []
            self.used.add(template.name.text)
            return self.use(body, template, env, ((rel, env, self._site), *outer))
        kind, args, value = self.shape(body, env)
        if kind is None:
            return []
        quals = self.qualifiers(rel, env, _tolerance_kind(kind), outer)
        return self.prims(kind, args, value, quals, self._site or rel.span)

    def shape(
        self, body: ast.Call | ast.Comparison, env: dict[str, Arg]
    ) -> tuple[str | None, list[Ref], Val | None]:
        """The primitive kind, its role arguments and its value (angle comparisons)."""
        if isinstance(body, ast.Comparison):
            lhs, rhs = body.lhs, body.rhs
            if not (isinstance(lhs, ast.Call) and lhs.func.text == "angle"):
                self.malformed(lhs.span, "the left side of '==' must be angle(a, b)")
                return None, [], None
            a = self.refs(lhs, 2, env)
            if isinstance(rhs, ast.Call) and rhs.func.text == "angle":
                b = self.refs(rhs, 2, env)
                if a is None or b is None:
                    return None, [], None
                return "symmetry", a + b, None
            val = self.value(rhs, Dimension.ANGLE, env)
            if a is None or val is None:
                return None, [], None
            return "angle", a, val
        name = body.func.text
        args = body.args
        if name == "parallel":
            if len(args) == 2 and all(_is_call(x, "edge") for x in args):
                e1 = self.refs(args[0], 2, env)  # type: ignore[arg-type]
                e2 = self.refs(args[1], 2, env)  # type: ignore[arg-type]
                if e1 is None or e2 is None:
                    return None, [], None
                self.check_edge(e1, args[0].span)
                self.check_edge(e2, args[1].span)
                return "parallel_edge", e1 + e2, None
            refs = self.refs(body, 2, env)
            return ("parallel", refs, None) if refs is not None else (None, [], None)
        if name == "position":
            refs = self.refs(body, 1, env)
            return ("position", refs, None) if refs is not None else (None, [], None)
        if name == "edge":
            if len(args) == 1 and _is_call(args[0], "edge"):
                refs = self.refs(args[0], 2, env)  # type: ignore[arg-type]
                if refs is None:
                    return None, [], None
                self.check_edge(refs, args[0].span)
                return "edge", refs, None
            if len(args) == 1 and isinstance(args[0], ast.Path):
                refs = self.refs(body, 1, env)
                return ("edge", refs, None) if refs is not None else (None, [], None)
            self.malformed(
                body.span,
                "edge(...) as a relation is the measurement edge(edge(a, b)) or edge(self)",
            )
            return None, [], None
        # angle(a, b) alone
        self.malformed(body.span, "angle(a, b) is not a relation on its own")
        return None, [], None

    def malformed(self, span: Span, message: str) -> None:
        self.report(
            diag(
                codes.MALFORMED_RELATION,
                message,
                span,
                "the relations are angle(a, b) == V, parallel(a, b), "
                "parallel(edge(a, b), edge(c, d)), angle(a, b) == angle(c, d), position(p), "
                "edge(edge(a, b))",
            )
        )

    def refs(self, call: ast.Call, n: int, env: dict[str, Arg]) -> list[Ref] | None:
        """The role arguments of ``call``, exactly ``n`` of them."""
        if len(call.args) != n:
            self.malformed(
                call.span,
                f"{call.func.text}(...) takes {n} part{'s' if n > 1 else ''}, "
                f"given {len(call.args)}",
            )
            return None
        out: list[Ref] = []
        for a in call.args:
            r = self.ref(a, env)
            if r is None:
                return None
            out.append(r)
        return out

    # -- arguments
    def ref(self, expr: ast.Expr, env: dict[str, Arg]) -> Ref | None:
        """A role path argument, resolved in the scope."""
        if not isinstance(expr, ast.Path):
            self.report(
                diag(codes.ARGUMENT_TYPE, f"a role path is due here, not '{expr}'", expr.span)
            )
            return None
        first = expr.parts[0].text
        bound = env.get(first)
        if bound is not None:
            if isinstance(bound, Val):
                self.report(
                    diag(
                        codes.ARGUMENT_TYPE,
                        f"'{first}' is a value parameter; a role is due here",
                        expr.span,
                    )
                )
                return None
            if len(expr.parts) == 1:
                return bound
            if bound.concept is None:
                return None
            rest = ast.Path(expr.parts[1:], expr.span)
            res = self.table.resolve_path(bound.concept, rest)
            return self._ref_from(res, expr, bound)
        if self.owner is None:
            assert self.template is not None
            self.report(
                diag(
                    codes.UNKNOWN_ROLE,
                    f"'{first}' is no parameter of template {self.template.name.text}",
                    expr.parts[0].span,
                    did_you_mean(first, [p.name.text for p in self.template.params]),
                )
            )
            return None
        res = self.table.resolve_path(self.owner, expr)
        return self._ref_from(res, expr, None)

    def _ref_from(
        self, res: PathRes | Diagnostic | None, expr: ast.Path, base: Ref | None
    ) -> Ref | None:
        if res is None:
            return None
        if isinstance(res, Diagnostic):
            self.report(res)
            return None
        if res.slot is not None and res.slot.kind is SlotKind.ATTRIBUTE:
            self.report(
                diag(
                    codes.ARGUMENT_TYPE,
                    f"'{expr.dotted}' is an attribute; a part is due here",
                    expr.span,
                )
            )
            return None
        if base is None:
            return Ref(res.dotted, res.concept, res.requires)
        shifted = tuple((f"{base.dotted}.{p}" if p else base.dotted, c) for p, c in res.requires)
        return Ref(
            f"{base.dotted}.{res.dotted}", res.concept, _merge_requires(base.requires, shifted)
        )

    def value(self, expr: ast.Expr, kind: Dimension, env: dict[str, Arg]) -> Val | None:
        """A value of ``kind`` (angle, length, number, image), in SI."""
        if isinstance(expr, ast.Quantity):
            k = UNIT_KIND.get(expr.unit)
            if k is None:
                return None  # an unknown unit: reported by the parser
            if k != kind:
                self.report(
                    diag(
                        codes.UNIT_MISMATCH,
                        f"{expr.text} is {_KIND_WORDS[k]}, but {_KIND_WORDS[kind]} is due here",
                        expr.span,
                        f"write a value such as {_EXAMPLE[kind]}",
                    ),
                    use_dependent=True,
                )
                return None
            return Val(((quantity_si(expr), ()),), kind)
        if isinstance(expr, ast.Number):
            if kind is not Dimension.NUMBER:
                self.report(
                    diag(
                        codes.UNIT_MISMATCH,
                        f"{expr.text} has no unit, but {_KIND_WORDS[kind]} is due here",
                        expr.span,
                        f"give the unit: {expr.text} {_SI[kind] or ''}".rstrip(),
                    ),
                    use_dependent=True,
                )
                return None
            return Val(((expr.value, ()),), kind)
        if isinstance(expr, ast.Path):
            bound = env.get(expr.parts[0].text) if expr.is_simple else None
            if bound is not None:
                if isinstance(bound, Ref):
                    self.report(
                        diag(
                            codes.ARGUMENT_TYPE,
                            f"'{expr.dotted}' is a role parameter; {_KIND_WORDS[kind]} is due",
                            expr.span,
                        )
                    )
                    return None
                if bound.kind != kind:
                    self.report(
                        diag(
                            codes.UNIT_MISMATCH,
                            f"'{expr.dotted}' is {_KIND_WORDS[bound.kind]}, but "
                            f"{_KIND_WORDS[kind]} is due here",
                            expr.span,
                        )
                    )
                    return None
                return bound
            return self.attribute_value(expr, kind)
        self.report(
            diag(
                codes.ARGUMENT_TYPE, f"'{expr}' is no value; {_KIND_WORDS[kind]} is due", expr.span
            )
        )
        return None

    def attribute_value(self, expr: ast.Path, kind: Dimension) -> Val | None:
        """A value read from an attribute (``meeting``, ``wings.meeting``)."""
        if self.owner is None:
            assert self.template is not None
            self.report(
                diag(
                    codes.UNKNOWN_ROLE,
                    f"'{expr.dotted}' is no parameter of template {self.template.name.text}",
                    expr.span,
                    did_you_mean(expr.dotted, [p.name.text for p in self.template.params]),
                )
            )
            return None
        res = self.table.resolve_path(self.owner, expr)
        if res is None:
            return None
        if isinstance(res, Diagnostic):
            self.report(res)
            return None
        slot = res.slot
        if slot is None or slot.kind is not SlotKind.ATTRIBUTE:
            self.report(
                diag(
                    codes.ARGUMENT_TYPE,
                    f"'{expr.dotted}' is a role; {_KIND_WORDS[kind]} is due here",
                    expr.span,
                )
            )
            return None
        assert isinstance(slot.node, ast.Attribute)
        if slot.node.type.text != kind:
            self.report(
                diag(
                    codes.UNIT_MISMATCH,
                    f"attribute '{expr.dotted}' is of type {slot.node.type.text}, but "
                    f"{_KIND_WORDS[kind]} is due here",
                    expr.span,
                )
            )
            return None
        prefix = ".".join(p.text for p in expr.parts[:-1])
        holder = self.owner
        if prefix:
            pres = self.table.resolve_path(self.owner, ast.Path(expr.parts[:-1], expr.span))
            if not isinstance(pres, PathRes) or pres.concept is None:
                return None
            holder = pres.concept
        return self._attribute_alternatives(expr, holder, prefix or "self", kind, res.requires)

    def _attribute_alternatives(
        self, expr: ast.Path, holder: str, prefix: str, kind: Dimension, requires: Requires
    ) -> Val | None:
        table = self.table
        attr = expr.parts[-1].text
        by_value: dict[float, list[str]] = {}
        missing: list[str] = []
        for c in [holder, *table.descendants(holder)]:
            info = table.concepts[c]
            slot = info.slots.get(attr)
            if info.node.abstract or slot is None:
                continue
            node = slot.node
            assert isinstance(node, ast.Attribute)
            v = _constant(node.default, kind)
            if v is None:
                missing.append(c)
            else:
                by_value.setdefault(v, []).append(c)
        if missing:
            self.report(
                diag(
                    codes.NO_ATTRIBUTE_VALUE,
                    f"attribute '{expr.dotted}' has no value in {', '.join(missing)}",
                    expr.span,
                    f"give '{attr}' a default (attribute {attr}: {kind} = ...) in each concrete "
                    "concept",
                ),
                use_dependent=True,
            )
            return None
        if len(by_value) == 1:
            v = next(iter(by_value))
            return Val(((v, requires),), kind)
        alts = tuple(
            (v, _merge_requires(requires, ((prefix, tuple(cs)),))) for v, cs in by_value.items()
        )
        return Val(alts, kind)

    # -- qualifiers
    def qualifiers(
        self,
        rel: ast.Relation,
        env: dict[str, Arg],
        tol_kind: Dimension,
        outer: _Outer = (),
        *,
        combined: bool = True,
    ) -> _Quals:
        """The relation's tolerance, weight and threshold; the enclosing uses' override them,
        each read in the unit of this relation and reported at its own place. When
        ``combined``, a threshold with a unit must be of the tolerance's kind (a measurement's
        tolerance and threshold both in pixels or both lengths: ``KB132``)."""
        tol = weight = None
        reject: _Threshold | None = None
        if rel.tolerance is not None:
            tol = self.tolerance(rel.tolerance, tol_kind, env)
        if rel.weight is not None:
            w = self.value(rel.weight, Dimension.NUMBER, env)
            if w is not None:
                weight = w.alts[0][0]
                if weight <= 0:
                    self.report(
                        diag(codes.BAD_QUALIFIER, "a weight must be positive", rel.weight.span)
                    )
                    weight = None
        if rel.reject is not None:
            reject = self.threshold(rel.reject, tol_kind, env)
        for use_rel, use_env, use_site in outer:
            saved, self._site = self._site, use_site
            try:
                over = self.qualifiers(use_rel, use_env, tol_kind, combined=False)
            finally:
                self._site = saved
            tol = over.tolerance or tol
            weight = over.weight if over.weight is not None else weight
            reject = over.reject or reject
        if (
            combined
            and tol is not None
            and reject is not None
            and not reject[1]
            and reject[2] != tol.kind
        ):
            self.report(
                diag(
                    codes.UNIT_MISMATCH,
                    f"the threshold is {_KIND_WORDS[reject[2]]}, but the tolerance is "
                    f"{_KIND_WORDS[tol.kind]}",
                    reject[3],
                    "give the tolerance and the threshold in the same kind of unit "
                    "(both px or both lengths), or the threshold as a multiple of sigma",
                ),
                use_dependent=True,
            )
            reject = None
        return _Quals(tol, weight, reject)

    def tolerance(self, expr: ast.Expr, kind: Dimension, env: dict[str, Arg]) -> Val | None:
        if (
            kind is Dimension.IMAGE
            and isinstance(expr, ast.Quantity)
            and expr.unit in ("m", "cm", "mm")
        ):
            kind = Dimension.LENGTH  # position(p) +- 2 cm: a distance along the normal
        v = self.value(expr, kind, env)
        if (
            v is not None
            and any(x <= 0 for x, _ in v.alts)
            and self._site is None
            and not (self.owner is None and isinstance(expr, ast.Path))
        ):
            self.report(diag(codes.BAD_QUALIFIER, "a tolerance must be positive", expr.span))
            return None
        if v is not None and any(0 < x < MIN_TOLERANCE for x, _ in v.alts):
            self.report(diag(codes.BAD_QUALIFIER, TOLERANCE_UNDERFLOW, expr.span))
            return None
        return v

    def threshold(self, expr: ast.Expr, kind: Dimension, env: dict[str, Arg]) -> _Threshold | None:
        if isinstance(expr, ast.Number):
            if expr.value <= 0:
                self.report(diag(codes.BAD_QUALIFIER, "a threshold must be positive", expr.span))
                return None
            return (expr.value, True, kind, expr.span)
        if (
            kind is Dimension.IMAGE
            and isinstance(expr, ast.Quantity)
            and expr.unit in ("m", "cm", "mm")
        ):
            kind = Dimension.LENGTH
        v = self.value(expr, kind, env)
        if v is None:
            return None
        return (v.alts[0][0], False, v.kind, expr.span)

    # -- template uses
    def use(
        self, call: ast.Call, template: ast.Template, env: dict[str, Arg], outer: _Outer
    ) -> list[Prim]:
        """Bind a template's parameters to the use's arguments and expand its body."""
        params = template.params
        if any(p.type.text not in VALUE_TYPES and p.type.text not in self.table.concepts
               for p in params):  # fmt: skip
            return []  # an unknown parameter type: reported once, at the template
        required, defaults = self.signature(template)
        given = len(call.args)
        if not required <= given <= len(params):
            sig = ", ".join(
                p.name.text if p.default is None else f"{p.name.text} = {p.default}" for p in params
            )
            want = str(required) if required == len(params) else f"{required} to {len(params)}"
            self.report(
                diag(
                    codes.TEMPLATE_ARITY,
                    f"template {template.name.text} takes {want} argument"
                    f"{'' if want == '1' else 's'}, given {given}",
                    call.func.span,
                    f"{template.name.text}({sig})",
                    ((template.name.span, "the template is declared here"),),
                )
            )
            return []
        bound: dict[str, Arg] = {}
        ok = True
        for i, p in enumerate(params):
            ptype = p.type.text
            if i < given:
                arg = call.args[i]
                v: Arg | None
                if ptype in VALUE_TYPES:
                    v = self.value(arg, Dimension(ptype), env)
                else:
                    r = self.ref(arg, env)
                    v = r if r is None or self.fits(r, ptype, arg.span, p, template) else None
            else:
                v = defaults[i]
            if v is None:
                ok = False
            else:
                bound[p.name.text] = v
        if not ok:
            return []
        name = template.name.text
        if name in self._expanding:
            cycle = self._expanding[self._expanding.index(name) :]
            if frozenset(cycle) not in self.table.template_cycles:
                # once per cycle, at the call in a template's body that closes it (every use
                # of a template on the cycle runs into it: no error there)
                self.table.template_cycles.add(frozenset(cycle))
                self.diagnostics.append(
                    diag(
                        codes.MALFORMED_RELATION,
                        f"template {name} uses itself: {chain_text(cycle, ' uses ')}",
                        call.func.span,
                        "a template's body is made of primitives and other templates, "
                        "without cycles",
                    )
                )
            return []
        outer_site = self._site
        if self._site is None:
            self._site = call.span
        self._expanding.append(name)
        try:
            prims: list[Prim] = []
            for rel in template.body:
                prims.extend(self.relation(rel, bound, outer))
            return prims
        finally:
            self._expanding.pop()
            self._site = outer_site

    def signature(self, template: ast.Template) -> tuple[int, tuple[Val | None, ...]]:
        """How many arguments a use must give (up to the last parameter without a default: only
        defaults at the end can be left out), and each parameter's default as a value (None: no
        default, or one that is no constant of the parameter's type). Computed once per
        template and knowledge base."""
        cache = self.table.signatures
        found = cache.get(template.name.text)
        if found is None or found[0] is not template:
            params = template.params
            # arguments go by position: every parameter up to the last without a default
            required = max((i + 1 for i, p in enumerate(params) if p.default is None), default=0)
            defaults = tuple(
                None if p.default is None else _default(p.default, p.type.text) for p in params
            )
            found = (template, required, defaults)
            cache[template.name.text] = found
        return found[1], found[2]

    def fits(self, ref: Ref, ptype: str, span: Span, p: ast.Param, t: ast.Template) -> bool:
        """Whether a role argument's concept is the parameter's concept or a specialisation."""
        if ref.concept is None or ptype not in self.table.concepts:
            return True
        if self.table.is_a(ref.concept, ptype):
            return True
        self.report(
            diag(
                codes.ARGUMENT_TYPE,
                f"'{ref.dotted}' is a {ref.concept}, but parameter '{p.name.text}' of template "
                f"{t.name.text} wants a {ptype}",
                span,
                f"pass a role whose concept is {ptype} or one of its specialisations",
            )
        )
        return False

    # -- primitives
    def check_edge(self, refs: list[Ref], span: Span) -> None:
        """``KB134`` when the two planes of an edge are not declared adjacent."""
        if self.owner is None:
            return
        a, b = refs[0].dotted, refs[1].dotted
        if self.adjacent(self.owner, a, b):
            return
        self.report(
            diag(
                codes.EDGE_NOT_ADJACENT,
                f"edge({a}, {b}): {a} and {b} are not declared adjacent in {self.owner}",
                span,
                f"declare them: adjacent pairs(({a}, {b}))",
            ),
            use_dependent=True,
        )

    def adjacent(self, owner: str, a: str, b: str) -> bool:
        table = self.table
        if owner not in table.concepts:
            return True
        if (a, b) in table.adjacent_pairs(owner):
            return True
        pa, pb = a.split("."), b.split(".")
        if len(pa) > 1 and len(pb) > 1 and pa[0] == pb[0]:
            slot = table.concepts[owner].slots.get(pa[0])
            inner_a, inner_b = ".".join(pa[1:]), ".".join(pb[1:])
            if slot is None:
                cands = [d for d in table.descendants(owner) if pa[0] in table.concepts[d].slots]
                return any(self.adjacent(d, a, b) for d in cands)
            if slot.concept is None or slot.concept not in table.concepts:
                return True
            return any(
                self.adjacent(c, inner_a, inner_b)
                for c in [slot.concept, *table.descendants(slot.concept)]
            )
        return False

    def prims(
        self, kind: str, refs: list[Ref], value: Val | None, quals: _Quals, span: Span
    ) -> list[Prim]:
        measurement = kind in _MEASUREMENTS
        tol_kind = _tolerance_kind(kind)
        sigma = None
        if quals.tolerance is not None:
            sigma = quals.tolerance.alts[0][0]
            tol_kind = quals.tolerance.kind
        elif quals.reject is not None and not quals.reject[1]:
            tol_kind = quals.reject[2]  # no tolerance: the threshold's unit is the relation's
        unit = _SI[tol_kind] if measurement else "rad"
        weight = quals.weight
        if weight is None:
            # MIN_TOLERANCE keeps sigma² a normal float (1e-300 deg: sigma² underflows to 0)
            weight = 1.0 / (sigma * sigma) if sigma and sigma >= MIN_TOLERANCE else 1.0
        reject = None
        if quals.reject is not None:
            r, multiple, _, _ = quals.reject
            if multiple:
                if sigma is None:
                    self.report(
                        diag(
                            codes.BAD_QUALIFIER,
                            "a threshold without a unit is a multiple of sigma, but this "
                            "relation has no tolerance",
                            span,
                            "give a tolerance (+- 1 deg) or a threshold with a unit",
                        ),
                        use_dependent=True,
                    )
                else:
                    reject = r * sigma
            else:
                reject = r
        args = tuple(r.dotted for r in refs)
        req = _merge_requires(*(r.requires for r in refs))
        alts = value.alts if value is not None else ((None, ()),)
        return [
            Prim(
                kind,
                args,
                v,
                unit,
                sigma,
                weight,
                reject,
                measurement,
                _merge_requires(req, vreq),
                span,
            )
            for v, vreq in alts
        ]


def _is_call(expr: ast.Expr, name: str) -> bool:
    return isinstance(expr, ast.Call) and expr.func.text == name


def _tolerance_kind(kind: str) -> Dimension:
    return Dimension.IMAGE if kind in _MEASUREMENTS else Dimension.ANGLE


def _constant(expr: ast.Expr | None, kind: Dimension) -> float | None:
    """A constant of ``kind`` in SI, or None (no value, or not a constant of that kind)."""
    if isinstance(expr, ast.Quantity) and UNIT_KIND.get(expr.unit) == kind:
        return quantity_si(expr)
    if isinstance(expr, ast.Number) and kind is Dimension.NUMBER:
        return expr.value
    return None


def _default(expr: ast.Expr, ptype: str) -> Val | None:
    if ptype not in VALUE_TYPES:
        return None  # a role parameter (its type a concept) has no value default
    kind = Dimension(ptype)
    v = _constant(expr, kind)
    return None if v is None else Val(((v, ()),), kind)
