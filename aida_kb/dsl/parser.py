"""Parse ``.kb`` source text into an `ast.Module` and syntax diagnostics; never raises.

The grammar (``grammars/kb.lark``) is parsed by Lark's LALR(1) parser with the contextual
lexer, driven by `aida_kb.dsl.lexer.FastContextualLexer` (the same tokens in one tight loop);
the AST is built *during* the parse by an inline transformer (no parse tree), so a parse costs
less than Lark's plain parse to a tree (``benchmarks/lint.py``). When the text has a syntax
error, the parser resynchronises: it cuts the text at every top-level declaration keyword
(``concept``, ``abstract``, ``template``, ``instance``, ``import``, ``layers``) and parses each
piece on its own, so one run reports every broken declaration and keeps every sound one.
"""

from __future__ import annotations

import bisect
import dataclasses
import difflib
import gc
import itertools
import re
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path as FsPath
from typing import Any, cast

from lark import Lark, Token, Transformer
from lark.exceptions import UnexpectedCharacters, UnexpectedInput, UnexpectedToken

from aida_kb.diagnostics import codes
from aida_kb.diagnostics.core import Diagnostic, Span
from aida_kb.dsl import ast
from aida_kb.dsl.lexer import install as install_fast_lexer

__all__ = ["ParseResult", "grammar_path", "make_lark", "parse"]


@dataclass(frozen=True, slots=True)
class ParseResult:
    """What `parse` found: the module (every declaration that parsed) and the diagnostics.

    ``broken`` names the declarations that failed to parse (``concept Foo`` with a syntax
    error gives ``"Foo"``), so that later phases need not report them again as unknown.
    """

    module: ast.Module
    diagnostics: tuple[Diagnostic, ...]
    broken: frozenset[str] = field(default_factory=frozenset)
    #: concepts kept without a member that did not parse: their other members may name it
    incomplete: frozenset[str] = field(default_factory=frozenset)

    @property
    def ok(self) -> bool:
        """True when no diagnostic is an error."""
        return not any(d.is_error for d in self.diagnostics)


def grammar_path() -> FsPath:
    """The grammar file: inside the installed wheel, else the repository's ``grammars/``."""
    from importlib import resources

    packaged = resources.files("aida_kb").joinpath("_data", "grammars", "kb.lark")
    if packaged.is_file():
        return FsPath(str(packaged))
    return FsPath(__file__).resolve().parents[2] / "grammars" / "kb.lark"


# ---- building the AST ---------------------------------------------------------------------------
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
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
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


class _Builder(Transformer[Token, Any]):
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


# ---- the parser, built once ---------------------------------------------------------------------
_lock = threading.Lock()
_builder = _Builder()
_lark: Lark | None = None


def make_lark(
    transformer: Transformer[Token, Any] | None = None,
    lexer_callbacks: dict[str, Callable[[Token], Token]] | None = None,
) -> Lark:
    """Lark's LALR parser with the contextual lexer for the grammar, as aida-kb configures it.

    Every token is kept and absent optional parts are ``None`` placeholders (the builder's
    callbacks rely on both). With ``transformer`` the parse builds its results inline. The
    lexer is Lark's own: `parse` drives it with `aida_kb.dsl.lexer.FastContextualLexer`.
    ``lexer_callbacks`` (terminal name -> function of the token) see every token of those
    terminals, the ignored comments too (the formatter collects them so).

    The tables are built from the packaged grammar in memory at every start (about 30 ms) and
    never cached: Lark's cache is a pickle under a predictable name in the shared temporary
    directory, and unpickling a file another user can write runs their code.
    """
    return Lark(
        grammar_path().read_text(encoding="utf-8"),
        parser="lalr",
        lexer="contextual",
        maybe_placeholders=True,
        keep_all_tokens=True,
        cache=False,
        transformer=transformer,
        lexer_callbacks=lexer_callbacks or {},
    )


def _parser() -> Lark:
    global _lark
    if _lark is None:
        _lark = make_lark(_builder)
        install_fast_lexer(_lark)
    return _lark


