"""The evidence view: the vertical, region classification by role, support offsets, edges."""

from __future__ import annotations

import math
from dataclasses import replace
from types import ModuleType

import numpy as np
import pytest

from aida_kb.errors import InterpretError
from aida_kb.interpret.edges import match_segments, plane_line
from aida_kb.interpret.hypotheses import (
    Frame,
    PlanarPart,
    candidates,
    front_region,
    predicted_normal,
    support_offset,
)
from aida_kb.interpret.observe import (
    CameraView,
    EvidenceView,
    estimate_up,
    intersect_rays_plane,
    slope_deg,
    view_of,
)
from aida_kb.synth import buildings as bld
from aida_kb.vision.rectify import undistort_pixels

TARGET = np.array([0.0, 5.0, 0.0])


def _house_view(synthetic: ModuleType, **noise: float) -> tuple[EvidenceView, object]:
    a = math.radians(-25.0)
    eye = np.array([30 * math.sin(a), 5.5, 30 * math.cos(a)])
    world = synthetic.place(bld.house(), eye, TARGET)
    evidence = synthetic.to_evidence(synthetic.evidence_of(world, seed=1, **noise))
    return view_of(evidence), world


def _truth_normal(world: object, role: str) -> np.ndarray:
    return np.asarray(world.face(role).normal)  # type: ignore[attr-defined]


def test_up_is_the_walls_common_perpendicular(synthetic: ModuleType) -> None:
    view, world = _house_view(synthetic, normal_noise_deg=0.5)
    up = estimate_up(list(view.regions.values()), view.camera)
    truth = -_truth_normal(world, "body.floor")
    # the camera looks down by ~1 degree; the estimate must beat the camera prior
    assert math.degrees(math.acos(float(up @ truth))) < 0.8
    prior = np.array([0.0, -1.0, 0.0])
    assert float(up @ truth) > float(prior @ truth)


def test_roles_from_orientation_and_slope(synthetic: ModuleType) -> None:
    view, world = _house_view(synthetic)
    up = estimate_up(list(view.regions.values()), view.camera)
    regions = list(view.regions.values())
    walls = [r for r in regions if abs(slope_deg(r.normal, up) - 90) < 15]
    front = front_region(walls, view.camera)
    assert front is not None
    np.testing.assert_allclose(front.normal, _truth_normal(world, "body.front"), atol=1e-9)
    frame = Frame.from_front(front.normal, up)
    wall = (85.0, 95.0)
    left_wall = PlanarPart("body.left", "left", "Wall", wall, False, "leftward")
    right_wall = PlanarPart("body.right", "right", "Wall", wall, False, "rightward")
    left = candidates(left_wall, regions, frame)
    right = candidates(right_wall, regions, frame)
    roof = PlanarPart("body.roof.front", "front", "RoofPlane", (0.0, 65.0), True, "forward")
    # a part the knowledge does not orient is no candidate for anything
    assert candidates(PlanarPart("body.x", "x", "Wall", wall, False), regions, frame) == []
    roof_front = candidates(roof, regions, frame)
    assert [r.normal @ _truth_normal(world, "body.left") for r in left] == [pytest.approx(1.0)]
    assert right == []  # the right wall faces away from the camera
    assert len(roof_front) == 1
    assert slope_deg(roof_front[0].normal, up) == pytest.approx(35.0, abs=0.1)
    # a roof plane is never a wall candidate and vice versa
    assert front not in candidates(roof, regions, frame)
    # the predicted normal of the inserted back roof mirrors the front's pitch
    back = PlanarPart("body.roof.back", "back", "RoofPlane", (0.0, 65.0), True, "backward")
    n_back = predicted_normal(back, frame, 35.0)
    assert float(n_back @ _truth_normal(world, "body.roof.back")) == pytest.approx(1.0, abs=1e-6)
    with pytest.raises(InterpretError, match="no 'orient'"):
        predicted_normal(replace(back, direction=None), frame, 35.0)


def test_support_offset_places_the_hidden_back_wall(synthetic: ModuleType) -> None:
    view, world = _house_view(synthetic)
    points = np.concatenate([view.points_on(r) for r in view.regions])
    n = _truth_normal(world, "body.back")
    assert support_offset(n, points) == pytest.approx(world.face("body.back").d, abs=1e-6)  # type: ignore[attr-defined]


