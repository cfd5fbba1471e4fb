"""Viewpoint registration: model edges, matching, the pose solve and the search without a guess."""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

from aida_kb.errors import SolveError
from aida_kb.geometry.camera import PinholeCamera
from aida_kb.geometry.rotation import rotation_from_rvec
from aida_kb.register import (
    RegionObservations,
    RegistrationOptions,
    Rig,
    RigidModel,
    StereoSegments,
    angle_about,
    match_segments,
    orbit_pivot,
    register_view,
    rival_turns,
    rivals_left,
    symmetry_order,
    turned,
    vertical_axis,
)
from aida_kb.register.pose import (
    MIN_POINT_SIGMA_PX,
    SCATTER_BIAS,
    SEGMENT_FLOOR_PX,
    EdgeObservations,
    point_sigma,
    pose_factors,
)
from aida_kb.solve.problem import Evaluation, build_problem
from aida_kb.testing.segments import simulated_segments

K = np.array([[800.0, 0.0, 319.5], [0.0, 800.0, 239.5], [0.0, 0.0, 1.0]])


def _box(
    w: float = 0.4,
    d: float = 0.3,
    h: float = 0.25,
    centre: tuple[float, float, float] = (0, 0.3, 1.4),
) -> RigidModel:
    """A box on the floor of a y-down world, 1.4 m in front of the origin."""
    c = np.array(centre, dtype=float)
    x, y, z = w / 2, h / 2, d / 2
    corners = {
        (sx, sy, sz): c + np.array([sx * x, sy * y, sz * z])
        for sx in (-1, 1)
        for sy in (-1, 1)
        for sz in (-1, 1)
    }
    faces = {  # outward normal, and the corners counter-clockwise seen from outside
        "front": ((0, 0, -1), [(-1, -1, -1), (1, -1, -1), (1, 1, -1), (-1, 1, -1)]),
        "back": ((0, 0, 1), [(-1, -1, 1), (-1, 1, 1), (1, 1, 1), (1, -1, 1)]),
        "left": ((-1, 0, 0), [(-1, -1, -1), (-1, 1, -1), (-1, 1, 1), (-1, -1, 1)]),
        "right": ((1, 0, 0), [(1, -1, -1), (1, -1, 1), (1, 1, 1), (1, 1, -1)]),
        "top": ((0, -1, 0), [(-1, -1, -1), (-1, -1, 1), (1, -1, 1), (1, -1, -1)]),
        "bottom": ((0, 1, 0), [(-1, 1, -1), (1, 1, -1), (1, 1, 1), (-1, 1, 1)]),
    }
    names = list(faces)
    normals = np.array([faces[n][0] for n in names], dtype=float)
    polys = [np.array([corners[k] for k in faces[n][1]]) for n in names]
    offsets = np.array([float(nrm @ p[0]) for nrm, p in zip(normals, polys, strict=True)])
    return RigidModel.from_polygons(names, normals, offsets, polys)


def _reference() -> PinholeCamera:
    # looking slightly down at the box from 0.3 m above its top
    tilt = math.radians(12.0)
    R = np.array(
        [
            [1.0, 0.0, 0.0],
            [0.0, math.cos(tilt), -math.sin(tilt)],
            [0.0, math.sin(tilt), math.cos(tilt)],
        ]
    )
    C = np.array([0.0, -0.05, 0.0])
    return PinholeCamera(K, R, -R @ C, 640, 480)


def test_box_edges_pair_the_faces() -> None:
    model = _box()
    assert model.edge_faces.shape == (12, 2)
    pairs = {frozenset(model.names[i] for i in f) for f in model.edge_faces}
    assert frozenset({"front", "back"}) not in pairs
    assert frozenset({"front", "top"}) in pairs
    assert model.vertices.shape == (8, 3)
    assert model.size == pytest.approx(0.4)


def test_visible_edges_are_those_of_faces_facing_the_camera() -> None:
    model = _box()
    vis = model.visible_edges(_reference())
    seen = {frozenset(model.names[i] for i in model.edge_faces[e]) for e in vis.index}
    # front and top face the camera: their 7 edges (the 4 of the front, 3 more of the top)
    assert len(seen) == 7
    assert all("front" in s or "top" in s for s in seen)


def test_matching_takes_the_nearest_parallel_edge() -> None:
    a = np.array([[0.0, 0.0], [0.0, 10.0]])
    b = np.array([[100.0, 0.0], [100.0, 10.0]])
    p1 = np.array([[10.0, 9.0], [10.0, 1.5], [50.0, -20.0], [10.0, 0.0]])
    p2 = np.array([[60.0, 9.2], [60.0, 1.0], [50.0, 20.0], [12.0, 40.0]])
    m = match_segments(a, b, p1, p2, max_distance_px=3.0, max_angle_rad=math.radians(5.0))
    assert m.segment.tolist() == [0, 1]
    assert m.edge.tolist() == [1, 0]
    np.testing.assert_allclose(m.distance_px, [0.9, 1.25])


