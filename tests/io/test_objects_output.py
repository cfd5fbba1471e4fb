"""Several objects per scene in the outputs: model.json, CityJSON (a Building per object),
the batch's CityJSONSeq (a feature per building) and its verdicts."""

from __future__ import annotations

import numpy as np

from aida_kb.batch.cityseq import _features
from aida_kb.batch.work import verdicts_of
from aida_kb.interpret.result import Interpretation, SceneObject
from aida_kb.io.export import cityjson_document
from aida_kb.io.model import ModelObject, ModelPart, ReconstructedModel


def _box(role: str, x0: float, width: float) -> list[ModelPart]:
    """A closed box [x0, x0 + width] x [0, 2] x [0, 2] under `role`, its faces' roles."""
    xs = (x0, x0 + width)
    c = {(i, j, k): (xs[i], 2.0 * j, 2.0 * k) for i in (0, 1) for j in (0, 1) for k in (0, 1)}
    faces = {
        "x0": ((-1, 0, 0), -x0, [(0, 0, 0), (0, 0, 1), (0, 1, 1), (0, 1, 0)]),
        "x1": ((1, 0, 0), x0 + width, [(1, 0, 0), (1, 1, 0), (1, 1, 1), (1, 0, 1)]),
        "y0": ((0, -1, 0), 0.0, [(0, 0, 0), (1, 0, 0), (1, 0, 1), (0, 0, 1)]),
        "y1": ((0, 1, 0), 2.0, [(0, 1, 0), (0, 1, 1), (1, 1, 1), (1, 1, 0)]),
        "z0": ((0, 0, -1), 0.0, [(0, 0, 0), (0, 1, 0), (1, 1, 0), (1, 0, 0)]),
        "z1": ((0, 0, 1), 2.0, [(0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]),
    }
    return [
        ModelPart(
            role=f"{role}.body.{name}",
            concept="Plane",
            normal=(float(n[0]), float(n[1]), float(n[2])),
            offset_m=d,
            polygon=[c[k] for k in poly],
        )
        for name, (n, d, poly) in faces.items()
    ]


def _terrace() -> ReconstructedModel:
    """Two touching boxes: the first's x1 face is the second's x0 (a party wall)."""
    return ReconstructedModel(
        parts=[*_box("houses[0]", 0.0, 3.0), *_box("houses[1]", 3.0, 2.0)],
        up=(0.0, 1.0, 0.0),
        objects=[
            ModelObject(role="houses[0]", concept="House", verdict="verified"),
            ModelObject(role="houses[1]", concept="House", verdict="doubtful"),
        ],
    )


def test_cityjson_has_a_building_per_object_even_touching() -> None:
    doc = cityjson_document(_terrace())
    buildings = {k: v for k, v in doc["CityObjects"].items() if v["type"] == "Building"}
    assert sorted(buildings) == ["building-0", "building-1"]
    assert buildings["building-0"]["attributes"]["aida-kb:verdict"] == "verified"
    assert buildings["building-1"]["attributes"]["aida-kb:verdict"] == "doubtful"
    assert buildings["building-1"]["attributes"]["aida-kb:object"] == "houses[1]"
    for b in buildings.values():  # each a closed box of six faces
        assert len(b["geometry"][0]["boundaries"][0]) == 6
    # one object: one building, as before
    single = _terrace().model_copy(update={"objects": []})
    assert [v["type"] for v in cityjson_document(single)["CityObjects"].values()].count(
        "Building"
    ) == 1


def test_city_sequence_has_a_feature_per_building() -> None:
    doc = cityjson_document(_terrace())
    vertices = np.asarray(doc["vertices"], dtype=np.int64)
    roots = [n for n, o in doc["CityObjects"].items() if "parents" not in o]
    features = _features(doc["CityObjects"], roots, vertices)
    assert [f[0] for f in features] == ["building-0", "building-1"]
    for root, members, own in features:
        assert list(members) == [root]
        rings = members[root]["geometry"][0]["boundaries"][0]
        used = {v for face in rings for ring in face for v in ring}
        assert used == set(range(len(own)))  # only its own vertices, renumbered
        # the same corners as in the scene's document
        original = doc["CityObjects"][root]["geometry"][0]["boundaries"][0]
        first = [vertices[v].tolist() for v in original[0][0]]
        assert [own[v] for v in rings[0][0]] == first
    # the party wall's corners are in both features
    assert len(features[0][2]) == 8
    assert len(features[1][2]) == 8


def test_batch_verdicts_one_per_object() -> None:
    model = _terrace()
    objects = [
        SceneObject(
            role=o.role, concept=o.concept, verdict=o.verdict, message=f"{o.role} m", expanded=3
        )
        for o in model.objects
    ]
    interp = Interpretation(
        goal="Street",
        accepted=True,
        message="m",
        model=model,
        expanded=6,
        verdict="doubtful",
        objects=objects,
    )
    verdicts = verdicts_of(interp)
    assert [(v.goal, v.verdict) for v in verdicts] == [
        ("House houses[0]", "verified"),
        ("House houses[1]", "doubtful"),
    ]
    one = interp.model_copy(update={"objects": [], "verdict": "verified"})
    assert [(v.goal, v.verdict) for v in verdicts_of(one)] == [("Street", "verified")]