def test_segments_match_edges_of_adjacent_parts(synthetic: ModuleType) -> None:
    view, world = _house_view(synthetic, pixel_noise=0.3)
    roles = ["body.front", "body.left", "body.roof.front"]
    binding = {}
    for rid, r in view.regions.items():
        for role in roles:
            if float(r.normal @ _truth_normal(world, role)) > 0.999:
                binding[rid] = role
    faces = {f.role: (f.normal, f.d) for f in world.faces}  # type: ignore[attr-defined]
    adjacency = {
        "body.left": frozenset(
            {"body.front", "body.back", "body.floor", "body.roof.front", "body.roof.back"}
        ),
        "body.front": frozenset({"body.left", "body.right", "body.floor", "body.roof.front"}),
        "body.roof.front": frozenset({"body.front", "body.left", "body.right", "body.roof.back"}),
    }
    for role, others in list(adjacency.items()):
        for o in others:
            adjacency[o] = adjacency.get(o, frozenset()) | {role}
    matches = match_segments(view.segments, binding, faces, adjacency, view.cameras)
    pairs = sorted(m.parts for m in matches)
    assert ("body.back", "body.left") in pairs  # the silhouette of the hidden back wall
    assert ("body.front", "body.right") in pairs
    assert ("body.roof.back", "body.roof.front") in pairs  # the ridge
    assert ("body.left", "body.roof.back") in pairs  # the gable's back slope
    assert ("body.floor", "body.front") in pairs
    assert all(m.distance_px < 2.0 for m in matches)
    assert len(matches) == len(view.segments)


def test_parallel_planes_have_no_line() -> None:
    n = np.array([0.0, 0.0, 1.0])
    assert plane_line(n, 1.0, n, 2.0) is None
    point, direction = plane_line(n, 1.0, np.array([1.0, 0.0, 0.0]), 2.0)  # type: ignore[misc]
    np.testing.assert_allclose(point, [2.0, 0.0, 1.0], atol=1e-12)
    assert abs(direction[1]) == pytest.approx(1.0)


def test_regions_beside_each_other_by_segment_or_outline(synthetic: ModuleType) -> None:
    from dataclasses import replace

    view, _ = _house_view(synthetic)
    ids = sorted(r for r in view.regions if r != "00/8")
    front, left = ids[0], ids[1]  # the synthetic evidence shares the corner segment
    assert view.beside(front, left)
    # without segments, the outlines decide: touching squares, then squares 20 px apart
    square = np.array([[0.0, 0.0], [50.0, 0.0], [50.0, 50.0], [0.0, 50.0]])
    bare = replace(view, segments=(), _by_region={})
    touching = replace(bare, outlines={front: (square,), left: (square + np.array([52.0, 10.0]),)})
    assert touching.beside(front, left)
    apart = replace(bare, outlines={front: (square,), left: (square + np.array([70.0, 0.0]),)})
    assert not apart.beside(front, left)


def test_one_wall_direction_and_a_level_region_give_up_not_the_camera_axis() -> None:
    """A box on a turntable seen from the front by a camera pitched 17 degrees down: one wall
    direction, the lid and the table. Up is the level regions' normal, not the camera's -y."""
    from aida_kb.interpret.observe import CameraView, RegionView

    pitch = math.radians(17.0)
    # the camera looks down by `pitch`; the world's up is -y (OpenCV, y down)
    R = np.array(
        [
            [1.0, 0.0, 0.0],
            [0.0, math.cos(pitch), -math.sin(pitch)],
            [0.0, math.sin(pitch), math.cos(pitch)],
        ]
    )
    camera = CameraView("00", np.diag([800.0, 800.0, 1.0]), R, np.zeros(3), 640, 480)
    front = np.array([0.0, 0.0, -1.0])  # the box's front faces the camera (world frame)
    rng = np.random.default_rng(0)

    def region(rid: str, normal: np.ndarray, weight: float) -> RegionView:
        n = normal + rng.normal(0.0, 0.002, 3)
        return RegionView(rid, "00", n / np.linalg.norm(n), np.zeros(3), weight, 1000.0, 0.001)

    up_world = np.array([0.0, -1.0, 0.0])
    regions = [
        region("00/1", front, 0.78),
        region("00/5", up_world, 0.12),
        region("00/1000", up_world, 0.10),
    ]
    up = estimate_up(regions, camera)
    assert math.degrees(math.acos(float(up @ up_world))) < 0.5
    # the camera's axis would have been 17 degrees off
    prior = R.T @ np.array([0.0, -1.0, 0.0])
    assert math.degrees(math.acos(float(prior @ up_world))) == pytest.approx(17.0)


