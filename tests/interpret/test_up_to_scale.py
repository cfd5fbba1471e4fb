"""A scene known up to scale only: the summary line and the model say so."""

from __future__ import annotations

from aida_kb.interpret.pipeline import UP_TO_SCALE, up_to_scale
from aida_kb.interpret.result import Interpretation
from aida_kb.io.model import ModelPart, ReconstructedModel


def test_up_to_scale_is_said_in_the_summary_and_the_model() -> None:
    part = ModelPart(
        role="body.front",
        concept="Wall",
        normal=(0.0, 0.0, -1.0),
        offset_m=-10.0,
        polygon=[(-1.0, -1.0, 10.0), (1.0, -1.0, 10.0), (1.0, 1.0, 10.0)],
    )
    interp = Interpretation(
        goal="House",
        accepted=True,
        message="House verified",
        model=ReconstructedModel(parts=[part]),
        expanded=1,
    )
    assert interp.model is not None
    assert interp.model.units == "m"
    marked = up_to_scale(interp)
    assert marked.message == f"House verified [{UP_TO_SCALE}]"
    assert "up to scale" in marked.message
    assert marked.model is not None
    assert marked.model.units == "unknown"
    assert marked.model.parts == interp.model.parts
