"""The compiled model of buildings.kb: inheritance, overriding, expanded constraints, the net."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from aida_kb.kb import (
    CompileResult,
    ConstraintSpec,
    KnowledgeBase,
    build_net,
    compile_path,
    compile_text,
)

ROOT = Path(__file__).resolve().parents[2]
DEG = math.pi / 180


@pytest.fixture(scope="module")
def kb() -> KnowledgeBase:
    result = compile_path(ROOT / "kb" / "buildings.kb")
    assert isinstance(result, CompileResult)
    assert result.ok
    assert result.kb is not None
    return result.kb


def _spec(kb: KnowledgeBase, concept: str, label: str) -> list[ConstraintSpec]:
    return [s for s in kb.concepts[concept].constraints if s.label == label]


def test_layers_and_concepts(kb: KnowledgeBase) -> None:
    assert kb.layers == ("scene", "world", "image")
    assert kb.concepts["House"].layer == "scene"
    assert kb.concepts["Wall"].layer == "world"  # inherited from Plane
    assert kb.concepts["Contour"].layer == "image"
    assert kb.concepts["Roof"].abstract
    assert set(kb.concepts["Roof"].specialisations) == {
        "GableRoof",
        "AsymmetricGableRoof",
        "HipRoof",
        "FlatRoof",
        "ShedRoof",
    }
    assert kb.concrete_specialisations("Wing") == ("RightWing", "SkewWing")
    assert kb.is_a("SkewWing", "Wing")
    assert not kb.is_a("Wing", "SkewWing")


def test_inherited_members_know_where_they_come_from(kb: KnowledgeBase) -> None:
    wall = kb.concepts["Wall"]
    assert wall.con_ofs["region"].declared_in == "Plane"
    assert wall.con_ofs["region"].concept == "Region"
    assert (wall.con_ofs["region"].min, wall.con_ofs["region"].max) == (0, 1)
    tilt = wall.attributes["tilt"]
    assert tilt.declared_in == "Wall"
    assert tilt.unit == "rad"
    assert tilt.low == pytest.approx(85 * DEG)
    assert tilt.high == pytest.approx(95 * DEG)
    assert tilt.default == pytest.approx(90 * DEG)
    assert kb.concepts["Wall"].attributes["height"].high == pytest.approx(30.0)


def test_overriding_attribute_keeps_the_inherited_range(kb: KnowledgeBase) -> None:
    meeting = kb.concepts["SkewWing"].attributes["meeting"]
    assert meeting.declared_in == "SkewWing"
    assert meeting.default == pytest.approx(135 * DEG)
    assert meeting.low == pytest.approx(90 * DEG)
    wing_specs = [s.label for s in kb.concepts["RightWing"].constraints]
    assert wing_specs == [s.label for s in kb.concepts["Wing"].constraints]
    assert all(s.concept == "Wing" for s in kb.concepts["RightWing"].constraints)


def test_parts_and_cardinalities(kb: KnowledgeBase) -> None:
    body = kb.concepts["HouseBody"]
    assert set(body.parts) == {
        "front",
        "back",
        "left",
        "right",
        "floor",
        "roof",
        "oriels",
        "wings",
    }
    assert body.parts["roof"].concept == "Roof"
    oriels = body.parts["oriels"]
    assert (oriels.min, oriels.max, oriels.optional) == (0, None, True)
    assert (body.parts["wings"].min, body.parts["wings"].max) == (0, 4)


def test_template_expansion_in_si(kb: KnowledgeBase) -> None:
    (corner,) = _spec(kb, "HouseBody", "corner_fl")
    assert corner.kind == "angle"
    assert corner.args == ("front", "left")
    assert corner.value == pytest.approx(math.pi / 2)
    assert corner.unit == "rad"
    assert corner.sigma == pytest.approx(1 * DEG)  # the template's default tolerance
    assert corner.weight == pytest.approx(1 / (1 * DEG) ** 2)
    assert corner.reject_above is None
    assert not corner.measurement
    assert corner.concept == "HouseBody"
    assert corner.span.line > 0
    (ground,) = _spec(kb, "HouseBody", "ground")
    assert ground.weight == 10.0  # explicit weight wins
    (eaves,) = _spec(kb, "HouseBody", "eaves")
    assert eaves.kind == "parallel_edge"
    assert eaves.args == ("front", "roof.front", "back", "roof.back")
    assert eaves.sigma == pytest.approx(0.5 * DEG)
    (slopes,) = _spec(kb, "HouseBody", "slopes")
    assert slopes.kind == "symmetry"
    assert slopes.value is None


def test_paths_through_an_abstract_role_are_conditional(kb: KnowledgeBase) -> None:
    (eaves,) = _spec(kb, "HouseBody", "eaves")
    assert eaves.requires == (("roof", ("AsymmetricGableRoof", "GableRoof", "HipRoof")),)
    (top,) = _spec(kb, "HouseBody", "top_left")
    assert top.requires == (("roof", ("FlatRoof", "ShedRoof")),)
    (corner,) = _spec(kb, "HouseBody", "corner_fl")
    assert corner.requires == ()
    hips = [a for a in kb.concepts["HouseBody"].adjacencies if a.b == "roof.left"]
    assert hips[0].requires == (("roof", ("HipRoof",)),)


def test_values_from_attributes_expand_per_specialisation(kb: KnowledgeBase) -> None:
    meets = _spec(kb, "HouseBody", "wings_meet")
    by_concept = {s.requires[0][1]: s.value for s in meets}
    assert by_concept[("RightWing",)] == pytest.approx(90 * DEG)
    assert by_concept[("SkewWing",)] == pytest.approx(135 * DEG)
    assert all(s.args == ("front", "wings.front") for s in meets)


def test_measurements(kb: KnowledgeBase) -> None:
    (pos,) = kb.concepts["Region"].constraints
    assert pos.kind == "position"
    assert pos.args == ("self",)
    assert pos.measurement
    assert pos.unit == "px"
    assert pos.sigma == 1.0
    assert pos.reject_above == 4.0
    assert pos.label == "Region#1"
    edges = [s for s in kb.concepts["HouseBody"].constraints if s.kind == "edge"]
    assert [s.args for s in edges] == [("front", "left"), ("front", "roof.front")]
    assert all(s.measurement for s in edges)
    # the side edge is an image measure; the eave is measured at the object, in metres
    assert [(s.unit, s.sigma, s.reject_above) for s in edges] == [
        ("px", 1.0, 3.0),
        ("m", 0.1, 0.5),
    ]


def test_qualifiers_threshold_in_sigmas_and_units() -> None:
    text = (
        "layers scene > world > image\n"
        "concept W in world { }\n"
        "concept A in world { part f, l: W\n"
        "  constraint a: angle(f, l) == 90 deg +- 2 deg reject above 3\n"
        "  constraint b: parallel(f, l) +- 0.01 rad reject above 5 deg\n"
        "}\n"
    )
    result = compile_text(text, "q.kb")
    assert result.kb is not None
    a, b = result.kb.concepts["A"].constraints
    assert a.reject_above == pytest.approx(6 * DEG)  # 3 sigma
    assert b.sigma == pytest.approx(0.01)
    assert b.reject_above == pytest.approx(5 * DEG)


def test_measurement_units_follow_the_tolerance_or_else_the_threshold() -> None:
    text = (
        "layers scene > world > image\n"
        "concept R in image {\n"
        "  measure position(self) reject above 2 cm\n"
        "  measure position(self) +- 1 cm reject above 3\n"
        "  measure position(self) +- 2 px reject above 5 px\n"
        "}\n"
    )
    result = compile_text(text, "u.kb")
    assert result.kb is not None
    a, b, c = result.kb.concepts["R"].constraints
    assert (a.unit, a.sigma, a.reject_above) == ("m", None, pytest.approx(0.02))
    assert (b.unit, b.sigma, b.reject_above) == ("m", pytest.approx(0.01), pytest.approx(0.03))
    assert (c.unit, c.sigma, c.reject_above) == ("px", 2.0, 5.0)


def test_models_are_frozen(kb: KnowledgeBase) -> None:
    spec = kb.concepts["HouseBody"].constraints[0]
    with pytest.raises(Exception, match="frozen"):
        spec.value = 1.0  # type: ignore[misc]
    again = ConstraintSpec.model_validate(spec.model_dump())
    assert again == spec


def test_model_round_trips_through_json(kb: KnowledgeBase) -> None:
    text = kb.model_dump_json()
    back = KnowledgeBase.model_validate_json(text)
    assert back.concepts["HouseBody"].constraints == kb.concepts["HouseBody"].constraints
    assert KnowledgeBase.model_json_schema()["title"] == "KnowledgeBase"


def test_net(kb: KnowledgeBase) -> None:
    g = build_net(kb)
    assert g.nodes["House"]["kind"] == "concept"
    assert g.nodes["House"]["layer"] == "scene"
    kinds = {(u, v, d["kind"], d.get("role")) for u, v, d in g.edges(data=True)}
    assert ("House", "HouseBody", "con-of", "body") in kinds
    assert ("HouseBody", "Roof", "part-of", "roof") in kinds
    assert ("GableRoof", "Roof", "is-a", None) in kinds
    oriel = next(d for u, v, d in g.edges(data=True) if (u, v) == ("HouseBody", "Oriel"))
    assert (oriel["min"], oriel["max"]) == (0, None)


def test_instances_in_the_net() -> None:
    text = (
        "layers scene > world > image\n"
        "concept H in scene { con-of body: B }\n"
        "concept B in world { part front: W  con-of region: R [0..1] }\n"
        "concept W in world { attribute tilt: angle = 90 deg }\n"
        "concept R in image { measure position(self) }\n"
        'instance h1 of H { body = b1 }\ninstance b1 of B { front = w1  region = "v00/r3" }\n'
        "instance w1 of W { tilt = 89 deg }\n"
    )
    result = compile_text(text, "i.kb")
    assert result.ok, result.diagnostics
    assert result.kb is not None
    b1 = result.kb.instances["b1"]
    assert b1.bindings["front"].instances == ("w1",)
    assert b1.bindings["region"].evidence == ("v00/r3",)
    assert result.kb.instances["w1"].bindings["tilt"].value == pytest.approx(89 * DEG)
    g = build_net(result.kb)
    assert g.nodes["b1"]["kind"] == "instance"
    edges = {(u, v, d["kind"]) for u, v, d in g.edges(data=True)}
    assert ("b1", "B", "instance-of") in edges
    assert ("h1", "b1", "con-of") in edges
    assert ("b1", "w1", "part-of") in edges


def test_errors_mean_no_model() -> None:
    result = compile_text("layers a > b\nconcept X in c { }", "e.kb")
    assert not result.ok
    assert result.kb is None
    assert result.errors
    assert result.sources == {"e.kb": "layers a > b\nconcept X in c { }"}


def test_use_site_qualifiers_override_the_body_in_its_unit() -> None:
    text = (
        "layers scene > world > image\n"
        "template m(p: R) { position(p) +- 1 px }\n"
        "concept R in image { measure m(self) +- 3 px reject above 2 }\n"
        "concept Q is-a R { measure m(self) +- 3 deg }\n"
    )
    result = compile_text(text, "u.kb")
    bad = [(d.code, d.span.line, d.span.column) for d in result.diagnostics if d.is_error]
    assert bad == [("KB132", 4, 39)]
    result = compile_text(text.rsplit("concept Q", 1)[0], "u.kb")
    assert result.kb is not None
    (spec,) = result.kb.concepts["R"].constraints
    assert (spec.sigma, spec.reject_above, spec.unit) == (3.0, 6.0, "px")
    assert (spec.span.line, spec.span.column) == (3, 30)  # the use, not the template body


def test_narrowing_a_role_drops_the_conditional_members_that_no_longer_apply() -> None:
    text = (ROOT / "kb" / "buildings.kb").read_text(encoding="utf-8") + (
        "concept FlatHouseBody is-a HouseBody { part roof: FlatRoof }\n"
        "concept FlatHouse in scene { con-of body: FlatHouseBody }\n"
    )
    result = compile_text(text, "flat.kb")
    assert result.diagnostics == (), result.diagnostics
    assert result.kb is not None
    flat = result.kb.concepts["FlatHouseBody"]
    labels = {s.label: s for s in flat.constraints}
    assert "eaves" not in labels
    assert "slopes" not in labels
    assert labels["top_left"].requires == ()  # roof.top is now a member of the role's concept
    assert labels["corner_fl"].concept == "HouseBody"
    assert not any(a.b == "roof.front" for a in flat.adjacencies)
    assert any(a.b == "roof.top" for a in flat.adjacencies)