def test_matching_whole_lines_by_mean_distance_and_a_mask() -> None:
    """The interpreter's use of the one matcher: edges as whole lines, the ends' mean distance
    bounded, candidate pairs given as a mask."""
    a = np.array([[0.0, 0.0], [0.0, 10.0]])
    b = np.array([[100.0, 0.0], [100.0, 10.0]])
    # beyond both edges' ends; ends 1 and 4 px off edge 0 (mean 2.5), 9 and 6 off edge 1
    p1 = np.array([[200.0, 1.0]])
    p2 = np.array([[260.0, 4.0]])
    match = functools.partial(
        match_segments, a, b, p1, p2, max_distance_px=3.0, max_angle_rad=math.radians(5.0)
    )
    assert match().size == 0  # no overlap with the edge
    assert match(min_overlap=None).size == 0  # one end 4 px off
    m = match(min_overlap=None, mean_distance=True)
    assert m.edge.tolist() == [0]
    np.testing.assert_allclose(m.distance_px, [2.5])
    only_edge_1 = np.array([[False], [True]])
    assert match(min_overlap=None, mean_distance=True, allowed=only_edge_1).size == 0


def test_pose_factors_jacobian_matches_finite_differences() -> None:
    model = _box()
    cam = turned(_reference(), np.array([0.0, -1.0, 0.0]), model.centroid, 0.4)
    rng = np.random.default_rng(3)
    n = np.array([[0.1, 0.2, -1.0], [0.0, -1.0, -0.2]])
    regions = RegionObservations(
        np.array([0, 4]),
        n / np.linalg.norm(n, axis=1, keepdims=True),
        rng.normal(size=(2, 3)) + np.array([0.0, 0.0, 1.4]),
        np.array([0.01, 0.02]),
        np.array([0.03, 0.05]),
    )
    vis = model.visible_edges(cam)
    k = min(4, vis.a.shape[0])
    edges = EdgeObservations(model.edge_faces[vis.index[:k]], vis.a[:k] + 0.7, vis.b[:k] - 0.4)
    factors = pose_factors(edges, regions, None, sigma_px=1.0, f_scale=2.0)
    assert [f.kind for f in factors] == ["edge"] * k + ["camera_position"] * 2
    problem = build_problem(
        model.normals,
        model.offsets,
        factors,
        fixed_parts=range(model.normals.shape[0]),
        cameras=[cam],
        free_cameras=[0],
    )
    for loss in ("linear", "soft_l1"):
        ev = Evaluation(problem, np.zeros(0, dtype=np.intp), free_cameras=np.array([0]), loss=loss)
        x = cam.pose
        _, J = ev.residuals_and_dense_jacobian(x)
        eps = 1e-7
        for i in range(6):
            dp = np.zeros(6)
            dp[i] = eps
            fd = (ev.residuals(x + dp) - ev.residuals(x - dp)) / (2 * eps)
            np.testing.assert_allclose(J[:, i], fd, rtol=1e-5, atol=1e-3)


@pytest.mark.parametrize("turn_deg", [40.0, -65.0])
def test_registration_without_a_guess_recovers_the_turn(turn_deg: float) -> None:
    model = _box()
    ref = _reference()
    up = vertical_axis(model, ref)
    np.testing.assert_allclose(up, [0.0, -1.0, 0.0])
    truth = turned(ref, up, model.centroid, math.radians(turn_deg))
    p1, p2 = simulated_segments(model, truth, np.random.default_rng(7), noise_px=0.5)
    reg = register_view(model, ref, p1, p2)
    assert abs(reg.angle_deg - turn_deg) < 0.1
    assert abs(angle_about(ref, truth, up) - turn_deg) < 1e-9
    assert np.linalg.norm(reg.camera.centre - truth.centre) < 0.005  # metres, at 1.4 m
    assert reg.rms_px < 0.5
    assert reg.n_edges >= 6
    # the box looks the same turned by a half turn: that twin, and nothing else, is as good
    assert all(abs((a - turn_deg) % 360.0 - 180.0) < 0.5 for a, _ in reg.alternatives)
    # with no images to tell the twins apart, the expected turn chose: the twin is undecided
    assert len(reg.undecided) == 1
    assert abs((reg.undecided[0] - reg.angle_deg) % 360.0 - 180.0) < 1e-6


def test_symmetric_gap_measures_turns_modulo_the_symmetry() -> None:
    from aida_kb.register.register import _symmetric_gap

    assert _symmetric_gap(10.0, 190.0, 2) == pytest.approx(0.0)
    assert _symmetric_gap(10.0, 100.0, 2) == pytest.approx(90.0)
    assert _symmetric_gap(10.0, 100.0, 4) == pytest.approx(0.0)
    assert _symmetric_gap(-175.0, 170.0, 1) == pytest.approx(15.0)
    assert _symmetric_gap(5.0, 100.0, 1) == pytest.approx(95.0)


