"""`evaluate`: a result judged against a scene's truth — every check can fail on its own."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from aida_kb.cli.main import main
from aida_kb.interpret.evaluate import evaluate, format_evaluation
from aida_kb.interpret.result import Instance, Interpretation, write_interpretation
from aida_kb.interpret.robustness import SceneOutcome, sd_figures
from aida_kb.io.model import ModelCamera, ModelPart, PartSd, ReconstructedModel
from aida_kb.io.scene import PartTruth, PoseTruth, SceneTruth, StereoCalib, ViewData, write_scene
from aida_kb.synth import buildings as bld

K = ((500.0, 0.0, 79.5), (0.0, 500.0, 59.5), (0.0, 0.0, 1.0))
I3 = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


def _truth(obj: str = "House") -> SceneTruth:
    model = bld.house(10.0, 8.0, 6.0, "gable", 30.0).transformed(np.eye(3), np.array([0, 0, 30.0]))
    parts = [
        PartTruth(
            role=f.role,
            concept=f.concept,
            label=i + 1,
            normal=tuple(f.normal),  # type: ignore[arg-type]
            d=f.d,
            polygon=[tuple(v) for v in f.polygon],  # type: ignore[misc]
        )
        for i, f in enumerate(model.faces)
    ]
    pose = PoseTruth(view="00", K=K, R=I3, t=(0.0, 0.0, 0.0))
    return SceneTruth(object=obj, parts=parts, views=[pose], concepts={"body.roof": "GableRoof"})


def _result(
    truth: SceneTruth,
    *,
    roof: str = "GableRoof",
    accepted: bool = True,
    turn_deg: float = 0.0,
    cam_shift_m: float = 0.0,
) -> Interpretation:
    parts = []
    for p in truth.parts:
        n, poly = np.array(p.normal), np.array(p.polygon)
        if p.role == "body.front" and turn_deg:
            a = np.radians(turn_deg)
            rot = np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])
            centre = poly.mean(axis=0)
            n, poly = rot @ n, (poly - centre) @ rot.T + centre
        parts.append(
            ModelPart(
                role=p.role,
                concept=p.concept,
                normal=tuple(n),  # type: ignore[arg-type]
                offset_m=float(n @ poly[0]),
                polygon=[tuple(v) for v in poly],  # type: ignore[misc]
            )
        )
    cam = ModelCamera(
        view="00", K=K, R=I3, t=(cam_shift_m, 0.0, 0.0), image_width=160, image_height=120
    )
    model = ReconstructedModel(parts=parts, cameras=[cam])
    instances = [
        Instance(role="", concept="House", instance_of="House", parent=None, link="goal"),
        Instance(role="body.roof", concept=roof, instance_of="Roof", parent="body", link="part-of"),
    ]
    return Interpretation(
        goal="House",
        accepted=accepted,
        message="m",
        instances=instances,
        model=model if accepted else None,
        expanded=1,
    )


def test_a_perfect_result_is_correct_and_each_fault_is_named() -> None:
    truth = _truth()
    ok = evaluate(_result(truth), truth)
    assert ok.correct
    assert ok.cause == ""
    assert ok.comparison is not None
    assert ok.comparison.max_normal_error_deg == pytest.approx(0.0, abs=1e-6)
    assert evaluate(_result(truth, roof="HipRoof"), truth).cause == "specialisation"
    assert evaluate(_result(truth, turn_deg=0.8), truth).cause == "normals"
    assert evaluate(_result(truth, turn_deg=0.3), truth).correct
    assert evaluate(_result(truth, cam_shift_m=0.5), truth).cause == "camera"
    assert evaluate(_result(truth, accepted=False), truth).cause == "nothing found"
    doubted = _result(truth).model_copy(update={"verdict": "doubtful", "doubts": ["view 00: x"]})
    right_but_doubted = evaluate(doubted, truth)
    assert not right_but_doubted.correct
    assert right_but_doubted.cause == "right but doubtful"
    assert right_but_doubted.summary()["doubts"] == ["view 00: x"]


def test_each_part_off_target_is_named_with_its_error_in_the_models_own_sds() -> None:
    truth = _truth()
    result = _result(truth, turn_deg=0.8)
    assert result.model is not None
    parts = [
        p.model_copy(update={"sd": PartSd(normal_deg=0.2, offset_m=0.01)})
        if p.role == "body.front"
        else p
        for p in result.model.parts
    ]
    result = result.model_copy(update={"model": result.model.model_copy(update={"parts": parts})})
    judged = evaluate(result, truth)
    normals = judged.summary()["normals"]
    assert isinstance(normals, dict)
    assert normals["body.front"] == [pytest.approx(0.8, abs=1e-3), 0.2]
    assert normals["body.back"] == [pytest.approx(0.0, abs=1e-3), None]  # no sd: not fixed
    lines = format_evaluation(judged)
    assert "    normal of body.front: 0.800 deg off; the model's sd 0.200 deg: 4.0 sd" in lines
    assert not any("normal of body.back" in line for line in lines)  # within target


def test_the_sds_honesty_is_measured_where_the_model_has_the_truths_form() -> None:
    def row(cause: str, normals: dict[str, list[float | None]], cams: list[object]) -> Any:
        figures = {"expected_object": True, "normals": normals, "cameras": cams}
        return SceneOutcome(1, "gable", False, 2, "doubtful", False, cause, 1.0, figures)

    cam = {"view": "01", "angle_deg": 0.06, "sd_deg": 0.04}
    far = {"view": "02", "angle_deg": 40.0, "sd_deg": 0.5}  # a wrong pose: not noise
    rows = [
        row("normals", {"a": [0.9, 0.1], "b": [0.1, 0.2], "c": [0.2, None]}, [cam, far]),
        row("right but doubtful", {"a": [0.05, 0.1]}, []),
        row("specialisation", {"a": [30.0, 0.1]}, [{**cam, "angle_deg": 1.0}]),
    ]
    figures = sd_figures(rows)
    assert figures["part_normals_judged"] == 3  # the wrong specialisation's part left out
    assert figures["part_normal_error_over_sd_median"] == 0.5
    assert figures["part_normals_within_2sd"] == pytest.approx(2 / 3, abs=1e-3)
    assert figures["camera_error_over_sd_median"] == 1.5


def test_a_scene_without_the_object_expects_nothing() -> None:
    truth = _truth("nothing")
    assert evaluate(_result(truth, accepted=False), truth).correct
    found = evaluate(_result(truth), truth)
    assert not found.correct
    assert found.cause == "found an object where there is none"


def test_cli_evaluate_exit_status_and_json(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    truth = _truth()
    img = np.zeros((120, 160, 3), np.uint8)
    calib = StereoCalib(
        np.array(K),
        np.zeros(5),
        np.array(K),
        np.zeros(5),
        np.eye(3),
        np.array([-0.3, 0, 0]),
        (160, 120),
    )
    write_scene(tmp_path / "scene", calib, [ViewData(left=img, right=img)], truth=truth)
    (tmp_path / "out").mkdir()
    write_interpretation(tmp_path / "out" / "interpretation.json", _result(truth))
    args = ["evaluate", str(tmp_path / "out"), str(tmp_path / "scene")]
    assert main([*args, "--json"]) == 0
    figures = json.loads(capsys.readouterr().out)
    assert figures["correct"] is True
    assert figures["outcome"] == "verified"
    write_interpretation(tmp_path / "out" / "interpretation.json", _result(truth, roof="HipRoof"))
    assert main(args) == 1
    assert "specialisation of body.roof: chose HipRoof, truth GableRoof" in capsys.readouterr().out
    assert main(["evaluate", str(tmp_path / "nope"), str(tmp_path / "scene")]) == 2
