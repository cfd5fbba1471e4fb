"""Verification of a hypothesis with aida_kb.solve: compromises, rejections, fixed parts."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from aida_kb.constraints import Constraint, EdgeData, Origin
from aida_kb.geometry.camera import PinholeCamera
from aida_kb.interpret.knowledge import Knowledge
from aida_kb.interpret.observe import CameraView, RegionView
from aida_kb.interpret.verify import (
    EdgeEvidence,
    PlaneInit,
    Verification,
    build_verification,
    fragment_scatter_px,
    outline_priors,
    position_data,
    tilt_constraints,
    tilt_px_per_rad,
    verify,
)
from aida_kb.kb.model import KnowledgeBase

CAMERA = CameraView("00", np.diag([800.0, 800.0, 1.0]), np.eye(3), np.zeros(3), 640, 480, 0.4)


def _turn(n: np.ndarray, deg: float) -> np.ndarray:
    a = math.radians(deg)
    c, s = math.cos(a), math.sin(a)
    return np.array([c * n[0] + s * n[2], n[1], -s * n[0] + c * n[2]])


def _region(rid: str, normal: np.ndarray, centroid: list[float]) -> RegionView:
    return RegionView(rid, "00", normal, np.asarray(centroid, float), 9000.0, 10000.0, 0.01)


def _position(part: int, region: RegionView, sigma: float = 1.0) -> Constraint:
    return Constraint(
        kind="position",
        parts=(part,),
        sigma=sigma,
        reject_above=4.0,
        unit="px",
        measurement=True,
        label="Region#1",
        position=position_data(region, CAMERA),
        origin=Origin("Region#1", "knowledge", "Region", region.id),
    )


def _angle(parts: tuple[int, int], value: float, sigma_deg: float, reject_deg: float) -> Constraint:
    return Constraint(
        kind="angle",
        parts=parts,
        value=value,
        sigma=math.radians(sigma_deg),
        reject_above=math.radians(reject_deg),
        unit="rad",
        label="corner",
    )


def test_perpendicular_walls_meet_the_regions_part_way() -> None:
    front, left = np.array([0.0, 0.0, -1.0]), np.array([-1.0, 0.0, 0.0])
    # the regions say the corner is 92 degrees; the knowledge says 90 +- 1
    seen = {"a": (_turn(front, 1.0), [0, 0, 20.0]), "b": (_turn(left, -1.0), [-5.0, 0, 22.0])}
    planes = tuple(PlaneInit(r, "Wall", n, float(n @ c)) for r, (n, c) in seen.items())
    positions = [_position(i, _region(r, n, c)) for i, (r, (n, c)) in enumerate(seen.items())]
    corner = _angle((0, 1), math.pi / 2, 1.0, 5.0)
    v = Verification(planes, (corner, *positions))
    out = verify(v)
    n_a, n_b = out.planes["a"][0], out.planes["b"][0]
    meeting = 180.0 - math.degrees(math.acos(float(n_a @ n_b)))
    # a degree of tilt costs 1 px (sigma 1 px) times the mean certainty 0.9 at each region, a
    # degree of corner costs 1 sigma: minimising 2·0.9·x² + (2 - 2x)² leaves 2 - 2x = 0.621
    assert meeting == pytest.approx(90.0 + 2.0 - 2.0 * 8.0 / 11.6, abs=0.01)
    corner_row = next(r for r in out.residuals if r.label == "corner")
    assert corner_row.normalised_cost == pytest.approx((meeting - 90.0) ** 2, rel=0.02)
    assert corner_row.threshold == pytest.approx(25.0)  # (reject above / sigma)²
    assert out.worst_rejected() is None


def test_a_region_tilt_counts_pixels_of_what_its_fit_resolves() -> None:
    # a 96 m² wall of 24,144 inliers, rms 0.138 m (dev seed 59012's front wall): its fit
    # resolves sqrt(96.3 / 12) · sqrt(24144 / 81) / 0.138 = 354 px/rad (0.16 deg); twice that
    # sigma with the 1 deg floor in quadrature: 1.05 deg, 0.95 px per degree
    big = float(tilt_px_per_rad(0.138, 24144, 96.3))
    assert math.radians(1.0) * big == pytest.approx(0.951, abs=0.002)
    # a side wall seen edge-on from 134 m (street 62000): 5.5 m², 165 inliers, rms 0.138 m:
    # sigma_fit 8.2 deg, so 16 deg per pixel: its 10.8 deg tilt costs 0.66 px, not 10.8
    edge_on = float(tilt_px_per_rad(0.138, 165, 5.5))
    assert math.radians(10.8) * edge_on == pytest.approx(0.66, abs=0.01)
    # a region without its fit's statistics (old evidence): a degree, a pixel, as before
    assert float(tilt_px_per_rad(0.01, 0, 0.0)) == pytest.approx(math.degrees(1.0))
    # a fit that kept none of the image's pixels is one point, not unknown: dev seed 61510's
    # dark roof (43.8 m², rms 0.246 m, 121 depth pixels, no inlier) has sigma_fit
    # 0.246 / sqrt(43.8 / 12) = 7.38 deg, 14.8 deg a pixel: its fit 6.2 deg off the true
    # slope costs 0.42 px, where a degree a pixel (6.2 px) rejected the right roof
    dark = float(tilt_px_per_rad(0.246, 0, 43.8))
    assert math.radians(6.2) * dark == pytest.approx(0.42, abs=0.01)
    # unknown inliers (NaN): a degree, a pixel
    assert float(tilt_px_per_rad(0.246, math.nan, 43.8)) == pytest.approx(math.degrees(1.0))
    # vectorised: one scale per region, the same as one at a time
    many = tilt_px_per_rad(np.array([0.138, 0.138, 0.246]), np.array([24144, 165, 0]), 43.8)
    assert many.shape == (3,)
    assert many[2] == pytest.approx(dark)
    assert many[0] == pytest.approx(float(tilt_px_per_rad(0.138, 24144, 43.8)))
    # the constraint carries it: a region with its statistics, at 20 m
    region = RegionView(
        "00/1",
        "00",
        np.array([0.0, 0.0, -1.0]),
        np.array([0, 0, 20.0]),
        9000.0,
        10000.0,
        0.138,
        165,
        5.5,
    )
    assert position_data(region, CAMERA).tilt_px_per_rad == pytest.approx(edge_on)
    # a region made without its fit's statistics (inliers None) keeps a degree a pixel; one
    # whose fit kept no pixel is one point
    unknown = replace(region, inliers=None)
    assert position_data(unknown, CAMERA).tilt_px_per_rad == pytest.approx(math.degrees(1.0))
    none_kept = replace(region, inliers=0, rms_m=0.246, area_m2=43.8)
    assert position_data(none_kept, CAMERA).tilt_px_per_rad == pytest.approx(dark)


def test_a_contradiction_over_the_threshold_is_flagged_and_fixed_parts_stay() -> None:
    n = np.array([0.0, 0.0, -1.0])
    tilted = _turn(n, 40.0)
    planes = (
        PlaneInit("a", "Wall", n, -20.0, fixed=True),
        PlaneInit("b", "Wall", tilted, float(tilted @ [3.0, 0.0, 20.0])),
    )
    strict = Constraint(
        kind="parallel",
        parts=(0, 1),
        sigma=math.radians(0.5),
        reject_above=math.radians(2.0),
        unit="rad",
        label="parallel",
    )
    pos = _position(1, _region("b", tilted, [3.0, 0.0, 20.0]), sigma=0.01)
    out = verify(Verification(planes, (strict, pos)))
    np.testing.assert_allclose(out.planes["a"][0], n)
    worst = out.worst_rejected()
    assert worst is not None
    assert worst.label == "parallel"
    assert worst.residual > math.radians(2.0)
    assert worst.normalised_cost > worst.threshold


def _corner_fragments(
    knowledge: Knowledge, offsets_px: list[float]
) -> tuple[Verification, tuple[PlaneInit, ...]]:
    """A front and a left wall meeting at a vertical corner 20 m away, and fragments of the
    corner line seen `offsets_px` to the side (x) of where the planes put it."""
    roles = ["body.front", "body.left"]
    normals = [np.array([0.0, 0.0, -1.0]), np.array([-1.0, 0.0, 0.0])]
    corner = np.array([-5.0, 0.0, 20.0])
    planes = [
        PlaneInit(r, "Wall", n, float(n @ corner)) for r, n in zip(roles, normals, strict=True)
    ]
    cam = PinholeCamera(np.diag([800.0, 800.0, 1.0]), np.eye(3), np.zeros(3), 640, 480)
    x = cam.project(corner + np.array([[0, -2.0, 0], [0, 2.0, 0]]))
    fragments = [x + np.array([dx, 0.0]) for dx in offsets_px]
    edges = [EdgeEvidence(("body.front", "body.left"), "body.front", 0, f) for f in fragments]
    v = build_verification(knowledge, "body", "HouseBody", planes, {}, {}, edges, set(), (cam,))
    fixed = tuple(PlaneInit(p.role, p.concept, p.normal, p.offset_m, fixed=True) for p in planes)
    return v, fixed


def test_fragments_of_one_edge_share_one_verdict(buildings_kb: KnowledgeBase) -> None:
    knowledge = Knowledge.from_kb(buildings_kb)
    # two fragments on one line 4 px beside the model's corner: they agree with each other,
    # not with the model
    v, fixed = _corner_fragments(knowledge, [4.0, 4.0])
    assert [c.kind for c in v.constraints] == ["angle", "edge", "edge"]
    assert [str(c.source.owner) for c in v.constraints] == [
        "body",
        "body.front.region.contours[0]",
        "body.front.region.contours[1]",
    ]
    assert [c.sigma for c in v.constraints[1:]] == [1.0, 1.0]  # no scatter: the knowledge's
    out = verify(Verification(fixed, v.constraints, v.cameras))
    edge = [r for r in out.residuals if r.kind == "edge"]
    assert len(edge) == 1  # pooled: RMS over the fragments, summed costs and thresholds
    # each fragment's residual: both end points 4 px off
    assert edge[0].residual == pytest.approx(math.sqrt(32.0), rel=1e-3)
    assert edge[0].threshold == pytest.approx(18.0)
    assert edge[0].rejected  # 64 > 18


def test_fragments_that_scatter_widen_their_edge_tolerance(buildings_kb: KnowledgeBase) -> None:
    # fragments 1 px and 5 px beside the corner: they scatter by 2.83 px about their common
    # line (4 end points, 2 degrees of freedom left): the evidence cannot place the edge
    # better than that, whatever the hypothesis
    knowledge = Knowledge.from_kb(buildings_kb)
    v, fixed = _corner_fragments(knowledge, [1.0, 5.0])
    ends = [c.edge for c in v.constraints if c.edge is not None]
    assert fragment_scatter_px(ends) == pytest.approx(math.sqrt(8.0), rel=1e-6)
    sigma = math.sqrt(1.0 + 8.0)
    assert [c.sigma for c in v.constraints[1:]] == pytest.approx([sigma, sigma])
    assert [c.reject_above for c in v.constraints[1:]] == pytest.approx([3 * sigma, 3 * sigma])
    out = verify(Verification(fixed, v.constraints, v.cameras))
    (edge,) = [r for r in out.residuals if r.kind == "edge"]
    # RMS over the fragments of their end points' residuals (1 and 5 px each)
    assert edge.residual == pytest.approx(math.sqrt((2 * 1.0 + 2 * 25.0) / 2), rel=1e-3)
    assert edge.normalised_cost == pytest.approx((2 * 1.0 + 2 * 25.0) / 9.0, rel=1e-3)
    assert not edge.rejected  # 5.8 of 18: within what the fragments themselves show
    # the same scatter 9 px beside the model still rejects
    v, fixed = _corner_fragments(knowledge, [7.0, 11.0])
    out = verify(Verification(fixed, v.constraints, v.cameras))
    (edge,) = [r for r in out.residuals if r.kind == "edge"]
    assert edge.rejected


def test_a_fragment_across_the_edge_widens_nothing() -> None:
    """Relief offsets lines parallel to an edge; a fragment 10 degrees across the others is
    another line near the model's edge (a hip where the hypothesis has an eave), not relief."""
    along = [
        EdgeData(0, (100.0, 100.0), (100.0, 160.0)),
        EdgeData(0, (104.0, 100.0), (104.0, 160.0)),
    ]
    assert fragment_scatter_px(along) == pytest.approx(math.sqrt(8.0), rel=1e-6)  # 4 x 2 px
    tip = 90.0 * math.tan(math.radians(10.0))
    across = [*along, EdgeData(0, (102.0, 280.0), (102.0 + tip, 370.0))]
    assert fragment_scatter_px(across) == 0.0
    # a short fragment's direction is known less well: 10 degrees off along 12 px is parallel
    short = [
        *along,
        EdgeData(0, (102.0, 280.0), (102.0 + 12 * math.tan(math.radians(10.0)), 292.0)),
    ]
    assert fragment_scatter_px(short) > 0.0


