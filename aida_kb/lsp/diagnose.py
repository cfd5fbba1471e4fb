"""The compiler's diagnostics as the protocol publishes them.

Each keeps its code (``KB100``), with a link to its explanation (``docs/diagnostics.md`` in a
source checkout; ``aida-kb explain CODE`` prints the same text), its hint after the message,
and its related places. A "did you mean 'X'?" hint also travels as ``data`` so that the
quick fix can replace the name. A problem inside an imported file is shown on the import
that leads to it, pointing at the place in that file.
"""

from __future__ import annotations

import os
import re
from collections.abc import Sequence
from pathlib import Path

from lsprotocol import types

from aida_kb.diagnostics.core import Diagnostic, Severity, Span
from aida_kb.lsp.analysis import Analysis
from aida_kb.lsp.convert import uri_of_path

__all__ = ["DID_YOU_MEAN", "SOURCE", "explain_href", "publishable"]

SOURCE = "aida-kb"
#: The compiler's hint for a misspelt name: ``did you mean 'Wall'?``
DID_YOU_MEAN = re.compile(r"did you mean '([A-Za-z_][A-Za-z0-9_.]*)'\?")

_SEVERITY = {
    Severity.ERROR: types.DiagnosticSeverity.Error,
    Severity.WARNING: types.DiagnosticSeverity.Warning,
    Severity.NOTE: types.DiagnosticSeverity.Information,
}
_DOCS = Path(__file__).resolve().parents[2] / "docs" / "diagnostics.md"


def explain_href(code: str) -> str | None:
    """The link to ``code``'s explanation in docs/diagnostics.md, when the docs are present."""
    if not _DOCS.is_file():
        return None
    return f"{uri_of_path(os.fspath(_DOCS))}#{code.lower()}"


def _convert(a: Analysis, d: Diagnostic, where: types.Range, prefix: str) -> types.Diagnostic:
    message = prefix + d.message + (f"\nhint: {d.hint}" if d.hint else "")
    related = [
        types.DiagnosticRelatedInformation(
            types.Location(a.uri_of(span.file), a.lines(span.file).range(span)), text
        )
        for span, text in d.related
        if span.file in a.sources
    ]
    if prefix:
        related.insert(
            0,
            types.DiagnosticRelatedInformation(
                types.Location(a.uri_of(d.span.file), a.lines(d.span.file).range(d.span)),
                d.message,
            ),
        )
    href = explain_href(d.code)
    data: dict[str, str] = {"code": d.code}
    if d.hint:
        data["hint"] = d.hint
        m = DID_YOU_MEAN.search(d.hint)
        if m and not prefix:
            data["replacement"] = m.group(1)
    return types.Diagnostic(
        range=where,
        message=message,
        severity=_SEVERITY[d.severity],
        code=d.code,
        code_description=types.CodeDescription(href) if href else None,
        source=SOURCE,
        related_information=related or None,
        data=data,
    )


def publishable(a: Analysis, context: Sequence[Analysis] = ()) -> list[types.Diagnostic]:
    """The diagnostics to show in the document ``a``: its own, and its imports' problems at the
    import that leads to them. For a library with ``context`` (compiled roots that import it,
    from the same text), its own are those the roots find in it (each once), as lint has them.
    """
    own = a.lines(a.path)
    mine = [d for d in a.diagnostics if d.span.file == a.path]
    if context:
        found: dict[tuple[object, ...], Diagnostic] = {}
        for root in context:
            for d in root.diagnostics:
                if d.span.file == a.path:
                    found.setdefault((d.code, d.span, d.message), d)
        mine = sorted(found.values(), key=Diagnostic.sort_key)
    out = [_convert(a, d, own.range(d.span), "") for d in mine]
    leads = _import_leads(a)
    for d in a.diagnostics:
        if d.span.file == a.path or d.severity is Severity.NOTE:
            continue
        via = leads.get(d.span.file)
        if via is None:
            continue
        where = f"in imported file {os.path.basename(d.span.file)}:{d.span.line}: "
        out.append(_convert(a, d, own.range(via), where))
    return out


def _import_leads(a: Analysis) -> dict[str, Span]:
    """Imported file -> the span of the document's import that (transitively) loads it."""
    module = a.module
    if module is None:
        return {}
    targets: dict[str, list[str]] = {}
    for m in a.modules:
        base = os.path.dirname(m.file)
        targets[m.file] = [
            t
            for imp in m.imports
            if (t := os.path.normpath(os.path.join(base, imp.path.value))) in a.sources
        ]
    leads: dict[str, Span] = {}
    for imp in module.imports:
        first = os.path.normpath(os.path.join(os.path.dirname(a.path), imp.path.value))
        todo = [first] if first in a.sources else []
        while todo:
            f = todo.pop()
            if f in leads or f == a.path:
                continue
            leads[f] = imp.span
            todo.extend(targets.get(f, []))
    return leads
