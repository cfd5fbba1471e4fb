"""Which name refers to what: the symbols of a knowledge base and every occurrence of each.

The compiler resolves names to check them but keeps no list of where each is used; an
editor needs exactly that (go to definition, find references, rename). `build_index` walks
the parsed modules once and asks the resolved `Table` what each name means:

- a concept, template, instance or layer is one symbol, keyed by its name;
- a role or attribute is keyed by the concept that declares it and its name,
  ``("role", "Wing", "front")``; a path ``roof.front`` resolves part by part with the
  compiler's own rule (`Table.resolve_path`, docs/language.md §3.8);
- a template parameter is keyed by its template and name.

Roles that must keep one name are *linked*: an override and the declaration it overrides,
and the specialisations' roles one conditional path names at once (``roof.front`` in a
concept whose roof may be either of two specialisations). Renaming one renames the group.
"""

from __future__ import annotations

import bisect
from collections.abc import Iterable
from dataclasses import dataclass
from enum import StrEnum

from aida_kb.diagnostics.core import Span
from aida_kb.dsl import ast
from aida_kb.kb.resolve import PathRes, Table

__all__ = ["Index", "NameKind", "Occurrence", "Symbol", "SymbolKey", "build_index"]


class NameKind(StrEnum):
    """What a symbol is."""

    CONCEPT = "concept"
    TEMPLATE = "template"
    ROLE = "role"
    PARAM = "param"
    LAYER = "layer"
    INSTANCE = "instance"


#: ``(kind, *names)``: ``("concept", "House")``, ``("role", "Wing", "front")``,
#: ``("param", "perpendicular", "tol")``, ``("template", ...)``, ``("instance", ...)``,
#: ``("layer", ...)``.
SymbolKey = tuple[str, ...]


@dataclass(frozen=True, slots=True)
class Symbol:
    """A declared name: its kind, key, the name and where it is declared."""

    key: SymbolKey
    decl: Span

    @property
    def kind(self) -> NameKind:
        """What the symbol is."""
        return NameKind(self.key[0])

    @property
    def name(self) -> str:
        """The name as declared."""
        return self.key[-1]


@dataclass(frozen=True, slots=True)
class Occurrence:
    """One place a name is written: its span, the symbol it names, and whether it declares it."""

    span: Span
    key: SymbolKey
    decl: bool


class Index:
    """The symbols of a knowledge base and where each is written, searchable by position."""

    def __init__(self) -> None:
        self.symbols: dict[SymbolKey, Symbol] = {}
        self.occurrences: list[Occurrence] = []
        #: import string span -> the imported file it names (as the loader found it)
        self.imports: list[tuple[Span, str]] = []
        self._parent: dict[SymbolKey, SymbolKey] = {}
        self._by_file: dict[str, list[tuple[int, int, Occurrence]]] | None = None

    # -- building
    def declare(self, key: SymbolKey, name: ast.Name) -> None:
        """Record the declaration of ``key`` at ``name`` (the first declaration wins)."""
        self.symbols.setdefault(key, Symbol(key, name.span))
        self.occurrences.append(Occurrence(name.span, key, True))

    def refer(self, key: SymbolKey, name: ast.Name | Span) -> None:
        """Record a use of ``key`` at ``name``."""
        span = name if isinstance(name, Span) else name.span
        self.occurrences.append(Occurrence(span, key, False))

    def link(self, a: SymbolKey, b: SymbolKey) -> None:
        """Put ``a`` and ``b`` into one group: renamed together."""
        ra, rb = self._root(a), self._root(b)
        if ra != rb:
            self._parent[max(ra, rb)] = min(ra, rb)

    def _root(self, key: SymbolKey) -> SymbolKey:
        while key in self._parent:
            key = self._parent[key]
        return key

    # -- queries
    def group(self, key: SymbolKey) -> set[SymbolKey]:
        """The symbols renamed together with ``key`` (itself included)."""
        root = self._root(key)
        keys = {k for k in [*self.symbols, *self._parent] if self._root(k) == root}
        return keys | {key}

    def at(self, file: str, line: int, column: int) -> Occurrence | None:
        """The occurrence under the 1-based ``line:column`` of ``file`` (or just before it)."""
        if self._by_file is None:
            by_file: dict[str, list[tuple[int, int, Occurrence]]] = {}
            for occ in self.occurrences:
                by_file.setdefault(occ.span.file, []).append((occ.span.line, occ.span.column, occ))
            for entries in by_file.values():
                entries.sort(key=lambda e: (e[0], e[1]))
            self._by_file = by_file
        entries = self._by_file.get(file, [])
        i = bisect.bisect_right(entries, (line, column), key=lambda e: (e[0], e[1]))
        for _, _, occ in reversed(entries[max(i - 2, 0) : i]):
            s = occ.span
            if s.line == line and s.column <= column <= s.end_column:
                return occ
        return None


