"""What the server answers, computed from an `Analysis`: hover, definition, references, rename,
the outline and quick fixes. Completion lives in `aida_kb.lsp.complete`.

Each function takes the analysis of the document the request is about (and, for references
and rename, the analyses of the other open documents) and returns lsprotocol values.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterable, Sequence

from lsprotocol import types

from aida_kb.diagnostics.core import Span
from aida_kb.diagnostics.explain import explanation
from aida_kb.dsl import ast
from aida_kb.kb.resolve import Slot
from aida_kb.lsp.analysis import Analysis
from aida_kb.lsp.diagnose import DID_YOU_MEAN, explain_href
from aida_kb.lsp.index import NameKind, Occurrence, SymbolKey

__all__ = [
    "NAME",
    "RenameError",
    "code_actions",
    "definition",
    "document_symbols",
    "hover",
    "occurrence_at",
    "prepare_rename",
    "references",
    "rename",
    "slot_text",
    "workspace_symbols",
]

#: A name of the language (the grammar's NAME terminal).
NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
#: Words that cannot be a new name: the declaration keywords start error recovery, and
#: ``self`` names the concept itself in a path (docs/language.md §2).
RESERVED = frozenset(
    {"concept", "abstract", "template", "instance", "import", "layers", "self", "part", "is"}
)
_UNIT_WORDS = {
    "angle": f"rad; write {' or '.join(ast.ANGLE_UNITS)}",
    "length": f"m; write {', '.join(ast.LENGTH_UNITS)}",
    "number": "none (a plain number)",
}


class RenameError(ValueError):
    """A rename that cannot be done: the message says why."""


def occurrence_at(a: Analysis, uri: str, position: types.Position) -> Occurrence | None:
    """The indexed name at ``position`` of the document ``uri``."""
    file = a.file_of(uri)
    if file is None:
        return None
    column = a.lines(file).column(position)
    return a.index.at(file, position.line + 1, column)


def _location(a: Analysis, span: Span) -> types.Location:
    return types.Location(a.uri_of(span.file), a.lines(span.file).range(span))


def snippet(a: Analysis, span: Span) -> str:
    """The source text of ``span`` (its lines joined by spaces when it runs over several)."""
    lines = a.lines(span.file).lines
    if span.line == span.end_line:
        return lines[span.line - 1][span.column - 1 : span.end_column - 1]
    first = lines[span.line - 1][span.column - 1 :]
    middle = lines[span.line : span.end_line - 1]
    last = lines[span.end_line - 1][: span.end_column - 1] if span.end_line <= len(lines) else ""
    return " ".join(t.strip() for t in [first, *middle, last] if t.strip())


# ---- hover ----------------------------------------------------------------------------------
def slot_text(slot: Slot) -> str:
    """One member as a declaration of its own: ``part front: Wall``, ``attribute tilt: angle``."""
    node = slot.node
    if isinstance(node, ast.Attribute):
        text = f"attribute {slot.name.text}: {node.type.text}"
        if node.range is not None:
            text += f" in [{node.range.low}, {node.range.high}]"
        if node.default is not None:
            text += f" = {node.default}"
        if node.measure is not None:
            text += f" is {node.measure.call}"
        return text
    card = f" {node.cardinality}" if node.cardinality is not None else ""
    if isinstance(node, ast.Part):
        optional = "optional " if node.optional else ""
        return f"{optional}part {slot.name.text}: {node.concept.text}{card}"
    return f"con-of {slot.name.text}: {node.concept.text}{card}"


def _concept_hover(a: Analysis, name: str) -> str:
    info = a.table.concepts.get(name)
    if info is None:
        return f"concept **{name}**"
    node = info.node
    head = f"{'abstract ' if node.abstract else ''}concept {name}"
    if node.layer is not None:
        head += f" in {node.layer.text}"
    if node.parents:
        head += " is-a " + ", ".join(p.text for p in node.parents)
    out = [f"```kb\n{head}\n```"]
    if node.doc:
        out.append(node.doc)
    facts = [f"layer: **{info.layer or '?'}**"]
    ancestors = sorted(a.table.ancestors(name) - {name})
    if ancestors:
        facts.append("is-a (transitively): " + ", ".join(ancestors))
    specs = a.table.descendants(name)
    if specs:
        facts.append("specialisations: " + ", ".join(specs))
    out.append(" · ".join(facts))
    if info.slots:
        rows = []
        for slot in info.slots.values():
            where = "own" if slot.owner == name else f"inherited from **{slot.owner}**"
            rows.append(f"- `{slot_text(slot)}` — {where}")
        out.append("members:\n" + "\n".join(rows))
    inherited_rules = [r for r in info.rules if r.owner != name]
    if inherited_rules:
        owners = sorted({r.owner for r in inherited_rules})
        out.append(
            f"{len(inherited_rules)} constraints and measures inherited from " + ", ".join(owners)
        )
    return "\n\n".join(out)


def _template_signature(t: ast.Template) -> str:
    params = ", ".join(
        f"{p.name.text}: {p.type.text}" + (f" = {p.default}" if p.default is not None else "")
        for p in t.params
    )
    return f"template {t.name.text}({params})"


def _role_hover(a: Analysis, key: SymbolKey) -> str:
    _, owner, name = key
    info = a.table.concepts.get(owner)
    slot = info.slots.get(name) if info is not None else None
    if slot is None or slot.owner != owner:
        return f"role **{name}** of {owner}"
    out = [f"```kb\n{slot_text(slot)}\n```", f"declared in concept **{owner}**"]
    node = slot.node
    if isinstance(node, ast.Attribute):
        unit = _UNIT_WORDS.get(node.type.text)
        if unit is not None:
            out.append(f"unit: {unit}")
        if node.range is not None:
            out.append(f"range: [{node.range.low}, {node.range.high}]")
        if node.default is not None:
            out.append(f"default: {node.default}")
        if node.measure is not None:
            out.append(f"measured as `{node.measure.call}`")
    else:
        low, high = slot.min, "*" if slot.max is None else slot.max
        filler = a.table.concepts.get(slot.concept or "")
        layer = f" (layer {filler.layer})" if filler is not None and filler.layer else ""
        out.append(f"filled by **{slot.concept}**{layer}, [{low}..{high}]")
        if filler is not None and filler.node.doc:
            out.append(filler.node.doc)
    overriding = sorted(
        c
        for c, ci in a.table.concepts.items()
        if c != owner and name in ci.slots and ci.slots[name].owner == c and a.table.is_a(c, owner)
    )
    if overriding:
        out.append("overridden in " + ", ".join(overriding))
    return "\n\n".join(out)


def _symbol_hover(a: Analysis, key: SymbolKey) -> str:
    kind = key[0]
    if kind == NameKind.CONCEPT:
        return _concept_hover(a, key[1])
    if kind == NameKind.TEMPLATE:
        t = a.table.templates.get(key[1])
        if t is None:
            return f"template **{key[1]}**"
        text = f"```kb\n{_template_signature(t)}\n```"
        return text + (f"\n\n{t.doc}" if t.doc else "")
    if kind == NameKind.ROLE:
        return _role_hover(a, key)
    if kind == NameKind.PARAM:
        t = a.table.templates.get(key[1])
        p = next((p for p in t.params if p.name.text == key[2]), None) if t else None
        if t is None or p is None:
            return f"parameter **{key[2]}**"
        unit = _UNIT_WORDS.get(p.type.text)
        text = (
            f"```kb\n{p.name.text}: {p.type.text}\n```\n\nparameter of `{_template_signature(t)}`"
        )
        return text + (f"\n\nunit: {unit}" if unit else "")
    if kind == NameKind.LAYER:
        layers = a.table.layers
        members = sorted(c for c, i in a.table.concepts.items() if i.layer == key[1])
        where = f"{layers.index(key[1]) + 1} of {len(layers)}" if key[1] in layers else "?"
        text = f"layer **{key[1]}** ({where}: {' > '.join(layers)})"
        return text + (f"\n\nconcepts: {', '.join(members)}" if members else "")
    inst = a.table.instances.get(key[1])
    if inst is None:
        return f"instance **{key[1]}**"
    text = f"```kb\ninstance {key[1]} of {inst.concept.text}\n```"
    return text + (f"\n\n{inst.doc}" if inst.doc else "")


def _diagnostic_hover(a: Analysis, file: str, line: int, column: int) -> list[str]:
    out = []
    for d in a.diagnostics:
        s = d.span
        if s.file != file or not (s.line <= line <= s.end_line):
            continue
        if (line == s.line and column < s.column) or (line == s.end_line and column > s.end_column):
            continue
        ex = explanation(d.code)
        title = f": {ex.title}" if ex is not None else ""
        href = explain_href(d.code)
        link = f"[{d.code}]({href})" if href else d.code
        out.append(f"{link}{title} — `aida-kb explain {d.code}`")
    return out


def _builtin_hover(a: Analysis, line: str, column: int) -> str | None:
    """A primitive relation or an attribute's measure under ``column`` (1-based) of ``line``."""
    from aida_kb.kb.shape import MEASURES
    from aida_kb.lsp.signature import PRIMITIVE_SIGNATURES

    for m in NAME.finditer(line):
        if not m.start() < column <= m.end() + 1 or not line[m.end() :].lstrip().startswith("("):
            continue
        word = m.group()
        if word in a.table.templates:
            return None
        if word in MEASURES and re.search(r"\bis\s+$", line[: m.start()]):
            arity, dimension = MEASURES[word]
            args = ", ".join(["a", "b"][:arity])
            return f"```kb\n{word}({args})\n```\n\nmeasure of an attribute: gives {dimension}"
        if word in PRIMITIVE_SIGNATURES:
            params, meaning = PRIMITIVE_SIGNATURES[word]
            return f"```kb\n{word}({', '.join(params)})\n```\n\nprimitive relation: {meaning}"
    return None