def test_constraints_come_from_the_knowledge_base(buildings_kb: KnowledgeBase) -> None:
    knowledge = Knowledge.from_kb(buildings_kb)
    body = ["front", "back", "left", "right", "floor", "roof.front", "roof.back"]
    wing = ["front", "back", "left", "right", "roof.front", "roof.back"]
    up = np.array([0.0, -1.0, 0.0])
    planes = [PlaneInit(f"body.{r}", "", up, 0.0, fixed=True) for r in body]
    planes += [PlaneInit(f"body.wings[0].{r}", "Wall", up, 0.0) for r in wing]
    fillers = {"body.roof": "GableRoof", "body.wings[0]": "SkewWing"}
    index = {p.role: i for i, p in enumerate(planes)}
    walls = [(f"body.wings[0].{r}", "Wall") for r in ("front", "back")]
    tilts = tilt_constraints(knowledge, walls, "body.floor", index)
    v = build_verification(
        knowledge, "body", "HouseBody", planes, fillers, {}, [], set(), (), tilts
    )
    labels = {(c.source.label, str(c.source.owner)) for c in v.constraints}
    # the body's own constraints relate fixed parts only: verified with the body, left out
    assert ("corner_fl", "body") not in labels
    assert ("wings_meet", "body") in labels
    meet = next(c for c in v.constraints if c.source.label == "wings_meet")
    assert meet.value == pytest.approx(math.radians(135.0))
    assert ("Wing#1", "body.wings[0]") in labels
    assert ("Wall.tilt", "body.wings[0].back") in labels
    tilt = next(c for c in v.constraints if str(c.source.owner) == "body.wings[0].back")
    assert tilt.source.rule == "attribute"
    assert tilt.source.span is not None
    assert tilt.source.span.file.endswith("buildings.kb")
    assert tilt.sigma == pytest.approx(math.radians(0.5))  # the tolerance the knowledge states
    assert tilt.reject_above == pytest.approx(math.radians(5.0))


