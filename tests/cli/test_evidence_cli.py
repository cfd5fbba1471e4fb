"""`aida-kb evidence` on bad scenes: one-line errors, non-zero exit, no evidence file written."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aida_kb.cli.main import main
from aida_kb.io.scene import StereoCalib, ViewData, write_scene


def _scene(tmp_path: Path, value: int = 0) -> Path:
    """A 64x48 one-view scene whose images are a single grey level (nothing to match)."""
    K = np.array([[60.0, 0.0, 31.5], [0.0, 60.0, 23.5], [0.0, 0.0, 1.0]])
    calib = StereoCalib(K, np.zeros(5), K, np.zeros(5), np.eye(3), np.array([-0.3, 0, 0]), (64, 48))
    flat = np.full((48, 64, 3), value, np.uint8)
    return write_scene(tmp_path / "scene", calib, [ViewData(flat, flat.copy())])


def test_featureless_images_are_an_error_and_write_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scene = _scene(tmp_path)
    out = tmp_path / "ev.json"
    code = main(["evidence", str(scene), "-o", str(out), "--max-disp", "16", "--quiet"])
    err = capsys.readouterr().err
    assert code == 1
    assert "warning: view 00: no planar region" in err
    assert f"{scene}: no planar region in any view" in err
    assert not out.exists()


def test_output_below_a_file_is_a_usage_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scene = _scene(tmp_path, 128)
    (tmp_path / "afile").write_text("x")
    code = main(["evidence", str(scene), "-o", str(tmp_path / "afile" / "ev.json"), "--quiet"])
    assert code == 2
    assert "afile is a file, not a directory" in capsys.readouterr().err


def test_view_image_of_the_wrong_size(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import cv2

    scene = _scene(tmp_path, 128)
    cv2.imwrite(str(scene / "views" / "00" / "right.png"), np.zeros((40, 64), np.uint8))
    code = main(["evidence", str(scene), "-o", str(tmp_path / "ev.json"), "--quiet"])
    err = capsys.readouterr().err
    assert code != 0
    assert "right.png" in err
    assert "internal error" not in err
    assert not (tmp_path / "ev.json").exists()


@pytest.mark.parametrize("views", ["00,00", "00,,01"])
def test_views_option_must_name_distinct_views(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], views: str
) -> None:
    scene = _scene(tmp_path, 128)
    code = main(["evidence", str(scene), "-o", str(tmp_path / "ev.json"), "--views", views])
    assert code == 1
    assert "expected distinct comma-separated view ids" in capsys.readouterr().err


def test_output_over_an_input_file_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scene = _scene(tmp_path, 128)
    index = (scene / "scene.yaml").read_text()
    code = main(["evidence", str(scene), "-o", str(scene / "scene.yaml"), "--quiet"])
    assert code == 2
    assert "over the input file" in capsys.readouterr().err
    assert (scene / "scene.yaml").read_text() == index