def test_registration_with_a_guess_searches_near_it() -> None:
    model = _box()
    ref = _reference()
    up = vertical_axis(model, ref)
    truth = turned(ref, up, model.centroid, math.radians(160.0))
    p1, p2 = simulated_segments(model, truth, np.random.default_rng(8), noise_px=0.5)
    # the box looks the same turned by a half turn: the guess decides
    reg = register_view(model, ref, p1, p2, init_angle_deg=150.0)
    assert abs(reg.angle_deg - 160.0) < 0.1
    reg = register_view(model, ref, p1, p2, init_angle_deg=-30.0)
    assert abs(reg.angle_deg + 20.0) < 0.1


def test_registration_with_too_few_segments_is_an_error() -> None:
    with pytest.raises(SolveError, match="only 1 usable line segments"):
        register_view(_box(), _reference(), [[0.0, 0.0]], [[50.0, 0.0]])


def _rig() -> Rig:
    R = rotation_from_rvec([0.0015, -0.0087, 0.0])
    return Rig(K, R, -R @ np.array([0.12, 0.0, 0.0]), 640, 480)


def test_right_camera_pose_jacobian_matches_finite_differences() -> None:
    rig = _rig()
    x = np.array([0.3, -1.2, 0.4, 0.5, -0.2, 1.0])
    right, J = rig.pose_jacobian(x)
    np.testing.assert_allclose(
        right.centre, rig.right_of(PinholeCamera.from_pose(K, x, 640, 480)).centre
    )
    eps = 1e-6
    for i in range(6):
        dx = np.zeros(6)
        dx[i] = eps
        fd = (rig.pose_jacobian(x + dx)[0].pose - rig.pose_jacobian(x - dx)[0].pose) / (2 * eps)
        np.testing.assert_allclose(J[:, i], fd, rtol=1e-6, atol=1e-7)


def test_stereo_registration_uses_both_images() -> None:
    model = _box()
    ref = _reference()
    up = vertical_axis(model, ref)
    rig = _rig()
    truth = turned(ref, up, model.centroid, math.radians(50.0))
    rng = np.random.default_rng(9)
    p1, p2 = simulated_segments(model, truth, rng, noise_px=0.5)
    r1, r2 = simulated_segments(model, rig.right_of(truth), rng, noise_px=0.5)
    mono = register_view(model, ref, p1, p2, init_angle_deg=45.0)
    both = register_view(
        model, ref, p1, p2, init_angle_deg=45.0, stereo=StereoSegments(rig, r1, r2)
    )
    assert both.n_edges > mono.n_edges  # the right image's segments count too
    assert abs(both.angle_deg - 50.0) < 0.05
    assert np.linalg.norm(both.camera.centre - truth.centre) < 0.003


def test_segment_sigmas_weigh_each_segment_and_drop_the_far_ones() -> None:
    model = _box()
    ref = _reference()
    up = vertical_axis(model, ref)
    truth = turned(ref, up, model.centroid, math.radians(50.0))
    rng = np.random.default_rng(4)
    p1, p2 = simulated_segments(model, truth, rng, noise_px=0.1)
    n = np.linalg.norm(p2 - p1, axis=1)
    sigma = np.full(len(p1), 0.1)
    # one long segment 1.5 px off its edge, known to be noisy or not
    k = int(np.argmax(n))
    normal = np.array([-(p2[k] - p1[k])[1], (p2[k] - p1[k])[0]]) / n[k]
    p1[k] += 1.5 * normal
    p2[k] += 1.5 * normal
    plain = register_view(model, ref, p1, p2, init_angle_deg=45.0)
    own = register_view(model, ref, p1, p2, init_angle_deg=45.0, sigma_px=sigma)
    assert abs(own.angle_deg - 50.0) < 0.02
    assert abs(own.angle_deg - 50.0) < abs(plain.angle_deg - 50.0)
    with pytest.raises(SolveError, match="one per segment"):
        register_view(model, ref, p1, p2, sigma_px=sigma[:-1])
    # the noise model: a segment's mean offset is never known better than the floor
    edges = EdgeObservations(
        np.zeros((2, 2), np.intp),
        np.zeros((2, 2)),
        np.array([[100.0, 0.0], [10.0, 0.0]]),
        np.array([0.1, 0.0]),
    )
    s = point_sigma(edges, 1.0)
    own = np.array([0.1, MIN_POINT_SIGMA_PX])
    np.testing.assert_allclose(
        s / np.sqrt([100.0, 10.0]),
        np.sqrt(own**2 / [100.0, 10.0] + SEGMENT_FLOOR_PX**2 + (SCATTER_BIAS * own) ** 2),
    )
    assert point_sigma(EdgeObservations(edges.faces, edges.p1, edges.p2), 1.0).tolist() == [1, 1]


