"""Parts no view shows: placed where the knowledge allows, and named as not measured."""

from __future__ import annotations

import math
from types import ModuleType

import numpy as np
import pytest

from aida_kb.interpret.run import interpret
from aida_kb.interpret.verdict import DOUBTFUL, judge
from aida_kb.kb.model import KnowledgeBase
from aida_kb.synth import buildings as bld

NOISE = {"normal_noise_deg": 0.5, "offset_noise_m": 0.03, "pixel_noise": 0.3}


def test_a_front_seen_alone_is_a_doubtful_house_of_the_least_depth(
    synthetic: ModuleType, generate: ModuleType, buildings_kb: KnowledgeBase
) -> None:
    """A flat-roofed house 16 m wide seen straight on from eye height: the front wall and the
    ground, nothing of its sides, back or roof. The back wall stood on the front's own
    points (a body 0 m deep that closes no solid: nothing found); now it lies at the least
    depth the knowledge allows (HouseBody's depth in [2 m, 60 m]) and the verdict says that
    the back, the sides and the roof are placed by the knowledge, not measured. Without the
    least extent, `aida_kb.interpret.unseen.least_extents`, this evidence gave nothing."""
    world = synthetic.place(
        bld.house(roof="flat"), generate.eye(0.0, 25.0, 1.5), np.array([0.0, 4.0, 0.0])
    )
    evidence = synthetic.to_evidence(synthetic.evidence_of(world, seed=1, **NOISE))
    assert len(evidence.views[0].regions) == 2  # the front and the ground
    interp = interpret(buildings_kb, evidence, goal="House")
    assert interp.accepted
    assert interp.model is not None
    parts = {p.role: p for p in interp.model.parts}
    front, back = parts["body.front"], parts["body.back"]
    n = np.asarray(front.normal)
    depth = float(np.max(np.asarray(back.polygon) @ -n)) + front.offset_m
    assert depth == pytest.approx(2.0, abs=0.05)
    width = np.ptp(np.asarray(front.polygon)[:, 0])
    assert width == pytest.approx(16.0, rel=0.02)
    # the flat roof's top, seen nowhere and turning freely about the measured eave, stays as
    # the knowledge orients it (verify.orientation_priors): it came out 27 degrees steep
    top, floor = np.asarray(parts["body.roof.top"].normal), np.asarray(parts["body.floor"].normal)
    assert math.degrees(math.acos(min(1.0, float(-top @ floor)))) < 1.0
    verdict = judge(buildings_kb, interp, evidence)
    assert verdict.verdict == DOUBTFUL
    text = "; ".join(verdict.reasons)
    for role in ("body.back", "body.left", "body.right"):
        assert f"{role} is placed by the knowledge, not measured" in text
