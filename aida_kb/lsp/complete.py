"""Completion: what may be written at the cursor, from the words before it on its line and the
declaration around it.

A line being typed rarely parses, so the context is read from the text before the cursor
(``part roof: `` wants a concept, ``roof.`` the members of the roof's concept, ``90 `` a
unit); the names offered come from the last analysis (the resolved table). The keyword lists
are the grammar's (grammars/kb.lark; a test checks that every word here is a keyword there).
"""

from __future__ import annotations

import os
import re

from lsprotocol import types

from aida_kb.dsl import ast
from aida_kb.kb.relations import PRIMITIVES
from aida_kb.kb.resolve import VALUE_TYPES, PathRes, SlotKind
from aida_kb.kb.shape import MEASURES
from aida_kb.lsp.analysis import Analysis
from aida_kb.lsp.features import slot_text
from aida_kb.lsp.index import NameKind

__all__ = [
    "DECLARATION_KEYWORDS",
    "MEMBER_KEYWORDS",
    "NEXT_KEYWORDS",
    "QUALIFIER_KEYWORDS",
    "completions",
    "enclosing",
]

#: Words that start a declaration at the top level of a file.
DECLARATION_KEYWORDS = ("layers", "import", "template", "abstract", "concept", "instance")
#: Words that start a member of a concept.
MEMBER_KEYWORDS = (
    "part",
    "optional",
    "con-of",
    "attribute",
    "adjacent",
    "constraint",
    "measure",
    "frame",
    "orient",
    "unseen",
    "attach",
    "touching",
)
#: Words that qualify a relation.
QUALIFIER_KEYWORDS = ("weight", "reject")
_NAME = r"[A-Za-z_]\w*"
#: The words that may follow what the line holds so far: (pattern of the text before the
#: cursor, the keywords offered). The grammar (grammars/kb.lark) in small.
NEXT_KEYWORDS: tuple[tuple[str, tuple[str, ...]], ...] = (
    (rf"^\s*(?:abstract\s+)?concept\s+{_NAME}\s+\w*$", ("in", "is-a")),
    (rf"^\s*instance\s+{_NAME}\s+\w*$", ("of",)),
    (r"^\s*adjacent\s+\w*$", ("ring", "pairs")),
    (r"^\s*frame\s+\w*$", ("from",)),
    (r"^\s*unseen\s[^:]*:\s*\w*$", ("mirror", "at", "reach")),
    (r"\bmirror\s+[\w.]+\s+\w*$", ("about",)),
    (r"^\s*attach\s[^:]*:\s*\w+\s+\w*$", ("in", "against")),
    (r"^\s*orient\s[^:]*:\s*\w+\s+\w*$", ("tilted",)),
    (r"\btilted\s+\w*$", ("by",)),
    (r"\breject\s+\w*$", ("above",)),
    (rf"^\s*touching\s+{_NAME}\s+\w*$", ("share",)),
    (rf"^\s*attribute\s+{_NAME}\s*:\s*{_NAME}\s+\w*$", ("in", "is")),
)

_COMMENT = re.compile(r"//[^\n]*|/\*.*?(?:\*/|$)", re.S)
_STRING = re.compile(r'"(?:[^"\\\n]|\\.)*"?')
_HEADER = re.compile(
    r"(?:^|\n)[ \t]*(?:(?:abstract[ \t]+)?(concept)|(template)|(instance))[ \t]+"
    r"([A-Za-z_]\w*)(?:[ \t]+of[ \t]+([A-Za-z_]\w*))?"
)


def enclosing(text: str) -> tuple[NameKind, str, str | None] | None:
    """The declaration whose body the end of ``text`` is in: ``(kind, name, concept)`` for
    ``concept``/``template``/``instance`` (``concept`` is an instance's), or None at top level."""
    clean = _STRING.sub(lambda m: " " * len(m.group()), _COMMENT.sub(" ", text))
    found = None
    for m in _HEADER.finditer(clean):
        found = m
    if found is None:
        return None
    rest = clean[found.end() :]
    depth = 0
    opened = False
    for ch in rest:
        if ch == "{":
            depth += 1
            opened = True
        elif ch == "}":
            depth -= 1
            if depth <= 0 and opened:
                return None
    if not opened:
        return None
    kind = (
        NameKind.CONCEPT
        if found.group(1)
        else NameKind.TEMPLATE
        if found.group(2)
        else NameKind.INSTANCE
    )
    return kind, found.group(4), found.group(5)


