"""Multi-view reconstruction: the two-view house with the second view's pose unknown."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from aida_kb.geometry.camera import PinholeCamera
from aida_kb.interpret import joint
from aida_kb.interpret.evaluate import compare_with_truth
from aida_kb.interpret.joint import kb_constraints
from aida_kb.interpret.multiview import (
    REGISTERED_EXPLAINED_MIN,
    _fits_worse,
    explained_shares,
    reconstruct_from_first,
    reconstruct_views,
)
from aida_kb.interpret.result import Interpretation
from aida_kb.io.evidence import Evidence
from aida_kb.io.model import ModelCamera, ReconstructedModel
from aida_kb.io.scene import read_scene
from aida_kb.register import Registration, RigidModel, turned, vertical_axis
from aida_kb.register.evidence import register_evidence_view
from aida_kb.solve import ResidualReport, solve
from aida_kb.solve.report import ConstraintResidual
from aida_kb.synth.scenes import preset, render_scene
from aida_kb.vision.evidence import scene_evidence


@pytest.fixture(scope="module")
def house(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("mv") / "house"
    render_scene(preset("house", seed=0), out)
    return out


@pytest.fixture(scope="module")
def evidence(house: Path) -> Evidence:
    return scene_evidence(read_scene(house, with_truth=False))[0]


def test_two_view_house_registers_the_second_view_and_refines_the_model(
    house: Path, evidence: Evidence, buildings_kb: object
) -> None:
    assert [v.frame for v in evidence.views] == ["world", "camera"]  # view 01's pose unknown
    interp = reconstruct_views(buildings_kb, evidence)  # type: ignore[arg-type]
    assert interp.accepted
    assert interp.model is not None
    assert [c.view for c in interp.model.cameras] == ["00", "01"]
    truth = read_scene(house).truth
    assert truth is not None
    c = compare_with_truth(interp.model, truth)
    assert not c.missing
    assert c.max_vertex_error_rel < 0.01
    cam = interp.model.cameras[1]
    true = truth.pose("01")
    R, t = np.array(cam.R), np.array(cam.t)
    Rt, tt = np.array(true.R), np.array(true.t)
    assert np.linalg.norm(R.T @ t - Rt.T @ tt) < 0.2  # metres, at 30 m
    angle = np.degrees(np.arccos(np.clip((np.trace(R @ Rt.T) - 1) / 2, -1.0, 1.0)))
    assert angle < 0.5
    # the residuals are the joint adjustment's: both views' evidence, the knowledge's own
    # constraints at their .kb lines, the first shape's angles as a prior
    rules = {r.rule for r in interp.residuals}
    assert {"evidence", "knowledge", "prior"} <= rules
    assert any(r.label.endswith("@01") for r in interp.residuals)
    knowledge = [r for r in interp.residuals if r.rule == "knowledge"]
    assert all(r.span is not None and r.span.file.endswith("buildings.kb") for r in knowledge)
    assert {r.owner for r in knowledge} == {"body"}


def test_a_refinement_that_takes_the_model_out_of_its_ranges_is_not_taken(
    evidence: Evidence, buildings_kb: object, monkeypatch: pytest.MonkeyPatch
) -> None:
    # the final rounds re-match the segments: where they pull the model out of the ranges it
    # met once registered (dev 61802: 9 m deep, then 170 m), the model stays as it was
    import aida_kb.interpret.multiview as mv
    from aida_kb.register.model import RigidModel

    adjusted = mv._adjusted
    calls: list[int] = []

    def blown(*args: Any, **kwargs: Any) -> Any:
        step = adjusted(*args, **kwargs)
        calls.append(len(calls))
        if isinstance(step, str) or len(calls) == 1:  # the registration's step is kept
            return step
        rigid, polygons = step[0], [40.0 * p for p in step[1]]
        far = RigidModel.from_polygons(rigid.names, rigid.normals, 40.0 * rigid.offsets, polygons)
        return (far, polygons, *step[2:])

    monkeypatch.setattr(mv, "_adjusted", blown)
    interp = reconstruct_views(buildings_kb, evidence)  # type: ignore[arg-type]
    assert interp.model is not None
    assert [c.view for c in interp.model.cameras] == ["00", "01"]
    assert mv.model_sizes_broken(buildings_kb, interp, evidence) == []  # type: ignore[arg-type]
    assert "refinement with all views stopped: it takes the model out of the knowledge's" in (
        interp.message
    )
    assert len(calls) == 2  # the registration's step and the first final round only


def test_a_view_that_cannot_be_registered_is_left_out_and_named(
    evidence: Evidence, buildings_kb: object
) -> None:
    # no segments to register by, no regions to start from (`multiview.reconstruct_views`
    # interprets a later view first where the first view's model registers none)
    blind = evidence.views[1].model_copy(update={"lines": [], "regions": [], "contours": []})
    bad = evidence.model_copy(update={"views": [evidence.views[0], blind]})
    interp = reconstruct_views(buildings_kb, bad)  # type: ignore[arg-type]
    assert interp.model is not None
    assert [c.view for c in interp.model.cameras] == ["00"]
    assert "view 01: registration: the view has only 0 usable line segments" in interp.message
    assert "interpreted from view" not in interp.message


def test_kb_constraints_are_the_interpreted_objects_internal_ones(
    interpreted: Callable[[str], Interpretation], buildings_kb: object
) -> None:
    interp = interpreted("house_correct.json")
    assert interp.model is not None
    names = [p.role for p in interp.model.parts]
    cons = kb_constraints(buildings_kb, interp, names)  # type: ignore[arg-type]
    labels = {c.label.split("(")[0] for c in cons}
    assert {".:corner_fl", ".:opposite_fb", ".:ground", ".:eaves", ".:slopes"} <= labels
    assert not any(c.measurement for c in cons)
    front, left = names.index("body.front"), names.index("body.left")
    corner = next(c for c in cons if c.label.startswith(".:corner_fl"))
    assert corner.parts == (front, left)
    assert corner.value == pytest.approx(np.pi / 2)


def test_the_joint_adjustment_takes_the_attributes_and_drops_the_first_views_stated_angles(
    interpreted: Callable[[str], Interpretation], buildings_kb: object
) -> None:
    # the walls' slope attributes tie them to the floor as in the single-view adjustment
    # (90 deg, the sigma kb/buildings.kb states: 0.5 deg); the first shape's angle of a pair
    # the knowledge relates is left out (it counted the first view twice and kept its tilt of
    # the floor)
    interp = interpreted("house_correct.json")
    assert interp.model is not None
    rigid = RigidModel.from_model(interp.model)
    names = list(rigid.names)
    cons = kb_constraints(buildings_kb, interp, names)  # type: ignore[arg-type]
    floor = names.index("body.floor")
    tilts = [c for c in cons if c.source.rule == "attribute"]
    walls = {"body.front", "body.back", "body.left", "body.right"}
    assert {names[c.parts[0]] for c in tilts} == walls
    assert all(c.parts[1] == floor for c in tilts)
    assert all(c.value == pytest.approx(np.pi / 2) for c in tilts)
    assert all(c.sigma == pytest.approx(math.radians(0.5)) for c in tilts)
    problem = joint.joint_problem(rigid, [], [], [], joint.JointInputs(internal=cons))
    priors = {c.parts for c in problem.constraints if c.label.startswith("first-shape")}
    stated = joint.stated_pairs(cons)
    assert priors  # the pairs the knowledge leaves free keep the first shape's angle
    assert not priors & stated
    front, left = sorted((names.index("body.front"), names.index("body.left")))
    assert (min(front, floor), max(front, floor)) in stated
    assert (front, left) in stated
    # without the knowledge's constraints every adjacent pair keeps it
    bare = joint.joint_problem(rigid, [], [], [])
    assert {c.parts for c in bare.constraints} == set(joint.meeting_angles(rigid))


@pytest.mark.parametrize(
    ("fixture", "face", "plane", "sign"),
    [
        ("oriel.json", "body.oriels[0].back", "body.front", -1),  # against the wall
        ("wing_90.json", "body.wings[0].floor", "body.floor", 1),  # in the floor
    ],
)
def test_a_closing_face_stays_in_the_plane_of_its_whole_in_the_joint_adjustment(
    interpreted: Callable[[str], Interpretation],
    buildings_kb: object,
    fixture: str,
    face: str,
    plane: str,
    sign: int,
) -> None:
    # the knowledge's `attach`: an oriel's open back lies against the wall it stands out of, a
    # wing's floor in the body's floor; freed in the joint adjustment, they had drifted up to
    # 2.6 deg and 1.3 m off (dev 70014, 70025)
    interp = interpreted(fixture)
    assert interp.model is not None
    rigid = RigidModel.from_model(interp.model)
    names = list(rigid.names)
    cons = kb_constraints(buildings_kb, interp, names)  # type: ignore[arg-type]
    ties = [c for c in cons if c.kind == "coincident"]
    tied = {(names[c.parts[0]], names[c.parts[1]], c.sign) for c in ties}
    assert (face, plane, sign) in tied
    last = face.rsplit(".", 1)[1]
    assert all(p == plane and s == sign and f.rsplit(".", 1)[1] == last for f, p, s in tied)
    # the face turned 2 deg and moved 0.5 m off: the knowledge's constraints bring it back
    i, j = names.index(face), names.index(plane)
    normals, offsets = rigid.normals.copy(), rigid.offsets.copy()
    axis = np.cross(normals[i], [0.3, 0.5, 0.8])
    turned_normal = normals[i] + math.radians(2.0) * axis / np.linalg.norm(axis)
    normals[i] = turned_normal / np.linalg.norm(turned_normal)
    offsets[i] += 0.5
    moved = RigidModel.from_polygons(names, normals, offsets, rigid.polygons)
    inputs = joint.JointInputs(angles=joint.meeting_angles(rigid), internal=cons)
    result = solve(joint.joint_problem(moved, [], [], [], inputs))
    n_face, n_plane = result.normals[i], sign * result.normals[j]
    assert math.degrees(math.acos(min(1.0, float(n_face @ n_plane)))) < 0.05
    assert abs(result.offsets[i] - sign * result.offsets[j]) < 0.02  # metres
    # a house without oriels or wings has no closing face and no tie
    house = interpreted("house_correct.json")
    assert house.model is not None
    roles = [p.role for p in house.model.parts]
    bare = kb_constraints(buildings_kb, house, roles)  # type: ignore[arg-type]
    assert not [c for c in bare if c.kind == "coincident"]


def test_a_single_later_view_pose_converges_in_the_final_rounds(
    tmp_path: Path, buildings_kb: object
) -> None:
    # view 01's region positions enter an adjustment in the world frame of its pose at the
    # start of it: after one adjustment the 135-degree L-shape's view 01 stayed 0.26 m off
    # (0.35 m at full size, the model shifted with it); the final rounds take them again
    scene = tmp_path / "lshape135"
    small = {"image_width": "480", "image_height": "360", "focal_px": "600"}
    render_scene(preset("lshape", seed=0, params={"meeting_deg": "135", **small}), scene)
    evidence = scene_evidence(read_scene(scene, with_truth=False))[0]
    interp = reconstruct_views(buildings_kb, evidence)  # type: ignore[arg-type]
    assert interp.model is not None, interp.message
    truth = read_scene(scene).truth
    assert truth is not None
    cam, true = interp.model.cameras[1], truth.pose("01")
    R, t = np.array(cam.R), np.array(cam.t)
    Rt, tt = np.array(true.R), np.array(true.t)
    assert np.linalg.norm(R.T @ t - Rt.T @ tt) < 0.15  # metres, at 26 m (0.06 m now)
    assert compare_with_truth(interp.model, truth).max_vertex_error_rel < 0.04


def test_joint_adjustment_can_take_the_right_images_through_rig_cameras(
    house: Path, evidence: Evidence, buildings_kb: object, monkeypatch: pytest.MonkeyPatch
) -> None:
    # off by default (JOINT_RIGHT_IMAGES' measurement); on, each view's right image joins the
    # adjustments through a camera that follows the view's, and the model stays right
    import aida_kb.interpret.multiview as mv

    monkeypatch.setattr(mv, "JOINT_RIGHT_IMAGES", True)
    seen: list[int] = []
    original = joint.joint_adjustment

    def spy(*args: object, **kwargs: object) -> object:
        inputs = args[4]
        assert isinstance(inputs, joint.JointInputs)
        seen.append(sum(s is not None for s in inputs.stereo))
        return original(*args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(mv, "joint_adjustment", spy)
    scene = read_scene(house, with_truth=False)
    interp = mv.reconstruct_views(buildings_kb, evidence, scene=scene)  # type: ignore[arg-type]
    assert seen
    assert all(n == 2 for n in seen)  # both views' right images, in every adjustment
    assert interp.model is not None
    truth = read_scene(house).truth
    assert truth is not None
    assert compare_with_truth(interp.model, truth).max_vertex_error_rel < 0.02


@pytest.fixture(scope="module")
def refined(evidence: Evidence, buildings_kb: object) -> Interpretation:
    return reconstruct_views(buildings_kb, evidence)  # type: ignore[arg-type]


def _turned_camera(model: ReconstructedModel, view: str, deg: float) -> PinholeCamera:
    """The model's camera of `view` turned by `deg` about the vertical through the model."""
    cam = next(c for c in model.cameras if c.view == view)
    camera = PinholeCamera(
        np.array(cam.K), np.array(cam.R), np.array(cam.t), cam.image_width, cam.image_height
    )
    rigid = RigidModel.from_model(model)
    up = vertical_axis(rigid, camera)
    return turned(camera, up, rigid.centroid, math.radians(deg))


