"""Every semantic check fires on a minimal bad example, at the right line and column."""

from __future__ import annotations

from pathlib import Path

import pytest

from aida_kb.kb import compile_path, compile_text

ROOT = Path(__file__).resolve().parents[2]
H = "layers scene > world > image\n"
WARNINGS = {"KB300", "KB301", "KB302"}

# (name, text, code, line, column): the code must be reported exactly there; no other error.
CASES = [
    (
        "unknown-concept",
        H + "concept Wall in world { }\nconcept A in world { part x: Wal }",
        "KB100",
        3,
        30,
    ),
    ("unknown-parent", H + "concept A is-a Plan { }", "KB100", 2, 16),
    ("unknown-layer", H + "concept A in wrld { }", "KB101", 2, 14),
    (
        "unknown-role",
        H + "concept W in world { }\nconcept A in world { part front, left: W\n"
        " constraint parallel(front, lef) }",
        "KB102",
        4,
        29,
    ),
    (
        "unknown-role-in-path",
        H + "concept W in world { }\nconcept R in world { part a: W }\n"
        "concept A in world { part f: W\n part r: R\n adjacent pairs((f, r.b)) }",
        "KB102",
        6,
        23,
    ),
    (
        "unknown-relation",
        H + "concept W in world { }\nconcept A in world { part f, l: W\n"
        " constraint paralel(f, l) }",
        "KB103",
        4,
        13,
    ),
    (
        "unknown-instance",
        H + "concept W in world { }\nconcept A in world { part f: W }\ninstance a of A { f = w9 }",
        "KB104",
        4,
        23,
    ),
    ("unknown-type", H + "concept W in world { attribute t: angel }", "KB105", 2, 35),
    ("duplicate-definition", H + "concept A in world { }\nconcept A in world { }", "KB110", 3, 9),
    (
        "duplicate-template",
        H + "template t(a: W) { position(a) }\n"
        "template t(a: W) { position(a) }\nconcept W in world { }",
        "KB110",
        3,
        10,
    ),
    (
        "duplicate-member",
        H + "concept W in world { }\nconcept A in world { part f: W\n part f: W }",
        "KB111",
        4,
        7,
    ),
    (
        "duplicate-label",
        H + "concept W in world { }\nconcept A in world { part f, b: W\n"
        " constraint p: parallel(f, b)\n constraint p: parallel(b, f) }",
        "KB111",
        5,
        13,
    ),
    ("no-layers", "concept A in world { }", "KB112", 1, 1),
    ("two-layers", H + "layers a > b\nconcept A in world { }", "KB112", 2, 1),
    ("layer-conflict", H + "concept P in world { }\nconcept W in image is-a P { }", "KB113", 3, 14),
    (
        "isa-cycle",
        H + "concept A is-a C { }\nconcept B is-a A { }\nconcept C is-a B { }",
        "KB120",
        3,
        16,
    ),
    ("isa-self", H + "concept A in world is-a A { }", "KB120", 2, 25),
    (
        "part-cycle",
        H + "concept A in world { part b: B }\nconcept B in world { part a: A }",
        "KB121",
        3,
        27,
    ),
    (
        "conof-same-layer",
        H + "concept A in world { con-of r: R }\nconcept R in world { }",
        "KB122",
        2,
        32,
    ),
    (
        "conof-two-down",
        H + "concept A in scene { con-of r: R }\nconcept R in image { }",
        "KB122",
        2,
        32,
    ),
    ("part-layer", H + "concept A in world { part r: R }\nconcept R in image { }", "KB123", 2, 30),
    (
        "cardinality",
        H + "concept W in world { }\nconcept A in world { part w: W [3..2] }",
        "KB124",
        3,
        32,
    ),
    (
        "inherited-conflict",
        H + "concept W in world { }\nconcept V in world { }\n"
        "concept P in world { part x: W }\nconcept Q in world { part x: V }\n"
        "concept C is-a P, Q { }",
        "KB125",
        6,
        9,
    ),
    (
        "override-unrelated",
        H + "concept W in world { }\nconcept V in world { }\n"
        "concept P in world { part x: W }\nconcept C is-a P { part x: V }",
        "KB126",
        5,
        25,
    ),
    (
        "override-kind",
        H + "concept W in world { }\nconcept P in world { part x: W }\n"
        "concept C is-a P { attribute x: angle }",
        "KB126",
        4,
        30,
    ),
    (
        "only-trailing-defaults-may-be-left-out",
        H + "template t(v: angle = 90 deg, a: W, b: W) { angle(a, b) == v }\n"
        "concept W in world { }\nconcept A in world { part f, l: W\n constraint t(f, l) }",
        "KB130",
        5,
        13,
    ),
    (
        "arity",
        H + "template t(a: W, b: W) { parallel(a, b) }\nconcept W in world { }\n"
        "concept A in world { part f, l: W\n constraint t(f) }",
        "KB130",
        5,
        13,
    ),
    (
        "argument-type",
        H + "template t(a: W, b: W) { parallel(a, b) }\n"
        "concept W in world { }\nconcept V in world { }\n"
        "concept A in world { part f: W\n part l: V\n constraint t(f, l) }",
        "KB131",
        7,
        18,
    ),
    (
        "value-for-role",
        H + "concept W in world { attribute tilt: angle }\n"
        "concept A in world { part f, l: W\n constraint parallel(f, f.tilt) }",
        "KB131",
        4,
        25,
    ),
    (
        "unit-mismatch",
        H + "concept W in world { }\nconcept A in world { part f, l: W\n"
        " constraint angle(f, l) == 90 m }",
        "KB132",
        4,
        28,
    ),
    (
        "unit-missing",
        H + "concept W in world { }\nconcept A in world { part f, l: W\n"
        " constraint angle(f, l) == 90 }",
        "KB132",
        4,
        28,
    ),
    (
        "tolerance-unit",
        H + "concept W in world { }\nconcept A in world { part f, l: W\n"
        " constraint parallel(f, l) +- 2 cm }",
        "KB132",
        4,
        31,
    ),
    (
        "measurement-threshold-unit",
        H + "concept R in image { measure position(self) +- 1 px reject above 3 cm }",
        "KB132",
        2,
        66,
    ),
    ("attribute-unit", H + "concept W in world { attribute h: length = 3 deg }", "KB132", 2, 44),
    (
        "template-arg-unit",
        H + "template t(a: W, b: W, v: angle) { angle(a, b) == v }\n"
        "concept W in world { }\nconcept A in world { part f, l: W\n constraint t(f, l, 3 m) }",
        "KB132",
        5,
        21,
    ),
    (
        "out-of-range",
        H + "concept W in world { attribute t: angle in [85 deg, 95 deg] = 100 deg }",
        "KB133",
        2,
        63,
    ),
    (
        "empty-range",
        H + "concept W in world { attribute t: angle in [95 deg, 85 deg] }",
        "KB133",
        2,
        44,
    ),
    (
        "instance-out-of-range",
        H + "concept W in world { attribute t: angle in [85 deg, 95 deg] }\n"
        "instance w of W { t = 80 deg }",
        "KB133",
        3,
        23,
    ),
    (
        "edge-not-adjacent",
        H + "concept W in world { }\nconcept A in world { part f, l, b: W\n"
        " adjacent pairs((f, l))\n constraint parallel(edge(f, l), edge(f, b)) }",
        "KB134",
        5,
        34,
    ),
    (
        "edge-in-template-use",
        H + "template pe(a: W, b: W, c: W, d: W) "
        "{ parallel(edge(a, b), edge(c, d)) }\nconcept W in world { }\n"
        "concept A in world { part f, l, b: W\n adjacent ring(f, l, b)\n"
        " constraint pe(f, l, l, l) }",
        "KB134",
        6,
        13,
    ),
    (
        "malformed-angle",
        H + "concept W in world { }\nconcept A in world { part f, l: W\n constraint angle(f, l) }",
        "KB135",
        4,
        13,
    ),
    (
        "template-uses-itself",
        H + "template t(a: W) { t(a) }\nconcept W in world { }\n"
        "concept A in world { part f: W\n constraint t(f) }",
        "KB135",
        2,
        20,
    ),
    (
        "malformed-arity",
        H + "concept W in world { }\nconcept A in world { part f, l: W\n constraint parallel(f) }",
        "KB135",
        4,
        13,
    ),
    (
        "measure-internal",
        H + "concept W in world { }\nconcept A in world { part f, l: W\n measure parallel(f, l) }",
        "KB136",
        4,
        10,
    ),
    (
        "constraint-measurement",
        H + "concept R in image { constraint position(self) }",
        "KB136",
        2,
        33,
    ),
    (
        "zero-weight",
        H + "concept W in world { }\nconcept A in world { part f, l: W\n"
        " constraint parallel(f, l) weight 0 }",
        "KB137",
        4,
        35,
    ),
    (
        "threshold-without-sigma",
        H + "concept W in world { }\nconcept A in world { part f, l: W\n"
        " constraint parallel(f, l) reject above 3 }",
        "KB137",
        4,
        13,
    ),
    (
        "no-attribute-value",
        H + "concept W in world { }\n"
        "abstract concept G in world { part f: W  attribute m: angle }\n"
        "concept R is-a G { attribute m: angle = 90 deg }\nconcept S is-a G { }\n"
        "concept A in world { part f: W\n part g: G [0..*]\n"
        " constraint angle(f, g.f) == g.m }",
        "KB138",
        8,
        30,
    ),
    (
        "abstract-instance",
        H + "abstract concept W in world { }\ninstance w of W { }",
        "KB140",
        3,
        15,
    ),
    (
        "degenerate-ring",
        H + "concept W in world { }\nconcept A in world { part f: W\n adjacent ring(f) }",
        "KB139",
        4,
        2,
    ),
    ("unknown-instance-concept", H + "instance w of Wal { }", "KB100", 2, 15),
    (
        "missing-role",
        H + "concept W in world { }\nconcept A in world { part f: W }\ninstance a of A { }",
        "KB141",
        4,
        10,
    ),
    (
        "binding-wrong-concept",
        H + "concept W in world { }\nconcept V in world { }\n"
        "concept A in world { part f: W }\ninstance v of V { }\ninstance a of A { f = v }",
        "KB142",
        6,
        23,
    ),
    (
        "binding-too-many",
        H + "concept W in world { }\nconcept A in world { part f: W }\n"
        "instance w of W { }\ninstance a of A { f = [w, w] }",
        "KB142",
        5,
        23,
    ),
    (
        "expectation-unknown-verdict",
        H + "concept W in world { }\n// expect: verdict found",
        "KB143",
        3,
        1,
    ),
    (
        "unused-template",
        H + "template t(a: W, b: W) { parallel(a, b) }\nconcept W in scene { }",
        "KB300",
        2,
        10,
    ),
    (
        "orient-composite",
        H + "concept W in world { }\nconcept R in world { part a: W }\n"
        "concept A in world { part r: R\n orient r: upward }",
        "KB150",
        5,
        9,
    ),
    (
        "orient-twice",
        H + "concept W in world { }\nconcept A in world { part f: W\n orient f: forward\n"
        " orient f: backward }",
        "KB150",
        5,
        9,
    ),
    (
        "tilt-up",
        H + "concept W in world { }\nconcept A in world { part f: W\n"
        " orient f: upward tilted by 10 deg }",
        "KB150",
        4,
        29,
    ),
    (
        "frame-anchor-backward",
        H + "concept W in world { }\nconcept A in world { part f: W\n frame from f\n"
        " orient f: backward }",
        "KB151",
        4,
        13,
    ),
    (
        "unknown-measure",
        H + "concept W in world { attribute s: angle is slop(self) }",
        "KB152",
        2,
        44,
    ),
    (
        "measure-type",
        H + "concept W in world { attribute s: length is slope(self) }",
        "KB152",
        2,
        45,
    ),
    (
        "placement-composite",
        H + "concept W in world { }\nconcept R in world { part a: W }\n"
        "concept A in world { part f: W\n part r: R\n unseen r: at 2 m from f }",
        "KB153",
        6,
        9,
    ),
    (
        "placement-negative",
        H + "concept W in world { }\nconcept A in world { part f, b: W\n"
        " unseen b: at -2 m from f }",
        "KB153",
        4,
        15,
    ),
    (
        "attach-plane",
        H + "concept W in world { }\nconcept A in world { part f, b: W\n attach b: backward in f }",
        "KB154",
        4,
        9,
    ),
    (
        "when-unrelated",
        H + "concept W in world { }\nconcept A in world { part f, b: W\n when b is A { } }",
        "KB155",
        4,
        12,
    ),
    (
        "when-member",
        H + "concept W in world { }\nconcept A in world { part f, b: W\n"
        " when b is W { part c: W } }",
        "KB155",
        4,
        16,
    ),
    (
        "share-one",
        H + "concept W in world { }\nconcept R in world { part t: W }\n"
        "concept F is-a R { }\nconcept G in world { part r: R }\n"
        "concept K in scene { con-of g: G }\n"
        "concept S in scene { part k: K\n touching k share g.r }",
        "KB156",
        8,
        11,
    ),
    (
        "share-plane",
        H + "concept W in world { }\nconcept G in world { part f: W }\n"
        "concept K in scene { con-of g: G }\nconcept S in scene { part ks: K [0..*]\n"
        " touching ks share g.f }",
        "KB156",
        6,
        20,
    ),
    ("unreachable", H + "concept H in scene { }\nconcept W in world { }", "KB301", 3, 9),
    (
        "unverifiable",
        H + "concept H in scene { con-of w: W }\nconcept W in world { }",
        "KB302",
        3,
        9,
    ),
]