def _item(
    label: str,
    kind: types.CompletionItemKind,
    detail: str | None = None,
    doc: str | None = None,
) -> types.CompletionItem:
    return types.CompletionItem(
        label=label,
        kind=kind,
        detail=detail,
        documentation=types.MarkupContent(types.MarkupKind.Markdown, doc) if doc else None,
    )


K = types.CompletionItemKind


def _concepts(a: Analysis) -> list[types.CompletionItem]:
    return [
        _item(
            c,
            K.Class,
            f"{'abstract ' if i.node.abstract else ''}concept in {i.layer or '?'}",
            i.node.doc,
        )
        for c, i in sorted(a.table.concepts.items())
    ]


def _value_types() -> list[types.CompletionItem]:
    return [
        _item(t, K.TypeParameter, f"value type ({unit or 'no unit'})")
        for t, unit in VALUE_TYPES.items()
    ]


def _keywords(words: tuple[str, ...]) -> list[types.CompletionItem]:
    return [_item(w, K.Keyword) for w in words]


def _members(a: Analysis, concept: str) -> list[types.CompletionItem]:
    """The roles and attributes of ``concept``, then those only its specialisations have."""
    table = a.table
    info = table.concepts.get(concept)
    if info is None:
        return []
    out = []
    seen = set()
    for name, slot in sorted(info.slots.items()):
        seen.add(name)
        kind = K.Property if slot.kind == SlotKind.ATTRIBUTE else K.Field
        where = "" if slot.owner == concept else f" (from {slot.owner})"
        out.append(_item(name, kind, slot_text(slot) + where))
    for d in table.descendants(concept):
        for name, slot in sorted(table.concepts[d].slots.items()):
            if name not in seen:
                seen.add(name)
                kind = K.Property if slot.kind == SlotKind.ATTRIBUTE else K.Field
                out.append(_item(name, kind, f"{slot_text(slot)} (when it is a {slot.owner})"))
    return out


def _calls(a: Analysis) -> list[types.CompletionItem]:
    out = []
    for name, t in sorted(a.table.templates.items()):
        params = ", ".join(f"{p.name.text}: {p.type.text}" for p in t.params)
        out.append(_item(name, K.Function, f"template {name}({params})", t.doc))
    out.extend(_item(p, K.Function, "primitive relation") for p in PRIMITIVES)
    return out


#: At most this many files are offered after ``import "`` (a folder's tree can be large).
MAX_IMPORT_CHOICES = 200


def _importable(a: Analysis) -> list[types.CompletionItem]:
    """The .kb files below the document's folder, as an import names them (relative, ``/``)."""
    if not os.path.isabs(a.path):
        return []
    base = os.path.dirname(a.path)
    out: list[types.CompletionItem] = []
    for root, dirs, names in os.walk(base):
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))
        for n in sorted(names):
            path = os.path.join(root, n)
            if n.endswith(".kb") and path != a.path:
                rel = os.path.relpath(path, base).replace(os.sep, "/")
                out.append(_item(rel, K.File, "import"))
                if len(out) >= MAX_IMPORT_CHOICES:
                    return out
    return out


def _path_members(
    a: Analysis, where: tuple[NameKind, str, str | None] | None, prefix: list[str]
) -> list[types.CompletionItem]:
    """Members after ``prefix.`` in the declaration ``where``."""
    if where is None:
        return []
    kind, name, _ = where
    owner: str | None = None
    if kind == NameKind.CONCEPT:
        owner = name
    elif kind == NameKind.TEMPLATE:
        t = a.table.templates.get(name)
        p = next((p for p in t.params if p.name.text == prefix[0]), None) if t else None
        if p is None:
            return []
        owner, prefix = p.type.text, prefix[1:]
    if owner is None or owner not in a.table.concepts:
        return []
    target: str | None = owner
    if prefix:
        from aida_kb.diagnostics.core import Span

        dummy = Span("<completion>", 1, 1, 1, 1)
        path = ast.Path(tuple(ast.Name(p, dummy) for p in prefix), dummy)
        res = a.table.resolve_path(owner, path)
        target = res.concept if isinstance(res, PathRes) else None
    return _members(a, target) if target is not None else []


