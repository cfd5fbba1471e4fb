"""Check (j): a model face the view sees must be there, and a region on a face must not go on
far beyond it (`aida_kb.interpret.verdict.filled`)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import numpy.typing as npt

from aida_kb.interpret.result import Interpretation
from aida_kb.interpret.uncertainty import adjustment_uncertainty
from aida_kb.interpret.verdict import VERIFIED, judge
from aida_kb.interpret.verdict.filled import face_fills, fill_maps, unfilled
from aida_kb.io.evidence import Contour, ViewEvidence, read_evidence
from aida_kb.io.model import ModelCamera, ModelPart, ReconstructedModel
from aida_kb.kb.model import KnowledgeBase

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures"
F = 500.0  # focal length, pixels; the camera at the origin looks along +z (world = camera)
W, H = 400, 300
K = ((F, 0.0, W / 2), (0.0, F, H / 2), (0.0, 0.0, 1.0))
WALL_Z, BACKGROUND_Z = 10.0, 30.0  # metres: a wall facing the camera, the ground far behind


def _px(x: float, y: float, z: float) -> tuple[float, float]:
    return (F * x / z + W / 2, F * y / z + H / 2)


def _wall(top: float) -> ReconstructedModel:
    """A 6 m wide wall at WALL_Z from y = 2 (its foot, image down) up to y = top, metres."""
    poly = [(-3.0, top, WALL_Z), (3.0, top, WALL_Z), (3.0, 2.0, WALL_Z), (-3.0, 2.0, WALL_Z)]
    part = ModelPart(role="w", concept="C", normal=(0.0, 0.0, -1.0), offset_m=-WALL_Z, polygon=poly)
    camera = ModelCamera(
        view="00",
        K=K,
        R=((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),
        t=(0.0, 0.0, 0.0),
        image_width=W,
        image_height=H,
    )
    return ReconstructedModel(parts=[part], cameras=[camera])


def _view() -> ViewEvidence:
    """The wall from y = 2 up to y = 0 (region 1) before the background (region 2)."""
    template = read_evidence(FIXTURES / "house_correct.json").views[0]
    base = template.regions[0]
    wall = [_px(x, y, WALL_Z) for x, y in ((-3, 0), (3, 0), (3, 2), (-3, 2))]
    pixels = int(abs((wall[1][0] - wall[0][0]) * (wall[2][1] - wall[1][1])))
    regions = [
        base.model_copy(
            update={
                "id": rid,
                "pixel_count": n,
                "depth_pixel_count": n,
                "inlier_count": n,
                "n_init": (0.0, 0.0, -1.0),
                "d_init": -z,
                "c_init": (0.0, 0.0, z),
                "w_c": 0.9 * n,
                "bbox": (0, 0, W - 1, H - 1),
            }
        )
        for rid, n, z in ((1, pixels, WALL_Z), (2, W * H - pixels, BACKGROUND_Z))
    ]
    everything = [(0.0, 0.0), (W - 1.0, 0.0), (W - 1.0, H - 1.0), (0.0, H - 1.0)]
    contours = [
        Contour(id=1, region=1, points=wall),
        Contour(id=2, region=2, points=everything),
    ]
    return template.model_copy(
        update={
            "image_width": W,
            "image_height": H,
            "regions": regions,
            "contours": contours,
            "lines": [],
        }
    )


def test_the_true_wall_is_filled_and_a_taller_one_shows_the_ground_behind() -> None:
    view = _view()
    maps = fill_maps(view, _wall(0.0))
    assert maps is not None
    (true,) = face_fills(maps, _wall(0.0))
    assert true.at_depth == true.visible > 25_000  # all of it at the wall's depth
    assert unfilled(view, _wall(0.0), (1,)) == []
    tall = _wall(-2.0)  # twice as tall: its upper half lies over the background
    maps = fill_maps(view, tall)
    assert maps is not None
    (face,) = face_fills(maps, tall)
    assert 0.45 < face.contradicted < 0.55
    (reason,) = unfilled(view, tall, (1,))
    assert reason.startswith("view 00: the face w is not there:")


def test_a_region_going_on_beyond_its_face_is_named() -> None:
    view = _view()
    low = _wall(1.0)  # half the wall: the wall's region goes on above it
    (reason,) = unfilled(view, low, (1,))
    assert "region 00/1 on w has 4" in reason  # 45-50 % outside (less the grown border)
    assert unfilled(view, low, ()) == []  # a region not on the face is not judged so


def _with_outlines(interp: Interpretation, view: ViewEvidence) -> ViewEvidence:
    """The view with each region's outline: the projection of the model face its plane is
    (the ground, which is no face, the whole image: drawn first, the largest)."""
    model = interp.model
    assert model is not None
    cam = model.cameras[0]
    Km, R, t = (np.asarray(x, dtype=float) for x in (cam.K, cam.R, cam.t))
    contours: list[Contour] = []
    for r in view.regions:
        n = np.asarray(r.n_init)
        face = max(model.parts, key=lambda p: float(np.asarray(p.normal) @ n))
        if float(np.asarray(face.normal) @ n) < 0.99:
            points = [(0.0, 0.0), (639.0, 0.0), (639.0, 479.0), (0.0, 479.0)]
        else:
            x: npt.NDArray[np.float64] = (np.asarray(face.polygon) @ R.T + t) @ Km.T
            points = [(float(u), float(v)) for u, v in x[:, :2] / x[:, 2:]]
        contours.append(Contour(id=len(contours) + 1, region=r.id, points=points))
    return view.model_copy(update={"contours": contours})


def _shrunk(contour: Contour, factor: float) -> Contour:
    """The contour shrunk by `factor` about its vertices' mean."""
    points = np.asarray(contour.points, dtype=float)
    centre = points.mean(axis=0)
    small = centre + (points - centre) / factor
    return contour.model_copy(update={"points": [(float(u), float(v)) for u, v in small]})


def test_judge_runs_the_check_on_the_outlines(
    buildings_kb: KnowledgeBase,
    interpreted: Callable[[str], Interpretation],
    unbiased: None,
) -> None:
    interp = interpreted("house_correct.json")
    evidence = read_evidence(FIXTURES / "house_correct.json")
    view = _with_outlines(interp, evidence.views[0])
    drawn = evidence.model_copy(update={"views": [view]})
    ground = max(view.regions, key=lambda r: r.pixel_count).id
    once = adjustment_uncertainty(buildings_kb, interp, evidence)  # the same for both
    assert judge(buildings_kb, interp, drawn, uncertainty=once).verdict == VERIFIED
    # the outlines shrunk to a third about their centres: the faces show the ground beyond
    shrunk = [c if c.region == ground else _shrunk(c, 3.0) for c in view.contours]
    thin = evidence.model_copy(update={"views": [view.model_copy(update={"contours": shrunk})]})
    verdict = judge(buildings_kb, interp, thin, uncertainty=once)
    assert any("is not there" in r for r in verdict.reasons), verdict.reasons
