"""`aida-kb scene init`: a scene from a calibration (FileStorage, Middlebury, P1/P2) and pairs."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from aida_kb.cli.main import main
from aida_kb.errors import FormatError
from aida_kb.io.calibtext import decompose_projection, read_any_calib
from aida_kb.io.scene import StereoCalib, read_scene, write_calib

W, H = 64, 48


def _images(folder: Path, names: list[str]) -> list[Path]:
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(0)
    out = []
    for name in names:
        path = folder / name
        cv2.imwrite(str(path), rng.integers(0, 255, (H, W, 3), dtype=np.uint8))
        out.append(path)
    return out


MIDDLEBURY = """cam0=[500.5 0 31.5; 0 500.5 23.5; 0 0 1]
cam1=[500.5 0 35.25; 0 500.5 23.5; 0 0 1]
doffs=3.75
baseline=193.001
width=64
height=48
ndisp=40
isint=0
vmin=5
vmax=30
"""


def test_middlebury_calib_and_folder(tmp_path: Path) -> None:
    _images(tmp_path / "moto", ["im0.png", "im1.png"])
    (tmp_path / "moto" / "calib.txt").write_text(MIDDLEBURY)
    out = tmp_path / "scene"
    argv = ["scene", "init", "--calib", str(tmp_path / "moto" / "calib.txt")]
    assert main([*argv, "--images", str(tmp_path / "moto"), "-o", str(out)]) == 0
    scene = read_scene(out)
    rig = scene.views[0].rig
    assert rig.baseline_m == pytest.approx(0.193001)
    np.testing.assert_allclose(rig.T, [-0.193001, 0.0, 0.0])
    assert rig.K2[0, 2] == 35.25
    assert rig.image_size == (W, H)
    assert scene.views[0].left.read_bytes() == (tmp_path / "moto" / "im0.png").read_bytes()
    assert scene.metric


def test_projection_pair_unknown_unit_and_baseline(tmp_path: Path) -> None:
    left, right = _images(tmp_path / "img", ["a_L.png", "a_R.png"])
    K = np.array([[400.0, 0.0, 31.5], [0.0, 410.0, 23.5], [0.0, 0.0, 1.0]])
    c, s = np.cos(0.02), np.sin(0.02)
    R2 = np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])
    t2 = np.array([-2.5, 0.1, 0.05])
    P1 = K @ np.hstack([np.eye(3), np.zeros((3, 1))])
    P2 = 3.0 * (K @ np.hstack([R2, t2[:, None]]))  # a projection matrix is known up to scale
    text = "\n".join(
        f"{k}: " + " ".join(repr(float(v)) for v in P.ravel()) for k, P in (("P1", P1), ("P2", P2))
    )
    (tmp_path / "P.txt").write_text(text + "\n")
    calib = read_any_calib(tmp_path / "P.txt")
    np.testing.assert_allclose(calib.K1, K, atol=1e-9)
    np.testing.assert_allclose(calib.R, R2, atol=1e-12)
    np.testing.assert_allclose(calib.T, t2, atol=1e-9)
    out = tmp_path / "s1"
    base = ["scene", "init", "--calib", str(tmp_path / "P.txt"), "--pair", str(left), str(right)]
    assert main([*base, "--unit", "unknown", "-o", str(out)]) == 0
    scene = read_scene(out)
    assert scene.scale == "unknown"
    assert scene.calib.image_size == (W, H)  # from the images
    out = tmp_path / "s2"
    assert main([*base, "--baseline", "0.5", "-o", str(out)]) == 0
    assert read_scene(out).calib.baseline_m == pytest.approx(0.5)


def test_filestorage_and_decomposition_of_a_general_camera(tmp_path: Path) -> None:
    K = np.array([[500.0, 0.0, 31.5], [0.0, 500.0, 23.5], [0.0, 0.0, 1.0]])
    calib = StereoCalib(K, np.zeros(5), K, np.zeros(5), np.eye(3), np.array([-0.3, 0, 0]), (W, H))
    write_calib(tmp_path / "calib.yaml", calib)
    pairs = _images(tmp_path / "img", ["left_1.png", "right_1.png", "left_2.png", "right_2.png"])
    out = tmp_path / "s"
    argv = ["scene", "init", "--calib", str(tmp_path / "calib.yaml"), "--images"]
    assert main([*argv, str(tmp_path / "img"), "-o", str(out), "--unit", "mm"]) == 0
    scene = read_scene(out)
    assert len(scene.views) == 2
    assert scene.views[1].left.read_bytes() == pairs[2].read_bytes()
    assert scene.calib.baseline_m == pytest.approx(0.0003)
    # a turned, moved camera: K, R, t come back from its projection matrix
    c, s = np.cos(0.3), np.sin(0.3)
    R = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    t = np.array([0.2, -1.0, 4.0])
    K_, R_, t_ = decompose_projection(-2.0 * K @ np.hstack([R, t[:, None]]))
    np.testing.assert_allclose(K_, K, atol=1e-9)
    np.testing.assert_allclose(R_, R, atol=1e-12)
    np.testing.assert_allclose(t_, t, atol=1e-9)


@pytest.mark.parametrize(
    ("calib_text", "message"),
    [
        ("cam0=[500 0 31.5; 0 500 23.5; 0 0 1]\nbaseline=100\n", r"calib\.txt: cam1: missing"),
        ("cam0=[500 0 31.5; 0 500 23.5]\ncam1=[1]\nbaseline=1\n", r"calib\.txt:1: cam0: has 6"),
        ("cam0=[500 0 31.5; 0 500 23.5; 0 0 1]\ncam1=[500 0 31.5; 0 500 23.5; 0 0 1]\n"
         "baseline=-3\n", r"calib\.txt:3: baseline: must be > 0"),
        ("P1: 1 2 3\nP2: 1 2 3 4 5 6 7 8 9 10 11 12\n", r"calib\.txt:1: P1: has 3 numbers"),
        ("P1: 0 0 0 0 0 0 0 0 0 0 0 1\nP2: 1 0 0 0 0 1 0 0 0 0 1 0\n",
         r"calib\.txt:1: P1: .*singular"),
        ("hello world\n", r"calib\.txt:1: expected KEY=VALUE"),
        ("foo=1\n", r"calib\.txt: not a calibration aida-kb reads"),
    ],
)  # fmt: skip
def test_bad_calibration_names_file_and_line(tmp_path: Path, calib_text: str, message: str) -> None:
    (tmp_path / "calib.txt").write_text(calib_text)
    with pytest.raises(FormatError, match=message):
        read_any_calib(tmp_path / "calib.txt")


def test_bad_input_is_refused_and_nothing_written(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    left, right = _images(tmp_path / "img", ["left.png", "right.png"])
    (tmp_path / "calib.txt").write_text(MIDDLEBURY.replace("width=64", "width=80"))
    out = tmp_path / "out"
    argv = [
        "scene",
        "init",
        "--calib",
        str(tmp_path / "calib.txt"),
        "--pair",
        str(left),
        str(right),
    ]
    assert main([*argv, "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "left.png: image is 64x48, the calibration says 80x48" in err
    assert not out.exists()
    # into the image folder itself (an input): refused; a non-empty folder: refused
    (tmp_path / "calib.txt").write_text(MIDDLEBURY)
    assert main([*argv, "-o", str(tmp_path / "img")]) == 2
    assert main([*argv, "-o", str(tmp_path)]) == 2
    assert sorted(p.name for p in (tmp_path / "img").iterdir()) == ["left.png", "right.png"]
    assert main([*argv[:4], "-o", str(out)]) == 2  # no pairs given
    assert main([*argv, "--images", str(tmp_path / "img"), "-o", str(out)]) == 2  # both
    assert main([*argv, "--baseline", "nan", "-o", str(out)]) == 2
    assert not out.exists()