@pytest.mark.parametrize(
    ("text", "code", "line", "column"),
    [c[1:] for c in CASES],
    ids=[c[0] for c in CASES],
)
def test_check_fires_at_the_right_place(text: str, code: str, line: int, column: int) -> None:
    result = compile_text(text, "bad.kb")
    found = [(d.code, d.span.line, d.span.column) for d in result.diagnostics]
    assert (code, line, column) in found, result.diagnostics
    others = [d for d in result.diagnostics if d.is_error and d.code != code]
    assert not others, others
    if code not in WARNINGS:
        assert not result.ok
        assert result.kb is None


def test_every_semantic_code_has_a_case() -> None:
    from aida_kb.diagnostics import codes

    covered = {c[2] for c in CASES}
    # KB400-KB499 are notes of an interpretation, not of the compiler (tests/cli, tests/kb's
    # explanations check them)
    semantic = {c for c in codes.REGISTRY if "KB100" <= c < "KB400"} - {"KB399"}
    assert semantic <= covered, semantic - covered


def test_cycle_message_shows_the_whole_cycle() -> None:
    text = H + "concept A is-a C { }\nconcept B is-a A { }\nconcept C in world is-a B { }"
    (d,) = [d for d in compile_text(text, "x.kb").diagnostics if d.code == "KB120"]
    assert d.message == "is-a cycle: A is-a C is-a B is-a A"
    assert len(d.related) == 3


