"""The fast contextual-lexer driver yields exactly Lark's tokens and Lark's syntax errors."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from lark import Lark, Token
from lark.exceptions import UnexpectedInput

from aida_kb.dsl.lexer import FastContextualLexer, install
from aida_kb.dsl.parser import make_lark

ROOT = Path(__file__).resolve().parents[2]
SOURCES = sorted((ROOT / "kb").rglob("*.kb"))
BUILDINGS = (ROOT / "kb" / "buildings.kb").read_text(encoding="utf-8")


def _lark(fast: bool) -> Lark:
    lark = make_lark()
    if fast:
        assert install(lark)
    return lark


SLOW = _lark(False)
FAST = _lark(True)

_FIELDS = ("type", "value", "start_pos", "line", "column", "end_line", "end_column", "end_pos")


def _tokens(tree: Any) -> list[tuple[Any, ...]]:
    tokens = tree.scan_values(lambda v: isinstance(v, Token))
    return [tuple(getattr(t, f) for f in _FIELDS) for t in tokens]


def _outcome(lark: Lark, text: str) -> tuple[str, Any]:
    try:
        return "ok", _tokens(lark.parse(text))
    except UnexpectedInput as exc:
        token = getattr(exc, "token", None)
        where = (exc.line, exc.column, getattr(exc, "pos_in_stream", None))
        found = None if token is None else tuple(getattr(token, f) for f in _FIELDS)
        return type(exc).__name__, (where, found, sorted(getattr(exc, "expected", ()) or ()))


def test_installed_on_the_product_parser() -> None:
    from aida_kb.dsl.parser import _parser

    assert isinstance(_parser().parser.lexer, FastContextualLexer)


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: p.name)
def test_same_tokens_on_every_shipped_file(path: Path) -> None:
    text = path.read_text(encoding="utf-8")
    assert _outcome(FAST, text) == _outcome(SLOW, text)


@pytest.mark.parametrize(
    "text",
    [
        "",
        "layers scene > world\n",
        'concept A in world { "doc\\nwith escape" }\n/* block\ncomment */ concept B in world { }',
        "concept A in world {\n  attribute tilt: angle in [85 deg, 95 deg] = 90deg\n}",
        "concept A in world { part # : B }",  # an unexpected character
        'import "unterminated\n',
        "concept in world { }",  # an unexpected token
        "concept A in world {\n  part a: B\n",  # the end of the file
        "/* never closed\nconcept A in world { }",
        "\r\n\tconcept A in world { part p: B [1..*] }\r\n",
    ],
)
def test_same_tokens_and_errors(text: str) -> None:
    assert _outcome(FAST, text) == _outcome(SLOW, text)


@settings(max_examples=60, deadline=None)
@given(st.data())
def test_same_tokens_on_mutants(data: st.DataObject) -> None:
    start = data.draw(st.integers(0, len(BUILDINGS) - 1))
    length = data.draw(st.integers(0, 40))
    insert = data.draw(st.text(alphabet='abz_ 09.\n"/*{}()[]:,=+-#', max_size=6))
    text = BUILDINGS[:start] + insert + BUILDINGS[start + length :]
    assert _outcome(FAST, text) == _outcome(SLOW, text)


def test_install_leaves_other_lexers_alone() -> None:
    basic = Lark("start: NAME\nNAME: /[a-z]+/\n", parser="lalr", lexer="basic")
    assert not install(basic)
    assert basic.parse("abc").children == ["abc"]


def test_install_declines_a_lexer_without_the_reused_internals() -> None:
    lark = make_lark()
    lark.parser.lexer.root_lexer = None  # as if another Lark version had no root lexer
    assert not install(lark)
    assert not isinstance(lark.parser.lexer, FastContextualLexer)