def _knows(a: Analysis, where: tuple[NameKind, str, str | None] | None) -> bool:
    if where is None:
        return True
    kind, name, _ = where
    if kind == NameKind.CONCEPT:
        return name in a.table.concepts
    return kind != NameKind.TEMPLATE or name in a.table.templates


def completions(a: Analysis, text: str, position: types.Position) -> list[types.CompletionItem]:
    """What may be written at ``position`` of ``text`` (the document as the editor has it).

    The line being typed often breaks its declaration (a syntax error drops it from the
    table): then the names come from the text compiled without that line.
    """
    lines = text.split("\n")
    line = lines[position.line] if position.line < len(lines) else ""
    before_line = line[: position.character]
    before = "\n".join([*lines[: position.line], before_line])
    where = enclosing(before)
    if not _knows(a, where):
        without = "\n".join([*lines[: position.line], "", *lines[position.line + 1 :]])
        a = Analysis(a.uri, without, a.search_paths)
    s = before_line
    if re.search(r"(?:^|\s)import\s+\"[^\"]*$", s):
        return _importable(a)
    if "//" in s:
        return []
    if re.search(rf"^\s*(?:abstract\s+)?concept\s+{_NAME}\s+in\s+\w*$", s):
        return [_item(n, K.EnumMember, "layer") for n in a.table.layers]
    if re.search(r"is-a\s+(?:\w+\s*,\s*)*\w*$", s):
        return _concepts(a)
    if re.search(rf"^\s*instance\s+{_NAME}\s+of\s+\w*$", s):
        return _concepts(a)
    if re.search(rf"^\s*(?:optional\s+)?part\s+{_NAME}(?:\s*,\s*{_NAME})*\s*:\s*\w*$", s):
        return _concepts(a)
    if re.search(rf"^\s*con-of\s+{_NAME}\s*:\s*\w*$", s):
        return _concepts(a)
    if re.search(rf"^\s*attribute\s+{_NAME}\s*:\s*\w*$", s):
        return _value_types()
    if re.search(rf"^\s*template\s+{_NAME}\s*\(.*\b{_NAME}\s*:\s*\w*$", s):
        return _value_types() + _concepts(a)
    for pattern, words in NEXT_KEYWORDS:
        if re.search(pattern, s):
            return _keywords(words)
    if re.search(r"^\s*(?:optional\s+)?(?:part|con-of)\b.*\[[\d.\s]*$", s):
        return []  # a cardinality: numbers, not units
    if re.search(r"(?:^|[^\w.])-?\d+(?:\.\d+)?(?:[eE][+-]?\d+)?\s*[A-Za-z]*$", s):
        return [_item(u, K.Unit, "unit") for u in ast.UNITS]
    if re.search(r"^\s*(?:orient|attach)\s[^:]*:\s*\w*$", s):
        return _keywords(ast.DIRECTIONS)
    dotted = re.search(rf"({_NAME}(?:\.{_NAME})*)\.\w*$", s)
    if dotted:
        return _path_members(a, where, dotted.group(1).split("."))
    if re.search(r"\bis\s+\w*$", s) and re.match(r"^\s*attribute\b", s):
        return [_item(m, K.Function, f"measure ({kind})") for m, (_, kind) in MEASURES.items()]
    at_start = re.fullmatch(r"\s*[\w-]*", s) is not None
    if where is None:
        return _keywords(DECLARATION_KEYWORDS) if at_start else []
    kind, name, concept = where
    if kind == NameKind.INSTANCE:
        if at_start and concept is not None:
            return _members(a, concept)
        return [_item(i, K.Variable, "instance") for i in sorted(a.table.instances)]
    if kind == NameKind.TEMPLATE:
        t = a.table.templates.get(name)
        params = [_item(p.name.text, K.Variable, p.type.text) for p in t.params] if t else []
        return params + _calls(a) + _keywords(QUALIFIER_KEYWORDS)
    if at_start:
        return _keywords(MEMBER_KEYWORDS)
    roles = [*_members(a, name), _item("self", K.Keyword, "the concept itself")]
    return roles + _calls(a) + _keywords(QUALIFIER_KEYWORDS)
