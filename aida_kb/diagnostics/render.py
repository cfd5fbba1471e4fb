"""Render diagnostics for people (compiler-style text) and for tools (one JSON array).

Text looks like this::

    kb/examples/broken_syntax.kb:6:10: error[KB001]: expected a role name after 'part', found ':'
      |
    6 |     part : HouseBody
      |          ^
      = hint: a role is declared with 'part NAME: Concept'

The source line is shown with tabs expanded; the underline covers the span (``^`` for one
column, ``^^^^`` for several; a span over several lines underlines its first and last line).
Related places (the first definition of a duplicate, each link of a cycle) follow as notes.
Colour is plain ANSI escapes, used only when asked (the CLI asks on a terminal), so that
importing this module costs nothing.
"""

from __future__ import annotations

import json
import unicodedata
from collections.abc import Iterable, Mapping, Sequence

from aida_kb.diagnostics.core import Diagnostic, Severity, Span

__all__ = [
    "MAX_LINE",
    "TAB_SIZE",
    "diagnostic_to_json",
    "render_json",
    "render_sarif",
    "render_summary",
    "render_text",
]

TAB_SIZE = 4
#: Source lines longer than this many characters are shown as a window around the span.
MAX_LINE = 120

_RESET = "\x1b[0m"
_BOLD = "\x1b[1m"
_STYLE = {
    Severity.ERROR: "\x1b[1;31m",
    Severity.WARNING: "\x1b[1;33m",
    Severity.NOTE: "\x1b[1;36m",
}
_GUTTER = "\x1b[1;34m"
_HINT = "\x1b[1;32m"


class _Paint:
    def __init__(self, color: bool) -> None:
        self.color = color

    def __call__(self, style: str, text: str) -> str:
        return f"{style}{text}{_RESET}" if self.color and text else text


def _width(text: str) -> int:
    """Display width of `text` (East Asian wide characters take two cells, marks none)."""
    width = 0
    for ch in text:
        if unicodedata.combining(ch):
            continue
        width += 2 if unicodedata.east_asian_width(ch) in ("W", "F") else 1
    return width


def _display(line: str) -> str:
    return line.expandtabs(TAB_SIZE)


def _cell(line: str, column: int) -> int:
    """The 0-based display cell where 1-based character `column` of `line` starts."""
    prefix = line[: max(column - 1, 0)]
    # Columns past the end of the line (a span at the end of a line or file) extend with blanks.
    extra = max(column - 1 - len(line), 0)
    return _width(_display(prefix)) + extra


def _underline_cells(line: str, start_col: int, end_col: int | None) -> tuple[int, int]:
    """(first cell, number of cells) to underline on `line` from `start_col` to `end_col`."""
    first = _cell(line, start_col)
    last = _cell(line, end_col) if end_col is not None else _width(_display(line))
    return first, max(last - first, 1)


