"""A fixed handful of random scenes through the whole pipeline (benchmarks/robustness.py's
small brother): nothing wrong may be reported as verified."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from aida_kb.interpret.result import read_interpretation
from aida_kb.interpret.robustness import run_random_scene
from aida_kb.kb.model import KnowledgeBase

# (seed, kind): small images (256 px wide), at most two views, no supersampling
SCENES = ((112, "chessboard"), (133, "turntable"), (103, "gable"))


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
    assert outcomes[112].outcome in ("doubtful", "nothing")
    # a 0.3 m box: no house (walls below the knowledge's 2 m)
    assert outcomes[133].outcome == "nothing"
    assert outcomes[133].correct
