"""Check (b) in one view (`aida_kb.interpret.verdict.views.check_view`): where a region lies."""

from __future__ import annotations

import math
from pathlib import Path

from aida_kb.interpret.verdict.views import check_view
from aida_kb.io.evidence import Contour, Region, ViewEvidence, read_evidence
from aida_kb.io.model import ModelCamera, ModelPart, ReconstructedModel

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures"
F, W, H = 500.0, 400, 300  # the camera at the origin looks along +z (world = camera frame)
WALL_Z, ORIEL_Z = 10.0, 9.0  # metres: a wall facing the camera, two oriels' fronts before it
ORIEL_X = ((-2.0, -1.0), (1.0, 2.0))  # metres: the oriels, 2 m apart
FACING = (0.0, 0.0, -1.0)  # the wall's and the oriels' normal, towards the camera


def _face(role: str, z: float, x0: float, x1: float) -> ModelPart:
    poly = [(x0, -1.5, z), (x1, -1.5, z), (x1, 1.5, z), (x0, 1.5, z)]
    return ModelPart(role=role, concept="C", normal=FACING, offset_m=-z, polygon=poly)


def _model() -> ReconstructedModel:
    """A 6 m wide wall and the fronts of two oriels standing 1 m out of it."""
    parts = [_face("wall", WALL_Z, -3.0, 3.0)]
    parts += [_face(f"oriel{i}", ORIEL_Z, *x) for i, x in enumerate(ORIEL_X)]
    identity = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    camera = ModelCamera(
        view="00", K=((F, 0.0, W / 2), (0.0, F, H / 2), (0.0, 0.0, 1.0)), R=identity,
        t=(0.0, 0.0, 0.0), image_width=W, image_height=H,
    )  # fmt: skip
    return ReconstructedModel(parts=parts, cameras=[camera])


def _outline(x0: float, x1: float, z: float) -> list[tuple[float, float]]:
    return [
        (F * x / z + W / 2, F * y / z + H / 2) for x, y in ((x0, -1), (x1, -1), (x1, 1), (x0, 1))
    ]


def _view(
    pieces: tuple[tuple[float, float], ...],
    z: float = ORIEL_Z,
    normal: tuple[float, float, float] = FACING,
    kept: float = 1.0,
) -> ViewEvidence:
    """The wall (region 1) and one region (2) at depth z, its centre on the camera's axis
    (between the oriels), made of `pieces` (x0, x1 in metres, each 2 m tall); its plane fit
    has the `normal` and kept that share of its pixels."""
    template = read_evidence(FIXTURES / "house_correct.json").views[0]
    base = template.regions[0]

    def region(rid: int, z: float, weight: float, normal: tuple[float, float, float]) -> Region:
        return base.model_copy(
            update={"id": rid, "n_init": normal, "d_init": normal[2] * z, "c_init": (0.0, 0.0, z),
                    "w_c": weight * base.pixel_count,
                    "inlier_count": min(base.depth_pixel_count, round(kept * base.pixel_count))}
        )  # fmt: skip

    contours = [Contour(id=1, region=1, points=_outline(-3.0, 3.0, WALL_Z))]
    contours += [
        Contour(id=2 + i, region=2, points=_outline(x0, x1, z)) for i, (x0, x1) in enumerate(pieces)
    ]
    regions = [region(1, WALL_Z, 0.8, FACING), region(2, z, 0.2, normal)]
    return template.model_copy(update={"regions": regions, "contours": contours, "lines": []})


def test_a_region_joining_two_oriel_fronts_lies_on_them() -> None:
    # its pixels are the two fronts; its centre lies between them, 1 m before the wall
    check = check_view(_view(ORIEL_X), _model())
    assert check is not None
    assert set(check.explained_ids) == {1, 2}
    assert check.contradicting == []
    assert check.standing_out_weight == 0.0
    assert check.explained_on["oriel0"] > 0.0
    # the same region between the oriels stands out of the wall where the model has nothing
    check = check_view(_view(((-0.5, 0.5),)), _model())
    assert check is not None
    assert check.explained_ids == (1,)
    assert [c[0] for c in check.contradicting] == [2]
    assert "standing 1.00 m out of the model's surface" in check.contradicting[0][2]


def test_a_plane_fit_that_kept_next_to_nothing_is_not_seen_turned() -> None:
    # a region on the wall between the oriels, its fitted plane turned 20 degrees
    turned = (math.sin(math.radians(20.0)), 0.0, -math.cos(math.radians(20.0)))
    check = check_view(_view(((-0.5, 0.5),), WALL_Z, turned, kept=0.5), _model())
    assert check is not None
    assert [c[0] for c in check.contradicting] == [2]
    assert "on the model's surface at 20 deg to its face" in check.contradicting[0][2]
    # the fit kept 1 % of its pixels (dev 61431 view 01: 74 of 12,773): it does not tell its
    # orientation, and it is not explained either
    check = check_view(_view(((-0.5, 0.5),), WALL_Z, turned, kept=0.01), _model())
    assert check is not None
    assert check.contradicting == []
    assert check.explained_ids == (1,)
    assert check.explained_share < 1.0