def test_the_model_explains_a_registered_views_regions_only_at_its_own_turn(
    refined: Interpretation, evidence: Evidence
) -> None:
    model = refined.model
    assert model is not None
    rigid = RigidModel.from_model(model)
    view = evidence.views[1]
    shares = [
        explained_shares(model, rigid, rigid.polygons, [view], [_turned_camera(model, "01", d)])[0]
        for d in (0.0, 90.0, 180.0)
    ]
    assert shares[0] is not None
    assert shares[0] > 0.95
    # a quarter turn puts the house's end walls where the view sees its front: the view's
    # regions no longer lie on the faces before them
    assert shares[1] is not None
    assert shares[1] < REGISTERED_EXPLAINED_MIN
    # a half turn of the symmetric house is its twin: the regions lie on the faces it turns
    # towards the camera just as well (`register_view` decides that by the expected turn)
    assert shares[2] is not None
    assert shares[2] > 0.95


def _angle_deg(a: ModelCamera, b: ModelCamera) -> float:
    cos = (np.trace(np.array(a.R) @ np.array(b.R).T) - 1.0) / 2.0
    return float(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))


def _registered_a_quarter_turn_off(
    refined: Interpretation, monkeypatch: pytest.MonkeyPatch, *, rivals_too: bool
) -> None:
    """Make view 01's registration (`register_evidence_view` as multiview calls it) land a
    quarter turn off the refined model's camera: the first registration only, or also every
    registration again about a rival turn (`rivals_too`)."""
    assert refined.model is not None
    wrong = _turned_camera(refined.model, "01", 90.0)

    def quarter_turn_off(*args: Any, **kwargs: Any) -> Registration:
        reg = register_evidence_view(*args, **kwargs)
        if rivals_too:
            return dataclasses.replace(reg, camera=wrong)
        if kwargs.get("init_angle_deg") is not None:  # registered again about a rival turn
            return reg
        return dataclasses.replace(reg, camera=wrong, angle_deg=reg.angle_deg + 90.0)

    monkeypatch.setattr("aida_kb.interpret.multiview.register_evidence_view", quarter_turn_off)


