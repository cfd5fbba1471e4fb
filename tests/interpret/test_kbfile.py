"""interpretation.kb: the result as instances that import the knowledge base and lint clean."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from aida_kb.interpret.kbfile import instance_name, interpretation_kb, write_interpretation_kb
from aida_kb.interpret.result import read_interpretation

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


@pytest.mark.parametrize("name", FIXTURES)
def test_interpretation_kb_of_each_fixture_lints_clean_and_matches_the_json(
    name: str, interpreted: Any, buildings_kb: Any, check_interpretation_kb: Any, tmp_path: Path
) -> None:
    interp = interpreted(name)
    out = tmp_path / "out" / "interpretation.kb"
    write_interpretation_kb(out, buildings_kb, interp, KB)
    assert 'import "../../' in out.read_text(encoding="utf-8")  # relative to the folder
    check_interpretation_kb(out, buildings_kb, interp)


def test_interpretation_kb_is_deterministic_and_marks_doubts(
    interpreted: Any, buildings_kb: Any, check_interpretation_kb: Any, tmp_path: Path
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
    out = tmp_path / "interpretation.kb"
    write_interpretation_kb(out, buildings_kb, doubtful, KB)
    check_interpretation_kb(out, buildings_kb, doubtful)


def test_reconstruct_of_the_demo_house_writes_interpretation_kb(
    demo_run: Any, buildings_kb: Any, check_interpretation_kb: Any
) -> None:
    folder = demo_run.root / "model"
    interp = read_interpretation(folder / "interpretation.json")
    check_interpretation_kb(folder / "interpretation.kb", buildings_kb, interp)


def test_instance_names_are_identifiers() -> None:
    assert instance_name("", "House") == "house"
    assert instance_name("body.oriels[12].front", "House") == "body_oriels_12_front"


def test_instance_names_avoid_the_knowledge_bases_own_instances(
    interpreted: Any, buildings_kb: Any
) -> None:
    from aida_kb.kb import compile_text

    source = KB.read_text(encoding="utf-8") + "\ninstance body of Floor { }\n"
    kb = buildings_kb.model_copy(
        update={"instances": compile_text(source, str(KB)).kb.instances}  # type: ignore[union-attr]
    )
    text = interpretation_kb(kb, interpreted("house_correct.json"), "buildings.kb")
    assert "instance body_2 of HouseBody {" in text
    assert "    body = body_2" in text
