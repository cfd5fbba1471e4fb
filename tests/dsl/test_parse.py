"""Every construct of the language parses into the expected AST, with exact spans."""

from __future__ import annotations

from pathlib import Path

import pytest

from aida_kb.diagnostics.core import Span
from aida_kb.dsl import ast, grammar_path, parse

ROOT = Path(__file__).resolve().parents[2]


def _one(text: str) -> ast.Item:
    result = parse(text, "t.kb")
    assert result.diagnostics == ()
    assert len(result.module.items) == 1
    return result.module.items[0]


def _concept(body: str) -> ast.Concept:
    item = _one("concept C in world {\n" + body + "\n}")
    assert isinstance(item, ast.Concept)
    return item


def test_grammar_file_is_found() -> None:
    assert grammar_path().is_file()
    assert grammar_path().name == "kb.lark"


def test_layers() -> None:
    item = _one("layers scene > world > image")
    assert isinstance(item, ast.Layers)
    assert [n.text for n in item.names] == ["scene", "world", "image"]
    assert item.span == Span("t.kb", 1, 1, 1, 29)
    assert item.names[1].span == Span("t.kb", 1, 16, 1, 21)


def test_import() -> None:
    item = _one('\n  import "walls/basic.kb"')
    assert isinstance(item, ast.Import)
    assert item.path.value == "walls/basic.kb"
    assert item.span == Span("t.kb", 2, 3, 2, 26)


def test_template_with_typed_params_and_defaults() -> None:
    text = (
        "template perp(a: Plane, b: Plane, tol: angle = 1 deg) {\n"
        '  "Doc."\n  angle(a, b) == 90 deg +- tol\n}'
    )
    item = _one(text)
    assert isinstance(item, ast.Template)
    assert item.name.text == "perp"
    assert item.doc == "Doc."
    assert [(p.name.text, p.type.text) for p in item.params] == [
        ("a", "Plane"),
        ("b", "Plane"),
        ("tol", "angle"),
    ]
    assert item.params[0].default is None
    default = item.params[2].default
    assert isinstance(default, ast.Quantity)
    assert (default.value, default.unit) == (1.0, "deg")
    (rel,) = item.body
    assert isinstance(rel.body, ast.Comparison)
    assert isinstance(rel.body.lhs, ast.Call)
    assert rel.body.lhs.func.text == "angle"
    assert isinstance(rel.body.rhs, ast.Quantity)
    assert rel.body.rhs.value == 90.0
    assert isinstance(rel.tolerance, ast.Path)
    assert rel.tolerance.dotted == "tol"
    assert rel.span == Span("t.kb", 3, 3, 3, 31)
    assert item.span == Span("t.kb", 1, 1, 4, 2)


def test_template_without_params() -> None:
    item = _one("template t() { parallel(x, y) }")
    assert isinstance(item, ast.Template)
    assert item.params == ()
    assert isinstance(item.body[0].body, ast.Call)


def test_concept_header_forms() -> None:
    result = parse(
        'abstract concept P in world { "A plane." "More." }\n'
        "concept W is-a P, Q {}\n"
        "concept X in world is-a P {}",
        "t.kb",
    )
    assert result.diagnostics == ()
    p, w, x = result.module.concepts
    assert p.abstract
    assert p.layer is not None
    assert p.layer.text == "world"
    assert p.doc == "A plane.More."
    assert p.parents == ()
    assert not w.abstract
    assert w.layer is None
    assert [n.text for n in w.parents] == ["P", "Q"]
    assert w.parents[1].span == Span("t.kb", 2, 19, 2, 20)
    assert x.layer is not None
    assert [n.text for n in x.parents] == ["P"]
    assert p.span == Span("t.kb", 1, 1, 1, 51)


