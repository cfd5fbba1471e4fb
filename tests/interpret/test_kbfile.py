"""interpretation.kb: the result as instances that import the knowledge base and lint clean."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

from aida_kb.interpret.kbfile import (
    INSERTED_DOC,
    VERDICT_DOC,
    instance_name,
    interpretation_kb,
    write_interpretation_kb,
)
from aida_kb.interpret.result import INSERTED, Interpretation, read_interpretation
from aida_kb.interpret.verdict import measured_attributes
from aida_kb.kb import compile_path, compile_text
from aida_kb.kb.model import KnowledgeBase

KB = Path(__file__).resolve().parents[2] / "kb" / "buildings.kb"
FIXTURES = [
    "house_correct.json",
    "house_asymmetric_roof.json",
    "house_occluded.json",
    "wing_90.json",
    "wing_135.json",
    "oriel.json",
    "no_house.json",
]


def check_written(path: Path, kb: KnowledgeBase, interp: Interpretation) -> None:
    """`path` lints clean with the knowledge base's folder as import path, and its
    instances are `interp`'s: concepts, bindings, inserted parts, measured values."""
    result = compile_path(path, search_paths=[str(KB.parent)])
    assert not result.diagnostics, [d.message for d in result.diagnostics]
    assert result.kb is not None
    declared = result.kb.instances
    text = path.read_text(encoding="utf-8")
    verdict = interp.verdict or ("not judged" if interp.accepted else "nothing")
    assert f"// verdict: {verdict}\n" in text
    if not interp.accepted:
        assert declared == {}
        return
    # walk the written instances from the goal down, rebuilding the role paths
    goal = instance_name("", interp.goal)
    assert declared[goal].doc is not None
    assert declared[goal].doc.startswith(VERDICT_DOC)
    found: dict[str, tuple[str, str | None]] = {}  # role path -> (concept, doc)
    evidence: dict[str, list[str]] = {}  # role path of an image-layer instance -> ids
    values: dict[tuple[str, str], float] = {}
    todo = [("", goal)]
    while todo:
        role, name = todo.pop()
        inst = declared[name]
        found[role] = (inst.concept, inst.doc)
        concept = kb.concepts[inst.concept]
        for b in inst.bindings.values():
            path_of = f"{role}.{b.role}" if role else b.role
            if b.value is not None:
                values[(role, b.role)] = b.value
                continue
            slot = concept.parts.get(b.role) or concept.con_ofs.get(b.role)
            assert slot is not None
            if b.evidence:
                evidence[path_of] = list(b.evidence)
            several = slot.max != 1
            todo += [
                (f"{path_of}[{i}]" if several else path_of, child)
                for i, child in enumerate(b.instances)
            ]
    image = kb.layers[-1]
    expected = {i.role: i for i in interp.instances if kb.concepts[i.concept].layer != image}
    assert {r: c for r, (c, _) in found.items()} == {r: i.concept for r, i in expected.items()}
    for role, inst in expected.items():
        inserted = (found[role][1] or "").endswith(INSERTED_DOC)
        assert inserted == (INSERTED in inst.bindings), role
    bound = {i.role: i.bindings for i in interp.instances if kb.concepts[i.concept].layer == image}
    assert evidence == bound
    assert interp.model is not None
    measured = measured_attributes(kb, interp, interp.model)
    assert measured
    for inst, attr, value in measured:
        # written to 0.01 deg or 1 mm; values outside the range stay in a comment
        tol = math.radians(0.006) if attr.unit == "rad" else 6e-4
        assert abs(values[(inst.role, attr.name)] - value) <= tol, (inst.role, attr.name)


@pytest.mark.parametrize("name", FIXTURES)
def test_interpretation_kb_of_each_fixture_lints_clean_and_matches_the_json(
    name: str, interpreted: Any, buildings_kb: Any, tmp_path: Path
) -> None:
    interp = interpreted(name)
    out = tmp_path / "out" / "interpretation.kb"
    write_interpretation_kb(out, buildings_kb, interp, KB)
    assert 'import "../../' in out.read_text(encoding="utf-8")  # relative to the folder
    check_written(out, buildings_kb, interp)


def test_interpretation_kb_is_deterministic_and_marks_doubts(
    interpreted: Any, buildings_kb: Any
) -> None:
    interp = interpreted("oriel.json")
    text = interpretation_kb(buildings_kb, interp, "kb/buildings.kb")
    assert text == interpretation_kb(buildings_kb, interp, "kb/buildings.kb")
    assert "instance body_oriels_1_front of Wall {" in text
    assert "oriels = [body_oriels_0, body_oriels_1]" in text
    # a doubtful result: the doubts in the header, the verdict in the goal's doc string; a
    # measured value outside its range is a comment, not a binding (the file stays clean)
    assert interp.model is not None
    wall = next(p for p in interp.model.parts if p.role == "body.front")
    tall = [[x, y * 40.0, z] for x, y, z in wall.polygon]  # 40 times as high: out of range
    model = interp.model.model_copy(
        update={
            "parts": [
                p.model_copy(update={"polygon": tall}) if p.role == "body.front" else p
                for p in interp.model.parts
            ]
        }
    )
    doubtful = interp.model_copy(
        update={"verdict": "doubtful", "doubts": ["body.front: height too large"], "model": model}
    )
    text = interpretation_kb(buildings_kb, doubtful, "buildings.kb")
    assert "// doubt: body.front: height too large" in text
    assert '"verdict: doubtful"' in text
    assert "// measured height = " in text
    # checked as if it lay beside the knowledge base (the file is not written there)
    checked = compile_text(text, str(KB.parent / "doubtful_interpretation.kb"))
    assert [d.message for d in checked.diagnostics] == []


def test_reconstruct_of_the_demo_house_writes_interpretation_kb(
    demo_run: Any, buildings_kb: Any
) -> None:
    folder = demo_run.root / "model"
    interp = read_interpretation(folder / "interpretation.json")
    check_written(folder / "interpretation.kb", buildings_kb, interp)


def test_instance_names_are_identifiers() -> None:
    assert instance_name("", "House") == "house"
    assert instance_name("body.oriels[12].front", "House") == "body_oriels_12_front"