def parse(text: str, file: str = "<string>") -> ParseResult:
    """Parse one ``.kb`` source text.

    Parameters
    ----------
    text : str
        The source.
    file : str
        The file name put into every span and diagnostic.

    Returns
    -------
    ParseResult
        The module of every declaration that parsed, the syntax diagnostics (codes KB001-KB099)
        sorted by position, and the names of the declarations that did not parse. Never raises.
    """
    # The AST is a tree of fresh objects without reference cycles: the cyclic garbage
    # collector would only re-scan them over and over (superlinear on large files).
    collecting = gc.isenabled()
    gc.disable()
    try:
        with _lock:
            return _parse_locked(text, file)
    except Exception as exc:  # the last safety net: parse() must never raise
        span = Span.point(file, 1, 1)
        diag = Diagnostic(
            codes.INTERNAL_PARSER_ERROR.code,
            codes.INTERNAL_PARSER_ERROR.severity,
            f"internal parser error: {type(exc).__name__}: {exc}",
            span,
        )
        return ParseResult(ast.Module(file, (), span), (diag,))
    finally:
        if collecting:
            gc.enable()


def _module_span(text: str, file: str) -> Span:
    last_start = text.rfind("\n") + 1
    return Span(file, 1, 1, text.count("\n") + 1, len(text) - last_start + 1)


def _keyword_as_name(exc: UnexpectedInput) -> bool:
    """Lark's ``on_error``: a keyword where a name may stand is that name (keywords are
    contextual, docs/language.md §1). An LALR state shared by several contexts lets the
    contextual lexer read ``weight`` as the keyword after a binding's number (where only
    a relation could take it): retyped, the parse goes on."""
    if not isinstance(exc, UnexpectedToken) or "NAME" not in exc.expected:
        return False
    tok = exc.token
    if tok.type == "NAME" or not _NAME.fullmatch(str(tok)) or exc.interactive_parser is None:
        return False
    exc.interactive_parser.feed_token(Token.new_borrow_pos("NAME", str(tok), tok))
    return True


def _parse_locked(text: str, file: str) -> ParseResult:
    lark = _parser()
    if text.startswith(BOM):  # a byte-order mark is no column of the first line
        text = text[1:]
    _builder.reset(file, 0)
    try:
        items: list[ast.Item] = lark.parse(text, on_error=_keyword_as_name)  # type: ignore[assignment]
    except UnexpectedInput:
        pass
    else:
        diags = tuple(sorted(_builder.diagnostics, key=Diagnostic.sort_key))
        return ParseResult(ast.Module(file, tuple(items), _module_span(text, file)), diags)
    return _recover(lark, text, file)


# ---- recovery -----------------------------------------------------------------------------------
_SCAN = re.compile(
    r'//[^\n]*|/\*.*?(?:\*/|\Z)|"(?:[^"\\\n]|\\.)*"?'
    r"|(?<![A-Za-z0-9_-])(abstract|concept|template|instance|import|layers)(?![A-Za-z0-9_-])",
    re.S,
)
_DECL_NAME = re.compile(r"(?:abstract\s+)?(?:concept|template|instance)\s+([A-Za-z_][A-Za-z0-9_]*)")


def _declaration_starts(text: str) -> list[int]:
    """Offsets where a top-level declaration keyword starts (outside strings and comments)."""
    starts: list[int] = []
    last_kw = ""
    last_end = 0
    for m in _SCAN.finditer(text):
        kw = m.group(1)
        if kw is None:
            continue
        if kw == "concept" and last_kw == "abstract" and not text[last_end : m.start()].strip():
            last_kw = kw
            continue
        starts.append(m.start())
        last_kw, last_end = kw, m.end()
    return starts


_MEMBER_START = re.compile(
    r'//[^\n]*|/\*.*?(?:\*/|\Z)|"(?:[^"\\\n]|\\.)*"?'
    r"|(?<![A-Za-z0-9_.-])(optional\s+part|part|con-of|attribute|adjacent|constraint|measure"
    r"|frame|orient|unseen|attach|when|touching)(?![A-Za-z0-9_-])",
    re.S,
)
#: A concept body with more broken members than this is reported up to this many (each retry
#: parses the declaration again).
MAX_MEMBER_ERRORS = 50