def test_parts_cardinality_and_optional() -> None:
    c = _concept(
        "part front, back: Wall\noptional part oriels: Oriel [0..*]\npart w: Wing [2]\n"
        "part r: Roof [1..4]"
    )
    a, b, d, e = c.parts
    assert [r.text for r in a.roles] == ["front", "back"]
    assert a.concept.text == "Wall"
    assert not a.optional
    assert a.cardinality is None
    assert a.span == Span("t.kb", 2, 1, 2, 23)
    assert b.optional
    assert b.cardinality is not None
    assert (b.cardinality.min, b.cardinality.max) == (0, None)
    assert b.cardinality.span == Span("t.kb", 3, 29, 3, 35)
    assert b.span == Span("t.kb", 3, 1, 3, 35)
    assert d.cardinality is not None
    assert (d.cardinality.min, d.cardinality.max) == (2, 2)
    assert e.cardinality is not None
    assert (e.cardinality.min, e.cardinality.max) == (1, 4)


def test_con_of() -> None:
    c = _concept("con-of region: Region [0..1]")
    (co,) = c.con_ofs
    assert (co.role.text, co.concept.text) == ("region", "Region")
    assert co.cardinality is not None
    assert co.cardinality.max == 1
    assert co.span == Span("t.kb", 2, 1, 2, 29)


def test_attribute_with_range_and_default() -> None:
    c = _concept("attribute tilt: angle in [85 deg, 1.6 rad] = 90deg\nattribute h: length")
    tilt, h = c.attributes
    assert (tilt.name.text, tilt.type.text) == ("tilt", "angle")
    assert tilt.range is not None
    low, high = tilt.range.low, tilt.range.high
    assert isinstance(low, ast.Quantity)
    assert (low.value, low.unit) == (85.0, "deg")
    assert isinstance(high, ast.Quantity)
    assert (high.value, high.unit) == (1.6, "rad")
    assert isinstance(tilt.default, ast.Quantity)
    assert tilt.default.text == "90deg"
    assert tilt.default.unit == "deg"
    assert tilt.range.span == Span("t.kb", 2, 26, 2, 43)
    assert h.range is None
    assert h.default is None


def test_adjacency_ring_and_pairs() -> None:
    c = _concept("adjacent ring(a, b, c)\nadjacent pairs((a, roof.front), (b, c))")
    ring, pairs = c.adjacencies
    assert ring.kind == "ring"
    assert [(x.dotted, y.dotted) for x, y in ring.edges] == [("a", "b"), ("b", "c"), ("c", "a")]
    assert pairs.kind == "pairs"
    assert [(x.dotted, y.dotted) for x, y in pairs.edges] == [("a", "roof.front"), ("b", "c")]
    assert pairs.groups[0][1].parts[1].span == Span("t.kb", 3, 25, 3, 30)


def test_constraints_with_qualifiers_and_labels() -> None:
    c = _concept(
        "constraint perpendicular(front, left)\n"
        "constraint eaves: parallel(edge(a, roof.front), edge(b, roof.back)) +- 0.5 deg\n"
        "constraint angle(a, b) == angle(c, d) weight 2 reject above 3 deg\n"
        "constraint parallel(a, b) reject above 2 +- 1 mm"
    )
    k1, k2, k3, k4 = c.constraints
    assert k1.label is None
    assert isinstance(k1.relation.body, ast.Call)
    assert k1.relation.body.func.text == "perpendicular"
    assert k1.span == Span("t.kb", 2, 1, 2, 38)
    assert k2.label is not None
    assert k2.label.text == "eaves"
    body = k2.relation.body
    assert isinstance(body, ast.Call)
    assert len(body.args) == 2
    edge0 = body.args[0]
    assert isinstance(edge0, ast.Call)
    assert edge0.func.text == "edge"
    assert str(edge0) == "edge(a, roof.front)"
    assert isinstance(k2.relation.tolerance, ast.Quantity)
    assert k2.relation.tolerance.value == 0.5
    assert isinstance(k3.relation.body, ast.Comparison)
    assert isinstance(k3.relation.weight, ast.Number)
    assert k3.relation.weight.value == 2.0
    assert isinstance(k3.relation.reject, ast.Quantity)
    assert k3.relation.reject.unit == "deg"
    assert k3.relation.tolerance is None
    assert isinstance(k4.relation.reject, ast.Number)
    assert isinstance(k4.relation.tolerance, ast.Quantity)
    assert k4.relation.tolerance.unit == "mm"