def test_symmetry_order_of_boxes() -> None:
    up = np.array([0.0, -1.0, 0.0])
    box = _box()
    assert symmetry_order(box, up, box.centroid) == 2
    cube = _box(0.3, 0.3, 0.25)
    assert symmetry_order(cube, up, cube.centroid) == 4
    # turned about another axis a box is no longer the same
    assert symmetry_order(box, np.array([1.0, 0.0, 0.0]), box.centroid) == 2
    assert symmetry_order(box, up, box.centroid + np.array([0.05, 0.0, 0.0])) == 1


def test_edges_hidden_behind_another_solid_are_cut() -> None:
    back = _box(centre=(0.0, 0.3, 2.0))
    front = _box(0.1, 0.1, 0.6, centre=(-0.13, 0.3, 1.2))  # a post before the box's left end
    both = RigidModel.from_polygons(
        [f"b.{n}" for n in back.names] + [f"f.{n}" for n in front.names],
        np.concatenate([back.normals, front.normals]),
        np.concatenate([back.offsets, front.offsets]),
        list(back.polygons) + list(front.polygons),
    )
    cam = _reference()
    alone = back.visible_edges(cam)
    seen = both.visible_edges(cam)
    top = {
        i
        for i, f in enumerate(both.edge_faces)
        if {both.names[f[0]], both.names[f[1]]} == {"b.front", "b.top"}
    }
    (edge,) = top
    assert edge in seen.index
    # the post hides the left part of the box's front top edge: the right stretch is kept
    k = int(np.flatnonzero(seen.index == edge)[0])
    j = int(np.flatnonzero(alone.index == edge)[0])
    assert 0.5 * alone.length_px[j] < seen.length_px[k] < 0.9 * alone.length_px[j]
    right_end = max(alone.a[j, 0], alone.b[j, 0])
    assert max(seen.a[k, 0], seen.b[k, 0]) == pytest.approx(right_end)


def test_the_search_turns_about_the_point_the_reference_looks_at() -> None:
    model = _box(centre=(0.3, 0.3, 1.4))
    ref = _reference()
    p = orbit_pivot(model, ref)
    # on the optical axis, level with the centroid along it
    np.testing.assert_allclose(np.cross(p - ref.centre, ref.optical_axis), 0.0, atol=1e-12)
    assert float((model.centroid - p) @ ref.optical_axis) == pytest.approx(0.0, abs=1e-12)


def test_regions_that_disagree_with_the_model_reveal_a_wrong_pose() -> None:
    from aida_kb.register.register import (
        RegionMeasurements,
        RegistrationOptions,
        region_disagreement_deg,
    )

    model = _box()
    truth = turned(_reference(), np.array([0.0, -1.0, 0.0]), model.centroid, 0.4)
    # the regions of the faces the true camera sees, measured in its frame
    front = model.front_facing(truth.centre)
    parts = np.flatnonzero(front)
    centres = np.array([np.mean(model.polygons[i], axis=0) for i in parts])
    R = truth.R_cam_world
    regions = RegionMeasurements(
        model.normals[parts] @ R.T, centres @ R.T + truth.t_cam_world, np.full(parts.size, 1e-3)
    )
    opts = RegistrationOptions()
    assert region_disagreement_deg(model, truth, regions, opts) == pytest.approx(0.0, abs=1e-6)
    off = turned(truth, np.array([0.0, -1.0, 0.0]), model.centroid, math.radians(10.0))
    assert region_disagreement_deg(model, off, regions, opts) == pytest.approx(10.0, abs=0.5)
    assert region_disagreement_deg(model, truth, None, opts) is None


def _box_image(model: RigidModel, camera: PinholeCamera, supersample: int = 6) -> np.ndarray:
    """An 8-bit image of the box's faces turned to `camera`, each its own grey, on a mid grey
    background: each pixel the mean of `supersample`² samples inside it, a sample taking the
    grey of the (convex) face it falls in, then a slight blur."""
    import cv2

    s = (np.arange(supersample) + 0.5) / supersample - 0.5
    ys = (np.arange(camera.height)[:, None] + s[None, :]).ravel()
    xs = (np.arange(camera.width)[:, None] + s[None, :]).ravel()
    big = np.full((ys.size, xs.size), 90.0)
    front = model.front_facing(camera.centre)
    greys = (200.0, 150.0, 60.0, 230.0, 120.0, 30.0)
    for i, poly in enumerate(model.polygons):
        if not front[i]:
            continue
        q = camera.project(poly)
        # the samples of the face's bounding box only
        r0, r1 = np.searchsorted(ys, [q[:, 1].min(), q[:, 1].max()])
        c0, c1 = np.searchsorted(xs, [q[:, 0].min(), q[:, 0].max()])
        X, Y = np.meshgrid(xs[c0:c1], ys[r0:r1])
        sides = [
            (b[0] - a[0]) * (Y - a[1]) - (b[1] - a[1]) * (X - a[0])
            for a, b in zip(q, np.roll(q, -1, axis=0), strict=True)
        ]
        inside = np.all([c >= 0 for c in sides], axis=0) | np.all([c <= 0 for c in sides], axis=0)
        big[r0:r1, c0:c1][inside] = greys[i % len(greys)]
    small = big.reshape(camera.height, supersample, camera.width, supersample).mean(axis=(1, 3))
    return np.asarray(np.clip(cv2.GaussianBlur(small, (0, 0), 0.7) + 0.5, 0, 255), dtype=np.uint8)