def test_level_regions_weigh_against_the_vanishing_point_by_their_fits() -> None:
    """A large, well-fitted level region (the ground) corrects a vanishing-point vertical
    0.8 deg off; a small rough one barely moves it; a pitched roof is not taken for level."""
    from aida_kb.interpret.observe import RegionView, with_level_regions

    truth = np.array([0.0, -1.0, 0.0])
    tilt = math.radians(0.8)
    up_vp = np.array([math.sin(tilt), -math.cos(tilt), 0.0])
    sigma_vp = math.radians(0.25)

    def region(rid: str, normal: np.ndarray, inliers: int, area_m2: float) -> RegionView:
        n = normal / np.linalg.norm(normal)
        return RegionView(rid, "00", n, np.zeros(3), 1.0, 1.0, 0.04, inliers, area_m2)

    ground = region("00/1", truth, 300_000, 3000.0)
    assert math.degrees(ground.normal_sigma_rad) < 0.02
    up = with_level_regions(up_vp, sigma_vp, [ground])
    assert math.degrees(math.acos(float(up @ truth))) < 0.02
    # a flat roof of 40 m², 2,000 pixels: weighed by its fit, it moves the estimate partly
    roof = region("00/2", truth, 2_000, 40.0)
    partly = with_level_regions(up_vp, sigma_vp, [roof])
    off = math.degrees(math.acos(float(partly @ truth)))
    assert 0.02 < off < 0.8
    # a shed roof pitched 10 deg, or a region without a fit, is no level region
    pitch = math.radians(10.0)
    shed = region("00/3", np.array([0.0, -math.cos(pitch), math.sin(pitch)]), 300_000, 3000.0)
    unknown = RegionView("00/4", "00", truth, np.zeros(3), 1.0, 1.0, 0.04)
    np.testing.assert_allclose(with_level_regions(up_vp, sigma_vp, [shed, unknown]), up_vp)


def test_one_wall_and_a_pitched_roof_keep_the_wall_vertical() -> None:
    """A shed seen from its front, no vanishing point: the front wall and the roof pitched
    14 or 22 deg towards it. The roof is not level: up lies in the wall's plane (dev seed
    58010 took the roof for level, the wall leaned by the pitch and no wall fitted it); a
    pitched roof facing the wall gives the rest of it. A flat roof over the wall gives up too,
    whichever region carries more weight."""
    from aida_kb.interpret.observe import CameraView, RegionView

    pitch = math.radians(7.4)  # the camera looks down by this
    R = np.array(
        [
            [1.0, 0.0, 0.0],
            [0.0, math.cos(pitch), -math.sin(pitch)],
            [0.0, math.sin(pitch), math.cos(pitch)],
        ]
    )
    camera = CameraView("00", np.diag([730.0, 730.0, 1.0]), R, np.zeros(3), 480, 360)
    yaw = math.radians(1.6)
    up_world = np.array([0.0, -1.0, 0.0])
    front = np.array([math.sin(yaw), 0.0, -math.cos(yaw)])  # towards the camera

    def region(rid: str, normal: np.ndarray, weight: float) -> RegionView:
        n = normal / np.linalg.norm(normal)
        return RegionView(rid, "00", n, np.zeros(3), weight, 1000.0, 0.001)

    for roof_deg, wall_w, roof_w in ((14.1, 3905.0, 2804.0), (22.0, 3905.0, 2804.0)):
        a = math.radians(roof_deg)
        roof = math.cos(a) * up_world + math.sin(a) * front
        up = estimate_up([region("00/2", front, wall_w), region("00/6", roof, roof_w)], camera)
        assert math.degrees(math.acos(float(up @ up_world))) < 0.01, roof_deg
    for wall_w, roof_w in ((3.0, 1.0), (1.0, 3.0)):
        flat = [region("00/2", front, wall_w), region("00/6", up_world, roof_w)]
        up = estimate_up(flat, camera)
        assert math.degrees(math.acos(float(up @ up_world))) < 0.01


