"""Expectation annotations (`// expect:`): reading them, and the compiler's checks of them."""

from __future__ import annotations

import math

from aida_kb.kb import compile_text
from aida_kb.kb.expectation import DEFAULT_TOLERANCE, expected_tree, line_comments, read_annotations

KB = """\
layers scene > world > image
concept Region in image { measure position(self) +- 2 cm }
concept Wall in world {
    con-of region: Region [0..1]
    attribute tilt: angle in [80 deg, 100 deg]
    constraint upright: angle(self, self) == 0 deg +- 1 deg
}
concept House in scene { con-of fronts: Wall [1..2] }
"""


def _codes(text: str) -> list[tuple[str, int]]:
    result = compile_text(KB + text, "t.kb")
    return sorted(
        (d.code, d.span.line - KB.count("\n"))
        for d in result.diagnostics
        if d.severity.value == "error"
    )


def test_line_comments_skip_strings_and_block_comments() -> None:
    text = 'a = "x // y"  // one\n/* // not\n */ b // two\n// three\n"s\\" // q" c\n'
    got = [(c.line, c.column, c.text, c.trailing) for c in line_comments(text)]
    assert got == [
        (1, 15, "// one", True),
        (3, 7, "// two", True),
        (4, 1, "// three", False),
    ]


def test_annotations_are_read_with_their_units() -> None:
    text = (
        "// expect: verdict doubtful\n"
        "// expect: reject fronts[0] of Wall by upright\n"
        "// expect: tolerance 2 deg, 10 cm\n"
        "instance w of Wall { tilt = 90 deg  // expect: +- 3 mm\n}\n"
        "// a comment that is no annotation: expect nothing of it\n"
    )
    ann = read_annotations(text, "t.kb")
    assert ann.problems == ()
    assert ann.verdict == "doubtful"
    assert [(r.role, r.concept, r.constraint, r.span.line) for r in ann.rejections] == [
        ("fronts[0]", "Wall", "upright", 2)
    ]
    assert ann.tolerance == {"rad": math.radians(2), "m": 0.1}
    assert ann.value_tolerances == {4: (0.003, "m")}
    assert ann.trailing == {4: "// expect: +- 3 mm"}
    assert {"rad": math.radians(0.5), "m": 0.05} == DEFAULT_TOLERANCE


def test_a_good_expectation_compiles_clean_and_gives_its_tree() -> None:
    text = (
        "// expect: verdict verified\n"
        "// expect: reject fronts[1] of Wall by upright\n"
        "instance h of House { fronts = [w1, w2] }\n"
        'instance w1 of Wall { region = "00/1"  tilt = 90 deg  // expect: +- 1 deg\n}\n'
        'instance w2 of Wall { "inserted from the knowledge base: no view shows this part" }\n'
    )
    assert _codes(text) == []
    result = compile_text(KB + text, "t.kb")
    assert result.kb is not None
    tree = expected_tree(result.kb, "t.kb", KB + text)
    assert sorted(tree.nodes) == ["", "fronts[0]", "fronts[1]"]
    assert tree.nodes[""].children == {"fronts": ("fronts[0]", "fronts[1]")}
    w1 = tree.nodes["fronts[0]"]
    assert (w1.concept, w1.inserted, w1.evidence) == ("Wall", False, {"region": ("00/1",)})
    assert math.isclose(w1.values["tilt"], math.radians(90))
    assert tree.nodes["fronts[1]"].inserted
    line = w1.binding_spans["tilt"].line
    assert tree.annotations.value_tolerances[line] == (math.radians(1), "rad")


def test_the_compiler_checks_the_annotations() -> None:
    assert _codes("// expect: verdict maybe\n") == [("KB143", 1)]
    assert _codes("// expect: verdict nothing\n// expect: verdict nothing\n") == [("KB143", 2)]
    assert _codes("// expect: verdict nothing\n// expect: frobnicate\n") == [("KB143", 2)]
    assert _codes("// expect: verdict nothing\n// expect: reject x\n") == [("KB143", 2)]
    assert _codes(
        "// expect: verdict nothing\n// expect: reject fronts[0] of Wal by upright\n"
    ) == [("KB100", 2)]
    assert _codes("// expect: verdict nothing\n// expect: reject roof of Wall by upright\n") == [
        ("KB143", 2)
    ]
    assert _codes("// expect: verdict nothing\n// expect: reject fronts of House by upright\n") == [
        ("KB143", 2)
    ]
    assert _codes("// expect: verdict nothing\n// expect: reject fronts of Wall by upright2\n") == [
        ("KB143", 2)
    ]
    # an unlabelled constraint's label, as the compiler makes it
    assert _codes("// expect: verdict nothing\n// expect: reject fronts of Wall by Wall#1\n") == []
    assert _codes("// expect: tolerance 5\n") == [("KB143", 1)]
    assert _codes("// expect: tolerance 1 deg, 2 deg\n") == [("KB143", 1)]
    # a value tolerance: after an attribute value, of its kind
    assert _codes("instance w of Wall { tilt = 90 deg  // expect: +- 1 m\n}\n") == [("KB132", 1)]
    assert _codes("instance w of Wall {  // expect: +- 1 deg\n}\n") == [("KB143", 1)]
    assert _codes("instance w of Wall { tilt = 90 deg  // expect: about right\n}\n") == [
        ("KB143", 1)
    ]


def test_the_compiler_checks_the_expected_tree() -> None:
    # nothing expected, yet an instance declared
    assert _codes("// expect: verdict nothing\ninstance w of Wall { }\n") == [("KB143", 2)]
    # a result expected: one goal instance, every instance below it
    assert _codes("// expect: verdict verified\ninstance w of Wall { }\n") == [("KB143", 1)]
    two = "instance h of House { fronts = w }\ninstance g of House { fronts = v }\n"
    walls = "instance w of Wall { }\ninstance v of Wall { }\n"
    assert _codes("// expect: verdict verified\n" + two + walls) == [("KB143", 3)]
    off = "instance h of House { fronts = w }\ninstance w of Wall { }\ninstance v of Wall { }\n"
    assert _codes("// expect: verdict verified\n" + off) == [("KB143", 4)]
    # an instance shared by two roles, or a cycle back to one above
    shared = "instance h of House { fronts = [w, w] }\ninstance w of Wall { }\n"
    assert _codes("// expect: verdict verified\n" + shared) == [("KB143", 2)]
    # a file without annotations is no expectation: instances are checked as always
    assert _codes("instance w of Wall { }\ninstance v of Wall { }\n") == []


def test_a_missing_knowledge_base_gives_no_cascade_of_annotation_errors() -> None:
    text = (
        'import "nowhere.kb"\n// expect: verdict verified\n'
        "// expect: reject body.roof of GableRoof by slopes\n"
        "instance h of House {\n    width = 3 m  // expect: +- 1 cm\n}\n"
        "// expect: bogus\n"
    )
    found = {(d.code, d.span.line) for d in compile_text(text, "t.kb").diagnostics}
    # the import and what it would have declared; of the annotations only the unreadable one
    assert ("KB901", 1) in found
    assert {c for c, _ in found} <= {"KB901", "KB100", "KB112", "KB143"}
    assert [line for c, line in found if c == "KB143"] == [7]
