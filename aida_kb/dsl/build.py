"""The AST built during the parse: Lark's inline transformer for the grammar's rules.

`AstBuilder` is the transformer `aida_kb.dsl.parser` gives Lark: each grammar rule's callback
returns its `aida_kb.dsl.ast` node with its span, so a parse builds no parse tree. Literals
(strings, quantities with their units, cardinalities) are checked here and reported as
diagnostics the builder collects (`AstBuilder.diagnostics`).
"""

from __future__ import annotations

import dataclasses
import difflib
import re
from typing import Any, cast

from lark import Token, Transformer

from aida_kb.diagnostics import codes
from aida_kb.diagnostics.core import Diagnostic, Span
from aida_kb.dsl import ast

__all__ = ["BOM", "MAX_EXPR_DEPTH", "NAME_PATTERN", "AstBuilder"]


class _Doc:
    __slots__ = ("text",)

    def __init__(self, text: str | None) -> None:
        self.text = text


class _InLayer:
    __slots__ = ("name", "span")

    def __init__(self, name: ast.Name, span: Span) -> None:
        self.name = name
        self.span = span


class _IsA:
    __slots__ = ("names", "span")

    def __init__(self, names: tuple[ast.Name, ...], span: Span) -> None:
        self.names = names
        self.span = span


class _Qualifier:
    __slots__ = ("kind", "span", "value")

    def __init__(self, kind: str, value: ast.Expr, span: Span) -> None:
        self.kind = kind
        self.value = value
        self.span = span


class _Tilt:
    __slots__ = ("span", "value")

    def __init__(self, value: ast.Expr, span: Span) -> None:
        self.value = value
        self.span = span


#: The byte-order mark some editors write at the start of a UTF-8 file; dropped before parsing.
BOM = "\ufeff"
NAME_PATTERN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_ESCAPE = re.compile(r"\\(.)")
_ESCAPES = {"n": "\n", "t": "\t", "r": "\r"}
_QUANTITY = re.compile(r"(-?[0-9.eE+-]+?)[ \t]*([A-Za-z_][A-Za-z0-9_]*)$")
_INTEGER = re.compile(r"[0-9]+$")
#: Calls and lists nested deeper than this are refused (KB011): the checks and the build walk
#: expressions recursively, and the deepest in a real knowledge base is edge(edge(a, b)).
MAX_EXPR_DEPTH = 32
#: A cardinality bound longer than this is refused (KB006); 10**9 parts are no building.
_MAX_BOUND_DIGITS = 9


def _unescape(literal: str) -> str:
    body = literal[1:-1]
    if "\\" not in body:
        return body
    return _ESCAPE.sub(lambda m: _ESCAPES.get(m.group(1), m.group(1)), body)


