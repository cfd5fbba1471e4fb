"""Rendering diagnostics: compiler-style text (carets, tabs, notes, colour) and JSON."""

from __future__ import annotations

import json

from aida_kb.diagnostics.core import Diagnostic, Severity, Span
from aida_kb.diagnostics.render import (
    MAX_LINE,
    diagnostic_to_json,
    render_json,
    render_summary,
    render_text,
)

SOURCE = "layers scene > world\nconcept Wall in world {\n\tpart : Wall\n}\n"
SOURCES = {"a.kb": SOURCE}


def _diag(
    line: int,
    col: int,
    end_line: int,
    end_col: int,
    *,
    severity: Severity = Severity.ERROR,
    hint: str | None = None,
    related: tuple[tuple[Span, str], ...] = (),
) -> Diagnostic:
    return Diagnostic(
        "KB001", severity, "a message", Span("a.kb", line, col, end_line, end_col), hint, related
    )


def test_head_line_source_line_and_single_caret() -> None:
    text = render_text([_diag(2, 9, 2, 10)], SOURCES)
    assert text.splitlines() == [
        "a.kb:2:9: error[KB001]: a message",
        "  |",
        "2 | concept Wall in world {",
        "  |         ^",
    ]


def test_multi_column_span_is_underlined_in_full() -> None:
    text = render_text([_diag(2, 9, 2, 13)], SOURCES)
    assert text.splitlines()[-1] == "  |         ^^^^"


def test_tabs_are_expanded_and_the_caret_follows_them() -> None:
    # line 3 is "\tpart : Wall"; column 7 is the ':' (the tab counts as one column).
    text = render_text([_diag(3, 7, 3, 8)], SOURCES)
    lines = text.splitlines()
    assert lines[2] == "3 |     part : Wall"
    assert lines[3] == "  |          ^"
    assert lines[2].index(":") == lines[3].index("^")


def test_wide_characters_take_two_cells() -> None:
    src = {"w.kb": 'concept 家 in world { "x" }\n'}
    diag = Diagnostic("KB001", Severity.ERROR, "m", Span("w.kb", 1, 11, 1, 13))  # "in"
    lines = render_text([diag], src).splitlines()
    assert lines[3] == "  |" + " " * 12 + "^^"  # one blank, then 11 cells: "concept 家 "


def test_span_past_the_end_of_the_line_points_after_it() -> None:
    text = render_text([_diag(4, 2, 4, 3)], SOURCES)
    assert text.splitlines()[-1] == "  |  ^"


def test_multi_line_span_underlines_first_and_last_line() -> None:
    text = render_text([_diag(2, 1, 4, 2)], SOURCES)
    lines = text.splitlines()
    assert lines[1:] == [
        "  |",
        "2 | concept Wall in world {",
        "  | ^^^^^^^^^^^^^^^^^^^^^^^",
        "...",
        "4 | }",
        "  | ^",
    ]


def test_hint_and_related_notes() -> None:
    first = Span("a.kb", 2, 9, 2, 13)
    diag = _diag(3, 8, 3, 12, hint="rename one of them", related=((first, "first defined here"),))
    lines = render_text([diag], SOURCES).splitlines()
    assert "  = hint: rename one of them" in lines
    note = lines.index("a.kb:2:9: note: first defined here")
    assert lines[note + 2] == "2 | concept Wall in world {"
    assert lines[note + 3] == "  |         ----"


def test_file_without_source_gets_its_head_line_only() -> None:
    diag = Diagnostic("KB900", Severity.ERROR, "cannot read", Span("gone.kb", 1, 1, 1, 2))
    assert render_text([diag], {}) == "gone.kb:1:1: error[KB900]: cannot read"


def test_warning_word_and_colour_only_when_asked() -> None:
    diag = _diag(2, 9, 2, 10, severity=Severity.WARNING)
    plain = render_text([diag], SOURCES)
    assert "warning[KB001]" in plain
    assert "\x1b[" not in plain
    coloured = render_text([diag], SOURCES, color=True)
    assert "\x1b[1;33mwarning[KB001]:\x1b[0m" in coloured


def test_blocks_are_separated_by_a_blank_line() -> None:
    text = render_text([_diag(2, 9, 2, 10), _diag(3, 2, 3, 6)], SOURCES)
    assert "\n\na.kb:3:2:" in text


def test_summary_counts() -> None:
    diags = [_diag(2, 9, 2, 10), _diag(3, 2, 3, 6), _diag(1, 1, 1, 2, severity=Severity.WARNING)]
    assert render_summary(diags, 2) == "2 errors, 1 warning in 2 files"
    assert render_summary([], 1) == "no problems in 1 file"


def test_json_has_exactly_the_contract_keys_and_one_based_positions() -> None:
    diags = [_diag(2, 9, 2, 13), _diag(1, 1, 1, 2, severity=Severity.WARNING)]
    data = json.loads(render_json(diags))
    assert data == [
        {
            "code": "KB001",
            "severity": "error",
            "message": "a message",
            "file": "a.kb",
            "line": 2,
            "column": 9,
            "end_line": 2,
            "end_column": 13,
            "hint": None,
            "related": [],
        },
        diagnostic_to_json(diags[1]),
    ]
    assert data[1]["severity"] == "warning"
    assert json.loads(render_json([])) == []


def test_long_lines_are_cropped_around_the_span() -> None:
    line = "x" * 300 + "target" + "y" * 300
    diag = Diagnostic("KB001", Severity.ERROR, "m", Span("l.kb", 1, 301, 1, 307))
    lines = render_text([diag], {"l.kb": line}).splitlines()
    shown, marks = lines[2], lines[3]
    assert len(shown) <= len("1 | ") + MAX_LINE + 6
    assert shown.startswith("1 | ...x")
    assert shown.endswith("y...")
    assert shown[marks.index("^") : marks.rindex("^") + 1] == "target"


def test_short_lines_are_not_cropped() -> None:
    line = "a" * MAX_LINE
    diag = Diagnostic("KB001", Severity.ERROR, "m", Span("s.kb", 1, MAX_LINE, 1, MAX_LINE + 1))
    lines = render_text([diag], {"s.kb": line}).splitlines()
    assert lines[2] == "1 | " + line
    assert lines[3] == "  | " + " " * (MAX_LINE - 1) + "^"


def test_each_source_is_split_once_however_many_diagnostics() -> None:
    """Splitting the source per diagnostic made lint's text output quadratic (issue 16)."""
    from collections.abc import Iterator, Mapping

    from aida_kb.diagnostics.core import Diagnostic, Severity, Span
    from aida_kb.diagnostics.render import render_text

    class Counting(Mapping[str, str]):
        def __init__(self, data: dict[str, str]) -> None:
            self.data = data
            self.reads = 0

        def __getitem__(self, key: str) -> str:
            self.reads += 1
            return self.data[key]

        def __iter__(self) -> Iterator[str]:
            return iter(self.data)

        def __len__(self) -> int:
            return len(self.data)

    text = "\n".join(f"line {i}" for i in range(500))
    sources = Counting({"a.kb": text})
    diags = [
        Diagnostic("KB001", Severity.ERROR, "bad", Span("a.kb", i, 1, i, 5)) for i in range(1, 501)
    ]
    out = render_text(diags, sources)
    assert out.count("error[KB001]") == 500
    assert "line 499" in out
    assert sources.reads == 1
