"""Faces inside another solid of the model are no surface of the object
(`aida_kb.interpret.verdict.geometry.enclosed_parts`), and the object's centre that a
verification's planes turn about (`aida_kb.interpret.verify.object_centre`)."""

from __future__ import annotations

import numpy as np

from aida_kb.constraints import Constraint, PositionData
from aida_kb.interpret.verdict.geometry import enclosed_parts
from aida_kb.interpret.verify import object_centre
from aida_kb.io.model import ReconstructedModel
from tests.interpret.test_touching import _box


def _model(*boxes: tuple[str, float, float, float, float]) -> ReconstructedModel:
    """Boxes 6 m tall (`test_touching._box`: role, x0, x1, z0, z1 in metres)."""
    return ReconstructedModel(parts=[p for box in boxes for p in _box(*box)])


def test_a_wing_end_inside_the_body_is_enclosed_and_nothing_else() -> None:
    # the wing (x 4..8) runs out of the body's front (z 8) to z 14; its back end lies at z 4
    body = ("a", 0.0, 10.0, 0.0, 8.0)
    assert enclosed_parts(_model(body, ("wing", 4.0, 8.0, 4.0, 14.0))) == {"wing.body.back"}


def test_a_wing_end_outside_the_body_is_no_enclosed_face() -> None:
    # the wing passes through the body and out of its back (z 0): its end is a surface
    body = ("a", 0.0, 10.0, 0.0, 8.0)
    assert enclosed_parts(_model(body, ("wing", 4.0, 8.0, -2.0, 14.0))) == frozenset()


def test_boxes_side_by_side_enclose_nothing() -> None:
    assert enclosed_parts(_model(("a", 0.0, 10.0), ("b", 12.0, 20.0))) == frozenset()


def _position(centre: tuple[float, float, float], weight: float) -> Constraint:
    return Constraint(
        kind="position",
        parts=(0,),
        position=PositionData(n_init=(0.0, 0.0, 1.0), c_init=centre, w_c=weight),
    )


def test_object_centre_is_the_weighted_mean_of_the_measured_region_centres() -> None:
    cons = [_position((0.0, 0.0, 50.0), 1.0), _position((4.0, 2.0, 50.0), 3.0)]
    np.testing.assert_allclose(object_centre(cons), [3.0, 1.5, 50.0])
    assert object_centre([]) is None


def _flush(z0: float) -> set[tuple[str, str]]:
    """The edges of house a (x 0..10) that house b (x 10..20, `z0` deeper set) makes flush."""
    from aida_kb.interpret.verdict.edges import flush_edges
    from aida_kb.register.model import RigidModel

    own = _box("a", 0.0, 10.0)
    rigid = RigidModel.from_model(
        ReconstructedModel(parts=[*own, *_box("b", 10.0, 20.0, z0, 8.0 + z0)])
    )
    index = np.flatnonzero((rigid.edge_faces < len(own)).all(axis=1))
    flush = flush_edges(rigid, len(own), index)
    return {
        tuple(sorted(rigid.names[int(f)].rsplit(".", 1)[1] for f in rigid.edge_faces[k]))
        for k in index[flush]
    }


def test_a_party_wall_makes_the_edges_across_it_flush_where_the_fronts_go_on() -> None:
    # terrace in one line: the front, back, floor and top go on across a's right wall
    assert _flush(0.0) == {
        ("front", "right"),
        ("back", "right"),
        ("floor", "right"),
        ("right", "top"),
    }
    # b set 3 m back: a's front ends at a corner the image shows; back, floor, top go on
    # no further than b's overlapping part, which still holds the edges' midpoints
    assert ("front", "right") not in _flush(3.0)