class AstBuilder(Transformer[Token, Any]):
    """Inline transformer: each grammar rule's callback returns its AST node."""

    def __init__(self) -> None:
        super().__init__()
        self.file = "<string>"
        self.line_offset = 0
        self.diagnostics: list[Diagnostic] = []
        self.depth: dict[int, int] = {}  # id of a Call or ListExpr -> its nesting depth

    def reset(self, file: str, line_offset: int) -> None:
        self.file = file
        self.line_offset = line_offset
        self.diagnostics = []
        self.depth = {}

    def nested(self, children: Any, span: Span) -> int:
        """The nesting depth of a new call or list over `children`; KB011 the first time that
        it exceeds `MAX_EXPR_DEPTH` (the caller then drops the children: no deep tree)."""
        depth = self.depth
        inner = max((depth.get(id(c), 0) for c in children if isinstance(c, _NESTING)), default=0)
        if inner == MAX_EXPR_DEPTH:
            self.report(
                codes.NESTED_TOO_DEEP,
                f"calls or lists nested more than {MAX_EXPR_DEPTH} deep",
                span,
                "write the relation with fewer levels (a template per level of meaning)",
            )
        return inner + 1

    def finite(self, tok: Token, text: str) -> float:
        """`text` as a float; KB010 (and 1.0 in its place) when it is beyond float64's range."""
        value = float(text)
        if value in (_INF, -_INF):
            self.report(
                codes.NUMBER_TOO_LARGE,
                f"the number {str(tok)[:24]} is beyond the range of a 64-bit float (about 1.8e308)",
                self.tspan(tok),
            )
            return 1.0
        return value

    # -- spans
    def span(self, ch: list[Any]) -> Span:
        """The span from the first to the last positioned child (all tokens are kept)."""
        off = self.line_offset
        first: Any = None
        last: Any = None
        for c in ch:
            if c is not None and not isinstance(c, _UNPOSITIONED):
                first = c
                break
        for c in reversed(ch):
            if c is not None and not isinstance(c, _UNPOSITIONED):
                last = c
                break
        if first is None or last is None:
            return Span.point(self.file, 1 + off, 1)
        if isinstance(first, Token):  # lexer tokens always carry their position
            line, column = cast(int, first.line) + off, cast(int, first.column)
        else:
            fs = first.span
            line, column = fs.line, fs.column
        if isinstance(last, Token):
            end_line, end_column = cast(int, last.end_line) + off, cast(int, last.end_column)
        else:
            ls = last.span
            end_line, end_column = ls.end_line, ls.end_column
        return _make_span(self.file, line, column, end_line, end_column)

    def tspan(self, tok: Token) -> Span:
        t: Any = tok  # lexer tokens always carry their position
        off = self.line_offset
        return _make_span(self.file, t.line + off, t.column, t.end_line + off, t.end_column)

    def name(self, tok: Token) -> ast.Name:
        t: Any = tok
        off = self.line_offset
        span = _make_span(self.file, t.line + off, t.column, t.end_line + off, t.end_column)
        return _make_name(str(tok), span)

    def report(self, code: codes.Code, message: str, span: Span, hint: str | None = None) -> None:
        self.diagnostics.append(Diagnostic(code.code, code.severity, message, span, hint))

    # -- top level
    def start(self, ch: list[Any]) -> list[Any]:
        return [c for c in ch if c is not None]

    def layers_decl(self, ch: list[Token]) -> ast.Layers:
        return ast.Layers(tuple(self.name(t) for t in _names(ch)), self.span(ch))

    def import_decl(self, ch: list[Token]) -> ast.Import:
        tok = ch[1]
        return ast.Import(ast.String(_unescape(str(tok)), self.tspan(tok)), self.span(ch))

    def template_decl(self, ch: list[Any]) -> ast.Template:
        doc = next((c.text for c in ch if isinstance(c, _Doc)), None)
        return ast.Template(
            self.name(ch[1]),
            tuple(c for c in ch if isinstance(c, ast.Param)),
            doc,
            tuple(c for c in ch if isinstance(c, ast.Relation)),
            self.span(ch),
        )

    def param(self, ch: list[Any]) -> ast.Param:
        # NAME ":" NAME ["=" expr]  (placeholders: "=" and expr are None when absent)
        default = ch[-1] if len(ch) > 3 and not isinstance(ch[-1], Token) else None
        return ast.Param(self.name(ch[0]), self.name(ch[2]), default, self.span(ch))

    def concept_decl(self, ch: list[Any]) -> ast.Concept:
        abstract = isinstance(ch[0], Token) and ch[0].type == "ABSTRACT"
        layer: ast.Name | None = None
        parents: tuple[ast.Name, ...] = ()
        doc: str | None = None
        members: list[ast.Member] = []
        for c in ch:
            if isinstance(c, Token):
                continue
            if isinstance(c, _InLayer):
                layer = c.name
            elif isinstance(c, _IsA):
                parents = c.names
            elif isinstance(c, _Doc):
                doc = c.text
            elif c is not None:
                members.append(c)
        name = _names(ch)[0]
        return ast.Concept(
            self.name(name), abstract, layer, parents, doc, tuple(members), self.span(ch)
        )

    def in_layer(self, ch: list[Token]) -> _InLayer:
        return _InLayer(self.name(ch[1]), self.span(ch))

    def is_a(self, ch: list[Token]) -> _IsA:
        return _IsA(tuple(self.name(t) for t in _names(ch)), self.span(ch))

    def instance_decl(self, ch: list[Any]) -> ast.Instance:
        names = _names(ch)
        doc = next((c.text for c in ch if isinstance(c, _Doc)), None)
        return ast.Instance(
            self.name(names[0]),
            self.name(names[1]),
            doc,
            tuple(c for c in ch if isinstance(c, ast.Binding)),
            self.span(ch),
        )

    def binding(self, ch: list[Any]) -> ast.Binding:
        return ast.Binding(self.name(ch[0]), ch[2], self.span(ch))

    def list_value(self, ch: list[Any]) -> ast.ListExpr:
        items = tuple(c for c in ch if c is not None and not isinstance(c, Token))
        span = self.span(ch)
        depth = self.nested(items, span)
        node = ast.ListExpr(items if depth <= MAX_EXPR_DEPTH else (), span)
        self.depth[id(node)] = depth
        return node

    def doc(self, ch: list[Token]) -> _Doc:
        if not ch:
            return _Doc(None)
        return _Doc("".join(_unescape(str(t)) for t in ch))

    # -- members
    def part(self, ch: list[Any]) -> ast.Part:
        names = _names(ch)
        card = ch[-1] if isinstance(ch[-1], ast.Cardinality) else None
        optional = isinstance(ch[0], Token) and ch[0].type == "OPTIONAL"
        return ast.Part(
            tuple(self.name(t) for t in names[:-1]),
            self.name(names[-1]),
            optional,
            card,
            self.span(ch),
        )

    def con_of(self, ch: list[Any]) -> ast.ConOf:
        names = _names(ch)
        card = ch[-1] if isinstance(ch[-1], ast.Cardinality) else None
        return ast.ConOf(self.name(names[0]), self.name(names[1]), card, self.span(ch))

    def cardinality(self, ch: list[Token | None]) -> ast.Cardinality:
        span = self.span(ch)
        bounds = [t for t in ch if t is not None and t.type in ("NUMBER", "STAR")]
        low = self.int_bound(bounds[0], span)
        if len(bounds) == 1:
            return ast.Cardinality(low, low, span)
        high_tok = bounds[1]
        high = None if high_tok.type == "STAR" else self.int_bound(high_tok, span)
        return ast.Cardinality(low, high, span)

    def int_bound(self, tok: Token, span: Span) -> int:
        text = str(tok)
        if _INTEGER.match(text) and len(text.lstrip("0")) <= _MAX_BOUND_DIGITS:
            return int(text)
        whole = _INTEGER.match(text) is not None
        self.report(
            codes.BAD_CARDINALITY,
            f"a cardinality bound must be at most {_MAX_BOUND_DIGITS} digits long"
            if whole
            else f"a cardinality bound must be a whole number, not {text[:24]}",
            self.tspan(tok),
            "write [1..*], [0..4] or [2]",
        )
        return 0

    def attribute(self, ch: list[Any]) -> ast.Attribute:
        names = _names(ch)
        rng = next((c for c in ch if isinstance(c, ast.Range)), None)
        measure = ch[-1] if isinstance(ch[-1], ast.AttributeMeasure) else None
        last = ch[-2] if len(ch) > 1 else None
        default = last if last is not None and not isinstance(last, Token | ast.Range) else None
        return ast.Attribute(
            self.name(names[0]), self.name(names[1]), rng, default, self.span(ch), measure
        )

    def attr_measure(self, ch: list[Any]) -> ast.AttributeMeasure:
        tol = ch[2].value if ch[2] is not None else None
        return ast.AttributeMeasure(ch[1], tol, self.span(ch))

    # -- geometry members
    def frame(self, ch: list[Any]) -> ast.Frame:
        return ast.Frame(ch[2], self.span(ch))

    def orient(self, ch: list[Any]) -> ast.Orient:
        paths = tuple(c for c in ch if isinstance(c, ast.Path))
        direction = next(c for c in ch if isinstance(c, ast.Name))
        tilt = ch[-1] if isinstance(ch[-1], _Tilt) else None
        return ast.Orient(paths, direction, tilt.value if tilt else None, self.span(ch))

    def tilted(self, ch: list[Any]) -> _Tilt:
        return _Tilt(ch[2], self.span(ch))

    def direction(self, ch: list[Token]) -> ast.Name:
        return self.name(ch[0])

    def unseen(self, ch: list[Any]) -> ast.Unseen:
        paths = tuple(c for c in ch if isinstance(c, ast.Path))
        return ast.Unseen(paths, ch[-1], self.span(ch))

    def mirror(self, ch: list[Any]) -> ast.Placement:
        return ast.Placement(ast.PlacementKind.MIRROR, ch[1], None, ch[3], self.span(ch))

    def offset(self, ch: list[Any]) -> ast.Placement:
        return ast.Placement(ast.PlacementKind.OFFSET, ch[3], ch[1], None, self.span(ch))

    def reach(self, ch: list[Any]) -> ast.Placement:
        return ast.Placement(ast.PlacementKind.REACH, None, None, ch[1], self.span(ch))

    def attach(self, ch: list[Any]) -> ast.Attach:
        paths = [c for c in ch if isinstance(c, ast.Path)]
        face, contact = (c for c in ch if isinstance(c, ast.Name))
        name = self.name(ch[-1]) if isinstance(ch[-1], Token) and ch[-1].type == "NAME" else None
        return ast.Attach(paths[0], face, contact, tuple(paths[1:]), name, self.span(ch))

    def touching(self, ch: list[Any]) -> ast.Touching:
        # "touching" NAME "share" path ("," path)*
        role = next(c for c in ch if isinstance(c, Token) and c.type == "NAME")
        paths = tuple(c for c in ch if isinstance(c, ast.Path))
        return ast.Touching(self.name(role), paths, self.span(ch))

    def contact(self, ch: list[Token]) -> ast.Name:
        return self.name(ch[0])

    def when(self, ch: list[Any]) -> ast.When:
        # "when" path "is" NAME ("," NAME)* "{" _member* "}"
        role = next(c for c in ch if isinstance(c, ast.Path))
        brace = next(i for i, c in enumerate(ch) if isinstance(c, Token) and c.type == "LBRACE")
        names = [c for c in ch[:brace] if isinstance(c, Token) and c.type == "NAME"]
        head = self.span(ch[:brace])
        condition = ast.Condition(role, tuple(self.name(t) for t in names), head)
        members = tuple(
            dataclasses.replace(c, condition=condition)
            if isinstance(c, ast.Adjacency | ast.Constraint | ast.Measure | ast.Unseen)
            else c
            for c in ch[brace + 1 :]
            if c is not None and not isinstance(c, Token)
        )
        return ast.When(condition, members, self.span(ch))

    def attr_range(self, ch: list[Any]) -> ast.Range:
        return ast.Range(ch[1], ch[3], self.span(ch))

    def adjacent_ring(self, ch: list[Any]) -> ast.Adjacency:
        paths = tuple(c for c in ch if isinstance(c, ast.Path))
        return ast.Adjacency(ast.AdjacencyKind.RING, (paths,), self.span(ch))

    def adjacent_pairs(self, ch: list[Any]) -> ast.Adjacency:
        pairs = tuple(c for c in ch if isinstance(c, tuple))
        return ast.Adjacency(ast.AdjacencyKind.PAIRS, pairs, self.span(ch))

    def pair(self, ch: list[Any]) -> tuple[ast.Path, ast.Path]:
        return (ch[1], ch[3])

    def constraint(self, ch: list[Any]) -> ast.Constraint | None:
        relation = ch[-1]
        if relation is None:
            return None
        label = self.name(ch[1]) if isinstance(ch[1], Token) else None
        return ast.Constraint(label, relation, self.span(ch))

    def measure(self, ch: list[Any]) -> ast.Measure | None:
        if ch[1] is None:
            return None
        return ast.Measure(ch[1], self.span(ch))

    # -- relations
    def relation(self, ch: list[Any]) -> ast.Relation | None:
        lhs, eq, rhs = ch[0], ch[1], ch[2]
        body: ast.Call | ast.Comparison
        if eq is not None:
            span = Span(
                lhs.span.file,
                lhs.span.line,
                lhs.span.column,
                rhs.span.end_line,
                rhs.span.end_column,
            )
            body = ast.Comparison(lhs, "==", rhs, span)
        elif isinstance(lhs, ast.Call):
            body = lhs
        else:
            self.report(
                codes.BAD_RELATION,
                f"'{lhs}' is not a relation",
                lhs.span,
                "a relation is a call such as parallel(a, b) or a comparison such as "
                "angle(a, b) == 90 deg",
            )
            return None
        found: dict[str, _Qualifier] = {}
        for q in ch[3:]:
            if q.kind in found:
                self.report(
                    codes.DUPLICATE_QUALIFIER,
                    f"this relation already has a {q.kind}",
                    q.span,
                    "give each of '+-', 'weight' and 'reject above' at most once",
                )
            else:
                found[q.kind] = q
        return ast.Relation(
            body,
            found["tolerance"].value if "tolerance" in found else None,
            found["weight"].value if "weight" in found else None,
            found["threshold"].value if "threshold" in found else None,
            self.span(ch),
        )

    def tolerance(self, ch: list[Any]) -> _Qualifier:
        return _Qualifier("tolerance", ch[-1], self.span(ch))

    def weight(self, ch: list[Any]) -> _Qualifier:
        return _Qualifier("weight", ch[-1], self.span(ch))

    def reject(self, ch: list[Any]) -> _Qualifier:
        return _Qualifier("threshold", ch[-1], self.span(ch))

    # -- expressions
    def call(self, ch: list[Any]) -> ast.Call:
        args = tuple(c for c in ch[2:] if c is not None and not isinstance(c, Token))
        span = self.span(ch)
        depth = self.nested(args, span)
        node = ast.Call(self.name(ch[0]), args if depth <= MAX_EXPR_DEPTH else (), span)
        self.depth[id(node)] = depth
        return node

    def path(self, ch: list[Token]) -> ast.Path:
        if len(ch) == 1:
            name = self.name(ch[0])
            return _make_path((name,), name.span)
        return _make_path(tuple(self.name(t) for t in _names(ch)), self.span(ch))

    def number(self, ch: list[Token]) -> ast.Number:
        tok = ch[0]
        return ast.Number(self.finite(tok, str(tok)), str(tok), self.tspan(tok))

    def quantity(self, ch: list[Token]) -> ast.Quantity:
        tok = ch[0]
        text = str(tok)
        span = self.tspan(tok)
        m = _QUANTITY.match(text)
        number, unit = (m.group(1), m.group(2)) if m else (text, "")
        if unit not in ast.UNITS:
            unit_col = span.end_column - len(unit)
            self.report(
                codes.UNKNOWN_UNIT,
                f"unknown unit '{unit}' — expected {', '.join(ast.UNITS)}",
                Span(span.file, span.end_line, unit_col, span.end_line, span.end_column),
                _unit_hint(unit, number),
            )
        return ast.Quantity(self.finite(tok, number), unit, text, span)

    def string(self, ch: list[Token]) -> ast.String:
        return ast.String(_unescape(str(ch[0])), self.tspan(ch[0]))


