"""Syntax errors speak the language's words: what was expected where, not grammar terminals."""

from __future__ import annotations

import pytest

from aida_kb.dsl import parse


@pytest.mark.parametrize(
    ("source", "where", "message"),
    [
        (
            "concept A in world {\n    part front, back Wall\n}",
            (2, 22),
            "expected ':' and the part's concept after the role names, as in 'part front: Wall', "
            "found 'Wall'",
        ),
        (
            "concept A in world {\n    con-of region Region\n}",
            (2, 19),
            "expected ':' and the realising concept after the role, "
            "as in 'con-of region: Region', found 'Region'",
        ),
        (
            "concept A in world {\n    attribute tilt angle\n}",
            (2, 20),
            "expected ':' and a type after the attribute name, as in 'attribute tilt: angle', "
            "found 'angle'",
        ),
        (
            "template t(a: Plane, b Plane) { parallel(a, b) }",
            (1, 24),
            "expected ':' and a type after the parameter name, as in 'a: Plane', found 'Plane'",
        ),
        (
            "template t(a: Plane { parallel(a, a) }",
            (1, 21),
            "expected ',' or a closing ')', found '{'",
        ),
        (
            "concept A in world {\n    constraint parallel(a b)\n}",
            (2, 27),
            "expected ',' or a closing ')', found 'b'",
        ),
    ],
)
def test_messages_name_what_the_language_expects(
    source: str, where: tuple[int, int], message: str
) -> None:
    result = parse("layers world\n" + source, "w.kb")
    [diag] = result.diagnostics
    assert diag.code == "KB001"
    assert (diag.span.line - 1, diag.span.column) == where
    assert diag.message == message
    assert "NAME" not in diag.message
    assert "COLON" not in diag.message
