"""Golden tests: each file of kb/examples gives exactly the diagnostics its comments expect.

A comment ``// error[KB102] 19:37 ...`` in any file the example loads says that the compiler
reports that code at that line and column of that file; the errors must be exactly those
marked. Warnings (``// warning[KB301] 16:9``) are compared too in the files that mark any (in
the broken files, a declaration that does not parse leaves warnings about what it would have
linked, which are not the point of those files).
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from aida_kb.kb import compile_path

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = sorted((ROOT / "kb" / "examples").glob("*.kb"))
MARKER = re.compile(r"//\s*(error|warning)\[(KB\d{3})\]\s+(\d+):(\d+)")


def _expected(sources: dict[str, str]) -> set[tuple[str, str, str, int, int]]:
    found = set()
    for file, text in sources.items():
        for m in MARKER.finditer(text):
            severity, code, line, column = m.groups()
            found.add((Path(file).name, severity, code, int(line), int(column)))
    return found


def test_there_are_enough_broken_examples() -> None:
    assert len(EXAMPLES) >= 4


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.name)
def test_example_gives_exactly_its_marked_diagnostics(path: Path) -> None:
    result = compile_path(path)
    got = {
        (Path(d.span.file).name, d.severity.value, d.code, d.span.line, d.span.column)
        for d in result.diagnostics
    }
    expected = _expected(result.sources)
    assert expected, f"{path.name} has no expectation markers"
    if not any(e[1] == "warning" for e in expected):
        got = {g for g in got if g[1] == "error"}
    assert got == expected


def test_every_semantic_error_code_appears_in_an_example() -> None:
    codes_seen = set()
    for path in EXAMPLES:
        codes_seen |= {d.code for d in compile_path(path).diagnostics}
    wanted = {
        "KB100", "KB101", "KB102", "KB103", "KB104", "KB110", "KB111", "KB120", "KB121",
        "KB122", "KB123", "KB124", "KB125", "KB126", "KB130", "KB131", "KB132", "KB133",
        "KB134", "KB135", "KB136", "KB137", "KB140", "KB141", "KB142", "KB150", "KB151",
        "KB152", "KB153", "KB154", "KB155", "KB300", "KB301", "KB302", "KB901", "KB902",
        "KB001", "KB003", "KB005", "KB012", "KB105",
    }  # fmt: skip
    assert wanted <= codes_seen, wanted - codes_seen
