"""Chessboard stereo calibration against the rig that rendered the views."""

from __future__ import annotations

import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest

from aida_kb.cli.main import main
from aida_kb.errors import VisionError
from aida_kb.io.scene import read_calib
from aida_kb.vision.calibration import calibrate_stereo


def test_calibrate_recovers_the_rig(
    small_chessboard: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "calib.yaml"
    assert main(["calibrate", str(small_chessboard), "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert "RMS reprojection error" in err
    est, truth = read_calib(out), read_calib(small_chessboard / "calib.yaml")
    assert est.image_size == truth.image_size
    np.testing.assert_allclose(est.K1, truth.K1, rtol=0.01, atol=1.5)
    np.testing.assert_allclose(est.K2, truth.K2, rtol=0.01, atol=1.5)
    assert est.baseline_m == pytest.approx(truth.baseline_m, rel=0.01)
    rot = est.R @ truth.R.T
    angle = np.degrees(np.arccos(np.clip((np.trace(rot) - 1) / 2, -1, 1)))
    assert angle < 0.5
    stereo = float(err.split("stereo ")[1].split(" px")[0])
    assert stereo < 0.3


def test_calibrate_bad_input(
    small_chessboard: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "calib.yaml"
    assert main(["calibrate", str(tmp_path), "-o", str(out)]) == 1
    assert "no *left*.png" in capsys.readouterr().err
    blank = tmp_path / "blank"
    blank.mkdir()
    for i in range(3):
        for side in ("left", "right"):
            cv2.imwrite(str(blank / f"{side}_{i}.png"), np.full((60, 80), 128, np.uint8))
    assert main(["calibrate", str(blank), "-o", str(out)]) == 1
    assert "at least 3" in capsys.readouterr().err
    assert main(["calibrate", str(small_chessboard), "-o", str(out), "--pattern", "nine"]) == 1
    assert "COLSxROWS" in capsys.readouterr().err
    broken = tmp_path / "broken"
    shutil.copytree(small_chessboard / "views", broken)
    (broken / "02" / "left.png").write_bytes(b"junk")
    assert main(["calibrate", str(broken), "-o", str(out)]) == 2
    assert "left.png" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize("square_m", [float("nan"), float("inf"), 0.0, -0.03])
def test_calibrate_refuses_a_square_size_that_is_not_a_positive_number(
    square_m: float, tmp_path: Path
) -> None:
    # refused before any image is read: the pair need not exist
    pair = (tmp_path / "left.png", tmp_path / "right.png")
    with pytest.raises(VisionError, match=r"bad chessboard: 9x6 corners, square"):
        calibrate_stereo([pair], (9, 6), square_m)
