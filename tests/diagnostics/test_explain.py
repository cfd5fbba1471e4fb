"""Explanations: one file per registered code, examples that really show the code, docs in sync."""

from __future__ import annotations

from pathlib import Path

import pytest

from aida_kb.diagnostics import codes
from aida_kb.diagnostics.docs import generate
from aida_kb.diagnostics.docs import main as docs_main
from aida_kb.diagnostics.explain import available, explanation, normalize_code
from aida_kb.dsl import parse

ROOT = Path(__file__).resolve().parents[2]
ALL_CODES = sorted(codes.REGISTRY)
# Codes whose Bad example cannot show them from text alone: an internal parser failure (no known
# trigger) and an unreadable file (needs the file system; tested with the compiler's imports).
NOT_FROM_TEXT = {"KB099", "KB900"}


def _codes_of(text: str) -> set[str]:
    return {d.code for d in parse(text, "example.kb").diagnostics}


@pytest.mark.parametrize("code", ALL_CODES)
def test_every_registered_code_has_an_explanation_file(code: str) -> None:
    assert code in available(), f"aida_kb/diagnostics/explanations/{code}.md is missing"
    found = explanation(code)
    assert found is not None
    assert found.text.startswith(f"# {code}: ")
    assert found.title
    assert found.bad is not None, f"{code}.md has no '## Bad' example in a ```kb fence"
    assert found.fixed is not None, f"{code}.md has no '## Fixed' example in a ```kb fence"


@pytest.mark.parametrize("code", [c for c in ALL_CODES if c < "KB100" and c not in NOT_FROM_TEXT])
def test_syntax_examples_show_their_code_and_the_fix_removes_it(code: str) -> None:
    found = explanation(code)
    assert found is not None
    assert found.bad is not None
    assert found.fixed is not None
    assert code in _codes_of(found.bad)
    assert _codes_of(found.fixed) == set()


def test_every_explanation_file_is_a_registered_code() -> None:
    assert set(available()) <= set(codes.REGISTRY)


def test_code_spellings() -> None:
    assert normalize_code("kb3") == "KB003"
    assert normalize_code(" 3 ") == "KB003"
    assert normalize_code("KB900") == "KB900"
    assert normalize_code("KB1234") is None
    assert normalize_code("x") is None
    assert explanation("KB777") is None
    assert explanation("nonsense") is None


def test_committed_docs_are_in_sync() -> None:
    committed = (ROOT / "docs" / "diagnostics.md").read_text(encoding="utf-8")
    assert committed == generate(), "docs/diagnostics.md is out of date: run 'make docs'"


def test_docs_list_every_code(tmp_path: Path) -> None:
    text = generate()
    for code in ALL_CODES:
        assert f"## {code}: " in text
        assert f"| [{code}](#{code.lower()}) |" in text
    out = tmp_path / "d.md"
    assert docs_main(["-o", str(out)]) == 0
    assert out.read_text(encoding="utf-8") == text
    assert docs_main(["-o", str(out), "--check"]) == 0
    out.write_text("stale", encoding="utf-8")
    assert docs_main(["-o", str(out), "--check"]) == 1