def _crop(text: str, start: int, end: int | None) -> tuple[str, int, int | None]:
    """Cut a line longer than `MAX_LINE` characters to a window around its span.

    Returns the shown text (``...`` marks what was cut) and the span's columns in it.
    """
    if len(text) <= MAX_LINE:
        return text, start, end
    first = max(0, min(start - 1 - MAX_LINE // 3, len(text) - MAX_LINE))
    last = first + MAX_LINE
    head = "..." if first > 0 else ""
    tail = "..." if last < len(text) else ""
    shift = len(head) - first
    new_end = None if end is None else min(end, last + 1) + shift
    if new_end is None and tail:
        new_end = last + 1 + shift
    return head + text[first:last] + tail, start + shift, new_end


class _Lines:
    """Each source split into lines once (splitting per diagnostic made the output quadratic:
    72 s for 40,000 diagnostics of one file)."""

    def __init__(self, sources: Mapping[str, str]) -> None:
        self.sources = sources
        self.split: dict[str, list[str] | None] = {}

    def get(self, file: str) -> list[str] | None:
        if file not in self.split:
            text = self.sources.get(file)
            self.split[file] = None if text is None else text.split("\n")
        return self.split[file]


def _snippet(span: Span, sources: _Lines, paint: _Paint, mark: str, style: str) -> list[str]:
    lines = sources.get(span.file)
    if lines is None or not 1 <= span.line <= len(lines):
        return []
    last_line = min(max(span.end_line, span.line), len(lines))
    numbers = [span.line] if last_line == span.line else [span.line, last_line]
    gutter = len(str(numbers[-1]))
    pad = " " * gutter
    out = [paint(_GUTTER, f"{pad} |")]
    for index, number in enumerate(numbers):
        if index == 1 and number > span.line + 1:
            out.append(paint(_GUTTER, "..."))
        text = lines[number - 1].rstrip("\r")
        if len(numbers) == 1:
            start: int = span.column
            end: int | None = span.end_column if span.end_line == span.line else None
        elif index == 0:
            start, end = span.column, None
        else:
            start, end = len(text) - len(text.lstrip()) + 1, span.end_column
        text, start, end = _crop(text, start, end)
        out.append(paint(_GUTTER, f"{number:>{gutter}} |") + (" " + _display(text) if text else ""))
        first, count = _underline_cells(text, start, end)
        out.append(paint(_GUTTER, f"{pad} |") + " " + " " * first + paint(style, mark * count))
    return out


def _severity_word(severity: Severity) -> str:
    return severity.value


def _render_one(diag: Diagnostic, sources: _Lines, paint: _Paint) -> str:
    style = _STYLE[diag.severity]
    head = (
        paint(_BOLD, f"{diag.span}:")
        + " "
        + paint(style, f"{_severity_word(diag.severity)}[{diag.code}]:")
        + " "
        + paint(_BOLD, diag.message)
    )
    out = [head]
    out.extend(_snippet(diag.span, sources, paint, "^", style))
    gutter = " " * len(str(max(diag.span.line, diag.span.end_line)))
    if diag.hint:
        out.append(f"{gutter} {paint(_GUTTER, '=')} {paint(_HINT, 'hint:')} {diag.hint}")
    for span, message in diag.related:
        note = _STYLE[Severity.NOTE]
        out.append(f"{paint(_BOLD, f'{span}:')} {paint(note, 'note:')} {message}")
        out.extend(_snippet(span, sources, paint, "-", note))
    return "\n".join(out)


def render_text(
    diagnostics: Iterable[Diagnostic],
    sources: Mapping[str, str],
    *,
    color: bool = False,
) -> str:
    """Render diagnostics as compiler-style text, one block per diagnostic.

    Parameters
    ----------
    diagnostics : iterable of Diagnostic
        In the order to print them (callers sort them).
    sources : mapping of str to str
        File name -> source text, for the source lines under each message. A file missing
        here gets its message line only.
    color : bool
        Add ANSI colour escapes (for a terminal).

    Returns
    -------
    str
        The blocks separated by blank lines, without a trailing newline ("" for none).
    """
    paint = _Paint(color)
    lines = _Lines(sources)
    return "\n\n".join(_render_one(d, lines, paint) for d in diagnostics)


def render_summary(diagnostics: Sequence[Diagnostic], files: int, *, color: bool = False) -> str:
    """One line counting errors and warnings: ``2 errors, 1 warning in 3 files``."""
    paint = _Paint(color)
    errors = sum(d.severity is Severity.ERROR for d in diagnostics)
    warnings = sum(d.severity is Severity.WARNING for d in diagnostics)
    where = f"in {files} file{'s' if files != 1 else ''}"
    if not errors and not warnings:
        return paint(_HINT, f"no problems {where}") if files else "no files checked"
    parts = []
    if errors:
        parts.append(paint(_STYLE[Severity.ERROR], f"{errors} error{'s' if errors != 1 else ''}"))
    if warnings:
        word = f"{warnings} warning{'s' if warnings != 1 else ''}"
        parts.append(paint(_STYLE[Severity.WARNING], word))
    return f"{', '.join(parts)} {where}"


def _span_json(span: Span) -> dict[str, str | int]:
    return {
        "file": span.file,
        "line": span.line,
        "column": span.column,
        "end_line": span.end_line,
        "end_column": span.end_column,
    }


def diagnostic_to_json(diag: Diagnostic) -> dict[str, object]:
    """The JSON object of one diagnostic: code, severity, message, file and its 1-based span,
    the hint (or null) and the related places (``related``: each a span and its message; the
    "imported from" chain of a diagnostic inside an imported file is among them).

    Notes (severity ``note``) are reported as ``"warning"``: the JSON format knows only
    ``"error"`` and ``"warning"``.
    """
    return {
        "code": diag.code,
        "severity": "error" if diag.severity is Severity.ERROR else "warning",
        "message": diag.message,
        **_span_json(diag.span),
        "hint": diag.hint,
        "related": [{**_span_json(span), "message": text} for span, text in diag.related],
    }


def render_json(diagnostics: Iterable[Diagnostic]) -> str:
    """Exactly one JSON array of diagnostic objects (see `diagnostic_to_json`), indented."""
    return json.dumps([diagnostic_to_json(d) for d in diagnostics], indent=2, ensure_ascii=False)


#: The SARIF version written and the schema it follows (tests/data/sarif-schema-2.1.0.json).
SARIF_VERSION = "2.1.0"
SARIF_SCHEMA = "https://json.schemastore.org/sarif-2.1.0.json"
_SARIF_LEVEL = {Severity.ERROR: "error", Severity.WARNING: "warning", Severity.NOTE: "note"}


def _uri(file: str) -> str:
    """A file name as a SARIF artifact URI: relative names as relative references (``/``
    separators), absolute ones as ``file://`` URIs; characters outside a URI %-escaped."""
    from pathlib import PurePath
    from urllib.parse import quote

    path = PurePath(file)
    if path.is_absolute():
        return "file://" + quote(path.as_posix())
    return quote(path.as_posix())


def _sarif_location(span: Span) -> dict[str, object]:
    # SARIF's property names as keywords: the words of the format, not of a knowledge base
    where = dict(
        startLine=max(span.line, 1),
        startColumn=max(span.column, 1),
        endLine=max(span.end_line, span.line, 1),
        endColumn=max(span.end_column, 1),
    )
    physical = dict(artifactLocation={"uri": _uri(span.file)}, region=where)
    return {"physicalLocation": physical}


def render_sarif(diagnostics: Sequence[Diagnostic], sources: Mapping[str, str]) -> str:
    """A SARIF 2.1.0 log (one run of the tool ``aida-kb``) of the diagnostics, for code scanning.

    Each code used is a rule (its summary from the registry, its explanation named as
    ``aida-kb explain CODE``); each diagnostic a result with its level, message (the hint
    appended), location and related locations. Columns count Unicode code points, as the
    spans do. `sources` names the artifacts (the files read).
    """
    from aida_kb import __version__
    from aida_kb.diagnostics.codes import lookup

    rule_index: dict[str, int] = {}
    rules: list[dict[str, object]] = []
    results: list[dict[str, object]] = []
    for d in diagnostics:
        if d.code not in rule_index:
            rule_index[d.code] = len(rules)
            entry = lookup(d.code)
            summary = entry.summary if entry else d.code
            level = _SARIF_LEVEL[entry.severity if entry else d.severity]
            rules.append(
                {
                    "id": d.code,
                    "shortDescription": {"text": summary},
                    "fullDescription": {
                        "text": f"{summary}. Run 'aida-kb explain {d.code}' for an example."
                    },
                    "defaultConfiguration": {"level": level},
                }
            )
        text = d.message if not d.hint else f"{d.message}\nhint: {d.hint}"
        result: dict[str, object] = {
            "ruleId": d.code,
            "ruleIndex": rule_index[d.code],
            "level": _SARIF_LEVEL[d.severity],
            "message": {"text": text},
            "locations": [_sarif_location(d.span)],
        }
        if d.related:
            result["relatedLocations"] = [
                {"id": i, **_sarif_location(span), "message": {"text": note}}
                for i, (span, note) in enumerate(d.related)
            ]
        results.append(result)
    log = {
        "$schema": SARIF_SCHEMA,
        "version": SARIF_VERSION,
        "runs": [
            {
                "tool": {
                    "driver": {
                        "name": "aida-kb",
                        "version": __version__,
                        "rules": rules,
                    }
                },
                "artifacts": [{"location": {"uri": _uri(f)}} for f in sorted(sources)],
                "columnKind": "unicodeCodePoints",
                "results": results,
            }
        ],
    }
    return json.dumps(log, indent=2, ensure_ascii=False)