@pytest.mark.parametrize("adjustment_fails", [False, True])
def test_a_pose_its_regions_do_not_confirm_gives_way_to_a_rival_turn_they_do(
    refined: Interpretation,
    evidence: Evidence,
    buildings_kb: object,
    monkeypatch: pytest.MonkeyPatch,
    adjustment_fails: bool,
) -> None:
    assert refined.model is not None
    # the first registration took a pose a quarter turn off; the right one is its rival
    _registered_a_quarter_turn_off(refined, monkeypatch, rivals_too=False)
    if adjustment_fails:
        # no joint adjustment can be made (a model whose planes no longer close, dev 61902):
        # the registered pose is judged on the model as it was (before, it stayed unjudged)
        monkeypatch.setattr("aida_kb.interpret.multiview._adjusted", lambda *a, **k: "no solve")
    interp = reconstruct_from_first(buildings_kb, evidence)  # type: ignore[arg-type]
    assert interp.model is not None
    assert [c.view for c in interp.model.cameras] == ["00", "01"]
    # unadjusted, the registration's own pose: within a degree of the refined one
    limit = 1.0 if adjustment_fails else 0.05
    assert _angle_deg(interp.model.cameras[1], refined.model.cameras[1]) < limit
    assert "where the evidence confirms it (adjusted with it, at a turn of" in interp.message
    assert "of its region weight inside its projection (at least 50%)" in interp.message
    skipped = "joint adjustment with view 01 skipped: no solve" in interp.message
    assert skipped == adjustment_fails