#: Spellings of the language's units that people write, and what to write instead.
_UNIT_ALIASES = {
    **dict.fromkeys(("meter", "meters", "metre", "metres", "M"), "m"),
    **dict.fromkeys(("centimeter", "centimeters", "centimetre", "centimetres", "CM"), "cm"),
    **dict.fromkeys(("millimeter", "millimeters", "millimetre", "millimetres", "MM"), "mm"),
    **dict.fromkeys(("degree", "degrees", "Deg", "DEG", "grad"), "deg"),
    **dict.fromkeys(("radian", "radians", "RAD", "Rad"), "rad"),
    **dict.fromkeys(("pixel", "pixels", "pix", "PX"), "px"),
}
#: Units of length outside the metric system, in metres.
_IMPERIAL = {"ft": 0.3048, "feet": 0.3048, "foot": 0.3048, "inch": 0.0254, "inches": 0.0254,
             "yd": 0.9144, "yard": 0.9144, "yards": 0.9144}  # fmt: skip


def _unit_hint(unit: str, number: str) -> str | None:
    """What to write instead of the unknown `unit` after `number`."""
    if unit in _UNIT_ALIASES:
        return f"write {number} {_UNIT_ALIASES[unit]}"
    if unit in _IMPERIAL:
        try:
            metres = float(number) * _IMPERIAL[unit]
        except ValueError:
            metres = None
        where = f": {number} {unit} is {metres:.4g} m" if metres is not None else ""
        return f"lengths are metric (m, cm, mm){where}"
    close = difflib.get_close_matches(unit, ast.UNITS, n=1, cutoff=0.5)
    return f"did you mean '{close[0]}'?" if close else None