def test_levels_are_solved_main_parts_first() -> None:
    from aida_kb.interpret.verify import verify_levels

    front = np.array([0.0, 0.0, -1.0])
    seen = _turn(front, 1.0)  # the body's region: 1 degree off
    body = Verification(
        (PlaneInit("body.front", "Wall", seen, float(seen @ [0, 0, 20.0])),),
        (_position(0, _region("b", seen, [0, 0, 20.0])),),
    )
    main = verify(body)
    n_main, d_main = main.planes["body.front"]
    # the oriel's region is 3 degrees off the other way; the knowledge says parallel
    oriel_seen = _turn(front, -3.0)
    strict = Constraint(
        kind="parallel", parts=(0, 1), sigma=math.radians(0.5), unit="rad", label="aligned"
    )
    pos = _position(1, _region("o", oriel_seen, [1.0, 0, 19.0]))
    oriel = Verification(
        (
            PlaneInit("body.front", "Wall", n_main, d_main, fixed=True),
            PlaneInit("body.oriels[0].front", "Wall", oriel_seen, float(oriel_seen @ [1, 0, 19])),
        ),
        (strict, pos),
    )
    small = verify(oriel)
    whole = verify_levels([body, oriel])
    # the body is solved first and fixed: the oriel aligns with it, it does not move the body
    np.testing.assert_allclose(whole.planes["body.front"][0], n_main, atol=1e-9)
    for role in ("body.front", "body.oriels[0].front"):
        np.testing.assert_allclose(whole.planes[role][0], small.planes[role][0], atol=1e-7)
    assert [r.label for r in whole.residuals] == ["Region#1", "aligned", "Region#1"]
    # solved jointly instead, the oriel's evidence would pull the body's front
    free = tuple(PlaneInit(p.role, p.concept, p.normal, p.offset_m) for p in oriel.planes)
    joint = verify(Verification(free, (body.constraints[0], strict, pos)))
    moved = math.degrees(math.acos(min(1.0, float(joint.planes["body.front"][0] @ n_main))))
    assert moved > 0.1


