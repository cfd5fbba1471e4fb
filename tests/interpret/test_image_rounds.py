"""The joint adjustment's image-edge rounds: clean fits, the segments of the edges without
one, and the cameras' deviations from those measurements kept by the verdict."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest

import aida_kb.interpret.multiview as mv
from aida_kb.geometry.camera import PinholeCamera
from aida_kb.interpret import imagefit, joint
from aida_kb.interpret.result import Interpretation
from aida_kb.interpret.uncertainty import (
    IMAGE_EDGE_LABEL,
    IMAGE_EDGE_MIN_FACTOR,
    adjustment_uncertainty,
    camera_rotation_covariance,
    covariance_of,
    problem_information,
    problem_uncertainty,
    stereo_fit_pairs,
)
from aida_kb.interpret.verdict import camera_doubts, judge, with_verdict
from aida_kb.io.evidence import Evidence, read_evidence
from aida_kb.io.model import CameraSd
from aida_kb.kb.model import KnowledgeBase
from aida_kb.register import (
    EdgeObservations,
    RegionMeasurements,
    Rig,
    RigidModel,
    image_edges,
    turned,
    vertical_axis,
)
from aida_kb.register.evidence import ViewMeasurements
from aida_kb.register.pose import point_sigma
from aida_kb.solve import Evaluation
from aida_kb.testing.segments import simulated_segments
from tests.register.test_register import _box

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures"
K = np.array([[800.0, 0.0, 319.5], [0.0, 800.0, 239.5], [0.0, 0.0, 1.0]])
FloatArray = npt.NDArray[np.float64]
Get = Callable[[str], Interpretation]


def _cameras(model: RigidModel) -> tuple[PinholeCamera, PinholeCamera]:
    tilt = math.radians(12.0)
    c, s = math.cos(tilt), math.sin(tilt)
    R = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])  # looking 12 deg down
    ref = PinholeCamera(K, R, -R @ np.array([0.0, -0.05, 0.0]), 640, 480)
    return ref, turned(ref, vertical_axis(model, ref), model.centroid, math.radians(35.0))


def _image(model: RigidModel, camera: PinholeCamera) -> np.ndarray:
    """The box's faces turned to `camera`, each its own grey on a mid grey, 4x supersampled."""
    import cv2

    n = 4
    ys, xs = np.mgrid[0 : camera.height * n, 0 : camera.width * n]
    u, v = (xs + 0.5) / n - 0.5, (ys + 0.5) / n - 0.5
    big = np.full(u.shape, 90.0)
    front = model.front_facing(camera.centre)
    for i, poly in enumerate(model.polygons):
        if not front[i]:
            continue
        q = camera.project(poly)
        sides = [
            (b[0] - a[0]) * (v - a[1]) - (b[1] - a[1]) * (u - a[0])
            for a, b in zip(q, np.roll(q, -1, axis=0), strict=True)
        ]
        inside = np.all([s >= 0 for s in sides], axis=0) | np.all([s <= 0 for s in sides], axis=0)
        big[inside] = (200.0, 150.0, 60.0, 230.0, 120.0, 30.0)[i]
    small = big.reshape(camera.height, n, camera.width, n).mean(axis=(1, 3))
    return np.asarray(np.clip(cv2.GaussianBlur(small, (0, 0), 0.7) + 0.5, 0, 255), np.uint8)


def _view(name: str, p1: np.ndarray, p2: np.ndarray) -> ViewMeasurements:
    none = RegionMeasurements(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0))
    return ViewMeasurements(name, K, 640, 480, p1, p2, none)


