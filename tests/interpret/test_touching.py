"""What touching objects of a scene share (kb/street.kb: ``touching houses share body.roof``,
`interpret.scene.shared_choices`, `confirmed_choices`, `alike_doubts`), on hand-built scenes."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from aida_kb.constraints import compile_blocks
from aida_kb.interpret.party import touching_ties
from aida_kb.interpret.result import Instance, Interpretation, SceneObject
from aida_kb.interpret.scene import alike_doubts, confirmed_choices, shared_choices, touching
from aida_kb.io.model import ModelPart, ReconstructedModel
from aida_kb.kb.compiler import compile_path
from aida_kb.kb.model import KnowledgeBase

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def kb() -> KnowledgeBase:
    kb = compile_path(ROOT / "kb" / "street.kb").kb
    assert kb is not None
    return kb


def _box(role: str, x0: float, x1: float, z0: float = 0.0, z1: float = 8.0) -> list[ModelPart]:
    """A house's body as a box (world frame, y up, m): x0..x1 wide, z0..z1 deep, 6 m tall."""
    y0, y1 = 0.0, 6.0
    faces = {
        "front": ((0.0, 0.0, 1.0), [(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)]),
        "back": ((0.0, 0.0, -1.0), [(x0, y0, z0), (x0, y1, z0), (x1, y1, z0), (x1, y0, z0)]),
        "left": ((-1.0, 0.0, 0.0), [(x0, y0, z0), (x0, y0, z1), (x0, y1, z1), (x0, y1, z0)]),
        "right": ((1.0, 0.0, 0.0), [(x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (x1, y0, z1)]),
        "floor": ((0.0, -1.0, 0.0), [(x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)]),
        "roof.top": ((0.0, 1.0, 0.0), [(x0, y1, z0), (x0, y1, z1), (x1, y1, z1), (x1, y1, z0)]),
    }
    return [
        ModelPart(
            role=f"{role}.body.{name}",
            concept="Wall",
            normal=n,
            offset_m=n[0] * poly[0][0] + n[1] * poly[0][1] + n[2] * poly[0][2],
            polygon=poly,
        )
        for name, (n, poly) in faces.items()
    ]


def _scene(
    houses: list[tuple[float, float, str, list[str], str, list[str]]], z0: float = 0.0
) -> Interpretation:
    """Houses (x0, x1, roof kind, ties, verdict, shared) in a row, touching where their x
    ranges meet; the second one `z0` metres deeper set when given."""
    parts: list[ModelPart] = []
    instances = [
        Instance(role="", concept="Street", instance_of="Street", parent=None, link="goal")
    ]
    objects = []
    for k, (x0, x1, roof, ties, verdict, shared) in enumerate(houses):
        role = f"houses[{k}]"
        shift = z0 if k == 1 else 0.0
        parts += _box(role, x0, x1, shift, 8.0 + shift)
        instances.append(
            Instance(
                role=f"{role}.body.roof",
                concept=roof,
                instance_of="Roof",
                parent=None,
                link="part-of",
            )
        )
        objects.append(
            SceneObject(
                role=role,
                concept="House",
                verdict=verdict,
                message=f"house {k}",
                expanded=1,
                evidence=[f"00/{k}"],
                ties=ties,
                shared=shared,
            )
        )
    return Interpretation(
        goal="Street",
        accepted=True,
        message="",
        instances=instances,
        model=ReconstructedModel(parts=parts),
        objects=objects,
        expanded=1,
    )


def test_houses_sharing_a_party_wall_touch_free_standing_ones_do_not() -> None:
    row = _scene(
        [
            (0, 10, "GableRoof", [], "verified", []),
            (10.4, 20, "GableRoof", [], "verified", []),
            (24, 34, "GableRoof", [], "verified", []),
        ]
    )
    assert row.model is not None
    assert touching(row.model, "houses[0]", "houses[1]")  # party walls 0.4 m apart
    assert not touching(row.model, "houses[1]", "houses[2]")  # a 4 m gap
    behind = _scene(
        [(0, 10, "GableRoof", [], "verified", []), (10, 20, "GableRoof", [], "verified", [])],
        z0=-14.0,
    )
    assert behind.model is not None
    assert not touching(behind.model, "houses[0]", "houses[1]")  # in line, but 14 m back


def test_a_tie_takes_the_touching_neighbours_decided_choice_along_the_terrace(
    kb: KnowledgeBase,
) -> None:
    tie = ["body.roof=GableRoof"]
    row = _scene(
        [
            (0, 10, "GableRoof", [], "doubtful", []),
            (10, 20, "ShedRoof", tie, "doubtful", []),
            (20, 30, "ShedRoof", tie, "doubtful", []),
            (34, 44, "FlatRoof", [], "doubtful", []),
        ]
    )
    chosen = shared_choices(kb, row)
    assert set(chosen) == {"houses[1]", "houses[2]"}
    assert chosen["houses[1]"].choices == frozenset(tie)
    assert chosen["houses[1]"].regions == frozenset({"00/1"})
    assert "touching houses[0] has it" in chosen["houses[1]"].reason
    assert "touching houses[1] has it" in chosen["houses[2]"].reason  # along the terrace
    assert "street.kb:" in chosen["houses[2]"].reason
    # neighbours decided otherwise on either side: the knowledge does not choose
    split = _scene(
        [
            (0, 10, "GableRoof", [], "doubtful", []),
            (10, 20, "ShedRoof", tie, "doubtful", []),
            (20, 30, "HipRoof", [], "doubtful", []),
        ]
    )
    assert shared_choices(kb, split) == {}


def test_a_choice_already_made_is_confirmed_by_its_touching_neighbour(kb: KnowledgeBase) -> None:
    row = _scene(
        [
            (0, 10, "GableRoof", [], "doubtful", []),
            (10, 20, "GableRoof", ["body.roof=ShedRoof"], "doubtful", []),
        ]
    )
    done = confirmed_choices(kb, row)
    assert done.objects[0] == row.objects[0]
    assert done.objects[1].ties == []
    assert done.objects[1].shared == ["body.roof=GableRoof"]
    assert "the knowledge decided body.roof=GableRoof over body.roof=ShedRoof" in (
        done.objects[1].message
    )
    # nothing to confirm when the neighbour is tied there too
    tied = _scene(
        [
            (0, 10, "GableRoof", ["body.roof=ShedRoof"], "doubtful", []),
            (10, 20, "GableRoof", ["body.roof=ShedRoof"], "doubtful", []),
        ]
    )
    assert confirmed_choices(kb, tied) is tied


def test_touching_objects_filled_otherwise_or_resting_on_a_doubt_are_doubtful(
    kb: KnowledgeBase,
) -> None:
    both = _scene(
        [(0, 10, "GableRoof", [], "verified", []), (10, 20, "ShedRoof", [], "verified", [])]
    )
    judged = alike_doubts(kb, both, list(both.objects))
    assert [o.verdict for o in judged] == ["doubtful", "doubtful"]
    assert "touching houses[1]'s is a ShedRoof" in judged[0].doubts[0]
    taken = ["body.roof=GableRoof"]
    on_verified = _scene(
        [(0, 10, "GableRoof", [], "verified", []), (10, 20, "GableRoof", [], "verified", taken)]
    )
    assert alike_doubts(kb, on_verified, list(on_verified.objects)) == list(on_verified.objects)
    on_doubt = _scene(
        [(0, 10, "GableRoof", [], "doubtful", []), (10, 20, "GableRoof", [], "verified", taken)]
    )
    judged = alike_doubts(kb, on_doubt, list(on_doubt.objects))
    assert judged[1].verdict == "doubtful"
    assert "no touching object verified on its own evidence has it" in judged[1].doubts[-1]
    # free-standing houses of different roofs: nothing to say
    apart = _scene(
        [(0, 10, "GableRoof", [], "verified", []), (15, 25, "ShedRoof", [], "verified", [])]
    )
    assert alike_doubts(kb, apart, list(apart.objects)) == list(apart.objects)


def test_a_terrace_ties_each_party_wall_into_one_plane_and_measures_how_far_apart() -> None:
    row = _scene(
        [
            (0, 10, "GableRoof", [], "verified", []),
            (10.3, 20, "GableRoof", [], "verified", []),
            (20, 30, "GableRoof", [], "verified", []),
            (34, 44, "GableRoof", [], "verified", []),  # free-standing: 4 m on
        ]
    )
    assert row.model is not None
    names = [p.role for p in row.model.parts]
    ties = touching_ties(row.model, [o.role for o in row.objects], names)
    assert sorted((names[c.parts[0]], names[c.parts[1]]) for c in ties) == [
        ("houses[0].body.right", "houses[1].body.left"),
        ("houses[1].body.right", "houses[2].body.left"),
    ]
    normals = np.array([p.normal for p in row.model.parts], dtype=np.float64)
    offsets = np.array([p.offset_m for p in row.model.parts], dtype=np.float64)
    (block,) = compile_blocks(ties, len(names), 0)
    r = block.evaluate(normals, offsets, [])[0]  # (2, 4): rad x3, m
    np.testing.assert_allclose(r[:, :3], 0.0, atol=1e-12)  # parallel, facing each other
    np.testing.assert_allclose(np.abs(r[:, 3]), [0.3, 0.0], atol=1e-12)  # 0.3 m apart, or one
    # turned 1 deg about the vertical, the middle house's party wall is off by that much
    i = names.index("houses[1].body.left")
    turn = math.radians(1.0)
    normals[i] = (-math.cos(turn), 0.0, math.sin(turn))
    r = block.evaluate(normals, offsets, [])[0]
    assert math.degrees(float(np.linalg.norm(r[0, :3]))) == pytest.approx(1.0, abs=1e-9)
    # no names for the faces (an adjustment of other parts): no tie
    assert touching_ties(row.model, [o.role for o in row.objects], names[:6]) == []