def _member_starts(text: str, body: int) -> list[int]:
    """Offsets in `text` after `body` where a concept member starts (outside strings and
    comments)."""
    return [m.start() for m in _MEMBER_START.finditer(text, body) if m.group(1) is not None]


def _blank(text: str, start: int, end: int) -> str:
    """`text` with ``[start, end)`` replaced by blanks (line breaks kept: positions hold)."""
    cut = text[start:end]
    return text[:start] + re.sub(r"[^\n]", " ", cut) + text[end:]


def _error_offset(exc: UnexpectedInput, text: str) -> int:
    if isinstance(exc, UnexpectedToken):
        if exc.token.type == "$END":
            return len(text)
        return exc.token.start_pos if exc.token.start_pos is not None else len(text)
    return exc.pos_in_stream if exc.pos_in_stream is not None else len(text)


def _parse_declaration(
    lark: Lark, padded: str, file: str, line_index: int, last: bool, incomplete: set[str]
) -> tuple[list[ast.Item], list[Diagnostic], bool]:
    """Parse one declaration (`padded`: blanks before it keep its columns), member by member.

    A syntax error inside a concept's body blanks the broken member (from its keyword to the
    next member's) and parses again, so that every broken member is reported and the sound
    ones are kept; a body that the next declaration cuts short (not `last`) is ``KB012`` and
    closed. Returns the items, the diagnostics and whether the declaration had an error; a
    concept kept without its broken members is added to `incomplete`.
    """
    diags: list[Diagnostic] = []
    attempt = padded
    brace = padded.find("{")
    is_concept = _DECL_NAME.match(padded.lstrip()) is not None and (
        padded.lstrip().startswith(("concept", "abstract"))
    )
    closed = False
    for _ in range(MAX_MEMBER_ERRORS):
        _builder.reset(file, line_index)
        try:
            items: list[ast.Item] = lark.parse(attempt, on_error=_keyword_as_name)  # type: ignore[assignment]
        except UnexpectedInput as exc:
            pos = _error_offset(exc, attempt)
            at_end = isinstance(exc, UnexpectedToken) and exc.token.type == "$END"
            expects_brace = isinstance(exc, UnexpectedToken) and "RBRACE" in exc.expected
            if at_end and brace >= 0 and not closed and expects_brace:
                # the body runs to the next declaration (or the end of the file): say so,
                # close it, and parse its members
                unclosed = _describe(lark, exc, attempt, file, line_index)
                diags.append(unclosed if last else _unclosed(padded, brace, file, line_index))
                attempt = attempt.rstrip() + " }"
                closed = True
                continue
            diags.append(_describe(lark, exc, attempt, file, line_index))
            if not is_concept or brace < 0 or pos <= brace or at_end:
                return [], [*diags, *_builder.diagnostics], True
            starts = _member_starts(attempt, brace + 1)
            before = [p for p in starts if p < pos]
            if not before:
                return [], [*diags, *_builder.diagnostics], True
            after = [p for p in starts if p > pos]
            stop = after[0] if after else attempt.rfind("}")
            if stop <= before[-1]:
                stop = len(attempt.rstrip()) - (1 if attempt.rstrip().endswith("}") else 0)
            attempt = _blank(attempt, before[-1], stop)
            continue
        if diags and is_concept:
            incomplete.update(i.name.text for i in items if isinstance(i, ast.Concept))
        return items, [*diags, *_builder.diagnostics], bool(diags)
    return [], diags, True


def _unclosed(padded: str, brace: int, file: str, line_index: int) -> Diagnostic:
    """``KB012`` at the '{' of a declaration that the next declaration cuts short."""
    line = padded.count("\n", 0, brace) + 1 + line_index
    column = brace - (padded.rfind("\n", 0, brace) + 1) + 1
    end_line = line_index + padded.rstrip().count("\n") + 2
    name = _DECL_NAME.match(padded.lstrip())
    what = f"the body of {name.group(0).split()[-2]} {name.group(1)}" if name else "this body"
    return _diag(
        codes.UNCLOSED_BODY,
        f"'{{' of {what} is not closed before the next declaration",
        Span(file, line, column, line, column + 1),
        f"close it with '}}' before line {end_line}",
    )