def test_duplicate_points_at_the_first_definition() -> None:
    text = H + "concept A in world { }\nconcept A in world { }"
    (d,) = [d for d in compile_text(text, "x.kb").diagnostics if d.code == "KB110"]
    assert d.related[0][0].line == 2
    assert d.related[0][1] == "first defined here"


def test_did_you_mean() -> None:
    text = H + "concept Wall in world { }\nconcept A in world { part x: Wal }"
    (d,) = [d for d in compile_text(text, "x.kb").diagnostics if d.code == "KB100"]
    assert d.hint == "did you mean 'Wall'?"


def test_buildings_is_clean() -> None:
    result = compile_path(ROOT / "kb" / "buildings.kb")
    assert result.diagnostics == ()
    assert result.kb is not None


def test_imports_missing_and_cyclic(tmp_path: Path) -> None:
    (tmp_path / "a.kb").write_text('import "b.kb"\n' + H + "concept A in scene { }\n")
    (tmp_path / "b.kb").write_text('import "a.kb"\nimport "nope.kb"\n')
    result = compile_path(tmp_path / "a.kb")
    got = {(d.code, d.span.file.rsplit("/", 1)[-1], d.span.line) for d in result.diagnostics}
    assert ("KB902", "b.kb", 1) in got
    assert ("KB901", "b.kb", 2) in got
    cyc = next(d for d in result.diagnostics if d.code == "KB902")
    chain = [w.rsplit("/", 1)[-1] for w in cyc.message.split(": ", 1)[1].split(" imports ")]
    assert chain == ["a.kb", "b.kb", "a.kb"]