def hover(a: Analysis, uri: str, position: types.Position) -> types.Hover | None:
    """The hover at ``position``: the symbol's declaration, doc and facts; explained codes."""
    file = a.file_of(uri)
    if file is None:
        return None
    column = a.lines(file).column(position)
    occ = a.index.at(file, position.line + 1, column)
    parts = []
    if occ is not None:
        parts.append(_symbol_hover(a, occ.key))
    else:
        builtin = _builtin_hover(a, a.lines(file).line(position.line), column)
        if builtin is not None:
            parts.append(builtin)
    parts.extend(_diagnostic_hover(a, file, position.line + 1, column))
    if not parts:
        return None
    rng = a.lines(file).range(occ.span) if occ is not None else None
    return types.Hover(
        types.MarkupContent(types.MarkupKind.Markdown, "\n\n---\n\n".join(parts)), rng
    )


# ---- navigation -------------------------------------------------------------------------------
def definition(a: Analysis, uri: str, position: types.Position) -> list[types.Location]:
    """Where the name at ``position`` is declared; an import string leads to its file."""
    occ = occurrence_at(a, uri, position)
    if occ is not None:
        sym = a.index.symbols.get(occ.key)
        return [_location(a, sym.decl)] if sym is not None else []
    file = a.file_of(uri)
    if file is None:
        return []
    line, column = position.line + 1, a.lines(file).column(position)
    for m in a.modules:
        if m.file != file:
            continue
        for imp in m.imports:
            s = imp.path.span
            if s.line == line and s.column <= column <= s.end_column:
                target = _imported(a, m.file, imp)
                if target is not None:
                    start = types.Position(0, 0)
                    return [types.Location(a.uri_of(target), types.Range(start, start))]
    return []


