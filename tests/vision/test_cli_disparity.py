"""`aida-kb disparity`: writes float32 .npy maps; bad input is a message, not a traceback."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from aida_kb.cli.main import main


def _pair(tmp_path: Path) -> tuple[Path, Path]:
    rng = np.random.default_rng(0)
    tex = cv2.GaussianBlur(rng.normal(128, 40, (80, 140)).astype(np.float32), (0, 0), 1.0)
    left = np.clip(tex, 0, 255).astype(np.uint8)
    right = np.roll(left, -6, axis=1)  # disparity 6 everywhere (but the wrapped border)
    lp, rp = tmp_path / "l.png", tmp_path / "r.png"
    cv2.imwrite(str(lp), left)
    cv2.imwrite(str(rp), right)
    return lp, rp


@pytest.mark.parametrize("matcher", ["ncc", "sgm"])
def test_disparity_command(
    matcher: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    lp, rp = _pair(tmp_path)
    out, cert = tmp_path / "d.npy", tmp_path / "c.npy"
    code = main(
        [
            "disparity",
            str(lp),
            str(rp),
            "-o",
            str(out),
            "--max-disp",
            "16",
            "--certainty",
            str(cert),
            "--matcher",
            matcher,
        ]
    )
    assert code == 0
    d = np.load(out)
    c = np.load(cert)
    assert d.dtype == np.float32
    assert d.shape == (80, 140)
    inner = d[8:-8, 16:-16]
    assert np.nanmedian(np.abs(inner - 6.0)) < 0.05
    assert np.mean(~np.isnan(inner)) > 0.95
    assert c.dtype == np.float32
    assert 0.0 <= c.min() <= c.max() <= 1.0
    assert "density" in capsys.readouterr().err


def test_disparity_bad_input(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    lp, _ = _pair(tmp_path)
    missing = tmp_path / "nope.png"
    out = tmp_path / "d.npy"
    assert main(["disparity", str(lp), str(missing), "-o", str(out)]) == 2
    assert "nope.png: no such file" in capsys.readouterr().err
    garbage = tmp_path / "garbage.png"
    garbage.write_bytes(b"not a png")
    assert main(["disparity", str(garbage), str(lp), "-o", str(out)]) == 2
    assert "garbage.png: not a readable image" in capsys.readouterr().err
    small = tmp_path / "small.png"
    cv2.imwrite(str(small), np.zeros((10, 10), np.uint8))
    assert main(["disparity", str(lp), str(small), "-o", str(out)]) == 1
    assert "small.png" in capsys.readouterr().err
    assert main(["disparity", str(lp), str(lp), "-o", str(out), "--window", "4"]) == 1
    assert "odd" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize(
    ("window", "message"),
    [
        ("99999", "window 99999 does not fit the 140x80 image: it must be odd, >= 3 and sma"),
        ("8", "--window 8: the window must be odd and >= 3 pixels"),
        ("1", "--window 1: the window must be odd and >= 3 pixels"),
    ],
)
def test_a_wrong_window_is_reported_as_such(
    window: str, message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    lp, rp = _pair(tmp_path)
    out = tmp_path / "d.npy"
    assert main(["disparity", str(lp), str(rp), "-o", str(out), "--window", window]) == 1
    err = capsys.readouterr().err
    assert err.strip().startswith(f"aida-kb: error: {message}")
    assert len(err.strip().splitlines()) == 1
    assert not out.exists()
