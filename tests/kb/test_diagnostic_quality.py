"""Diagnostics that say the right thing once (issue 18): headlines, hints, follow-on errors,
long cycles, deep nesting. The golden files kb/examples/broken_syntax_members.kb and
kb/examples/broken_followon.kb hold the rest."""

from __future__ import annotations

from aida_kb.dsl import parse
from aida_kb.kb import compile_text
from aida_kb.kb.resolve import MAX_CYCLE_SHOWN

LAYERS = "layers scene > world > image\n"


def _codes(text: str) -> list[tuple[str, int, int]]:
    result = compile_text(text, "t.kb")
    return [(d.code, d.span.line, d.span.column) for d in result.errors]


def test_a_concept_is_not_offered_as_its_own_parent() -> None:
    result = compile_text(LAYERS + "concept ShedRoof in world is-a ShedRoof2 {}\n", "t.kb")
    [error] = result.errors
    assert error.code == "KB100"
    assert error.hint is None  # was: did you mean 'ShedRoof'?


def test_an_image_concept_without_a_measure_is_told_to_measure() -> None:
    text = LAYERS + "concept A in scene {\n    con-of r: R\n}\nconcept R in image {}\n"
    result = compile_text(text, "t.kb")
    hints = {d.hint for d in result.diagnostics if d.code == "KB302"}
    assert "give it a measure, as in 'measure position(self)'" in hints


def test_a_long_is_a_cycle_is_one_diagnostic_with_its_middle_elided() -> None:
    n = 1500
    text = LAYERS + "".join(f"concept C{i} in world is-a C{(i + 1) % n} {{}}\n" for i in range(n))
    cycles = [d for d in compile_text(text, "t.kb").errors if d.code == "KB120"]
    [cycle] = cycles
    assert len(cycle.related) == MAX_CYCLE_SHOWN + 1
    assert f"... {n - MAX_CYCLE_SHOWN} more links of the cycle ..." in cycle.related[4][1]
    assert f"... {n + 1 - MAX_CYCLE_SHOWN} more ..." in cycle.message
    assert len(cycle.message) < 200


def test_a_template_cycle_is_reported_once_at_the_template() -> None:
    text = LAYERS + (
        "concept House in scene {\n    constraint t1(self)\n}\n"
        "template t1(a: House) {\n    t2(a)\n}\n"
        "template t2(a: House) {\n    t1(a)\n}\n"
    )
    assert [c for c in _codes(text) if c[0] == "KB135"] == [("KB135", 9, 5)]


def test_a_byte_order_mark_is_no_column() -> None:
    result = parse("\ufefflayers scene > > image\n", "t.kb")
    [error] = result.diagnostics
    assert (error.span.line, error.span.column) == (1, 16)


def test_keywords_are_names_in_any_binding() -> None:
    text = LAYERS + (
        "concept R in image {\n    attribute part: number\n    attribute weight: number\n"
        "    attribute measure: number\n    measure position(self)\n}\n"
        "instance r of R {\n    part = 1\n    weight = 2\n    measure = 3\n}\n"
    )
    assert _codes(text) == []


def test_deep_nesting_is_one_diagnostic_and_keeps_the_others() -> None:
    deep = "f(" * 300 + "1" + ")" * 300
    text = LAYERS + (
        "concept A in scene {\n    part x Wall\n}\n"
        f"concept B in world {{\n    attribute t: angle = {deep}\n}}\n"
        "concept C in world is-a Missing {}\n"
    )
    got = _codes(text)
    assert ("KB001", 3, 12) in got
    assert ("KB100", 8, 25) in got
    assert [c[0] for c in got if c[1] == 6] == ["KB011"]  # no follow-on about the cut call
    assert not {"KB099", "KB399"} & {c[0] for c in got}


def test_a_file_ending_inside_a_body_keeps_its_members() -> None:
    text = LAYERS + "concept A in scene {\n    part x Wall\n    attribute h: length = 5 feet\n"
    got = _codes(text)
    assert ("KB001", 3, 12) in got
    assert ("KB003", 4, 29) in got
    assert ("KB008", 5, 1) in got