def _imported(a: Analysis, importer: str, imp: ast.Import) -> str | None:
    target = os.path.normpath(os.path.join(os.path.dirname(importer), imp.path.value))
    return target if target in a.sources else None


#: An occurrence and the analysis it was found in.
Located = tuple[Analysis, Occurrence]


def _same_symbol(a: Analysis, b: Analysis, key: SymbolKey) -> bool:
    """True when ``b`` declares ``key`` at the same place ``a`` does (the same knowledge base)."""
    sa, sb = a.index.symbols.get(key), b.index.symbols.get(key)
    return sa is not None and sb is not None and sa.decl == sb.decl


def _all_occurrences(a: Analysis, others: Iterable[Analysis], key: SymbolKey) -> list[Located]:
    """Every occurrence of ``key`` and the symbols linked to it in any of the analyses of the
    same knowledge base; each file's from the analysis that has its text as the editor does
    (the one whose root it is, else the first that imports it)."""
    relevant = [a, *(b for b in others if _same_symbol(a, b, key))]
    keys = {key}
    while True:  # a root that sees more of the net may link more roles
        grown = {k for b in relevant for known in keys for k in b.index.group(known)}
        if grown <= keys:
            break
        keys |= grown
    reader: dict[str, Analysis] = {}
    for b in relevant:
        for file in b.sources:
            if file == b.path or file not in reader:
                reader[file] = b
    found: dict[tuple[str, Span], Located] = {}
    for b in relevant:
        for occ in b.index.occurrences:
            if occ.key in keys and reader.get(occ.span.file) is b:
                found.setdefault((occ.span.file, occ.span), (b, occ))
    return sorted(found.values(), key=lambda e: (e[0].uri_of(e[1].span.file), e[1].span))


