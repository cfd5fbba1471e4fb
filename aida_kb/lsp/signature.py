"""Signature help: inside ``perpendicular(front, |`` the template's parameters, the one being
written marked; likewise for the primitive relations and the measures of an attribute.
"""

from __future__ import annotations

import re

from lsprotocol import types

from aida_kb.kb.shape import MEASURES
from aida_kb.lsp.analysis import Analysis

__all__ = ["PRIMITIVE_SIGNATURES", "signature_help"]

#: The primitive relations of the language (docs/language.md §4.2): parameters and meaning.
PRIMITIVE_SIGNATURES: dict[str, tuple[tuple[str, ...], str]] = {
    "angle": (("a", "b"), "the angle at which the planes a and b meet: `angle(a, b) == VALUE`"),
    "parallel": (("a", "b"), "the planes (or the edges) a and b are parallel"),
    "edge": (
        ("a", "b"),
        "the edge where the planes a and b meet; as a measurement `edge(edge(a, b))`",
    ),
    "position": (("p",), "measurement: the evidence region of p lies on its plane"),
}
_CALLEE = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)\s*$")


def _open_call(before: str) -> tuple[str, int, str] | None:
    """The name of the innermost call left open at the end of ``before``, how many of its
    arguments are complete (its top-level commas), and the text before the name."""
    depth = 0
    commas = 0
    for i in range(len(before) - 1, -1, -1):
        ch = before[i]
        if ch == ")":
            depth += 1
        elif ch == "(":
            if depth == 0:
                m = _CALLEE.search(before[:i])
                return (m.group(1), commas, before[: m.start()]) if m else None
            depth -= 1
        elif ch == "," and depth == 0:
            commas += 1
    return None


def _signature(label_name: str, params: list[str], doc: str | None) -> types.SignatureInformation:
    label = f"{label_name}({', '.join(params)})"
    infos = []
    at = len(label_name) + 1
    for p in params:
        infos.append(types.ParameterInformation(label=(at, at + len(p))))
        at += len(p) + 2
    return types.SignatureInformation(
        label=label,
        documentation=types.MarkupContent(types.MarkupKind.Markdown, doc) if doc else None,
        parameters=infos,
    )


def signature_help(a: Analysis, text: str, position: types.Position) -> types.SignatureHelp | None:
    """The signature of the call the cursor is in, with the parameter being written."""
    lines = text.split("\n")
    line = lines[position.line] if position.line < len(lines) else ""
    before = line[: position.character].split("//", 1)[0]
    found = _open_call(before)
    if found is None:
        return None
    name, active, head = found
    template = a.table.templates.get(name)
    if template is not None:
        params = [
            f"{p.name.text}: {p.type.text}" + (f" = {p.default}" if p.default is not None else "")
            for p in template.params
        ]
        sig = _signature(name, params, template.doc)
    elif name in MEASURES and re.search(r"\bis\s+$", head):
        arity, dimension = MEASURES[name]
        sig = _signature(name, ["a", "b"][:arity], f"measure: gives {dimension}")
    elif name in PRIMITIVE_SIGNATURES:
        params_, doc = PRIMITIVE_SIGNATURES[name]
        sig = _signature(name, list(params_), doc)
    else:
        return None
    count = len(sig.parameters or [])
    return types.SignatureHelp(
        signatures=[sig], active_signature=0, active_parameter=min(active, max(count - 1, 0))
    )
