"""A terrace's touching houses told apart: the front region the segmentation grew over both,
and the roof over both, split at the party wall the image shows (`interpret.party`)."""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
import numpy.typing as npt

from aida_kb.interpret.party import PARTY_MIN_M, StereoDepth, party_walls, split_terraces
from aida_kb.io.evidence import (
    Contour,
    Evidence,
    EvidenceCamera,
    LineSegment,
    Region,
    ViewEvidence,
)
from aida_kb.io.model import Cahv

FloatArray = npt.NDArray[np.float64]
K = np.array([[800.0, 0.0, 320.0], [0.0, 800.0, 240.0], [0.0, 0.0, 1.0]])
UP = np.array([0.0, -1.0, 0.0])  # OpenCV axes, y down
PITCH = math.radians(35.0)
# a row 12 m wide (x -6 .. 6) 20 m ahead: front 6 m tall (y 3 at the ground .. -3 at the
# eaves), a roof sloping back from the eaves; the party wall at x = 1
FRONT = np.array([[-6.0, -3.0, 20.0], [6.0, -3.0, 20.0], [6.0, 3.0, 20.0], [-6.0, 3.0, 20.0]])
SLOPE = np.array([0.0, -math.sin(PITCH), math.cos(PITCH)])  # up the roof, away from the eaves
ROOF = np.array([*FRONT[:2], FRONT[1] + 4.0 * SLOPE, FRONT[0] + 4.0 * SLOPE])[[0, 3, 2, 1]]
GROUND = np.array([[-30.0, 3.0, 8.0], [30.0, 3.0, 8.0], [30.0, 3.0, 60.0], [-30.0, 3.0, 60.0]])


def _px(points: FloatArray) -> FloatArray:
    uv = points @ K.T
    out: FloatArray = uv[:, :2] / uv[:, 2:3]
    return out


def _region(rid: int, poly: FloatArray, n: FloatArray) -> Region:
    px = _px(poly)
    x = px[:, 0]
    y = px[:, 1]
    area = 0.5 * abs(float(x @ np.roll(y, -1) - y @ np.roll(x, -1)))
    count = max(1, round(area))
    lo, hi = np.clip(px.min(axis=0), 0, [639, 479]), np.clip(px.max(axis=0), 0, [639, 479])
    c = poly.mean(axis=0)
    return Region(
        id=rid,
        pixel_count=min(count, int((hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1))),
        depth_pixel_count=min(count, int((hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1))),
        inlier_count=min(count, int((hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1))),
        area_m2=1.0,
        n_init=(float(n[0]), float(n[1]), float(n[2])),
        d_init=float(n @ c),
        c_init=(float(c[0]), float(c[1]), float(c[2])),
        w_c=0.5 * min(count, int((hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1))),
        rms_m=0.02,
        mean_certainty=0.5,
        bbox=(int(lo[0]), int(lo[1]), int(hi[0]), int(hi[1])),
    )


def _line(
    lid: int, a: FloatArray, b: FloatArray, left: int | None, right: int | None
) -> LineSegment:
    p = _px(np.stack([a, b]))
    return LineSegment(
        id=lid,
        p1=(float(p[0, 0]), float(p[0, 1])),
        p2=(float(p[1, 0]), float(p[1, 1])),
        length_px=float(np.linalg.norm(p[1] - p[0])),
        contrast=30.0,
        regions=sorted({r for r in (left, right) if r is not None}),
        left_region=left,
        right_region=right,
    )


def wall(y0: float, y1: float, x: float) -> tuple[FloatArray, FloatArray]:
    """A vertical segment on the front (x, y0 .. y1), metres."""
    return np.array([x, y0, 20.0]), np.array([x, y1, 20.0])