def test_fits_scattering_more_than_the_limit_are_left_out(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    model = _box()
    _, cam = _cameras(model)
    grey = _image(model, cam)
    every = image_edges(model, cam, grey)
    assert every.size >= 6
    assert every.sigma_px is not None
    assert float(every.sigma_px.max()) < imagefit.IMAGE_MAX_POINT_SIGMA_PX  # clean rendered edges
    fl, fr = imagefit.fitted_edges(model, [cam], [grey], [None])
    assert fl[0] is not None
    assert fl[0].size == every.size
    assert fr == [None]
    limit = float(np.median(every.sigma_px))
    monkeypatch.setattr(imagefit, "IMAGE_MAX_POINT_SIGMA_PX", limit)
    fl, _ = imagefit.fitted_edges(model, [cam], [grey], [None])
    kept = fl[0]
    assert kept is not None
    assert kept.sigma_px is not None
    assert 0 < kept.size < every.size
    assert float(kept.sigma_px.max()) <= limit


def test_edges_without_a_clean_fit_keep_their_segments(monkeypatch: pytest.MonkeyPatch) -> None:
    model = _box()
    ref, cam = _cameras(model)
    rng = np.random.default_rng(3)
    views = [
        _view(n, *simulated_segments(model, c, rng, clutter=0, split_fraction=0.0))
        for n, c in (("00", ref), ("01", cam))
    ]
    fits = image_edges(model, cam, _image(model, cam))
    two = EdgeObservations(fits.faces[:2], fits.p1[:2], fits.p2[:2], fits.sigma_px[:2])  # type: ignore[index]
    fitted_pairs = {tuple(sorted(int(x) for x in f)) for f in two.faces}

    def seen(keep: bool) -> tuple[list[tuple[int, ...]], list[tuple[int, ...]]]:
        monkeypatch.setattr(joint, "IMAGE_KEEP_SEGMENTS", keep)
        problem = joint.joint_problem(
            model, [ref, cam], views, [1], joint.JointInputs(fitted=[None, two])
        )
        edges = [c for c in problem.constraints if c.kind == "edge" and c.edge is not None]
        pairs = [tuple(sorted(c.parts)) for c in edges if c.edge is not None and c.edge.camera == 1]
        return pairs, [tuple(sorted(c.parts)) for c in edges if c.edge and c.edge.camera == 0]

    alone, first = seen(False)
    assert sorted(alone) == sorted(fitted_pairs)  # only the fits
    both, first_too = seen(True)
    assert first == first_too
    assert first
    assert sum(p in fitted_pairs for p in both) == 2  # a fitted edge: its fit, no segment
    others = {p for p in both if p not in fitted_pairs}
    assert len(others) >= 3  # the other visible edges: measured by their segments
    # the covariance: the fits have a variance factor of their own, never under
    # IMAGE_EDGE_MIN_FACTOR (fitted at the true pose, their residuals are a fraction of their
    # noise model's; over their redundancy numbers, 0.125 here); a third view (segments) gives
    # the redundancy to estimate the factors
    third = turned(ref, vertical_axis(model, ref), model.centroid, math.radians(-30.0))
    views3 = [*views, _view("02", *simulated_segments(model, third, rng, clutter=0))]
    cams = [ref, cam, third]
    problem = joint.joint_problem(
        model, cams, views3, [1, 2], joint.JointInputs(fitted=[None, fits, None])
    )
    unc = problem_uncertainty(problem, model.names, cams, [1, 2], ["01", "02"])
    assert unc is not None
    assert unc.measurements - unc.unknowns >= 10
    assert set(unc.factors) == {"edge", IMAGE_EDGE_LABEL}
    assert IMAGE_EDGE_MIN_FACTOR <= unc.factors[IMAGE_EDGE_LABEL] < 0.5
    assert unc.factors["edge"] < 0.2  # segments at 0.5 px noise: a tenth of the 4 px model
    assert 0.0 < unc.cameras["01"][0] < 1.0
    assert 0.0 < unc.cameras["02"][0] < 1.0
    # the same rows, whitened and rescaled, and each camera's rotation about its own axes
    info = problem_information(problem, len(model.names), cams, [1, 2])
    assert info is not None
    assert info.factors == unc.factors
    assert info.Jw.shape == info.J.shape == (info.rows.size, 3 * len(model.names) + 12)
    cov = covariance_of(info.Jw.T @ info.Jw)
    for k, view in enumerate(("01", "02")):
        rot = camera_rotation_covariance(cov, len(model.names), k, cams[k + 1])
        assert np.allclose(rot, rot.T)
        assert np.all(np.linalg.eigvalsh(rot) > 0.0)
        assert math.degrees(math.sqrt(np.trace(rot))) == pytest.approx(unc.cameras[view][0])


def _house(interpreted: Get) -> tuple[Interpretation, Evidence]:
    """The house fixture's interpretation and evidence."""
    return interpreted("house_correct.json"), read_evidence(FIXTURES / "house_correct.json")


def _far(
    interp: Interpretation,
) -> tuple[RigidModel, list[FloatArray], RigidModel, list[FloatArray]]:
    """The model of `interp` (planes, polygons) and the same 40 times as far from the origin
    (what a view registered at a wrong pose made of dev seed 58008: 292 m walls)."""
    assert interp.model is not None
    rigid = RigidModel.from_model(interp.model)
    polygons = [np.asarray(p.polygon, dtype=np.float64) for p in interp.model.parts]
    far_polygons = [40.0 * p for p in polygons]
    far = RigidModel.from_polygons(rigid.names, rigid.normals, 40.0 * rigid.offsets, far_polygons)
    return rigid, polygons, far, far_polygons


def test_a_camera_fixed_by_its_image_edges_keeps_that_deviation(
    buildings_kb: KnowledgeBase, interpreted: Get
) -> None:
    # the house's one view registered a second time; the reconstruction's image-edge rounds
    # gave its camera 0.03 deg / 0.02 m: the verdict takes those, not its segments' problem
    # (a few tenths of a degree with four segments), and model.json keeps them, marked
    interp, evidence = _house(interpreted)
    assert interp.model is not None
    view = evidence.views[0]
    again = view.model_copy(update={"id": "01", "lines": view.lines[:4]})
    two_views = evidence.model_copy(update={"views": [view, again]})

    def with_camera(sd: CameraSd | None) -> Interpretation:
        assert interp.model is not None
        second = interp.model.cameras[0].model_copy(update={"view": "01", "sd": sd})
        model = interp.model.model_copy(update={"cameras": [*interp.model.cameras, second]})
        return interp.model_copy(update={"model": model})

    segments = adjustment_uncertainty(buildings_kb, with_camera(None), two_views)
    assert segments is not None
    assert segments.cameras["01"][0] > 0.1
    own = CameraSd(rotation_deg=0.03, centre_m=0.02, measurements="image edges")
    mine = with_camera(own)
    unc = adjustment_uncertainty(buildings_kb, mine, two_views)
    assert unc is not None
    assert unc.cameras["01"] == (0.03, 0.02)
    assert unc.parts == segments.parts  # the parts' deviations are the segments' problem's
    verdict = judge(buildings_kb, mine, two_views)
    assert not any("camera is fixed" in r for r in verdict.reasons)
    model = with_verdict(mine, verdict).model
    assert model is not None
    assert model.cameras[1].sd == own
    # a deviation the verdict wrote itself (segments) is recomputed, not taken
    stale = with_camera(CameraSd(rotation_deg=0.03, centre_m=0.02))
    again_unc = adjustment_uncertainty(buildings_kb, stale, two_views)
    assert again_unc is not None
    assert again_unc.cameras["01"] == segments.cameras["01"]
    # too wide: doubtful, saying which measurements fixed it
    wide = CameraSd(rotation_deg=0.08, centre_m=0.02, measurements="image edges")
    doubts = camera_doubts("01", with_camera(wide).model, unc)  # type: ignore[arg-type]
    assert doubts == []  # the deviations judged are those given (unc), 0.03 deg
    wide_unc = adjustment_uncertainty(buildings_kb, with_camera(wide), two_views)
    said = camera_doubts("01", with_camera(wide).model, wide_unc)  # type: ignore[arg-type]
    assert said
    assert "+-0.16 deg" in said[0]  # at two sd, the figure held against 0.1 deg
    assert "sd 0.080 deg" in said[0]
    assert "fitted along the images" in said[0]


def test_a_fit_the_views_own_segments_contradict_is_left_out() -> None:
    model = _box()
    _, cam = _cameras(model)
    fits = image_edges(model, cam, _image(model, cam))
    assert fits.size >= 6
    # one segment of the view on each fitted line, 0.4 px off, along its middle half
    d = fits.p2 - fits.p1
    n = np.stack([-d[:, 1], d[:, 0]], axis=1) / np.linalg.norm(d, axis=1, keepdims=True)
    p1, p2 = fits.p1 + 0.25 * d + 0.4 * n, fits.p1 + 0.75 * d + 0.4 * n
    on = _view("01", p1, p2)
    assert imagefit.corroborated(fits, on).all()
    # on a texture line (the segment on it lies within one region): left out
    inside = replace(on, bounding=np.arange(fits.size) != 0)
    assert imagefit.corroborated(fits, inside).tolist() == [False] + [True] * (fits.size - 1)
    # the region's border 3 px beside the line and none on it: the edge is elsewhere
    beside = _view("01", p1 + 3.0 * n, p2 + 3.0 * n)
    assert not imagefit.corroborated(fits, beside).any()
    # nothing shows the edge, nothing contradicts it (a tenth of its length seen, or no
    # segment at all): kept
    short = _view("01", fits.p1 + 0.45 * d, fits.p1 + 0.55 * d)
    assert imagefit.corroborated(fits, short).all()
    assert imagefit.corroborated(fits, _view("01", np.zeros((0, 2)), np.zeros((0, 2)))).all()
    # fitted_edges keeps the left fits not contradicted
    first = replace(on, bounding=np.arange(fits.size) >= 2)
    grey = _image(model, cam)
    rig = Rig(K, np.eye(3), np.array([-0.1, 0.0, 0.0]), 640, 480)
    right = (rig, _image(model, rig.right_of(cam)))
    fl, fr = imagefit.fitted_edges(model, [cam], [grey], [right], views=[first])
    assert fl[0] is not None
    kept = {tuple(sorted(int(x) for x in f)) for f in fl[0].faces}
    assert kept == {tuple(sorted(int(x) for x in f)) for f in fits.faces[2:]}
    # the right image's fits: only those of the edges whose left fit is kept
    assert fr[0] is not None
    every_right = image_edges(model, rig.right_of(cam), right[1])
    assert fr[0][1].size < every_right.size
    assert {tuple(sorted(int(x) for x in f)) for f in fr[0][1].faces} <= kept


def test_an_edge_fitted_in_both_images_weighs_as_one_edge_seen_twice() -> None:
    model = _box()
    ref, cam = _cameras(model)
    fits = image_edges(model, cam, _image(model, cam))
    views = [_view("00", np.zeros((0, 2)), np.zeros((0, 2))), _view("01", fits.p1, fits.p2)]
    rig = Rig(K, np.eye(3), np.array([-0.2, 0.0, 0.0]), 640, 480)

    def information(right: bool) -> list[float]:
        inputs = joint.JointInputs(
            fitted=[None, fits], fitted_right=[None, (rig, fits) if right else None]
        )
        problem = joint.joint_problem(model, [ref, cam], views, [1], inputs)
        return [
            float(np.asarray(c.sqrt_information)[0, 0])
            for c in problem.constraints
            if c.label.startswith(IMAGE_EDGE_LABEL) and c.edge is not None and c.edge.camera == 1
        ]

    alone, paired = information(False), information(True)
    assert len(alone) == len(paired) == fits.size
    widen = math.sqrt(1.0 + joint.STEREO_FIT_CORRELATION)
    assert np.allclose(np.array(alone) / np.array(paired), widen)
    # the variance factor counts each such pair's residual rows as one edge's
    # (`uncertainty.paired_redundancy`): every fit's two rows against its right twin's
    inputs = joint.JointInputs(fitted=[None, fits], fitted_right=[None, (rig, fits)])
    problem = joint.joint_problem(model, [ref, cam], views, [1], inputs)
    ev = Evaluation(problem, np.arange(len(model.names), dtype=np.intp), free_cameras=np.array([1]))
    of_row = np.asarray(ev.constraint_of_row, dtype=np.intp)
    pairs = stereo_fit_pairs(problem, of_row)
    assert pairs.shape == (2 * fits.size, 2)
    for a, b in zip(of_row[pairs[:, 0]], of_row[pairs[:, 1]], strict=True):
        ca, cb = problem.constraints[int(a)], problem.constraints[int(b)]
        assert ca.edge is not None
        assert cb.edge is not None
        assert (ca.edge.camera, cb.edge.camera) == (1, 2)  # the view's, its right image's
        assert sorted(ca.parts) == sorted(cb.parts)
    alone_problem = joint.joint_problem(
        model, [ref, cam], views, [1], joint.JointInputs(fitted=[None, fits])
    )
    ev1 = Evaluation(alone_problem, np.arange(len(model.names), dtype=np.intp))
    assert stereo_fit_pairs(alone_problem, np.asarray(ev1.constraint_of_row)).shape == (0, 2)


def test_a_fitted_edge_is_known_to_its_points_scatter_across_it() -> None:
    """A fit of 100 px whose points scatter by 0.2 px: its mean offset is good to
    sqrt(0.2²/100 + 0.05² + (b 0.2)²) px, b = IMAGE_SCATTER_BIAS (1) in the image rounds, the
    registration's 0.5 elsewhere; the image rounds' factor and their outlier test whiten by it."""
    fits = EdgeObservations(
        faces=np.array([[0, 1]]),
        p1=np.array([[100.0, 200.0]]),
        p2=np.array([[200.0, 200.0]]),
        sigma_px=np.array([0.2]),
    )
    assert joint.IMAGE_SCATTER_BIAS == 1.0
    assert point_sigma(fits, 4.0, joint.IMAGE_SCATTER_BIAS)[0] == pytest.approx(2.0712, abs=1e-4)
    assert point_sigma(fits, 4.0)[0] == pytest.approx(1.1358, abs=1e-4)
    model = _box()
    (factor,) = joint._fitted_edge_factors(model, _cameras(model)[1], 1, fits, "01")
    sd_mean = 0.5 / float(np.asarray(factor.sqrt_information)[0, 0])  # (r1 + r2) / 2's sd
    assert sd_mean == pytest.approx(0.20712, abs=1e-4)


def test_a_view_whose_adjustment_breaks_the_size_ranges_is_named(
    buildings_kb: KnowledgeBase, interpreted: Get
) -> None:
    # the house as interpreted meets its ranges; the same planes 40 times as far from the
    # origin (what a view registered at a wrong pose made of dev seed 58008: 292 m walls) not
    interp, evidence = _house(interpreted)
    rigid, polygons, far, far_polygons = _far(interp)
    assert mv._sizes_broken(buildings_kb, interp, evidence, rigid, polygons) == []
    broken = mv._sizes_broken(buildings_kb, interp, evidence, far, far_polygons)
    assert broken
    assert all("outside" in b for b in broken)
    # a scene of unknown scale has no ranges in metres
    unknown = evidence.model_copy(update={"units": "unknown"})
    assert mv._sizes_broken(buildings_kb, interp, unknown, far, far_polygons) == []


def test_an_adjustment_step_is_not_taken_only_when_it_breaks_ranges_the_model_met(
    buildings_kb: KnowledgeBase, interpreted: Get
) -> None:
    # dev 61802: the final rounds took a model of 13.7 x 12.1 x 9.2 m to 170 m deep
    interp, evidence = _house(interpreted)
    rigid, polygons, far, far_polygons = _far(interp)
    broken = mv._newly_broken(
        buildings_kb, interp, evidence, (far, far_polygons), (rigid, polygons)
    )
    assert broken == mv._sizes_broken(buildings_kb, interp, evidence, far, far_polygons)
    assert broken
    # a step that keeps the ranges, or one from a model that had left them already, is taken
    assert (
        mv._newly_broken(buildings_kb, interp, evidence, (rigid, polygons), (far, far_polygons))
        == []
    )
    assert (
        mv._newly_broken(buildings_kb, interp, evidence, (far, far_polygons), (far, far_polygons))
        == []
    )
    note = mv._left_ranges("refinement with all views", broken)
    assert note.startswith("refinement with all views stopped: ")
    assert broken[0] in note


def test_fit_residuals_whiten_a_fit_s_offset_and_slope_by_its_own_sigma() -> None:
    # the box's visible edges at the true camera as exact fits of 0.1 px points: no residual;
    # moved 1 px across their edge, the offset is 1 px over sigma/sqrt(n); turned about
    # their middle by 0.2 px at the ends, the slope is 0.2 px over sigma*sqrt(3/n) (sigma the
    # image rounds' point sigma, `IMAGE_SCATTER_BIAS`)
    model = _box()
    _, cam = _cameras(model)
    vis = model.visible_edges(cam, min_length_px=20.0)
    faces = model.edge_faces[vis.index]
    exact = EdgeObservations(faces, vis.a, vis.b, np.full(len(faces), 0.1))
    offset, slope = imagefit.fit_residuals(model, cam, exact)
    assert len(faces) >= 6
    assert np.allclose(offset, 0.0, atol=1e-6)
    assert np.allclose(slope, 0.0, atol=1e-6)
    ends = cam.project(model.edge_ends[vis.index].reshape(-1, 3)).reshape(-1, 2, 2)
    d = ends[:, 1] - ends[:, 0]
    across = np.stack([-d[:, 1], d[:, 0]], axis=1) / np.linalg.norm(d, axis=1, keepdims=True)
    n = np.linalg.norm(vis.b - vis.a, axis=1)
    sigma = point_sigma(exact, joint.JOINT_EDGE_SIGMA_PX, joint.IMAGE_SCATTER_BIAS)
    moved = EdgeObservations(faces, vis.a + 1.0 * across, vis.b + 1.0 * across, exact.sigma_px)
    offset, slope = imagefit.fit_residuals(model, cam, moved)
    assert np.allclose(offset, 1.0 / (sigma / np.sqrt(n)), rtol=1e-6)
    assert np.allclose(slope, 0.0, atol=1e-6)
    assert float(offset.min()) > 6.0  # far beyond IMAGE_REJECT_SIGMAS: left out
    assert imagefit.consistent_edges(model, cam, moved, mv.IMAGE_REJECT_SIGMAS).size == 0
    turned_ = EdgeObservations(faces, vis.a + 0.2 * across, vis.b - 0.2 * across, exact.sigma_px)
    offset, slope = imagefit.fit_residuals(model, cam, turned_)
    assert np.allclose(offset, 0.0, atol=1e-6)
    assert np.allclose(slope, 0.2 / (sigma * np.sqrt(3.0 / n)), rtol=1e-6)
    # a fit of no edge of the model has no residual
    stray = EdgeObservations(np.array([[0, 0]]), vis.a[:1], vis.b[:1], np.array([0.1]))
    offset, slope = imagefit.fit_residuals(model, cam, stray)
    assert np.isnan(offset[0])
    assert np.isnan(slope[0])
    # an edge with an end behind the camera has no line in the image: no residual, no error
    # the camera moved forward along its axis to the median depth of the edges' ends
    R = cam.R_cam_world
    depth = float(np.median(cam.depth(model.edge_ends[vis.index].reshape(-1, 3))))
    within = PinholeCamera(
        cam.K, R, cam.t_cam_world - np.array([0.0, 0.0, depth]), cam.width, cam.height
    )
    ahead = within.in_front(model.edge_ends[vis.index].reshape(-1, 3)).reshape(-1, 2).all(axis=1)
    assert ahead.any()
    assert not ahead.all()
    offset, slope = imagefit.fit_residuals(model, within, exact)
    assert np.all(np.isnan(offset[~ahead]))
    assert np.all(np.isnan(slope[~ahead]))
    assert np.all(np.isfinite(offset[ahead]))
    assert imagefit.consistent_edges(model, within, exact, mv.IMAGE_REJECT_SIGMAS).size <= int(
        ahead.sum()
    )


def _every_edge_fitted(model: RigidModel, camera: PinholeCamera) -> EdgeObservations:
    """Every edge of `model` as an exact fit at `camera`, its points scattered by 0.1 px."""
    ends = camera.project(model.edge_ends.reshape(-1, 3)).reshape(-1, 2, 2)
    n = len(model.edge_faces)
    return EdgeObservations(model.edge_faces, ends[:, 0], ends[:, 1], np.full(n, 0.1))


def test_foot_edges_seen_at_a_grazing_angle_are_known_no_better_than_the_foot_bias() -> None:
    # the box stands at y = 0.425 m in a y-down world; a camera at the origin sees its foot
    # from 0.425 m above (the front foot's middle at 1.25 m: asin(0.425 / 1.320) = 18.78 deg),
    # one at y = 0.41 m from 15 mm above (asin(0.015 / 1.2501) = 0.688 deg: grazing)
    model = _box()
    up = (0.0, -1.0, 0.0)
    high = PinholeCamera(K, np.eye(3), np.zeros(3), 640, 480)
    low = PinholeCamera(K, np.eye(3), np.array([0.0, -0.41, 0.0]), 640, 480)
    fits = _every_edge_fitted(model, high)
    names = [tuple(sorted((model.names[a], model.names[b]))) for a, b in fits.faces]
    foot = np.array(["bottom" in pair for pair in names])
    front = names.index(("bottom", "front"))
    seen_high = joint.foot_grazing_deg(model, high, fits, up)
    assert int(foot.sum()) == 4
    assert np.all(np.isfinite(seen_high[foot]))
    assert np.all(np.isnan(seen_high[~foot]))
    assert seen_high[front] == pytest.approx(18.78, abs=0.01)
    assert joint.foot_grazing_deg(model, low, fits, up)[front] == pytest.approx(0.688, abs=0.001)
    assert np.all(np.isnan(joint.foot_grazing_deg(model, low, fits, None)))
    # seen from high above, every fit keeps its own sigma; seen grazing, the foot's fits get
    # the foot bias in quadrature on their mean offset: sqrt(s² + n·bias²)
    own = point_sigma(fits, joint.JOINT_EDGE_SIGMA_PX, joint.IMAGE_SCATTER_BIAS)
    assert np.array_equal(joint.fit_point_sigma(model, high, fits, up), own)
    assert np.array_equal(joint.fit_point_sigma(model, low, fits, None), own)
    grazing = joint.fit_point_sigma(model, low, fits, up)
    n = np.maximum(np.linalg.norm(fits.p2 - fits.p1, axis=1), 1.0)
    assert np.array_equal(grazing[~foot], own[~foot])
    assert np.allclose(grazing[foot], np.sqrt(own[foot] ** 2 + n[foot] * joint.FOOT_BIAS_PX**2))
    # the front foot's mean offset is known to 0.71 px, not 0.11: a fit 1 px below it (as the
    # ground squeezed beside a foot puts it) is 1.4 of its sigmas off, not 8.9, and stays
    at_low = _every_edge_fitted(model, low)
    sd_mean = grazing[front] / math.sqrt(n[front])
    assert joint.FOOT_BIAS_PX <= sd_mean < joint.FOOT_BIAS_PX + 0.01
    below = EdgeObservations(
        at_low.faces[[front]],
        at_low.p1[[front]] + [0.0, 1.0],
        at_low.p2[[front]] + [0.0, 1.0],
        at_low.sigma_px[[front]],  # type: ignore[index]
    )
    assert abs(float(imagefit.fit_residuals(model, low, below)[0][0])) > mv.IMAGE_REJECT_SIGMAS
    assert abs(float(imagefit.fit_residuals(model, low, below, up)[0][0])) < 1.5
    assert imagefit.consistent_edges(model, low, below, mv.IMAGE_REJECT_SIGMAS, up).size == 1
    # the image rounds' factor whitens the fit by the same sigma
    (factor,) = joint._fitted_edge_factors(model, low, 0, below, "00", up=up)
    assert 0.5 / float(np.asarray(factor.sqrt_information)[0, 0]) == pytest.approx(
        sd_mean, rel=1e-9
    )


def test_edge_rows_finds_each_edge_in_either_order() -> None:
    model_faces = np.array([[0, 1], [1, 2], [3, 0], [2, 3]])
    faces = np.array([[1, 0], [3, 2], [0, 3], [0, 2], [2, 1]])
    assert joint.edge_rows(model_faces, faces).tolist() == [0, 3, 2, -1, 1]
    assert joint.edge_rows(model_faces, np.zeros((0, 2), dtype=int)).tolist() == []
    assert joint.edge_rows(np.zeros((0, 2), dtype=int), faces).tolist() == [-1] * 5


def test_segments_on_a_foot_seen_at_a_grazing_angle_get_the_foot_bias() -> None:
    # the same box as above: a segment on the front foot, seen from 15 mm above (0.688 deg),
    # is whitened as a fit there (the line detector is pulled into the squeezed ground as the
    # fit is); seen from 0.225 m above (10 deg), or with no vertical, by its length alone
    model = _box()
    up = (0.0, -1.0, 0.0)
    high = PinholeCamera(K, np.eye(3), np.array([0.0, -0.2, 0.0]), 640, 480)
    low = PinholeCamera(K, np.eye(3), np.array([0.0, -0.41, 0.0]), 640, 480)

    def front_foot(camera: PinholeCamera, vertical: tuple[float, float, float] | None) -> float:
        fits = _every_edge_fitted(model, camera)
        names = [tuple(sorted((model.names[a], model.names[b]))) for a, b in fits.faces]
        k = names.index(("bottom", "front"))
        p1, p2 = fits.p1[[k]], fits.p2[[k]]
        inner1, inner2 = p1 + 0.1 * (p2 - p1), p2 - 0.1 * (p2 - p1)  # within the edge
        (factor,) = joint._edge_factors(model, camera, 0, inner1, inner2, "00", up=vertical)
        return 0.5 / float(np.asarray(factor.sqrt_information)[0, 0])  # its mean offset's sd

    plain = front_foot(low, None)
    assert front_foot(high, up) == pytest.approx(front_foot(high, None), rel=1e-12)
    widened = front_foot(low, up)
    assert widened == pytest.approx(math.sqrt(plain**2 + joint.FOOT_BIAS_PX**2), rel=1e-9)
    assert widened > 2.0 * plain


def test_a_segment_along_two_edges_meeting_nearly_in_line_measures_neither() -> None:
    # two projected edges meeting at (100, 1) nearly in line (two feet seen at a grazing
    # angle), and a third, a piece of the first model edge's after a gap (an edge cut by
    # what hides it)
    a = np.array([[0.0, 0.0], [100.0, 1.0], [210.0, 0.0]])
    b = np.array([[100.0, 1.0], [200.0, 0.0], [300.0, 0.0]])
    index = np.array([0, 1, 0])
    p1 = np.array([[40.0, 0.6], [10.0, 0.3], [140.0, 0.4]])
    p2 = np.array([[160.0, 0.6], [90.0, 1.0], [250.0, 0.1]])
    matched = joint.match_segments(
        a, b, p1, p2, max_distance_px=joint.JOINT_MATCH_PX, max_angle_rad=math.radians(10.0)
    )
    assert matched.segment.tolist() == [0, 1, 2]
    # the first crosses the corner: 60 px on each edge; the second lies on the first edge
    # alone; the third runs along edge 1 and the first model edge's other piece: two edges
    assert joint._along_two_edges(a, b, index, p1, p2, matched).tolist() == [True, False, True]
    # along one model edge cut in two pieces: one edge
    assert not joint._along_two_edges(a, b, np.array([0, 1, 1]), p1, p2, matched)[2]