def _setter(cls: type, field: str) -> Any:
    return getattr(cls, field).__set__


# Frozen slotted dataclasses are built through their slots' setters: twice as fast as their
# __init__ (which goes through object.__setattr__), and the parser builds tens of thousands.
_SPAN_SETTERS = tuple(
    _setter(Span, f) for f in ("file", "line", "column", "end_line", "end_column")
)
_NAME_SETTERS = (_setter(ast.Name, "text"), _setter(ast.Name, "span"))
_PATH_SETTERS = (_setter(ast.Path, "parts"), _setter(ast.Path, "span"))
_new = object.__new__


def _make_span(file: str, line: int, column: int, end_line: int, end_column: int) -> Span:
    s: Span = _new(Span)
    f, li, co, el, ec = _SPAN_SETTERS
    f(s, file)
    li(s, line)
    co(s, column)
    el(s, end_line)
    ec(s, end_column)
    return s


def _make_name(text: str, span: Span) -> ast.Name:
    n: ast.Name = _new(ast.Name)
    _NAME_SETTERS[0](n, text)
    _NAME_SETTERS[1](n, span)
    return n


def _make_path(parts: tuple[ast.Name, ...], span: Span) -> ast.Path:
    p: ast.Path = _new(ast.Path)
    _PATH_SETTERS[0](p, parts)
    _PATH_SETTERS[1](p, span)
    return p


_UNPOSITIONED = (_Doc, tuple)
_NESTING = (ast.Call, ast.ListExpr)
_INF = float("inf")


def _names(ch: list[Any]) -> list[Token]:
    return [c for c in ch if isinstance(c, Token) and c.type == "NAME"]
