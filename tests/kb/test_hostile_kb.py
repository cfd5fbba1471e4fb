"""Hostile .kb text gives diagnostics, never an exception, infinity or an internal error."""

from __future__ import annotations

import re
from pathlib import Path

from aida_kb.kb import compile_text

ROOT = Path(__file__).resolve().parents[2]
BUILDINGS = (ROOT / "kb" / "buildings.kb").read_text(encoding="utf-8")
HEAD = "layers scene > world\nconcept W in world {\n"


def _errors(text: str) -> list[tuple[str, str]]:
    result = compile_text(text, "hostile.kb")
    assert not result.ok
    return [(d.code, d.message) for d in result.diagnostics if d.is_error]


def test_a_number_beyond_float64_is_an_error_not_null() -> None:
    errors = _errors(HEAD + "    attribute h: length = 1e999 m\n}\n")
    assert errors == [("KB010", errors[0][1])]
    assert "1e999" in errors[0][1]


def test_calls_nested_900_deep_are_one_diagnostic() -> None:
    deep = "parallel(" * 900 + "a" + ")" * 900
    codes = [code for code, _ in _errors(HEAD + f"    constraint {deep}\n}}\n")]
    assert "KB011" in codes
    assert "KB099" not in codes  # no internal parser error (RecursionError)


def test_a_tolerance_whose_square_underflows_is_refused() -> None:
    tolerance = re.search(r"\+- *[0-9.]+ *deg", BUILDINGS)
    assert tolerance is not None
    text = BUILDINGS.replace(tolerance.group(0), "+- 1e-300 deg", 1)
    errors = _errors(text)
    assert [code for code, _ in errors] == ["KB137"]
    assert "at least 1e-12" in errors[0][1]


def test_an_attribute_tolerance_whose_square_underflows_is_refused() -> None:
    # as a relation's: its weight 1/sigma² would not be a finite number
    tilt = "= 90 deg is slope(self)"
    plain = re.sub(re.escape(tilt) + r" *\+- *[0-9.]+ *deg", tilt, BUILDINGS, count=1)
    assert tilt in plain  # the walls' tilt, with its stated tolerance taken off
    errors = _errors(plain.replace(tilt, tilt + " +- 1e-300 deg", 1))
    assert [code for code, _ in errors] == ["KB137"]
    assert "at least 1e-12" in errors[0][1]
    assert compile_text(plain.replace(tilt, tilt + " +- 0.2 deg", 1), "ok.kb").ok


def test_a_5000_digit_cardinality_is_a_diagnostic() -> None:
    text = HEAD + f"    part p: W [{'9' * 5000}]\n}}\n"
    found = dict(_errors(text))
    assert "KB099" not in found
    assert "digits" in found["KB006"]
