"""The geometry members in the compiled model: frames, orientations, measures, placements,
attachments (docs/language.md §3.9-3.12), and the shipped knowledge bases that use them."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from aida_kb.kb import compile_path, compile_text

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = sorted((ROOT / "kb").glob("*.kb"))

TEXT = """layers scene > world > image
concept Plane in world { }
concept Slope is-a Plane { attribute pitch: angle in [0 deg, 60 deg] = 35 deg is slope(self) }
concept Wall is-a Plane {
    attribute tilt: angle in [85 deg, 95 deg] = 90 deg is slope(self) +- 0.5 deg
}
concept Roof in world { }
concept Gable is-a Roof {
    part front, back: Slope
    orient front: forward tilted by front.pitch
    orient back: backward tilted by 40 deg
    adjacent pairs((front, back))
}
concept Flat is-a Roof { part top: Slope  orient top: upward }
concept Bay in world { part front: Wall }
concept Body in world {
    part front, back: Wall
    part floor: Plane
    part roof: Roof
    optional part bays: Bay [0..*]
    attribute depth: length in [2 m, 60 m] = 800 cm is distance(front, back)
    frame from front
    orient front: forward
    orient back: backward
    orient floor: downward
    unseen back: mirror front about edge(roof.front, roof.back)
    unseen back: at depth from front
    attach bays: backward against front, back
}
concept TurnedBody is-a Body { orient back: leftward }
concept House in scene { con-of body: Body }
"""


def _kb():  # type: ignore[no-untyped-def]
    result = compile_text(TEXT, "t.kb")
    assert result.ok, result.diagnostics
    assert result.kb is not None
    return result.kb


def test_frame_and_orientations_in_si() -> None:
    kb = _kb()
    body = kb.concepts["Body"]
    assert body.frame is not None
    assert body.frame.anchor == "front"
    assert body.orientations["front"].direction == "forward"
    assert body.orientations["front"].tilt_rad == pytest.approx(math.pi / 2)
    assert body.orientations["floor"].tilt_rad == pytest.approx(math.pi)
    gable = kb.concepts["Gable"]
    assert gable.frame is None  # the roof's planes face directions in the body's frame
    front = gable.orientations["front"]
    assert front.tilt_rad == pytest.approx(math.radians(35.0))
    assert front.tilt_from == "front.pitch"
    assert gable.orientations["back"].tilt_rad == pytest.approx(math.radians(40.0))
    assert gable.orientations["back"].tilt_from is None
    assert kb.concepts["Flat"].orientations["top"].tilt_rad == 0.0


def test_a_specialisation_reorients_an_inherited_part() -> None:
    kb = _kb()
    turned = kb.concepts["TurnedBody"]
    assert turned.orientations["back"].direction == "leftward"
    assert turned.orientations["back"].declared_in == "TurnedBody"
    assert turned.orientations["front"].declared_in == "Body"
    assert turned.frame is not None


def test_measures_of_attributes() -> None:
    kb = _kb()
    tilt = kb.concepts["Wall"].attributes["tilt"]
    assert tilt.measure is not None
    assert tilt.measure.kind == "slope"
    assert tilt.measure.args == ("self",)
    assert tilt.measure.sigma == pytest.approx(math.radians(0.5))
    depth = kb.concepts["Body"].attributes["depth"]
    assert depth.measure is not None
    assert depth.measure.args == ("front", "back")
    assert depth.default == pytest.approx(8.0)
    assert depth.measure.span.line == 21


def test_placements_and_attachments() -> None:
    kb = _kb()
    body = kb.concepts["Body"]
    mirror, offset = body.placements
    assert (mirror.part, mirror.kind, mirror.ref, mirror.line) == (
        "back",
        "mirror",
        "front",
        ("roof.front", "roof.back"),
    )
    assert mirror.requires == (("roof", ("Gable",)),)  # only a gable has those planes
    assert (offset.kind, offset.value, offset.value_attribute) == ("offset", 8.0, "depth")
    bays = body.attachments["bays"]
    assert (bays.face, bays.contact, bays.planes, bays.name) == (
        "backward",
        "against",
        ("front", "back"),
        "backward",
    )


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.name)
def test_shipped_knowledge_bases_are_clean(path: Path) -> None:
    result = compile_path(path)
    assert result.diagnostics == ()
    kb = result.kb
    assert kb is not None
    framed = [c for c in kb.concepts.values() if c.frame is not None]
    assert framed, f"{path.name} declares no frame"
    for c in framed:  # every planar part of a framed composite faces a declared direction
        for role, part in c.parts.items():
            family = (part.concept, *kb.concrete_specialisations(part.concept))
            if not any(kb.concepts[f].parts for f in family):
                assert role in c.orientations, (c.name, role)