def test_a_segment_along_a_notch_of_its_region_is_no_edge_of_its_face() -> None:
    """Dev seed 58002's front wall region (undistorted enough: k1 -0.012 near the centre):
    a stone block's top cuts into it 15 px above the wall's foot, a tree's side into its left.
    Those segments' lines have the region on both sides: no edge of the face. The foot and the
    right corner are support lines of the region: edges."""
    from aida_kb.interpret.observe import _cuts

    outline = np.array(
        [[208, 148], [214, 150], [214, 251], [210, 253], [171, 257], [170, 282], [185, 281],
         [186, 265], [251, 262], [276, 264], [277, 278], [342, 277], [341, 152]],
        dtype=np.float64,
    )  # fmt: skip
    block_top = np.array([[269.36, 262.50], [230.60, 263.46]])
    tree_side = np.array([[214.0, 160.0], [214.0, 240.0]])
    foot = np.array([[340.63, 277.25], [278.15, 278.92]])
    corner = np.array([[341.04, 148.11], [341.90, 220.61]])
    assert _cuts(block_top, [outline])
    assert _cuts(tree_side, [outline])
    assert not _cuts(foot, [outline])
    assert not _cuts(corner, [outline])
    # a wall's foot broken into short fragments, each tilted 6 deg by the jagged border (dev
    # seed 58020): extended, the line would pass 40 px above the wall's far corners
    wall = np.array([[270.0, 245.0], [720.0, 245.0], [720.0, 368.0], [270.0, 368.0]])
    assert not _cuts(np.array([[331.9, 368.8], [363.2, 365.5]]), [wall])
    # a face in two pieces (a tree in front of its middle) is still on one side of its edges
    assert not _cuts(foot, [outline[outline[:, 1] > 200], outline[outline[:, 1] < 200]])


def test_a_segment_between_two_notches_of_its_region_does_not_run_along_it() -> None:
    """The real courtyard wall's region (Strecha castle, exact NCC) reaches its true foot
    (y 580) between two bollards that cut notches up to y 548 into it; the plinth's top at y
    568 runs inside the region from notch to notch, its ends 1-3 px from the outline, its
    middle 12 px: no edge of the wall. The foot, along the outline all its length, is one; so
    is a foot the outline follows with a wiggle of 6 px along a fifth of it."""
    from aida_kb.interpret.observe import _along

    outline = np.array(
        [[600, 300], [900, 300], [900, 580], [820, 580], [818, 548], [812, 548], [810, 580],
         [712, 580], [710, 548], [704, 548], [702, 580], [600, 580]],
        dtype=np.float64,
    )  # fmt: skip
    plinth_top = np.array([[711.0, 568.0], [811.0, 568.0]])
    assert not _along(plinth_top, outline)
    assert _along(np.array([[720.0, 579.0], [800.0, 579.0]]), outline)
    wiggle = [[776.0, 580.0], [772.0, 586.0], [764.0, 586.0], [760.0, 580.0]]  # 6 px, 16 px
    wiggly = np.insert(outline, 7, wiggle, axis=0)  # between (810, 580) and (712, 580)
    assert _along(np.array([[720.0, 579.0], [800.0, 579.0]]), wiggly)


def test_a_vertical_that_makes_the_heaviest_wall_overhang_is_rejected() -> None:
    """Dev seed 58002's regions: a front wall, a sliver of side wall and a 47-deg roof. The
    side wall and the roof cross along a line 43 deg off the vertical under which the roof is a
    wall and the front wall overhangs by 42 deg; the front and side walls give the vertical."""
    from aida_kb.interpret.observe import CameraView, RegionView

    camera = CameraView("00", np.diag([685.0, 685.0, 1.0]), np.eye(3), np.zeros(3), 480, 360)

    def region(rid: str, normal: list[float], weight: float) -> RegionView:
        n = np.array(normal) / np.linalg.norm(normal)
        return RegionView(rid, "00", n, np.zeros(3), weight, 1000.0, 0.001)

    regions = [
        region("00/2", [0.3072, -0.0696, -0.9491], 2428.4),
        region("00/4", [-0.9545, -0.0202, -0.2977], 24.4),
        region("00/6", [0.2299, -0.7226, -0.6520], 4395.0),
    ]
    truth = np.array([0.0, -0.99826488, 0.05888324])
    up = estimate_up(regions, camera)
    assert math.degrees(math.acos(float(up @ truth))) < 1.0