def _recover(lark: Lark, text: str, file: str) -> ParseResult:
    line_starts = [0] + [i + 1 for i, ch in enumerate(text) if ch == "\n"]
    bounds = _declaration_starts(text)
    if not bounds or bounds[0] != 0:
        bounds.insert(0, 0)
    bounds.append(len(text))
    items: list[ast.Item] = []
    diags: list[Diagnostic] = []
    broken: set[str] = set()
    incomplete: set[str] = set()
    pairs = list(itertools.pairwise(bounds))
    for index, (start, end) in enumerate(pairs):
        chunk = text[start:end]
        if not chunk.strip():
            continue
        line_index = bisect.bisect_right(line_starts, start) - 1
        column = start - line_starts[line_index] + 1
        padded = " " * (column - 1) + chunk
        last = not any(text[s:e].strip() for s, e in pairs[index + 1 :])
        found, found_diags, failed = _parse_declaration(
            lark, padded, file, line_index, last, incomplete
        )
        items.extend(found)
        diags.extend(found_diags)
        if failed and not found:
            m = _DECL_NAME.match(chunk)
            if m:
                broken.add(m.group(1))
    diags = list(dict.fromkeys(diags))
    diags.sort(key=Diagnostic.sort_key)
    module = ast.Module(file, tuple(items), _module_span(text, file))
    return ParseResult(module, tuple(diags), frozenset(broken), frozenset(incomplete))


# ---- friendly messages --------------------------------------------------------------------------
_AFTER_KEYWORD: dict[str, str] = {
    "PART": "expected a role name after 'part'",
    "_CON_OF": "expected a role name after 'con-of'",
    "CONCEPT": "expected a concept name after 'concept'",
    "TEMPLATE": "expected a template name after 'template'",
    "INSTANCE": "expected an instance name after 'instance'",
    "ATTRIBUTE": "expected an attribute name after 'attribute'",
    "OF": "expected a concept name after 'of'",
    "_IS_A": "expected a parent concept name after 'is-a'",
    "LAYERS": "expected a layer name after 'layers'",
    "MORETHAN": "expected a layer name after '>'",
    "IMPORT": "expected a file name in double quotes after 'import'",
    "ADJACENT": "expected 'ring(...)' or 'pairs(...)' after 'adjacent'",
    "CONSTRAINT": "expected a relation after 'constraint', such as parallel(a, b) "
    "or angle(a, b) == 90 deg",
    "MEASURE": "expected a measurement after 'measure', such as position(self) or edge(edge(a, b))",
    "_PLUSMINUS": "expected a tolerance after '+-', such as 0.5 deg",
    "WEIGHT": "expected a number after 'weight'",
    "REJECT": "expected 'above' after 'reject'",
    "ABOVE": "expected a threshold after 'reject above', such as 3 deg",
    "EQ": "expected a value after '=='",
    "EQUAL": "expected a value after '='",
    "OPTIONAL": "expected 'part' after 'optional'",
    "ABSTRACT": "expected 'concept' after 'abstract'",
    "__ANON_0": "expected a number or '*' after '..'",
    "DOT": "expected a role name after '.'",
    "RING": "expected '(' and the parts of the ring after 'ring'",
    "PAIRS": "expected '(' and the pairs after 'pairs'",
    "FRAME": "expected 'from' and the part that gives the frame, as in 'frame from front'",
    "ORIENT": "expected the parts to orient after 'orient', as in 'orient front: forward'",
    "UNSEEN": "expected the unseen parts after 'unseen', as in 'unseen back: at depth from front'",
    "ATTACH": "expected the attached part after 'attach', as in 'attach oriels: backward in front'",
    "TILTED": "expected 'by' and an angle after 'tilted', as in 'tilted by pitch'",
    "BY": "expected an angle or an attribute after 'by'",
    "MIRROR": "expected a part after 'mirror', as in 'mirror front about edge(a, b)'",
    "ABOUT": "expected an edge after 'about', as in 'about edge(roof.front, roof.back)'",
    "REACH": "expected an edge after 'reach', as in 'reach edge(roof.front, roof.back)'",
    "AT": "expected a distance after 'at', as in 'at depth from front'",
    "FROM": "expected a part after 'from'",
    "IS": "expected a measure after 'is', such as slope(self) or height(self)",
    "AS": "expected a name for the face after 'as'",
    "WHEN": "expected a role after 'when', as in 'when roof is HipRoof { ... }'",
    "TOUCHING": "expected a part role after 'touching', as in 'touching houses share body.roof'",
    "SHARE": "expected a role path after 'share', as in 'share body.roof'",
}
_TERMINAL_WORDS: dict[str, str] = {
    "NAME": "a name",
    "NUMBER": "a number",
    "QUANTITY": "a quantity such as 90 deg",
    "STRING": "a string",
    "$END": "the end of the file",
}
_DECLARATION_KEYWORDS = {"CONCEPT", "TEMPLATE", "INSTANCE", "IMPORT", "LAYERS", "ABSTRACT"}
_MEMBER_KEYWORDS = {
    "PART",
    "OPTIONAL",
    "_CON_OF",
    "ATTRIBUTE",
    "ADJACENT",
    "CONSTRAINT",
    "FRAME",
    "ORIENT",
    "UNSEEN",
    "ATTACH",
    "WHEN",
    "TOUCHING",
}


