"""Measured length attributes of the knowledge (docs/language.md §3.10) are enforced: an object
whose closed model measures outside an attribute's range is rejected by that attribute, with
its declaration's line; with the range widened in the .kb text the same evidence is accepted.
No accepted object in a chessboard scene or the no-house fixture, and the reason names the
knowledge's line."""

from __future__ import annotations

import math
import re
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from aida_kb.interpret.run import interpret
from aida_kb.io.evidence import read_evidence
from aida_kb.kb import compile_text
from aida_kb.synth import buildings as bld
from aida_kb.synth.scenes import chessboard_spec

ROOT = Path(__file__).resolve().parents[2]
KB_LINE = re.compile(r"kb/buildings\.kb:(\d+):\d+")


def _doll_house(synthetic: ModuleType) -> Any:
    """The demo house at a tenth of its size (1.6 x 1.0 m, 0.9 m walls), seen from 3 m."""
    a = math.radians(-25.0)
    eye = np.array([3.0 * math.sin(a), 0.55, 3.0 * math.cos(a)])
    world = synthetic.place(bld.house(width=1.6, depth=1.0, height=0.9), eye, np.array([0, 0.5, 0]))
    return synthetic.to_evidence(synthetic.evidence_of(world, seed=1), scene="doll")


def _line(n: int) -> str:
    return (ROOT / "kb" / "buildings.kb").read_text(encoding="utf-8").splitlines()[n - 1]


def test_a_doll_house_is_rejected_by_the_knowledges_length_ranges(
    synthetic: ModuleType, buildings_kb: Any
) -> None:
    evidence = _doll_house(synthetic)
    got = interpret(buildings_kb, evidence, source="doll")
    assert not got.accepted
    assert "attribute depth of body" in got.message
    assert "outside its range [2 m, 60 m]" in got.message
    line = int(KB_LINE.search(got.message).group(1))  # type: ignore[union-attr]
    assert "attribute depth: length in [2 m, 60 m] is depth(self)" in _line(line)
    named = [h for h in got.trace if h.constraint == "HouseBody.depth"]
    assert named
    assert all(h.span is not None and h.span.line == line for h in named)
    # the same evidence with the ranges widened in the knowledge (not in code): a House
    text = (ROOT / "kb" / "buildings.kb").read_text(encoding="utf-8")
    text = text.replace("in [2 m, 60 m]", "in [0.5 m, 60 m]")
    text = text.replace("in [2 m, 100 m]", "in [0.5 m, 100 m]")
    text = text.replace("in [2 m, 30 m]", "in [0.5 m, 30 m]")
    widened = compile_text(text, "buildings.kb").kb
    assert widened is not None
    again = interpret(widened, evidence, source="doll")
    assert again.accepted, again.message
    assert again.model is not None
    depth = {p.role: p.offset_m for p in again.model.parts}
    assert len(depth) == 7  # the closed model: four walls, floor, two roof planes


def test_a_chessboard_and_the_no_house_fixture_are_no_house_and_the_reason_is_a_kb_line(
    synthetic: ModuleType, buildings_kb: Any
) -> None:
    board = synthetic.place(
        chessboard_spec({}, seed=0, views=1).model, np.array([0.0, 0.0, 1.5]), np.zeros(3)
    )
    chessboard = synthetic.to_evidence(synthetic.evidence_of(board, ground=False), scene="board")
    no_house = read_evidence(ROOT / "tests" / "fixtures" / "no_house.json")
    for name, evidence in (("board", chessboard), ("no_house", no_house)):
        got = interpret(buildings_kb, evidence, source=name)
        assert not got.accepted, name
        assert got.model is None
        line = KB_LINE.search(got.message)
        assert line is not None, got.message
        declared = _line(int(line.group(1))).strip()
        assert declared.startswith(("orient ", "attribute ", "constraint ")), declared


def test_a_shed_roof_is_a_tilted_plane_of_the_knowledge(
    synthetic: ModuleType, buildings_kb: Any
) -> None:
    """kb/buildings.kb orients a shed roof's plane forward tilted by its pitch: a mono-pitch
    house is a ShedRoof (it was a GableRoof with the back half missing when the knowledge said
    'upward'), and its closed model holds its seen planes."""
    a = math.radians(-25.0)
    eye = np.array([30.0 * math.sin(a), 5.5, 30.0 * math.cos(a)])
    world = synthetic.place(bld.house(roof="shed", pitch_deg=20.0), eye, np.array([0, 5, 0]))
    evidence = synthetic.to_evidence(synthetic.evidence_of(world, seed=1), scene="shed")
    got = interpret(buildings_kb, evidence, source="shed")
    assert got.accepted, got.message
    assert {i.role: i.concept for i in got.instances}["body.roof"] == "ShedRoof"
    assert got.model is not None
    top = next(p for p in got.model.parts if p.role == "body.roof.top")
    truth = world.face("body.roof.top").normal
    assert math.degrees(math.acos(float(np.dot(top.normal, truth)))) < 1.0


def test_a_scene_of_unknown_scale_is_not_judged_by_ranges_in_metres(
    synthetic: ModuleType, buildings_kb: Any
) -> None:
    """Lengths in unknown units (evidence.json ``units: unknown``, a scene up to scale): the
    doll house's 1 m depth may be 10 m; neither the search nor the verdict applies the
    knowledge's ranges in metres, while angles (slopes) still count."""
    from aida_kb.interpret.verdict import NOTHING, judge

    evidence = _doll_house(synthetic).model_copy(update={"units": "unknown"})
    got = interpret(buildings_kb, evidence, source="doll")
    assert got.accepted, got.message
    verdict = judge(buildings_kb, got, evidence)
    assert verdict.verdict != NOTHING
    assert not any(" m outside [" in r for r in verdict.reasons), verdict.reasons
    # the same evidence in metres: the sizes say it is no house
    metric = evidence.model_copy(update={"units": "m"})
    assert not interpret(buildings_kb, metric, source="doll").accepted