def test_polish_fits_the_model_edges_to_the_image() -> None:
    from aida_kb.register import image_edges, polish

    model = _box()
    ref = _reference()
    up = vertical_axis(model, ref)
    truth = turned(ref, up, model.centroid, math.radians(50.0))
    grey = _box_image(model, truth)
    # at the true pose every visible edge is found within a few hundredths of a pixel
    obs = image_edges(model, truth, grey)
    vis = model.visible_edges(truth)
    assert obs.size >= 6
    lines = {
        tuple(f): (a, b) for f, a, b in zip(model.edge_faces[vis.index], vis.a, vis.b, strict=True)
    }
    for f, p1, p2 in zip(obs.faces, obs.p1, obs.p2, strict=True):
        a, b = lines[tuple(f)]
        u = (b - a) / np.linalg.norm(b - a)
        off = [abs(float((p - a) @ np.array([-u[1], u[0]]))) for p in (p1, p2)]
        assert max(off) < 0.08, (f, off)
    # from a pose 0.3 degrees and 4 mm off, the image brings it back
    start = turned(truth, up, model.centroid, math.radians(0.3))
    start = PinholeCamera(
        K, start.R_cam_world, start.t_cam_world + np.array([0.004, 0.0, 0.0]), 640, 480
    )
    out = polish(model, start, grey)
    assert out is not None
    cam, rms, cov = out
    assert abs(angle_about(truth, cam, up)) < 0.05  # one image: turn and shift correlate
    assert np.linalg.norm(cam.centre - truth.centre) < 0.001
    assert rms < 0.1
    assert np.all(np.isfinite(cov))
    assert np.all(np.linalg.eigvalsh(cov) > 0)
    # a blank image holds no edges: nothing to polish with
    assert polish(model, start, np.full_like(grey, 90)) is None


def _wedge(rise: float) -> RigidModel:
    """The `_box` with its top's back edge raised by `rise` metres (a shed's slight slope):
    all but symmetric under a half turn (`symmetry_order` 2), its images not quite."""
    c = np.array([0.0, 0.3, 1.4])
    x, y, z = 0.2, 0.125, 0.15

    def corner(sx: int, sy: int, sz: int) -> np.ndarray:
        p = c + np.array([sx * x, sy * y, sz * z])
        if sy < 0 and sz > 0:  # the top's back edge (y points down)
            p[1] -= rise
        return p

    faces = {
        "front": [(-1, -1, -1), (1, -1, -1), (1, 1, -1), (-1, 1, -1)],
        "back": [(-1, -1, 1), (-1, 1, 1), (1, 1, 1), (1, -1, 1)],
        "left": [(-1, -1, -1), (-1, 1, -1), (-1, 1, 1), (-1, -1, 1)],
        "right": [(1, -1, -1), (1, -1, 1), (1, 1, 1), (1, 1, -1)],
        "top": [(-1, -1, -1), (-1, -1, 1), (1, -1, 1), (1, -1, -1)],
        "bottom": [(-1, 1, -1), (1, 1, -1), (1, 1, 1), (-1, 1, 1)],
    }
    polys = [np.array([corner(*k) for k in ks]) for ks in faces.values()]
    normals = []
    for p in polys:  # outward: the polygons run counter-clockwise seen from outside
        n = np.cross(p[1] - p[0], p[2] - p[0])
        n = n / np.linalg.norm(n)
        normals.append(n if float(n @ (p.mean(axis=0) - c)) > 0 else -n)
    N = np.array(normals)
    offsets = np.array([float(n @ p[0]) for n, p in zip(N, polys, strict=True)])
    return RigidModel.from_polygons(list(faces), N, offsets, polys)


def test_a_symmetric_twin_far_from_the_expected_turn_is_not_taken() -> None:
    # the camera turned 200 degrees, the sequence expecting 20: the images fit 200 best (the
    # model's slight slope), but a model that looks all but the same turned by a half turn
    # cannot tell 200 from its twin at 20 — a flip is named, never taken
    model = _wedge(0.008)
    ref = _reference()
    up = vertical_axis(model, ref)
    assert symmetry_order(model, up, model.centroid) == 2
    truth = turned(ref, up, model.centroid, math.radians(200.0))
    p1, p2 = simulated_segments(model, truth, np.random.default_rng(9), noise_px=0.3)
    with pytest.raises(SolveError, match=r"twin .* nearer the expected 20\.0"):
        register_view(model, ref, p1, p2, expected_turn_deg=20.0)
    # expected near it, the same view registers
    reg = register_view(model, ref, p1, p2, expected_turn_deg=190.0)
    assert abs(reg.angle_deg + 160.0) < 0.1


