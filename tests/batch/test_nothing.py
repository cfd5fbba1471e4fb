"""A result the verdict rejects is no result: no model files, and a batch counts no object."""

from __future__ import annotations

from pathlib import Path

import pytest

from aida_kb.batch.work import found_objects
from aida_kb.interpret import pipeline
from aida_kb.interpret.result import read_interpretation
from aida_kb.interpret.verdict import NOTHING, Verdict


def test_an_object_judged_nothing_publishes_no_model(
    tiny_houses: Path, kb: object, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The house is found and adjusted, then judged `nothing` (as an object whose sizes lie
    outside the knowledge's ranges is): the interpretation says why, no model file is
    written, and the batch's count of objects is 0."""
    reason = "body.front: height = 175 m outside [2, 30] (Wall)"
    monkeypatch.setattr(pipeline, "judge", lambda *a, **k: Verdict(NOTHING, (reason,), (), ()))
    out = tmp_path / "out"
    result = pipeline.reconstruct_scene(kb, tiny_houses / "house1", out)  # type: ignore[arg-type]
    interp = read_interpretation(out / "interpretation.json")
    assert interp.accepted  # the search accepted it; the verdict did not
    assert interp.verdict == NOTHING
    assert reason in interp.message
    assert sorted(p.name for p in out.iterdir()) == [
        "evidence.json",
        "interpretation.json",
        "interpretation.kb",
    ]
    assert found_objects(result.interpretation) == 0
    kept = result.interpretation.model_copy(update={"verdict": "verified"})
    assert found_objects(kept) == 1