def _terminal_word(lark: Lark, name: str) -> str:
    if name in _TERMINAL_WORDS:
        return _TERMINAL_WORDS[name]
    try:
        term = lark.get_terminal(name)
    except KeyError:
        return name
    if term.pattern.type == "str":
        return f"'{term.pattern.value}'"
    return name.lower()


def _found(tok: Token) -> str:
    if tok.type == "$END":
        return "the end of the file"
    return f"'{tok}'"


# A name followed by something other than ':' - what the ':' introduces depends on the keyword
# a few tokens back (``part front, back Wall``); "PARAM" stands for a template's parameter list.
_COLON_AFTER: dict[str, str] = {
    "PART": "expected ':' and the part's concept after the role names, as in 'part front: Wall'",
    "_CON_OF": (
        "expected ':' and the realising concept after the role, as in 'con-of region: Region'"
    ),
    "ATTRIBUTE": "expected ':' and a type after the attribute name, as in 'attribute tilt: angle'",
    "PARAM": "expected ':' and a type after the parameter name, as in 'a: Plane'",
}


def _in_context(stack: list[Any], prev_type: str | None, expected: set[str]) -> str | None:
    """A message that needs the keyword before the last names (None: no such case)."""
    if prev_type == "NAME" and "COLON" in expected:
        for item in reversed(stack):
            if isinstance(item, Token) and item.type in ("NAME", "COMMA"):
                continue
            keyword = item.type if isinstance(item, Token) else "PARAM"
            if keyword == "LPAR":
                keyword = "PARAM"
            return _COLON_AFTER.get(keyword)
    if {"RPAR", "COMMA"} <= expected:
        return "expected ',' or a closing ')'"
    return None


def _describe(lark: Lark, exc: UnexpectedInput, text: str, file: str, off: int) -> Diagnostic:
    """A diagnostic for a syntax error, in the language's words (not the grammar's)."""
    if isinstance(exc, UnexpectedCharacters):
        return _describe_characters(exc, text, file, off)
    if isinstance(exc, UnexpectedToken):
        return _describe_token(lark, exc, text, file, off)
    span = Span.point(file, max(exc.line, 1) + off, max(exc.column, 1))
    return _diag(codes.SYNTAX, "syntax error", span)


def _diag(code: codes.Code, message: str, span: Span, hint: str | None = None) -> Diagnostic:
    return Diagnostic(code.code, code.severity, message, span, hint)