def test_imports_share_names_and_search_paths(tmp_path: Path) -> None:
    lib = tmp_path / "lib"
    lib.mkdir()
    (lib / "walls.kb").write_text(
        "concept Wall in world { con-of r: Region }\n"
        "concept Region in image { measure position(self) }\n"
    )
    (tmp_path / "main.kb").write_text(
        'import "walls.kb"\n' + H + "concept House in scene { con-of w: Wall }\n"
    )
    assert not compile_path(tmp_path / "main.kb").ok
    result = compile_path(tmp_path / "main.kb", search_paths=[str(lib)])
    assert result.ok, result.diagnostics
    assert result.kb is not None
    assert set(result.kb.concepts) == {"Wall", "Region", "House"}
    assert len(result.sources) == 2


def test_unreadable_root_is_a_diagnostic(tmp_path: Path) -> None:
    result = compile_path(tmp_path / "missing.kb")
    assert [d.code for d in result.diagnostics] == ["KB900"]
    (tmp_path / "latin.kb").write_bytes(b"concept \xe9 in world { }")
    assert [d.code for d in compile_path(tmp_path / "latin.kb").diagnostics] == ["KB900"]


def test_internal_errors_become_diagnostics(monkeypatch: pytest.MonkeyPatch) -> None:
    import aida_kb.kb.check as check

    def boom(table: object) -> list[object]:
        raise RuntimeError("boom")

    monkeypatch.setattr(check, "run_checks", boom)
    result = compile_text(H + "concept A in scene { }", "x.kb")
    assert [d.code for d in result.diagnostics] == ["KB399"]
    assert "boom" in result.diagnostics[0].message
    assert result.kb is None


