"""From the compiled buildings.kb to a solved problem, with no per-concept glue."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from aida_kb.constraints import EdgeData, PositionData
from aida_kb.errors import SolveError
from aida_kb.geometry.polygon import intersect_planes
from aida_kb.kb import compile_path
from aida_kb.kb.model import KnowledgeBase
from aida_kb.solve.from_kb import constraints_from_kb, problem_from_kb
from aida_kb.solve.solver import solve
from aida_kb.testing.houses import SyntheticScene, house_row, perturbed

KB = Path(__file__).resolve().parents[2] / "kb" / "buildings.kb"


@pytest.fixture(scope="module")
def kb() -> KnowledgeBase:
    result = compile_path(KB)
    assert result.kb is not None, result.diagnostics
    return result.kb


@pytest.fixture(scope="module")
def scene() -> SyntheticScene:
    return house_row(1, seed=0, evidence_angle_deg=0.03, evidence_offset_m=0.01)


def _inputs(scene: SyntheticScene) -> tuple[dict[str, int], dict[int, PositionData]]:
    assignment = {n.removeprefix("h0.body."): i for i, n in enumerate(scene.names)}
    positions = {}
    for c in scene.constraints:
        if c.position is not None:  # pixels per metre at 30 m with f = 1000 px; 3 m regions
            positions[c.parts[0]] = replace(c.position, px_per_m=33.0, radius_m=3.0)
    return assignment, positions


def test_constraints_follow_the_knowledge(kb: KnowledgeBase, scene: SyntheticScene) -> None:
    assignment, positions = _inputs(scene)
    fillers = {"roof": "HipRoof", "wings[0]": "SkewWing"}
    found = constraints_from_kb(kb, "HouseBody", assignment, fillers=fillers, positions=positions)
    labels = {c.label: c for c in found.constraints}
    corner = labels[".:corner_fl(front, left)"]
    assert corner.parts == (assignment["front"], assignment["left"])
    assert corner.value == pytest.approx(math.pi / 2)
    # a role with several fillers stands for each of them
    assert ".:oriels_aligned(front, oriels[0].front)" in labels
    assert ".:oriels_aligned(front, oriels[1].front)" in labels
    assert "oriels[1]:Oriel#2(oriels[1].front, oriels[1].right)" in labels
    # requires: the skew wing's 135 degrees apply, the right wing's 90 are skipped
    meet = labels[".:wings_meet(front, wings[0].front)"]
    assert meet.value == pytest.approx(math.radians(135))
    assert any("requires wings[0] to be RightWing" in s for s in found.skipped)
    assert any(s.startswith(".:top_left") for s in found.skipped)  # no flat roof
    # every region evidence becomes a position constraint of the part it is con-of
    pos = [c for c in found.constraints if c.kind == "position"]
    front = next(c for c in pos if c.parts == (assignment["front"],))
    assert front.label == "front.region:Region#1(front.region)"
    assert front.unit == "px"
    assert front.measurement
    # edges without image segments are skipped, with segments they are constraints
    assert any("HouseBody#1(front, left): no image segment" in s for s in found.skipped)
    seg = EdgeData(0, (10.0, 20.0), (30.0, 200.0))
    pair = (assignment["front"], assignment["left"])
    with_edge = constraints_from_kb(
        kb, "HouseBody", assignment, fillers=fillers, positions=positions, edges={pair: [seg]}
    )
    edge = next(c for c in with_edge.constraints if c.kind == "edge")
    assert edge.parts == pair
    assert edge.edge == seg
    assert edge.reject_above == pytest.approx(3.0)


@pytest.mark.parametrize(("wing", "rejected"), [("SkewWing", False), ("RightWing", True)])
def test_kb_problem_solves_and_rejects_the_wrong_wing(
    kb: KnowledgeBase, scene: SyntheticScene, wing: str, rejected: bool
) -> None:
    assignment, positions = _inputs(scene)
    n0, d0 = perturbed(scene, seed=1, angle_deg=3.0, offset_m=0.3)
    problem, found = problem_from_kb(
        kb,
        "HouseBody",
        assignment,
        n0,
        d0,
        centres=scene.centres,
        fillers={"roof": "HipRoof", "wings[0]": wing},
        positions=positions,
    )
    assert problem.names[assignment["roof.front"]] == "roof.front"
    result = solve(problem)
    meet = result.report.by_label(".:wings_meet(front, wings[0].front)")
    assert meet.rejected is rejected
    if not rejected:
        assert not result.report.exceeding
        # parts the knowledge constrains are restored (the synthetic wing floor, oriel tops,
        # ... are not parts of the concepts, so they stay where they started)
        used = {p for c in found.constraints for p in c.parts}
        rows = [k for k, t in enumerate(scene.vertex_planes) if set(t.tolist()) <= used]
        v = intersect_planes(
            result.normals[scene.vertex_planes[rows]], result.offsets[scene.vertex_planes[rows]]
        )
        err = np.max(np.linalg.norm(v - scene.vertices[rows], axis=1))
        assert len(rows) >= 15
        assert err < 0.01 * scene.size


def test_unknown_concepts_are_errors(kb: KnowledgeBase) -> None:
    with pytest.raises(SolveError, match="unknown concept 'Castle'"):
        constraints_from_kb(kb, "Castle", {"front": 0})
    with pytest.raises(SolveError, match="unknown concept 'Pagoda'"):
        constraints_from_kb(
            kb, "HouseBody", {"front": 0, "roof.front": 1}, fillers={"roof": "Pagoda"}
        )