def test_the_image_edge_is_no_support_of_a_surface(synthetic: ModuleType) -> None:
    """A wall's region leaking through textureless background to the image's edge (dev
    63030: a gable wall seen at a grazing angle) would put its far end, back-projected onto
    the wall's plane, metres behind the house, and the inserted back wall with it. Its
    vertices on the image's edge are where the image ends: no support of the surface."""
    view, world = _house_view(synthetic)
    left = next(
        rid
        for rid, r in view.regions.items()
        if float(r.normal @ _truth_normal(world, "body.left")) > 0.999
    )
    # the region's outline: the wall's true face in the image
    outline = view.camera.pinhole.project(np.asarray(world.face("body.left").polygon))  # type: ignore[attr-defined]
    assert float(outline[:, 0].min()) > 20.0  # the wall lies inside the image
    x_in, y = float(outline[:, 0].min()), float(np.median(outline[:, 1]))
    # a strip from the region's leftmost point to the image's left edge
    leak = np.array([[x_in, y], [0.0, y], [0.0, y + 2.0], [x_in, y + 2.0]])
    clean_view = replace(view, outlines={**view.outlines, left: (outline,)})
    leaky = replace(view, outlines={**view.outlines, left: (outline, leak)})
    n = _truth_normal(world, "body.back")
    clean = support_offset(n, clean_view.points_on(left))
    # the strip's inner end lies by the wall's outline: the support moves by millimetres
    assert support_offset(n, leaky.points_on(left)) == pytest.approx(clean, abs=0.01)
    # the edge's pixels, back-projected onto the wall's plane, lie far behind the house
    cam = view.camera
    edge = intersect_rays_plane(cam.centre_m, cam.rays_world(leak[1:3]), view.regions[left])
    assert float(np.max(edge @ n)) > clean + 5.0


@pytest.mark.parametrize("k1", [-0.11, 0.04])
def test_the_image_edge_is_found_in_the_original_distorted_image(k1: float) -> None:
    """Undistorted, the original image's edge bends: barrel distortion (k1 < 0, dev 64013:
    -0.11) moves it 3-5 px out of the pinhole image, pincushion (k1 > 0) 1-2 px into it. The
    edge is found where it is a rectangle, in the original image."""
    K = np.array([[694.2, 0.0, 239.5], [0.0, 694.2, 179.5], [0.0, 0.0, 1.0]])
    D = np.array([k1, 0.0, 0.0, 0.0, 0.0])
    camera = CameraView("00", K, np.eye(3), np.zeros(3), 480, 360, 0.0, D)
    along = np.linspace(0.0, 1.0, 9)
    border = np.concatenate(
        [
            np.stack([along * 479.0, np.zeros(9)], axis=1),
            np.stack([along * 479.0, np.full(9, 359.0)], axis=1),
            np.stack([np.zeros(9), along * 359.0], axis=1),
            np.stack([np.full(9, 479.0), along * 359.0], axis=1),
        ]
    )
    inner = np.clip(border, 3.0, [476.0, 356.0])  # 3 px inside the original image's edge
    on_edge, inside = undistort_pixels(border, K, D), undistort_pixels(inner, K, D)
    # in the pinhole image the corners lie more than a pixel off the rectangle of its pixels
    off = np.minimum(np.abs(on_edge), np.abs(on_edge - [479.0, 359.0])).min(axis=1)
    assert float(off.max()) > 1.2
    assert camera.on_image_edge(on_edge).all()
    assert not camera.on_image_edge(inside).any()
    # beyond the original image (synthetic evidence's true corners): not its edge
    assert not camera.on_image_edge(undistort_pixels(np.array([[-30.0, 100.0]]), K, D)).any()
