"""`aida-kb register`: a view's pose against a model file; bad input."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from aida_kb.cli.main import main
from aida_kb.io.model import ModelCamera, ModelPart, ReconstructedModel, write_model
from aida_kb.io.scene import read_scene
from aida_kb.synth.scenes import preset, render_scene


@pytest.fixture(scope="module")
def house(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A rendered two-view house and a model file of its true shape with view 00's camera."""
    root = tmp_path_factory.mktemp("register")
    scene_dir = root / "house"
    render_scene(preset("house", seed=1), scene_dir, supersample=1)
    truth = read_scene(scene_dir).truth
    assert truth is not None
    v0 = truth.views[0]
    model = ReconstructedModel(
        parts=[
            ModelPart(
                role=p.role, concept=p.concept, normal=p.normal, offset_m=p.d, polygon=p.polygon
            )
            for p in truth.parts
        ],
        cameras=[ModelCamera(view="00", K=v0.K, R=v0.R, t=v0.t, image_width=640, image_height=480)],
    )
    write_model(root / "model.json", model)
    return root / "model.json", scene_dir


def test_register_finds_the_second_views_pose(
    house: tuple[Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    model, scene_dir = house
    code = main(["register", str(model), str(scene_dir), "--view", "01", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert code == 0
    true = read_scene(scene_dir).truth.pose("01")  # type: ignore[union-attr]
    C_true = -np.array(true.R).T @ np.array(true.t)
    assert np.linalg.norm(np.array(out["centre_m"]) - C_true) < 0.3  # metres, at 30 m
    assert abs(out["turn_deg"] + 45.0) < 0.5
    assert out["rms_px"] < 1.0
    assert out["segments"] >= 10
    # the adjustment's uncertainty: the turn is determined to hundredths of a degree
    assert 0.0 < out["turn_sigma_deg"] <= out["rotation_sigma_deg"] < 0.1
    assert len(out["centre_sigma_m"]) == 3
    # a gable house looks the same half turned; with no images to tell, the twin is undecided
    assert [round((a - out["turn_deg"]) % 360.0) for a in out["undecided_turns_deg"]] == [180]


def test_register_prints_the_pose_and_residual(
    house: tuple[Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    model, scene_dir = house
    code = main(["register", str(model), str(scene_dir), "--view", "01", "--init-angle", "-40"])
    text = capsys.readouterr().out
    assert code == 0
    assert "turn about the vertical: -4" in text
    assert "residual:" in text
    assert "px RMS over" in text
    assert "uncertainty (1 sigma, from the adjustment): turn" in text
    assert "undecided: nothing in the view rules out the turns 13" in text


def test_register_bad_input_is_one_line_and_non_zero(
    house: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    model, scene_dir = house
    assert main(["register", str(tmp_path / "none.json"), str(scene_dir), "--view", "01"]) == 2
    assert "none.json: no such file" in capsys.readouterr().err
    assert main(["register", str(model), str(scene_dir), "--view", "07"]) != 0
    assert "no view(s) 07" in capsys.readouterr().err
    bare = tmp_path / "bare.json"
    bare.write_text(model.read_text().replace('"cameras"', '"_cameras"'))
    assert main(["register", str(bare), str(scene_dir), "--view", "01"]) == 2
    err = capsys.readouterr().err
    assert "bare.json" in err
    assert "Traceback" not in err
    assert main(["register", str(model), str(scene_dir), "--view", "01", "--reference", "05"]) == 2
    assert "no camera of view '05'" in capsys.readouterr().err


def test_register_help_has_an_example(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["register", "--help"])
    assert exc.value.code == 0
    assert "aida-kb register out/m/model.json out/house --view 01" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("width", "height", "expected"),
    [
        (1, 1, "image_width x image_height 1x1 cannot hold the model's projection (0 of "),
        (640, 10**7, "image_width x image_height 640x10000000 is absurd"),
        (0, 480, "image_width"),
        (-640, 480, "image_width"),
    ],
)
def test_a_model_camera_whose_image_cannot_hold_the_model_is_refused(
    width: int,
    height: int,
    expected: str,
    house: tuple[Path, Path],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    model, _ = house
    data = json.loads(model.read_text())
    data["cameras"][0]["image_width"] = width
    data["cameras"][0]["image_height"] = height
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(data))
    # the scene is not even read: the model file is checked first
    code = main(["register", str(bad), str(tmp_path / "no-scene"), "--view", "01"])
    err = capsys.readouterr().err
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(f"aida-kb: error: {bad}")
    assert expected in lines[0]