def test_measures() -> None:
    c = _concept("measure position(self) +- 1 px\nmeasure edge(edge(a, b))")
    m1, m2 = c.measures
    assert isinstance(m1.relation.body, ast.Call)
    assert m1.relation.body.func.text == "position"
    assert m1.span == Span("t.kb", 2, 1, 2, 31)
    assert isinstance(m2.relation.body, ast.Call)
    inner = m2.relation.body.args[0]
    assert isinstance(inner, ast.Call)
    assert inner.func.text == "edge"


def test_instance_bindings() -> None:
    item = _one(
        'instance h1 of House {\n  body = b1\n  region = "v00/r17"\n'
        '  xs = [a, "e2"]\n  tilt = 89 deg\n}'
    )
    assert isinstance(item, ast.Instance)
    assert (item.name.text, item.concept.text) == ("h1", "House")
    body, region, xs, tilt = item.bindings
    assert isinstance(body.value, ast.Path)
    assert body.value.dotted == "b1"
    assert body.span == Span("t.kb", 2, 3, 2, 12)
    assert isinstance(region.value, ast.String)
    assert region.value.value == "v00/r17"
    assert isinstance(xs.value, ast.ListExpr)
    assert len(xs.value.items) == 2
    assert isinstance(tilt.value, ast.Quantity)


def test_numbers_strings_and_comments() -> None:
    text = (
        "// line comment\n/* block\n comment */\n"
        'concept C in world { "say \\"hi\\"" attribute a: number = -1.5e-3 }'
    )
    result = parse(text, "t.kb")
    assert result.diagnostics == ()
    (c,) = result.module.concepts
    assert c.doc == 'say "hi"'
    default = c.attributes[0].default
    assert isinstance(default, ast.Number)
    assert default.value == pytest.approx(-1.5e-3)
    assert c.span.line == 4


def test_keyword_followed_number_is_not_a_unit() -> None:
    c = _concept("constraint parallel(a, b) weight 2 reject above 3")
    rel = c.constraints[0].relation
    assert isinstance(rel.weight, ast.Number)
    assert isinstance(rel.reject, ast.Number)


def test_next_binding_on_the_same_line_is_not_a_unit() -> None:
    item = _one('instance w of W { "A wall." n = 2  k = 3 deg  m = 4 kk = 5 }')
    assert isinstance(item, ast.Instance)
    assert item.doc == "A wall."
    n, k, m, kk = item.bindings
    assert [b.role.text for b in item.bindings] == ["n", "k", "m", "kk"]
    assert isinstance(n.value, ast.Number)
    assert n.value.span == Span("t.kb", 1, 33, 1, 34)
    assert isinstance(k.value, ast.Quantity)
    assert (k.value.value, k.value.unit) == (3.0, "deg")
    assert isinstance(m.value, ast.Number)
    assert isinstance(kk.value, ast.Number)


def test_unknown_unit_is_still_reported_as_a_unit() -> None:
    result = parse("instance w of W { n = 2 degs }", "t.kb")
    assert [d.code for d in result.diagnostics] == ["KB003"]
    assert result.diagnostics[0].span == Span("t.kb", 1, 25, 1, 29)


def test_buildings_kb_parses_cleanly() -> None:
    path = ROOT / "kb" / "buildings.kb"
    result = parse(path.read_text(encoding="utf-8"), str(path))
    assert result.diagnostics == ()
    names = {c.name.text for c in result.module.concepts}
    for needed in (
        "House",
        "HouseBody",
        "Wall",
        "Floor",
        "Roof",
        "GableRoof",
        "HipRoof",
        "FlatRoof",
        "ShedRoof",
        "Oriel",
        "Wing",
        "Region",
        "Contour",
    ):
        assert needed in names
    assert [n.text for n in result.module.layers[0].names] == ["scene", "world", "image"]


def test_empty_and_comment_only_files() -> None:
    for text in ("", "   \n", "// nothing\n"):
        result = parse(text, "e.kb")
        assert result.diagnostics == ()
        assert result.module.items == ()