def test_an_edge_tolerance_in_metres_becomes_pixels_where_the_edge_is_seen() -> None:
    """`measure edge(...) +- 0.1 m reject above 0.5 m` on an edge 20 m away seen with f = 800
    px: sigma sqrt(1 + 4²) px, the threshold 5 sigma; twice as far, sqrt(1 + 2²); in a scene of
    unknown scale the pixel alone; a tolerance in pixels stays as it is."""
    from aida_kb.interpret.verify import edges_in_pixels

    cam = PinholeCamera(np.diag([800.0, 800.0, 1.0]), np.eye(3), np.zeros(3), 640, 480)
    n = np.array([0.0, 0.0, -1.0])
    planes = [PlaneInit("near", "Wall", n, -20.0), PlaneInit("far", "Wall", n, -40.0)]
    eave = EdgeData(0, (300.0, 200.0), (340.0, 200.0))

    def measure(part: int, sigma: float, reject: float, unit: str) -> Constraint:
        return Constraint(
            kind="edge",
            parts=(part, part),
            sigma=sigma,
            reject_above=reject,
            unit=unit,
            measurement=True,
            edge=eave,
        )

    given = [measure(0, 0.1, 0.5, "m"), measure(1, 0.1, 0.5, "m"), measure(0, 1.0, 3.0, "px")]
    near, far, pixel = edges_in_pixels(given, planes, [cam])
    assert (near.unit, far.unit) == ("px", "px")
    assert near.sigma == pytest.approx(math.hypot(1.0, 4.0))
    assert near.reject_above == pytest.approx(5 * math.hypot(1.0, 4.0))
    assert far.sigma == pytest.approx(math.hypot(1.0, 2.0))
    assert pixel == given[2]
    unscaled = edges_in_pixels(given, planes, [cam], metric=False)
    assert [c.sigma for c in unscaled] == pytest.approx([1.0, 1.0, 1.0])
    assert [c.reject_above for c in unscaled] == pytest.approx([5.0, 5.0, 3.0])