def references(
    a: Analysis,
    others: Sequence[Analysis],
    uri: str,
    position: types.Position,
    include_declaration: bool,
) -> list[types.Location]:
    """Every place the name at ``position`` (and the names linked to it) is written: in the
    document, the files it imports, and the other open documents of the same knowledge base."""
    occ = occurrence_at(a, uri, position)
    if occ is None:
        return []
    return [
        _location(b, o.span)
        for b, o in _all_occurrences(a, others, occ.key)
        if include_declaration or not o.decl
    ]


# ---- rename -----------------------------------------------------------------------------------
def prepare_rename(
    a: Analysis, uri: str, position: types.Position
) -> types.PrepareRenamePlaceholder | None:
    """The name under the cursor and its range, when it can be renamed."""
    occ = occurrence_at(a, uri, position)
    if occ is None:
        return None
    file = occ.span.file
    return types.PrepareRenamePlaceholder(
        range=a.lines(file).range(occ.span), placeholder=snippet(a, occ.span)
    )


def _check_new_name(a: Analysis, key: SymbolKey, new: str) -> None:
    if not NAME.fullmatch(new):
        raise RenameError(f"'{new}' is not a name: a letter or '_', then letters, digits, '_'")
    if new in RESERVED:
        raise RenameError(f"'{new}' is a keyword of the language")
    kind = key[0]
    named = (NameKind.CONCEPT, NameKind.TEMPLATE, NameKind.INSTANCE, NameKind.LAYER)
    if kind in named and (kind, new) in a.index.symbols:
        raise RenameError(f"a {kind} named '{new}' exists already")
    if kind == NameKind.ROLE:
        for k in a.index.group(key):
            owner = k[1]
            clashing = [
                c
                for c, info in a.table.concepts.items()
                if (c == owner or a.table.is_a(c, owner) or a.table.is_a(owner, c))
                and new in info.slots
            ]
            if clashing:
                raise RenameError(f"concept {clashing[0]} has a member named '{new}' already")
    if kind == NameKind.PARAM:
        t = a.table.templates.get(key[1])
        if t is not None and any(p.name.text == new for p in t.params):
            raise RenameError(f"template {key[1]} has a parameter named '{new}' already")


def rename(
    a: Analysis, others: Sequence[Analysis], uri: str, position: types.Position, new: str
) -> types.WorkspaceEdit | None:
    """Rename the symbol at ``position`` (and the names linked to it) everywhere it is written.

    Raises `RenameError` for a new name that is no name, a keyword, or taken.
    """
    occ = occurrence_at(a, uri, position)
    if occ is None:
        return None
    _check_new_name(a, occ.key, new)
    changes: dict[str, list[types.TextEdit]] = {}
    for b, o in _all_occurrences(a, others, occ.key):
        changes.setdefault(b.uri_of(o.span.file), []).append(
            types.TextEdit(b.lines(o.span.file).range(o.span), new)
        )
    return types.WorkspaceEdit(changes=changes)


# ---- outline ----------------------------------------------------------------------------------
def _symbol(
    a: Analysis,
    name: str,
    kind: types.SymbolKind,
    span: Span,
    name_span: Span,
    detail: str | None = None,
    children: list[types.DocumentSymbol] | None = None,
) -> types.DocumentSymbol:
    lines = a.lines(span.file)
    return types.DocumentSymbol(
        name=name,
        kind=kind,
        range=lines.range(span),
        selection_range=lines.range(name_span),
        detail=detail,
        children=children,
    )


def _member_symbols(a: Analysis, m: ast.Member) -> list[types.DocumentSymbol]:
    K = types.SymbolKind
    if isinstance(m, ast.Part):
        return [
            _symbol(a, r.text, K.Field, m.span, r.span, f"part: {m.concept.text}") for r in m.roles
        ]
    if isinstance(m, ast.ConOf):
        return [_symbol(a, m.role.text, K.Field, m.span, m.role.span, f"con-of: {m.concept.text}")]
    if isinstance(m, ast.Attribute):
        return [_symbol(a, m.name.text, K.Property, m.span, m.name.span, m.type.text)]
    if isinstance(m, ast.Constraint) and m.label is not None:
        return [_symbol(a, m.label.text, K.Event, m.span, m.label.span, "constraint")]
    if isinstance(m, ast.When):  # its labelled constraints are the concept's members
        return [s for x in m.members for s in _member_symbols(a, x)]
    return []