def build_index(modules: Iterable[ast.Module], table: Table) -> Index:
    """Index every name of ``modules`` with the meaning ``table`` gives it."""
    index = Index()
    modules = list(modules)
    for module in modules:
        for item in module.items:
            _Walker(index, table).item(item)
    for cname, info in table.concepts.items():
        for m in info.node.members:
            for name in _declared(m):
                for p in info.parents:
                    base = table.concepts[p].slots.get(name.text)
                    if base is not None:
                        index.link(
                            (NameKind.ROLE, cname, name.text),
                            (NameKind.ROLE, base.owner, name.text),
                        )
    return index


def _declared(m: ast.Member) -> tuple[ast.Name, ...]:
    """The role or attribute names a member declares."""
    if isinstance(m, ast.Part):
        return m.roles
    if isinstance(m, ast.ConOf):
        return (m.role,)
    if isinstance(m, ast.Attribute):
        return (m.name,)
    return ()


class _Walker:
    """Records the names of one declaration; ``owner`` is the concept whose roles paths name."""

    def __init__(self, index: Index, table: Table) -> None:
        self.index = index
        self.table = table
        self.owner: str | None = None
        self.template: ast.Template | None = None

    def item(self, item: ast.Item) -> None:
        index, table = self.index, self.table
        if isinstance(item, ast.Layers):
            for n in item.names:
                index.declare((NameKind.LAYER, n.text), n)
        elif isinstance(item, ast.Template):
            self.template_decl(item)
        elif isinstance(item, ast.Concept):
            self.concept(item)
        elif isinstance(item, ast.Instance):
            index.declare((NameKind.INSTANCE, item.name.text), item.name)
            self.concept_ref(item.concept)
            info = table.concepts.get(item.concept.text)
            for b in item.bindings:
                slot = info.slots.get(b.role.text) if info is not None else None
                if slot is not None:
                    index.refer((NameKind.ROLE, slot.owner, b.role.text), b.role)
                self.value(b.value)

    def concept_ref(self, name: ast.Name) -> None:
        if name.text in self.table.concepts:
            self.index.refer((NameKind.CONCEPT, name.text), name)

    def template_decl(self, t: ast.Template) -> None:
        self.template = t
        self.index.declare((NameKind.TEMPLATE, t.name.text), t.name)
        for p in t.params:
            self.index.declare((NameKind.PARAM, t.name.text, p.name.text), p.name)
            self.concept_ref(p.type)
            if p.default is not None:
                self.expr(p.default)
        for r in t.body:
            self.relation(r)
        self.template = None

    def concept(self, c: ast.Concept) -> None:
        index = self.index
        cname = c.name.text
        index.declare((NameKind.CONCEPT, cname), c.name)
        if c.layer is not None and c.layer.text in self.table.layer_index:
            index.refer((NameKind.LAYER, c.layer.text), c.layer)
        for p in c.parents:
            self.concept_ref(p)
        known = cname in self.table.concepts and self.table.concepts[cname].node is c
        self.owner = cname if known else None
        for m in c.members:
            for name in _declared(m):
                index.declare((NameKind.ROLE, cname, name.text), name)
            self.member(m)
        self.owner = None

    def member(self, m: ast.Member) -> None:
        if isinstance(m, ast.Part | ast.ConOf):
            self.concept_ref(m.concept)
        elif isinstance(m, ast.Attribute):
            if m.range is not None:
                self.expr(m.range.low)
                self.expr(m.range.high)
            if m.default is not None:
                self.expr(m.default)
            if m.measure is not None:
                self.expr(m.measure.call)
                if m.measure.tolerance is not None:
                    self.expr(m.measure.tolerance)
        elif isinstance(m, ast.Adjacency):
            for group in m.groups:
                for path in group:
                    self.path(path)
        elif isinstance(m, ast.Constraint | ast.Measure):
            self.relation(m.relation)
        elif isinstance(m, ast.Frame):
            self.path(m.anchor)
        elif isinstance(m, ast.Orient):
            for path in m.parts:
                self.path(path)
            if m.tilt is not None:
                self.expr(m.tilt)
        elif isinstance(m, ast.Unseen):
            for path in m.parts:
                self.path(path)
            pl = m.placement
            for e in (pl.ref, pl.value, pl.line):
                if e is not None:
                    self.expr(e)
        elif isinstance(m, ast.Attach):
            self.path(m.part)
            for path in m.planes:
                self.path(path)
        elif isinstance(m, ast.When):
            self.path(m.condition.role)
            for name in m.condition.concepts:
                self.concept_ref(name)
            for inner in m.members:
                self.member(inner)

    def relation(self, r: ast.Relation) -> None:
        body = r.body
        if isinstance(body, ast.Comparison):
            self.expr(body.lhs)
            self.expr(body.rhs)
        else:
            self.expr(body)
        for q in (r.tolerance, r.weight, r.reject):
            if q is not None:
                self.expr(q)

    def value(self, v: ast.Value) -> None:
        if isinstance(v, ast.ListExpr):
            for item in v.items:
                self.value(item)
        elif isinstance(v, ast.Path):
            if v.is_simple and v.dotted in self.table.instances:
                self.index.refer((NameKind.INSTANCE, v.dotted), v.parts[0])
        elif isinstance(v, ast.Call):
            self.expr(v)

    def expr(self, e: ast.Expr) -> None:
        if isinstance(e, ast.Call):
            if e.func.text in self.table.templates:
                self.index.refer((NameKind.TEMPLATE, e.func.text), e.func)
            for a in e.args:
                self.expr(a)
        elif isinstance(e, ast.Path):
            self.path(e)

    def path(self, path: ast.Path) -> None:
        parts = path.parts
        if self.template is not None:
            t = self.template
            param = next((p for p in t.params if p.name.text == parts[0].text), None)
            if param is None:
                return
            self.index.refer((NameKind.PARAM, t.name.text, param.name.text), parts[0])
            if len(parts) > 1 and param.type.text in self.table.concepts:
                self.role_path(param.type.text, parts[1:])
            return
        if self.owner is not None:
            self.role_path(self.owner, parts)

    def role_path(self, owner: str, parts: tuple[ast.Name, ...]) -> None:
        """Each part of a role path relative to the concept ``owner``."""
        table, index = self.table, self.index
        for i, name in enumerate(parts):
            if name.text == "self":
                continue
            prefix = parts[: i + 1]
            res = table.resolve_path(owner, ast.Path(prefix, name.span))
            if not isinstance(res, PathRes) or res.slot is None:
                return
            key: SymbolKey = (NameKind.ROLE, res.slot.owner, name.text)
            index.refer(key, name)
            before = ".".join(p.text for p in parts[:i])
            if res.requires and res.requires[-1][0] == before:
                for cand in res.requires[-1][1]:
                    other = table.concepts[cand].slots.get(name.text)
                    if other is not None:
                        index.link(key, (NameKind.ROLE, other.owner, name.text))