def test_a_joint_adjustment_takes_the_model_edges_fitted_to_the_images() -> None:
    from aida_kb.interpret.imagefit import consistent_edges, fitted_edges
    from aida_kb.interpret.joint import JointInputs, joint_adjustment
    from aida_kb.register import RegionMeasurements
    from aida_kb.register.evidence import ViewMeasurements

    model, ref = _box(), _reference()
    up = vertical_axis(model, ref)
    truth = turned(ref, up, model.centroid, math.radians(50.0))
    greys = [_box_image(model, ref), _box_image(model, truth)]
    # at the true pose every fitted edge is consistent with the model; one moved 3 px is not
    left, right = fitted_edges(model, [ref, truth], greys, [None, None])
    assert right == [None, None]
    found = left[1]
    assert found is not None
    assert found.size >= 6
    assert consistent_edges(model, truth, found, 6.0).size == found.size
    moved = EdgeObservations(
        found.faces,
        found.p1 + np.array([0.0, 3.0]),
        found.p2 + np.array([0.0, 3.0]),
        found.sigma_px,
    )
    assert consistent_edges(model, truth, moved, 6.0).size < found.size
    # the second camera 0.3 degrees off, the model free: the images' edges bring it back
    empty = np.zeros((0, 2))
    none = RegionMeasurements(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0))
    views = [ViewMeasurements(v, K, 640, 480, empty, empty, none) for v in ("00", "01")]
    cams = [ref, turned(truth, up, model.centroid, math.radians(0.3))]
    for _ in range(2):
        left, _ = fitted_edges(model, cams, greys, [None, None])
        normals, _, moved_cams, _ = joint_adjustment(
            model, cams, views, [1], JointInputs(fitted=left)
        )
        cams = list(moved_cams)
    assert abs(angle_about(truth, cams[1], up)) < 0.03
    cos = np.clip(np.sum(normals * model.normals, axis=1), -1.0, 1.0)
    assert float(np.degrees(np.arccos(cos)).max()) < 0.1


def _textured_image(
    model: RigidModel, camera: PinholeCamera, seed: int, alike: bool = False
) -> np.ndarray:
    """An 8-bit image of the box with every face its own texture (a few sinusoids of random
    direction and 3-8 cm wavelength in the face's plane; ``alike``: rings about each face's
    centre instead, which look the same on faces of one size however they are turned) on a
    blank background."""
    from aida_kb.geometry.polygon import plane_bases
    from aida_kb.texture.raycast import Faces, first_hits

    u, v = plane_bases(model.normals)
    faces = Faces(model.polygons, model.normals, model.offsets, u, v)
    ys, xs = np.mgrid[0 : camera.height, 0 : camera.width].astype(np.float64)
    pixels = np.stack([xs.ravel(), ys.ravel()], axis=1)
    face, depth, rays = first_hits(faces, camera, pixels, grid=True)
    grey = np.full(face.shape, 90.0)
    rng = np.random.default_rng(seed)
    for f in range(len(model.polygons)):
        on = face == f
        X = camera.centre + depth[on, None] * rays[on]
        if alike:
            r = np.linalg.norm(X - model.polygons[f].mean(axis=0), axis=1)
            grey[on] = 128.0 + 50.0 * np.sin(2 * np.pi * r / 0.04) + 30 * np.sin(r / 0.011)
            continue
        a, b = X @ u[f], X @ v[f]
        value = np.full(a.shape, 128.0)
        for _ in range(3):
            theta, wave, phase = rng.uniform(0, np.pi), rng.uniform(0.03, 0.08), rng.uniform(0, 6)
            value += 30.0 * np.sin(
                2 * np.pi * (a * np.cos(theta) + b * np.sin(theta)) / wave + phase
            )
        grey[on] = value
    return np.asarray(np.clip(grey.reshape(camera.height, camera.width), 0, 255), dtype=np.uint8)


