"""The compiler's codes: each explanation's Bad example shows its code, the Fixed one is clean."""

from __future__ import annotations

import pytest

from aida_kb.diagnostics import codes
from aida_kb.diagnostics.explain import explanation
from aida_kb.kb import compile_text

# KB399 (an internal compiler error) has no known trigger: a bug has none by definition.
SEMANTIC = [c for c in sorted(codes.REGISTRY) if "KB100" <= c < "KB400" and c != "KB399"]
# KB400-KB499 are notes of an interpretation: their examples compile clean (shown at run time).
INTERPRETATION = [c for c in sorted(codes.REGISTRY) if "KB400" <= c < "KB500"]


@pytest.mark.parametrize("code", SEMANTIC)
def test_bad_example_shows_the_code_and_fixed_removes_it(code: str) -> None:
    found = explanation(code)
    assert found is not None
    assert found.bad is not None
    assert found.fixed is not None
    bad = compile_text(found.bad, "example.kb")
    assert code in {d.code for d in bad.diagnostics}
    fixed = compile_text(found.fixed, "example.kb")
    assert code not in {d.code for d in fixed.diagnostics}
    assert fixed.ok, fixed.diagnostics


@pytest.mark.parametrize("code", INTERPRETATION)
def test_interpretation_notes_have_examples_that_compile(code: str) -> None:
    found = explanation(code)
    assert found is not None
    assert found.bad is not None
    assert found.fixed is not None
    for text in (found.bad, found.fixed):
        result = compile_text(text, "example.kb")
        assert result.ok, result.diagnostics