def document_symbols(a: Analysis) -> list[types.DocumentSymbol]:
    """The outline: layers, imports, templates (parameters), concepts (members), instances."""
    module = a.module
    if module is None:
        return []
    K = types.SymbolKind
    out = []
    for item in module.items:
        if isinstance(item, ast.Layers):
            layers = [_symbol(a, n.text, K.EnumMember, n.span, n.span) for n in item.names]
            out.append(_symbol(a, "layers", K.Namespace, item.span, item.span, None, layers))
        elif isinstance(item, ast.Import):
            out.append(_symbol(a, item.path.value, K.Module, item.span, item.path.span, "import"))
        elif isinstance(item, ast.Template):
            params = [
                _symbol(a, p.name.text, K.TypeParameter, p.span, p.name.span, p.type.text)
                for p in item.params
            ]
            detail = _template_signature(item).removeprefix(f"template {item.name.text}")
            out.append(
                _symbol(a, item.name.text, K.Function, item.span, item.name.span, detail, params)
            )
        elif isinstance(item, ast.Concept):
            members = [s for m in item.members for s in _member_symbols(a, m)]
            head = (f"in {item.layer.text} " if item.layer else "") + (
                "is-a " + ", ".join(p.text for p in item.parents) if item.parents else ""
            )
            out.append(
                _symbol(
                    a, item.name.text, K.Class, item.span, item.name.span, head.strip(), members
                )
            )
        else:
            bindings = [
                _symbol(a, b.role.text, K.Field, b.span, b.role.span) for b in item.bindings
            ]
            out.append(
                _symbol(
                    a,
                    item.name.text,
                    K.Object,
                    item.span,
                    item.name.span,
                    f"of {item.concept.text}",
                    bindings,
                )
            )
    return out


# ---- quick fixes ------------------------------------------------------------------------------
def code_actions(
    a: Analysis, uri: str, wanted: types.Range, diagnostics: Sequence[types.Diagnostic]
) -> list[types.CodeAction]:
    """A quick fix for each "did you mean 'X'?" diagnostic in ``wanted``: replace the name."""
    lines = a.lines(a.path) if uri == a.uri else None
    if lines is None:
        return []
    out = []
    for d in diagnostics:
        if not _overlaps(d.range, wanted):
            continue
        replacement = d.data.get("replacement") if isinstance(d.data, dict) else None
        if replacement is None:
            m = DID_YOU_MEAN.search(d.message)
            replacement = m.group(1) if m else None
        if not isinstance(replacement, str) or d.range.start.line != d.range.end.line:
            continue
        line = lines.line(d.range.start.line)
        old = line[d.range.start.character : d.range.end.character]
        if not re.fullmatch(r"[\w.]+", old):
            continue
        out.append(
            types.CodeAction(
                title=f"Replace '{old}' with '{replacement}'",
                kind=types.CodeActionKind.QuickFix,
                diagnostics=[d],
                is_preferred=True,
                edit=types.WorkspaceEdit(changes={uri: [types.TextEdit(d.range, replacement)]}),
            )
        )
    return out


def _overlaps(r: types.Range, s: types.Range) -> bool:
    def key(p: types.Position) -> tuple[int, int]:
        return (p.line, p.character)

    return key(r.start) <= key(s.end) and key(s.start) <= key(r.end)


#: The symbol kinds a workspace search lists (roles and parameters are found from them).
_SEARCHED = {
    NameKind.CONCEPT: types.SymbolKind.Class,
    NameKind.TEMPLATE: types.SymbolKind.Function,
    NameKind.INSTANCE: types.SymbolKind.Object,
}


def workspace_symbols(analyses: Sequence[Analysis], query: str) -> list[types.WorkspaceSymbol]:
    """The concepts, templates and instances whose name contains ``query`` (any case), each
    once however many of the analyses see it, sorted by name."""
    wanted = query.lower()
    found: dict[Span, types.WorkspaceSymbol] = {}
    for a in analyses:
        for sym in a.index.symbols.values():
            kind = _SEARCHED.get(NameKind(sym.kind))
            if kind is None or wanted not in sym.name.lower() or sym.decl in found:
                continue
            found[sym.decl] = types.WorkspaceSymbol(
                name=sym.name,
                kind=kind,
                location=_location(a, sym.decl),
                container_name=os.path.basename(sym.decl.file),
            )
    return sorted(found.values(), key=lambda s: (s.name, s.container_name or ""))