def _describe_characters(exc: UnexpectedCharacters, text: str, file: str, off: int) -> Diagnostic:
    pos = exc.pos_in_stream or 0
    line, col = exc.line + off, exc.column
    if text.startswith('"', pos):
        eol = text.find("\n", pos)
        length = (len(text) if eol < 0 else eol) - pos
        span = Span(file, line, col, line, col + max(length, 1))
        return _diag(
            codes.UNTERMINATED_STRING,
            "unterminated string",
            span,
            "close the string with '\"' on the same line; write \\\" for a quote inside it",
        )
    if text.startswith("/*", pos):
        return _diag(
            codes.UNTERMINATED_COMMENT,
            "unterminated comment: '/*' has no closing '*/'",
            Span(file, line, col, line, col + 2),
        )
    char = exc.char
    hints = {
        "#": "comments start with // or /*",
        ";": "no ';' is needed: members and declarations end by themselves",
        "'": "strings are written in double quotes",
        "°": "write angles with the unit deg: 90 deg",
        "′": "lengths are metric: write m, cm or mm",
        "″": "lengths are metric: write m, cm or mm",
    }
    return _diag(
        codes.UNEXPECTED_CHARACTER,
        f"unexpected character {char!r}",
        Span.point(file, line, col),
        hints.get(char),
    )


def _describe_token(lark: Lark, exc: UnexpectedToken, text: str, file: str, off: int) -> Diagnostic:
    tok = exc.token
    expected = set(exc.expected)
    found = _found(tok)
    if tok.type == "$END":
        lines = text.split("\n")
        span = Span.point(file, len(lines) + off, len(lines[-1]) + 1)
    else:
        span = Span(
            file,
            (tok.line or 1) + off,
            tok.column or 1,
            (tok.end_line or 1) + off,
            tok.end_column or 1,
        )
    prev: Any = None
    if exc.interactive_parser is not None:
        stack = exc.interactive_parser.parser_state.value_stack
        prev = stack[-1] if stack else None
    prev_type = prev.type if isinstance(prev, Token) else None

    message: str | None = None
    hint: str | None = None
    if prev_type == "NAME" and "IN" in expected and "_IS_A" in expected:
        message = "expected 'in LAYER' or 'is-a PARENT' after the concept name"
    elif prev_type == "IN" and "LSQB" in expected:
        message = "expected a range such as [85 deg, 95 deg] after 'in'"
    elif prev_type == "IN":
        message = "expected a layer name after 'in'"
    elif prev_type == "COLON" and expected <= {"NAME"}:
        message = "expected a concept or type name after ':'"
    elif prev_type is not None and prev_type in _AFTER_KEYWORD:
        message = _AFTER_KEYWORD[prev_type]
    elif expected & _DECLARATION_KEYWORDS and "RBRACE" not in expected:
        message = (
            "expected a declaration (concept, abstract concept, template, instance, import "
            "or layers)"
        )
        if tok.type == "RBRACE":
            hint = "this '}' closes nothing"
    elif prev_type == "COLON" and "FORWARD" in expected:
        message = "expected a direction: forward, backward, leftward, rightward, upward or downward"
    elif expected & _MEMBER_KEYWORDS:
        message = (
            "expected a member (part, optional part, con-of, attribute, adjacent, constraint, "
            "measure, frame, orient, unseen, attach, when, touching) or '}'"
        )
        if tok.type == "NAME":
            hint = "a role is declared with 'part NAME: Concept'"
    if (
        tok.type == "DOT"
        and tok.end_pos is not None
        and text[tok.end_pos : tok.end_pos + 1].isdigit()
    ):
        hint = f"a number starts with a digit: write 0.{text[tok.end_pos :].split()[0]}"
    if message is None and exc.interactive_parser is not None:
        message = _in_context(exc.interactive_parser.parser_state.value_stack, prev_type, expected)
    if message is None:
        words = sorted({_terminal_word(lark, t) for t in expected})
        if len(words) > 8:
            words = [*words[:8], "..."]
        message = "expected " + (words[0] if len(words) == 1 else "one of " + ", ".join(words))
    if tok.type == "$END":
        code = codes.UNEXPECTED_EOF if "RBRACE" in expected else codes.SYNTAX
        if "RBRACE" in expected and hint is None:
            hint = "a '}' is missing"
        return _diag(code, f"{message}, found the end of the file", span, hint)
    return _diag(codes.SYNTAX, f"{message}, found {found}", span, hint)