def _adjacency_diags(body: str) -> list[tuple[str, int, int, str]]:
    text = (
        H + "concept W in world { }\n"
        "concept A in world {\n part f, l, r: W\n part posts: W [2..4]\n"
        " optional part canopy: W\n" + body + "\n}"
    )
    result = compile_text(text, "adj.kb")
    return [
        (d.code, d.span.line, d.span.column, d.message) for d in result.diagnostics if d.is_error
    ]


@pytest.mark.parametrize(
    ("body", "column", "message"),
    [
        ("adjacent ring(f)", 1, "ring(f) declares no edge: a ring needs at least three parts"),
        (
            "adjacent ring(f, l)",
            1,
            "ring(f, l) declares one edge twice: a ring needs at least three parts",
        ),
        (
            "adjacent ring(f, l, f)",
            21,
            "'f' is repeated in the ring: a ring passes each plane once",
        ),
        (
            "adjacent ring(f, posts, r)",
            18,
            "'posts' has up to 4 fillers: a ring entry must be one plane",
        ),
        (
            "adjacent pairs((f, l), (r, r))",
            28,
            "'r' is paired with itself: a plane is not adjacent to itself",
        ),
    ],
    ids=["one-part", "two-parts", "repeated", "multi-filler", "self-pair"],
)
def test_degenerate_adjacency_is_kb139(body: str, column: int, message: str) -> None:
    assert _adjacency_diags(body) == [("KB139", 7, column, message)]


@pytest.mark.parametrize(
    "body",
    [
        "adjacent ring(f, l, r)",
        "adjacent ring(f, canopy, r)",  # optional: the ring is open where it is absent
        "adjacent pairs((f, posts), (l, canopy))",  # each post; the canopy when present
    ],
    ids=["ring-of-three", "ring-with-optional", "pairs-with-several-fillers"],
)
def test_legal_adjacency_has_no_diagnostic(body: str) -> None:
    assert _adjacency_diags(body) == []
