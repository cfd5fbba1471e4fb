"""docs/language.md: every `kb` example parses, and the examples cover the whole grammar."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from lark import Token, Tree
from lark.exceptions import UnexpectedInput

from aida_kb.dsl import grammar_path, parse
from aida_kb.dsl.parser import make_lark

ROOT = Path(__file__).resolve().parents[2]
DOC = (ROOT / "docs" / "language.md").read_text(encoding="utf-8")
EXAMPLES = re.findall(r"^```kb\n(.*?)^```", DOC, re.S | re.M)
LARK = make_lark()

# An example is a whole file, or members of a concept body.
_WRAPS = ("{}", "concept Example in world {{\n{}\n}}")


def _as_file(example: str) -> str:
    """The example as a file that parses (wrapped as concept members if need be)."""
    for wrap in _WRAPS:
        text = wrap.format(example)
        if not parse(text, "doc.kb").diagnostics:
            return text
    raise AssertionError(f"this example of docs/language.md does not parse:\n{example}")


def test_the_reference_has_examples() -> None:
    assert len(EXAMPLES) >= 15


@pytest.mark.parametrize("example", EXAMPLES, ids=lambda e: e.split("\n")[0][:40])
def test_every_example_parses(example: str) -> None:
    _as_file(example)


def _used(tree: Tree[Token]) -> set[str]:
    names = {str(tree.data)}
    for child in tree.children:
        if isinstance(child, Tree):
            names |= _used(child)
        elif isinstance(child, Token):
            names.add(child.type)
    return names


def test_every_rule_and_token_has_an_example() -> None:
    used: set[str] = set()
    for example in EXAMPLES:
        try:
            used |= _used(LARK.parse(_as_file(example)))
        except UnexpectedInput as exc:  # pragma: no cover - the test above says which
            raise AssertionError(example) from exc
    grammar = grammar_path().read_text(encoding="utf-8")
    rules = set(re.findall(r"^([a-z][a-z_]*)\s*:", grammar, re.M))  # rules that build nodes
    rules |= set(re.findall(r"->\s*([a-z_]+)", grammar))  # aliases: number, quantity
    terminals = {t.name for t in LARK.terminals if t.name not in LARK.ignore_tokens}
    missing = sorted((rules | terminals) - used)
    assert not missing, f"docs/language.md has no example of {missing}"
    comments = "".join(EXAMPLES)
    assert "//" in comments
    assert "/*" in comments