def _terrace(segmentation: Literal["labels", "orientation"] = "orientation") -> Evidence:
    camera = EvidenceCamera(
        K=((800.0, 0.0, 320.0), (0.0, 800.0, 240.0), (0.0, 0.0, 1.0)),
        D=[],
        R=((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),
        t=(0.0, 0.0, 0.0),
        cahv=Cahv(C=(0, 0, 0), A=(0, 0, 1), H=(800, 0, 320), V=(0, 800, 240)),
    )
    right = camera.model_copy(
        update={"t": (-0.4, 0.0, 0.0), "cahv": camera.cahv.model_copy(update={"C": (0.4, 0, 0)})}
    )
    n_roof = np.cross(FRONT[1] - FRONT[0], SLOPE)
    n_roof = -n_roof / np.linalg.norm(n_roof) if n_roof[2] > 0 else n_roof / np.linalg.norm(n_roof)
    regions = [
        _region(1, FRONT, np.array([0.0, 0.0, -1.0])),
        _region(2, ROOF, n_roof),
        _region(3, GROUND, UP),
    ]
    contours = [
        Contour(id=k + 1, region=r, points=[(float(x), float(y)) for x, y in _px(p)])
        for k, (r, p) in enumerate(((1, FRONT), (2, ROOF)))
    ]
    # the ground: the image below the row
    ground = [(0.0, 360.0), (639.0, 360.0), (639.0, 479.0), (0.0, 479.0)]
    contours.append(Contour(id=3, region=3, points=ground))
    lines = [
        # the party wall, broken where its contrast fades (0.3 m)
        _line(1, *wall(3.0, 0.2, 1.0), 1, 1),
        _line(2, *wall(-0.1, -3.0, 1.0), 1, 1),
        # window sides, 1.4 m tall, two storeys one above the other (1.6 m between them)
        _line(3, *wall(2.2, 0.8, -3.0), 1, 1),
        _line(4, *wall(-0.8, -2.2, -3.0), 1, 1),
        # the eaves along both houses: the front below, the roof above
        _line(5, FRONT[0], FRONT[1], 2, 1),
    ]
    view = ViewEvidence(
        id="00",
        frame="world",
        image_width=640,
        image_height=480,
        left=camera,
        right=right,
        segmentation=segmentation,
        disparity_density=0.8,
        regions=regions,
        lines=lines,
        contours=contours,
    )
    return Evidence(scene="terrace", views=[view])


def test_the_party_wall_is_found_not_the_windows() -> None:
    walls = party_walls(_terrace().views[0], UP)
    assert len(walls) == 1
    wall = walls[0]
    assert wall.region == 1
    assert abs(abs(float(wall.normal[0])) - 1.0) < 1e-6
    # the plane x = 1 (either sign), its segments spanning its 6 m (their 0.3 m gap bridged)
    assert abs(wall.offset_m * float(wall.normal[0]) - 1.0) < 1e-6
    assert wall.height_m == np.float64(wall.height_m)
    assert abs(wall.height_m - 6.0) < 1e-6
    assert wall.height_m > PARTY_MIN_M > 1.4 + 1e-9


def test_front_and_roof_split_at_the_party_wall() -> None:
    evidence = _terrace()
    view = split_terraces(evidence).views[0]
    by_id = {r.id: r for r in view.regions}
    assert 3 in by_id  # the ground stays whole
    assert 1 not in by_id
    assert 2 not in by_id
    pieces = [r for r in view.regions if r.id > 3]
    assert len(pieces) == 4  # two fronts, two roofs
    fronts = sorted((r for r in pieces if r.n_init[2] < -0.99), key=lambda r: r.c_init[0])
    roofs = sorted((r for r in pieces if r.n_init[2] >= -0.99), key=lambda r: r.c_init[0])
    assert len(fronts) == 2
    assert len(roofs) == 2
    # each house's front: 7 m and 5 m wide, 6 m tall, centred on its own width
    assert [round(r.area_m2, 6) for r in fronts] == [42.0, 30.0]
    assert [round(r.c_init[0], 6) for r in fronts] == [-2.5, 3.5]
    assert fronts[0].pixel_count + fronts[1].pixel_count == evidence.views[0].regions[0].pixel_count
    assert roofs[0].c_init[0] < 1.0 < roofs[1].c_init[0]
    # the pieces keep their region's plane
    assert all(r.d_init == -20.0 for r in fronts)
    # every piece has its own outline; the eave is cut in two, each house's own
    assert {c.region for c in view.contours} == {3, *(r.id for r in pieces)}
    eaves = sorted(
        (s for s in view.lines if s.left_region in {r.id for r in roofs}), key=lambda s: s.p1[0]
    )
    assert len(eaves) == 2
    assert [(s.left_region, s.right_region) for s in eaves] == [
        (roofs[0].id, fronts[0].id),
        (roofs[1].id, fronts[1].id),
    ]
    # the party wall's segments border both fronts; a window's side one
    party = [s for s in view.lines if s.id in (1, 2)]
    assert all(set(s.regions) == {fronts[0].id, fronts[1].id} for s in party)
    window = next(s for s in view.lines if s.id == 3)
    assert window.regions == [fronts[0].id]


def test_labelled_or_wall_free_evidence_is_left_alone() -> None:
    labelled = _terrace("labels")
    assert split_terraces(labelled) is labelled
    plain = _terrace()
    view = plain.views[0]
    no_wall = plain.model_copy(
        update={"views": [view.model_copy(update={"lines": view.lines[2:]})]}
    )
    assert split_terraces(no_wall) is no_wall


def _depth(evidence: Evidence, right_pitch_deg: float) -> StereoDepth:
    """The stereo depth of `_terrace`'s view: the front (region 1) on its plane z = 20, the
    left house's roof (region 2, x < 1) on the region's plane, the right house's roof on a
    plane of `right_pitch_deg` through the same eave; depths scattered by 0.1 % (fixed seed)."""
    h, w = 480, 640
    v, u = np.mgrid[0:h, 0:w].astype(np.float64)
    rays = np.stack([(u - 320.0) / 800.0, (v - 240.0) / 800.0, np.ones_like(u)], axis=-1)
    regions = np.zeros((h, w), np.int32)
    points = np.full((h, w, 3), np.nan)
    front = rays * 20.0
    on_front = (np.abs(front[..., 0]) <= 6.0) & (np.abs(front[..., 1]) <= 3.0)
    regions[on_front], points[on_front] = 1, front[on_front]
    for pitch, side in ((PITCH, -1.0), (math.radians(right_pitch_deg), 1.0)):
        slope = np.array([0.0, -math.sin(pitch), math.cos(pitch)])
        n = np.cross(FRONT[1] - FRONT[0], slope)
        n /= np.linalg.norm(n)
        s = float(n @ FRONT[0]) / (rays @ n)  # the ray's point on the roof's plane
        x = rays * s[..., None]
        up_roof = (x - FRONT[0]) @ slope
        mine = (side * (x[..., 0] - 1.0) >= 0) & (np.abs(x[..., 0]) <= 6.0)
        mine &= (up_roof >= 0.0) & (up_roof <= 4.0) & (regions == 0) & (s > 0)
        regions[mine], points[mine] = 2, x[mine]
    noise = 1.0 + 0.001 * np.random.default_rng(0).standard_normal((h, w, 1))
    return StereoDepth(
        regions=regions,
        points=(points * noise).astype(np.float32),
        certainty=(regions > 0).astype(np.float32),
    )


def test_pieces_of_other_planes_are_fitted_to_their_own_depths() -> None:
    evidence = _terrace()
    view = split_terraces(evidence, _depth(evidence, 41.0)).views[0]
    pieces = [r for r in view.regions if r.id > 3]
    fronts = [r for r in pieces if r.n_init[2] < -0.99]
    roofs = sorted((r for r in pieces if r.n_init[2] >= -0.99), key=lambda r: r.c_init[0])
    # the coplanar fronts: their depths hold the region's plane as well as their own
    assert [r.d_init for r in fronts] == [-20.0, -20.0]
    assert all(r.n_init == (0.0, 0.0, -1.0) for r in fronts)
    # the left roof lies on the region's plane; the right one, 6 deg steeper, on its own
    region_roof = next(r for r in evidence.views[0].regions if r.id == 2)
    assert roofs[0].n_init == region_roof.n_init
    steep = np.array([0.0, -math.sin(math.radians(41.0)), math.cos(math.radians(41.0))])
    n_true = np.cross(FRONT[1] - FRONT[0], steep)
    n_true /= np.linalg.norm(n_true)
    n_right = np.asarray(roofs[1].n_init)
    assert math.degrees(math.acos(min(1.0, abs(float(n_true @ n_right))))) < 0.1
    assert (
        abs(abs(float(n_true @ np.asarray(roofs[1].c_init))) - abs(float(n_true @ FRONT[0]))) < 0.01
    )
    # without depth the pieces keep their region's plane
    plain = split_terraces(evidence).views[0]
    assert all(
        r.n_init == region_roof.n_init for r in plain.regions if r.id > 3 and r.n_init[2] >= -0.99
    )