def test_the_buildings_eaves_are_measured_in_metres(buildings_kb: KnowledgeBase) -> None:
    """kb/buildings.kb: the eaves over the front have a tolerance at the object, in metres;
    the walls' corners one in pixels."""
    body = buildings_kb.concepts["HouseBody"]
    units = sorted(c.unit for c in body.constraints if c.measurement)
    assert units == ["m", "px"]


def _slope_deg(n: np.ndarray, up: np.ndarray) -> float:
    return math.degrees(math.acos(min(1.0, abs(float(n @ up)) / float(np.linalg.norm(n)))))


def test_an_inserted_slope_holds_its_outline() -> None:
    up = np.array([0.0, -1.0, 0.0])
    floor = PlaneInit("body.floor", "Floor", -up, -5.0, fixed=True)
    start = math.radians(35.0)  # where the adjustment took it: away from its outline's 21 deg
    tilted = np.array([0.0, -math.cos(start), math.sin(start)])
    roof = PlaneInit("body.roof.back", "RoofPlane", tilted, float(tilted @ [0, -8.0, 30.0]))
    index = {"body.floor": 0, "body.roof.back": 1}
    concepts = {"body.roof.back": "RoofPlane"}
    priors = outline_priors({"body.roof.back": 21.0}, concepts, "body.floor", index)
    assert [c.source.rule for c in priors] == ["prior"]
    assert outline_priors({"body.roof.back": 21.0}, concepts, None, index) == []
    held = verify(Verification((floor, roof), tuple(priors)))
    assert _slope_deg(held.planes["body.roof.back"][0], up) == pytest.approx(21.0, abs=0.01)
    assert held.worst_rejected() is None
    # a measurement that puts it 14 degrees off: the outline contradicts the adjustment
    measured = Constraint(
        kind="angle",
        parts=(1, 0),
        value=start,
        sigma=math.radians(0.2),
        unit="rad",
        label="measured",
    )
    against = verify(Verification((floor, roof), (*priors, measured)))
    worst = against.worst_rejected()
    assert worst is not None
    assert worst.label == "RoofPlane outline slope"