def test_a_pose_no_rival_explains_better_stays_for_the_verdict_to_judge(
    refined: Interpretation,
    evidence: Evidence,
    buildings_kb: object,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    assert refined.model is not None
    _registered_a_quarter_turn_off(refined, monkeypatch, rivals_too=True)
    interp = reconstruct_from_first(buildings_kb, evidence)  # type: ignore[arg-type]
    assert interp.model is not None
    # the model, not the pose, may be what the view contradicts: the view stays, named
    assert [c.view for c in interp.model.cameras] == ["00", "01"]
    assert _angle_deg(interp.model.cameras[1], refined.model.cameras[1]) > 45.0
    assert "and no rival turn explains it better" in interp.message


def test_a_pose_kept_unconfirmed_does_not_start_the_next_views_search(
    monkeypatch: pytest.MonkeyPatch, refined: Interpretation, evidence: Evidence, buildings_kb: Any
) -> None:
    assert refined.model is not None
    wrong = _turned_camera(refined.model, "01", 90.0)
    # a third view at view 01's pose; view 01 itself lands a quarter turn off at every try
    again = evidence.views[1].model_copy(update={"id": "02"})
    three = evidence.model_copy(update={"views": [*evidence.views, again]})
    starts: list[tuple[str, PinholeCamera, object]] = []

    def spy(*args: Any, **kwargs: Any) -> Registration:
        starts.append((args[2].id, args[1], kwargs.get("expected_turn_deg")))
        reg = register_evidence_view(*args, **kwargs)
        return dataclasses.replace(reg, camera=wrong) if args[2].id == "01" else reg

    monkeypatch.setattr("aida_kb.interpret.multiview.register_evidence_view", spy)
    interp = reconstruct_from_first(buildings_kb, three)
    assert interp.model is not None
    assert [c.view for c in interp.model.cameras] == ["00", "01", "02"]
    assert "view 01: adjusted with it at a turn of" in interp.message
    first = next(c for c in interp.model.cameras if c.view == "00")
    for view, reference, expected in starts:
        if view == "02":  # searched from view 00's camera, not from view 01's twin
            assert np.allclose(reference.R_cam_world, first.R)
            assert expected is None
    assert any(view == "02" for view, _, _ in starts)
    # so view 02 lands where view 01 truly is
    assert _angle_deg(interp.model.cameras[2], refined.model.cameras[1]) < 1.0


def _report(view: str, own: tuple[float, ...], other: tuple[float, ...]) -> ResidualReport:
    """A joint adjustment's report: `own` edge rows of `view` and `other` rows of view 00, each
    with its normalised cost (2 degrees of freedom a row)."""
    rows = tuple(
        ConstraintResidual(
            label=f"edge(body.front, body.left)@{v}",
            kind="edge",
            parts=("body.front", "body.left"),
            residual=0.0,
            unit="px",
            sigma=1.0,
            normalised_cost=c,
            threshold=13.8,
            reject_above=None,
            rejected=False,
        )
        for v, costs in ((view, own), ("00", other))
        for c in costs
    )
    return ResidualReport(rows, (2,) * len(rows))


def test_a_rival_turn_that_fits_clearly_worse_does_not_replace_the_first_pose() -> None:
    cam = PinholeCamera(np.diag([500.0, 500.0, 1.0]), np.eye(3), np.array([0.0, 0.0, 10.0]), 64, 48)
    reg = Registration(cam, -39.2, 0.5, 0.6, 11, 0, (), np.eye(6), 0.1, 0.1)
    first: Any = (None, None, None, _report("01", (1.0,) * 10, (1.0,) * 8))
    kept = (reg, first, "the model explains 0% of its region weight")
    # a quarter turn: as many of the view's segments held, each fitting four times worse
    worse: Any = (None, None, None, _report("01", (6.0,) * 10, (1.0,) * 8))
    why = _fits_worse(worse, kept, "01")
    assert "times worse" in why
    assert "-39.2 deg registered first" in why
    # about as good a fit (a symmetric model's twin): the rival may replace it, as may one that
    # holds more of the view's measurements, or where an adjustment failed
    alike: Any = (None, None, None, _report("01", (1.2,) * 10, (1.0,) * 8))
    assert _fits_worse(alike, kept, "01") == ""
    more: Any = (None, None, None, _report("01", (6.0,) * 12, (1.0,) * 8))
    assert _fits_worse(more, kept, "01") == ""
    assert _fits_worse("no solve", kept, "01") == ""
    assert _fits_worse(worse, (reg, "no solve", ""), "01") == ""
