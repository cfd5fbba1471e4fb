"""`evaluate`: a result judged against a scene's truth — every check can fail on its own."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from aida_kb.cli.main import main
from aida_kb.interpret.evaluate import evaluate
from aida_kb.interpret.result import Instance, Interpretation, write_interpretation
from aida_kb.io.model import ModelCamera, ModelPart, ReconstructedModel
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
