"""Syntax errors speak the language's words, at the right place; recovery finds them all."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aida_kb.dsl import ast, parse

ROOT = Path(__file__).resolve().parents[2]
BUILDINGS = (ROOT / "kb" / "buildings.kb").read_text(encoding="utf-8")


def _only(text: str) -> tuple[str, int, int, str]:
    result = parse(text, "bad.kb")
    assert len(result.diagnostics) == 1, result.diagnostics
    d = result.diagnostics[0]
    assert d.span.file == "bad.kb"
    return d.code, d.span.line, d.span.column, d.message


@pytest.mark.parametrize(
    ("text", "code", "line", "column", "message"),
    [
        (
            "concept A in world {\n  part : Wall\n}",
            "KB001",
            2,
            8,
            "expected a role name after 'part', found ':'",
        ),
        (
            "concept B {\n}",
            "KB001",
            1,
            11,
            "expected 'in LAYER' or 'is-a PARENT' after the concept name, found '{'",
        ),
        (
            "concept C in world { attribute t: angle in [85 dg, 95 deg] }",
            "KB003",
            1,
            48,
            "unknown unit 'dg' — expected deg, rad, m, cm, mm, px",
        ),
        ('concept D in world {\n  "oops\n}', "KB002", 2, 3, "unterminated string"),
        (
            "concept E in world { part a: B [1.5..2] }",
            "KB006",
            1,
            33,
            "a cardinality bound must be a whole number, not 1.5",
        ),
        (
            "concept F in world { constraint parallel(a, b) +- 1 deg +- 2 deg }",
            "KB007",
            1,
            57,
            "this relation already has a tolerance",
        ),
        (
            "concept G in world {\n  part x: Y\n",
            "KB008",
            3,
            1,
            "expected a member (part, optional part, con-of, attribute, adjacent, constraint, "
            "measure, frame, orient, unseen, attach, when, touching) or '}', found the end of "
            "the file",
        ),
        ("concept H in world { constraint front }", "KB009", 1, 33, "'front' is not a relation"),
        (
            "/* never closed\nconcept I in world {}",
            "KB004",
            1,
            1,
            "unterminated comment: '/*' has no closing '*/'",
        ),
        ("concept J in world { # no }", "KB005", 1, 22, "unexpected character '#'"),
        (
            "concept K in world { wall: Wall }",
            "KB001",
            1,
            22,
            "expected a member (part, optional part, con-of, attribute, adjacent, constraint, "
            "measure, frame, orient, unseen, attach, when, touching) or '}', found 'wall'",
        ),
        (
            "concept L is-a { }",
            "KB001",
            1,
            16,
            "expected a parent concept name after 'is-a', found '{'",
        ),
        ("instance i of { }", "KB001", 1, 15, "expected a concept name after 'of', found '{'"),
        (
            "concept M in world { constraint parallel(a, b) +- }",
            "KB001",
            1,
            51,
            "expected a tolerance after '+-', such as 0.5 deg, found '}'",
        ),
        (
            "concept N in world { adjacent circle(a, b) }",
            "KB001",
            1,
            31,
            "expected 'ring(...)' or 'pairs(...)' after 'adjacent', found 'circle'",
        ),
        (
            "concept O in world { optional wing: W }",
            "KB001",
            1,
            31,
            "expected 'part' after 'optional', found 'wing'",
        ),
        (
            "concept P in world { attribute t: angle in 5 }",
            "KB001",
            1,
            44,
            "expected a range such as [85 deg, 95 deg] after 'in', found '5'",
        ),
        (
            "import walls",
            "KB001",
            1,
            8,
            "expected a file name in double quotes after 'import', found 'walls'",
        ),
        (
            "}",
            "KB001",
            1,
            1,
            "expected a declaration (concept, abstract concept, template, instance, import or "
            "layers), found '}'",
        ),
    ],
)
def test_syntax_error_messages(text: str, code: str, line: int, column: int, message: str) -> None:
    assert _only(text) == (code, line, column, message)


def test_unknown_unit_suggests_the_closest() -> None:
    result = parse("concept C in world { attribute t: angle = 90 degs }", "x.kb")
    (d,) = result.diagnostics
    assert d.hint == "did you mean 'deg'?"


def test_recovery_reports_every_broken_declaration_and_keeps_the_rest() -> None:
    text = (
        "layers scene > world > image\n"  # 1
        "concept A in scene { part : Wall }\n"  # 2 broken
        "concept Good in world { part x: Y }\n"  # 3
        "concept B { }\n"  # 4 broken
        "template t(a: Plane) { angle(a, a) == }\n"  # 5 broken
        "abstract concept Also in world { }\n"  # 6
        "instance i of Good { x = }\n"  # 7 broken
        "concept Last in world { part y: Z }\n"  # 8
    )
    result = parse(text, "r.kb")
    assert [(d.code, d.span.line) for d in result.diagnostics] == [
        ("KB001", 2),
        ("KB001", 4),
        ("KB001", 5),
        ("KB001", 7),
    ]
    # A's body lost its one broken member (member-by-member recovery): A is kept, incomplete
    assert [c.name.text for c in result.module.concepts] == ["A", "Good", "Also", "Last"]
    assert result.module.concepts[0].members == ()
    assert result.module.concepts[2].abstract
    assert result.module.concepts[3].span.line == 8
    assert result.broken == frozenset({"B", "t", "i"})
    assert result.incomplete == frozenset({"A"})
    assert not result.ok


def test_recovery_ignores_keywords_in_strings_and_comments() -> None:
    text = (
        'concept A in world { "a concept template" part : X }\n'
        "// concept Fake in world {}\n"
        "concept B in world { }\n"
    )
    result = parse(text, "r.kb")
    assert [(d.code, d.span.line) for d in result.diagnostics] == [("KB001", 1)]
    assert [c.name.text for c in result.module.concepts] == ["A", "B"]  # A, its member dropped


def test_broken_examples_give_their_diagnostics() -> None:
    path = ROOT / "kb" / "examples" / "broken_syntax.kb"
    text = path.read_text(encoding="utf-8")
    result = parse(text, str(path))
    expected = []
    for number, line in enumerate(text.splitlines(), start=1):
        marker = line.find("// error[")
        if marker >= 0:
            code, place = line[marker + 9 :].split("]", 1)
            row, col = place.split()[0].split(":")
            expected.append((code, int(row), int(col)))
            assert int(row) >= number - 1
    got = [(d.code, d.span.line, d.span.column) for d in result.diagnostics]
    assert got == expected


_ALPHABET = st.sampled_from(
    [*list('{}()[]:,.=>"*/+-#;\n '), "part", "concept", "is-a", "con-of", "90 deg", "x", "1.5"]
)


@st.composite
def _mutants(draw: st.DrawFn) -> str:
    text = BUILDINGS
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(["delete", "insert", "truncate", "swap"]))
        pos = draw(st.integers(0, len(text)))
        if kind == "delete":
            text = text[:pos] + text[pos + draw(st.integers(1, 40)) :]
        elif kind == "insert":
            text = text[:pos] + draw(_ALPHABET) + text[pos:]
        elif kind == "truncate":
            text = text[:pos]
        else:
            other = draw(st.integers(0, len(text)))
            a, b = sorted((pos, other))
            text = text[:a] + text[b:] + text[a:b]
    return text


@settings(max_examples=100, deadline=None, derandomize=True)
@given(_mutants())
def test_mutations_of_buildings_only_give_diagnostics(text: str) -> None:
    result = parse(text, "m.kb")
    assert isinstance(result.module, ast.Module)
    lines = text.split("\n")
    for d in result.diagnostics:
        assert d.code != "KB099", d.message
        assert d.code.startswith("KB0")
        assert 1 <= d.span.line <= len(lines) + 1
        assert d.span.column >= 1


@settings(max_examples=100, deadline=None, derandomize=True)
@given(st.text(max_size=200))
def test_arbitrary_text_never_raises(text: str) -> None:
    result = parse(text, "a.kb")
    assert all(d.code != "KB099" for d in result.diagnostics)