def test_the_images_choose_between_a_symmetric_models_twins() -> None:
    from aida_kb.interpret.transfer import ImageTransfer

    # a box looks the same turned by a half turn: its segments alone register the view turned
    # 100 degrees at its twin, -80, the turn nearer the expected 0; the faces' textures (the
    # reference's image carried into the view through the model) tell them apart
    model = _box()
    up = vertical_axis(model, _reference())
    ref = turned(_reference(), up, model.centroid, math.radians(30.0))
    assert symmetry_order(model, up, model.centroid) == 2
    truth = turned(ref, up, model.centroid, math.radians(100.0))
    p1, p2 = simulated_segments(model, truth, np.random.default_rng(3), noise_px=0.3, clutter=10)
    fast = RegistrationOptions(starts=2, schedules_px=((12.0, 6.0, 3.0, 2.0),))
    twin = register_view(model, ref, p1, p2, expected_turn_deg=0.0, options=fast)
    assert abs(twin.angle_deg + 80.0) < 0.5
    images = [_textured_image(model, cam, seed=5) for cam in (ref, truth)]
    judge = ImageTransfer(model, [ref], [images[0]], images[1])
    right, wrong = judge(truth), judge(twin.camera)
    assert right.confirmed
    assert right.ncc > 0.75
    assert wrong.shares  # the twin sees the faces the reference sees, with other textures
    assert abs(wrong.ncc) < 0.1
    reg = register_view(model, ref, p1, p2, expected_turn_deg=0.0, photometric=judge, options=fast)
    assert abs(reg.angle_deg - 100.0) < 0.1
    assert reg.undecided == ()  # the images decided
    # faces that look alike (one texture on every face) correlate at both twins: the
    # segments' choice, the twin nearer the expected turn, stands but is said undecided
    alike = [_textured_image(model, cam, seed=5, alike=True) for cam in (ref, truth)]
    same = ImageTransfer(model, [ref], [alike[0]], alike[1])
    assert same(truth).confirmed
    assert same(twin.camera).confirmed
    open_ = register_view(model, ref, p1, p2, expected_turn_deg=0.0, photometric=same, options=fast)
    assert abs(open_.angle_deg + 80.0) < 0.5
    assert [round(a) for a in open_.undecided] == [100]
    # where the registered views show no texture, nothing confirms either twin: not registered
    blank = ImageTransfer(model, [ref], [np.full_like(images[0], 90)], images[1])
    with pytest.raises(SolveError, match="shares no textured face"):
        register_view(model, ref, p1, p2, expected_turn_deg=0.0, photometric=blank, options=fast)


def test_rivals_the_images_rule_out_at_the_adjusted_pose_are_dropped() -> None:
    from aida_kb.interpret.transfer import ImageTransfer
    from aida_kb.register import Registration

    # a registration that took its pose 3 degrees off: there the images hardly correlate (NCC
    # 0.33) and rule neither its twin (-77) nor a rival a quarter turn back (13 degrees) out;
    # judged again at the adjusted pose (the truth: 0.80), they do
    model = _box()
    up = vertical_axis(model, _reference())
    ref = turned(_reference(), up, model.centroid, math.radians(30.0))
    truth = turned(ref, up, model.centroid, math.radians(100.0))
    off = turned(truth, up, model.centroid, math.radians(3.0))
    images = [_textured_image(model, cam, seed=5) for cam in (ref, truth)]
    judge = ImageTransfer(model, [ref], [images[0]], images[1])
    twin = turned(off, up, model.centroid, math.radians(180.0))
    other = turned(off, up, model.centroid, math.radians(-90.0))
    assert not judge(off).confirmed
    assert judge(twin).shares  # both judged there, neither ruled out
    assert judge(other).shares
    turns = (angle_about(ref, twin, up), angle_about(ref, other, up))
    reg = Registration(
        off, angle_about(ref, off, up), 0.5, 0.5, 12, 0, (), np.eye(6), 0.1, 0.1, (), turns,
        (judge(twin), judge(other)),
    )  # fmt: skip
    kept, there = rivals_left(model, ref, reg, off, judge)
    assert kept.undecided == turns  # a pose the images do not confirm decides nothing
    narrowed, there = rivals_left(model, ref, reg, truth, judge)
    assert there.confirmed
    assert narrowed.undecided == ()
    assert narrowed.undecided_support == ()
    assert narrowed.camera is off  # the pose is the caller's to keep
    # faces that look alike: the exact twin of the adjusted pose correlates as well, and stays
    alike = [_textured_image(model, cam, seed=5, alike=True) for cam in (ref, truth)]
    same = ImageTransfer(model, [ref], [alike[0]], alike[1])
    doubt = Registration(
        off, reg.angle_deg, 0.5, 0.5, 12, 0, (), np.eye(6), 0.1, 0.1, (), turns[:1],
        (same(twin),),
    )  # fmt: skip
    left, _ = rivals_left(model, ref, doubt, truth, same)
    assert left.undecided == turns[:1]


def _regions_seen(model: RigidModel, camera: PinholeCamera) -> tuple[np.ndarray, object]:
    """The parts `camera` sees and their regions (true normals and centres, its frame)."""
    from aida_kb.register.register import RegionMeasurements

    parts = np.flatnonzero(model.front_facing(camera.centre))
    centres = np.array([np.mean(model.polygons[i], axis=0) for i in parts])
    R = camera.R_cam_world
    regions = RegionMeasurements(
        model.normals[parts] @ R.T, centres @ R.T + camera.t_cam_world, np.full(parts.size, 1e-3)
    )
    return parts, regions


