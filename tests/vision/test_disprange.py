"""The disparity range from sparse feature matches, and the warnings of a range too small."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from aida_kb.cli.main import main
from aida_kb.vision.disprange import disparity_range, saturation_warnings, sparse_disparities
from aida_kb.vision.stereo import ncc_disparity


def _pair(shift: int, width: int = 480, height: int = 160) -> tuple[np.ndarray, np.ndarray]:
    """A textured rectified pair with disparity `shift` everywhere (the right image moved)."""
    rng = np.random.default_rng(7)
    tex = cv2.GaussianBlur(rng.normal(128, 45, (height, width)).astype(np.float32), (0, 0), 1.2)
    left = np.clip(tex, 0, 255).astype(np.uint8)
    return left, np.roll(left, -shift, axis=1)


def test_range_found_around_a_large_disparity() -> None:
    left, right = _pair(150)
    d = sparse_disparities(left, right)
    assert len(d) > 100
    assert np.median(d) == pytest.approx(150.0, abs=0.5)
    found = disparity_range(left, right)
    assert found is not None
    assert found.min_disp <= 150 - 8
    assert found.min_disp + found.num_disp - 1 >= 150 + 8
    assert found.num_disp <= 24  # tight: 16 at least, the margin of 8 on either side
    assert not found.clipped


def test_featureless_pair_gives_no_range() -> None:
    flat = np.full((120, 200), 128, np.uint8)
    assert disparity_range(flat, flat) is None


def test_saturation_is_reported() -> None:
    left, right = _pair(40, width=240, height=96)
    small = ncc_disparity(left, right, num_disp=32, window=9)
    sparse = sparse_disparities(left, right)
    warnings = saturation_warnings(small, 0, 32, sparse)
    assert any("sparse feature matches lie outside" in w for w in warnings)
    enough = ncc_disparity(left, right, num_disp=64, window=9)
    assert saturation_warnings(enough, 0, 64, sparse) == []


def test_disparity_command_finds_the_range_and_warns_when_given_too_small(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    left, right = _pair(150)
    lp, rp, out = tmp_path / "l.png", tmp_path / "r.png", tmp_path / "d.npy"
    cv2.imwrite(str(lp), left)
    cv2.imwrite(str(rp), right)
    assert main(["disparity", str(lp), str(rp), "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert "warning" not in err
    d = np.load(out)[10:-10, 170:-10]
    assert np.nanmedian(d) == pytest.approx(150.0, abs=0.05)
    assert np.mean(~np.isnan(d)) > 0.9
    assert main(["disparity", str(lp), str(rp), "-o", str(out), "--max-disp", "128"]) == 0
    err = capsys.readouterr().err
    assert "warning: " in err
    assert "outside the range searched (0..127 px" in err
