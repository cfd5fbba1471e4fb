"""'when' blocks: relations that hold only for one kind of part (docs/language.md §3.13)."""

from __future__ import annotations

from pathlib import Path

from aida_kb.dsl.format import format_source
from aida_kb.kb import compile_text

ROOT = Path(__file__).resolve().parents[2]
BUILDINGS = (ROOT / "kb" / "buildings.kb").read_text(encoding="utf-8")


def _adjacency(kb_text: str, concept: str) -> dict[tuple[str, str], tuple[object, ...]]:
    result = compile_text(kb_text, "b.kb")
    assert result.kb is not None, result.diagnostics
    return {(a.a, a.b): a.requires for a in result.kb.concepts[concept].adjacencies}


def test_each_roof_kind_meets_the_walls_its_own_way() -> None:
    adj = _adjacency(BUILDINGS, "HouseBody")
    two_slopes = ("roof", ("AsymmetricGableRoof", "GableRoof", "HipRoof"))
    gables = ("roof", ("AsymmetricGableRoof", "GableRoof"))
    assert adj[("left", "roof.front")] == (two_slopes, gables)
    assert adj[("left", "roof.left")] == (("roof", ("HipRoof",)),)
    assert adj[("front", "roof.front")] == (two_slopes,)
    assert adj[("front", "roof.top")] == (("roof", ("FlatRoof", "ShedRoof")),)
    assert adj[("front", "floor")] == ()


def test_block_conditions_reach_constraints_measures_and_placements() -> None:
    result = compile_text(BUILDINGS, "b.kb")
    assert result.kb is not None
    body = result.kb.concepts["HouseBody"]
    labels = {s.label: s for s in body.constraints}
    assert ("roof", ("FlatRoof", "ShedRoof")) in labels["top_left"].requires
    assert ("roof", ("GableRoof", "HipRoof")) in labels["slopes"].requires
    assert labels["corner_fl"].requires == ()
    # the asymmetric gable's slopes may differ: neither symmetric nor mirrored about the ridge
    # (the block's condition and that of the paths through the abstract role both hold)
    assert ("roof", ("AsymmetricGableRoof", "GableRoof", "HipRoof")) in labels["eaves"].requires
    (back,) = [p for p in body.placements if p.part == "back"]
    assert ("roof", ("GableRoof", "HipRoof")) in back.requires
    assert ("roof", ("AsymmetricGableRoof", "GableRoof", "HipRoof")) in back.requires


def test_narrowing_keeps_the_blocks_that_hold_and_drops_the_others() -> None:
    text = BUILDINGS + (
        "concept HipBody is-a HouseBody { part roof: HipRoof }\n"
        "concept HipHouse in scene { con-of body: HipBody }\n"
    )
    adj = _adjacency(text, "HipBody")
    assert adj[("left", "roof.left")] == ()  # every filler is a HipRoof: unconditional
    assert ("left", "roof.front") not in adj  # the gable block cannot hold
    assert ("front", "roof.top") not in adj


def test_unrelated_concept_and_members_are_kb155() -> None:
    text = (
        "layers scene > world > image\n"
        "concept F in world { }\n"
        "abstract concept C in world { }\n"
        "concept R is-a C { part a, b: F }\n"
        "concept L is-a C { part t: F }\n"
        "concept B in world {\n"
        "    part f: F\n"
        "    part c: C\n"
        "    when c is L { adjacent pairs((f, c.a)) }\n"
        "    when c is R, F { adjacent pairs((f, c.a)) }\n"
        "}\n"
    )
    found = [(d.code, d.span.line, d.span.column) for d in compile_text(text, "c.kb").diagnostics]
    assert ("KB155", 9, 19) in found  # c.a is R's: never holds for L
    assert ("KB155", 10, 18) in found  # F cannot fill c
    assert [d for d in found if d[0] != "KB155" and not d[0].startswith("KB30")] == []


def test_format_lays_out_a_block_one_level_deeper() -> None:
    text = (
        "layers scene > world > image\n"
        "concept A in world { part x, y: A\n"
        "when x is A { adjacent pairs((x, y))  // why\n"
        "constraint parallel(x, y) +- 1 deg }\n"
        "when y is A {} }\n"
    )
    out = format_source(text).text
    assert out == (
        "layers scene > world > image\n\n"
        "concept A in world {\n"
        "    part x, y: A\n"
        "    when x is A {\n"
        "        adjacent pairs((x, y))  // why\n"
        "        constraint parallel(x, y) +- 1 deg\n"
        "    }\n"
        "    when y is A {}\n"
        "}\n"
    )
    assert not format_source(out).changed


def test_the_editor_follows_names_inside_a_block() -> None:
    from lsprotocol import types

    from aida_kb.lsp import features
    from aida_kb.lsp.analysis import Analysis
    from aida_kb.lsp.convert import uri_of_path

    path = ROOT / "kb" / "buildings.kb"
    uri = uri_of_path(str(path))
    a = Analysis(uri, BUILDINGS)
    lines = BUILDINGS.split("\n")
    row = next(i for i, line in enumerate(lines) if "adjacent pairs((left, roof.left)" in line)
    column = lines[row].index("roof.left") + len("roof.")
    (found,) = features.definition(a, uri, types.Position(row, column))
    declared = lines[found.range.start.line]
    assert "part front, back, left, right: RoofPlane" in declared  # HipRoof's part
    head = next(i for i, line in enumerate(lines) if line.strip() == "when roof is HipRoof {")
    column = lines[head].index("HipRoof")
    (found,) = features.definition(a, uri, types.Position(head, column))
    assert lines[found.range.start.line].startswith("concept HipRoof is-a Roof")