def test_realigned_takes_the_rotation_and_position_the_regions_give() -> None:
    from aida_kb.register.register import RegionMeasurements, realigned

    model = _box()
    up = np.array([0.0, -1.0, 0.0])
    truth = turned(_reference(), up, model.centroid, math.radians(30.0))
    parts, regions = _regions_seen(model, truth)
    assert isinstance(regions, RegionMeasurements)
    assert parts.size == 3  # two walls and the top: the rotation and the position are fixed
    # a pose whose segments fit in a wrong basin: 4 degrees off about a tilted axis, 5 cm away
    wrong = truth.with_pose(truth.pose + np.array([0.05, 0.04, 0.02, 0.03, -0.02, 0.04]))
    assert _angle_deg(wrong, truth) > 3.5
    sigma = np.full(parts.size, math.radians(0.05))
    back = realigned(model, wrong, regions, sigma, RegistrationOptions())
    assert back is not None
    assert _angle_deg(back, truth) < 1e-6
    # the position: the planes' (sigma 1 % of the size), the loose prior hardly pulls
    assert np.linalg.norm(back.centre - truth.centre) < 1e-4  # metres, at 1.4 m
    # a region measured badly (its normal 3 degrees off) hardly counts beside well measured
    # ones when its own sigma says so; weighed like them it tilts the rotation by a degree
    tilted = regions.normal_cam.copy()
    tilted[0] = rotation_from_rvec(np.array([0.0, math.radians(3.0), 0.0])) @ tilted[0]
    bad = RegionMeasurements(tilted, regions.centre_cam, regions.rms_m)
    sigmas = np.array([math.radians(3.0), math.radians(0.05), math.radians(0.05)])
    weighed = realigned(model, wrong, bad, sigmas, RegistrationOptions())
    alike = realigned(model, wrong, bad, np.full(3, math.radians(0.05)), RegistrationOptions())
    assert weighed is not None
    assert alike is not None
    assert _angle_deg(weighed, truth) < 0.01
    assert _angle_deg(alike, truth) > 0.5


def test_realigned_needs_two_regions_of_different_directions() -> None:
    from aida_kb.register.register import RegionMeasurements, realigned

    model = _box()
    truth = _reference()  # straight in front: the front wall and the top
    parts, regions = _regions_seen(model, truth)
    assert isinstance(regions, RegionMeasurements)
    front = [i for i, p in enumerate(parts) if model.names[p] == "front"]
    one = RegionMeasurements(
        regions.normal_cam[front], regions.centre_cam[front], regions.rms_m[front]
    )
    sigma = np.full(1, math.radians(0.05))
    assert realigned(model, truth, one, sigma, RegistrationOptions()) is None


def _angle_deg(a: PinholeCamera, b: PinholeCamera) -> float:
    cos = (float(np.trace(a.R_cam_world @ b.R_cam_world.T)) - 1.0) / 2.0
    return math.degrees(math.acos(float(np.clip(cos, -1.0, 1.0))))


def test_the_rival_turns_of_a_registration_lead_to_the_symmetric_twin() -> None:
    model = _box()
    ref = _reference()
    up = vertical_axis(model, ref)
    truth = turned(ref, up, model.centroid, math.radians(40.0))
    p1, p2 = simulated_segments(model, truth, np.random.default_rng(7), noise_px=0.5)
    reg = register_view(model, ref, p1, p2)
    assert abs(reg.angle_deg - 40.0) < 0.1
    # the half-turned twin fits the edges as well; poses near -50 deg fit 5 times worse
    rivals = rival_turns(reg)
    assert len(rivals) == 1
    assert abs(rivals[0] + 140.0) < 0.1
    again = register_view(model, ref, p1, p2, init_angle_deg=rivals[0])
    assert abs(again.angle_deg + 140.0) < 0.1
    assert again.cost == pytest.approx(reg.cost, abs=1e-6)


def test_the_search_also_turns_about_the_models_middle_when_the_reference_looks_aside() -> None:
    from aida_kb.register.register import orbit_pivots

    ref = _reference()
    up = np.array([0.0, -1.0, 0.0])
    on_axis = ref.centre + 1.4 * ref.optical_axis
    centred = _box(centre=(float(on_axis[0]), float(on_axis[1]), float(on_axis[2])))
    (only,) = orbit_pivots(centred, ref, up)
    np.testing.assert_allclose(only, centred.centroid, atol=1e-12)  # the box's middle
    aside = _box(centre=(float(on_axis[0]) + 0.3, float(on_axis[1]), float(on_axis[2])))
    look, middle = orbit_pivots(aside, ref, up)
    np.testing.assert_allclose(look, orbit_pivot(aside, ref))
    np.testing.assert_allclose(middle, aside.centroid)  # a box's middle is its centroid
