"""Property: any mutation of buildings.kb gives diagnostics (or a model), never an exception."""

from __future__ import annotations

import re
from pathlib import Path

from hypothesis import given, settings
from hypothesis import strategies as st

from aida_kb.diagnostics import codes
from aida_kb.kb import compile_text

ROOT = Path(__file__).resolve().parents[2]
BUILDINGS = (ROOT / "kb" / "buildings.kb").read_text(encoding="utf-8")
LINES = BUILDINGS.split("\n")
TOKENS = re.findall(r"\S+|\s+", BUILDINGS)


def _mutate(items: list[str], draw: st.DrawFn) -> list[str]:
    items = list(items)
    for _ in range(draw(st.integers(1, 4))):
        if not items:
            break
        i = draw(st.integers(0, len(items) - 1))
        kind = draw(st.sampled_from(["delete", "duplicate", "swap"]))
        if kind == "delete":
            del items[i]
        elif kind == "duplicate":
            items.insert(i, items[i])
        else:
            j = draw(st.integers(0, len(items) - 1))
            items[i], items[j] = items[j], items[i]
    return items


@st.composite
def _line_mutants(draw: st.DrawFn) -> str:
    return "\n".join(_mutate(LINES, draw))


@st.composite
def _token_mutants(draw: st.DrawFn) -> str:
    return "".join(_mutate(TOKENS, draw))


def _check(text: str) -> None:
    result = compile_text(text, "m.kb")
    n_lines = text.count("\n") + 1
    for d in result.diagnostics:
        assert d.code in codes.REGISTRY, d
        assert d.code != "KB099", d.message  # no internal error
        assert 1 <= d.span.line <= n_lines + 1
        assert d.span.column >= 1
    if result.ok:
        assert result.kb is not None
        assert "House" in result.kb.concepts or "House" not in text
    else:
        assert result.kb is None


@settings(max_examples=30, deadline=None, derandomize=True)
@given(_line_mutants())
def test_line_mutations_give_diagnostics_never_exceptions(text: str) -> None:
    _check(text)


@settings(max_examples=30, deadline=None, derandomize=True)
@given(_token_mutants())
def test_token_mutations_give_diagnostics_never_exceptions(text: str) -> None:
    _check(text)
