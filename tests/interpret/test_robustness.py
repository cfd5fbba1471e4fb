"""A fixed handful of random scenes through the whole pipeline (benchmarks/robustness.py's
small brother): nothing wrong may be reported as verified."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from aida_kb.interpret.result import read_interpretation
from aida_kb.interpret.robustness import run_random_scene
from aida_kb.kb.model import KnowledgeBase

# (seed, kind): small images (256 px wide), at most two views, no supersampling
SCENES = ((149, "chessboard"), (133, "turntable"), (103, "gable"))


def test_no_wrong_result_is_verified(
    buildings_kb: KnowledgeBase, tmp_path: Path, check_interpretation_kb: Any
) -> None:
    outcomes = {
        seed: run_random_scene(
            buildings_kb, seed, tmp_path, max_views=2, max_width=256, supersample=1
        )
        for seed, _ in SCENES
    }
    assert [outcomes[s].kind for s, _ in SCENES] == [k for _, k in SCENES]
    assert not any(o.wrong_accepted for o in outcomes.values())
    # each result also as instances (interpretation.kb), lint clean, matching the JSON
    for seed, _ in SCENES:
        out = tmp_path / f"out-{seed}"
        interp = read_interpretation(out / "interpretation.json")
        check_interpretation_kb(out / "interpretation.kb", buildings_kb, interp)
    # a chessboard on a stand is no house: never verified (the planar board is doubted)
    assert outcomes[149].outcome in ("doubtful", "nothing")
    # a 0.3 m box: no house (walls below the knowledge's 2 m)
    assert outcomes[133].outcome == "nothing"
    assert outcomes[133].correct


def test_a_random_tower_is_reconstructed_with_the_knowledge_it_names(
    buildings_kb: KnowledgeBase, tmp_path: Path
) -> None:
    """The tower kind names kb/tower.kb: given the knowledge by name, the scene is searched for
    a Tower (its truth's object), not a House; never verified wrong."""
    from aida_kb.kb import compile_path

    asked: list[str] = []

    def knowledge(name: str) -> KnowledgeBase:
        asked.append(name)
        result = compile_path(Path(__file__).resolve().parents[2] / "kb" / name)
        assert result.kb is not None
        return result.kb

    outcome = run_random_scene(
        buildings_kb,
        101,
        tmp_path,
        max_views=2,
        max_width=256,
        supersample=1,
        knowledge=knowledge,
    )
    assert outcome.kind == "tower"
    assert asked == ["tower.kb"]
    interp = read_interpretation(tmp_path / "out-101" / "interpretation.json")
    assert interp.goal == "Tower"
    assert outcome.figures["expected_object"] is True
    assert not outcome.wrong_accepted
