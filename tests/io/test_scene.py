"""Scene directory reader/writer: round trip, OpenCV compatibility, clear errors."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from aida_kb.errors import FormatError
from aida_kb.io.scene import (
    PartTruth,
    PoseTruth,
    SceneTruth,
    StereoCalib,
    ViewData,
    read_calib,
    read_depth,
    read_image,
    read_labels,
    read_scene,
    write_calib,
    write_scene,
)


def _calib() -> StereoCalib:
    K = np.array([[500.0, 0.0, 31.5], [0.0, 500.0, 23.5], [0.0, 0.0, 1.0]])
    c, s = np.cos(0.01), np.sin(0.01)
    R = np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])
    return StereoCalib(
        K,
        np.array([-0.1, 0.01, 0.0, 0.0, 0.0]),
        K * 1.0,
        np.zeros(5),
        R,
        np.array([-0.3, 0.0, 0.01]),
        (64, 48),
    )


def _truth() -> SceneTruth:
    return SceneTruth(
        object="House",
        parts=[
            PartTruth(
                role="body.front",
                concept="Wall",
                label=1,
                normal=(0.0, 0.0, -1.0),
                d=-10.0,
                polygon=[(-1.0, -1.0, 10.0), (1.0, -1.0, 10.0), (1.0, 1.0, 10.0)],
            )
        ],
        views=[
            PoseTruth(
                view="00",
                K=((500, 0, 31.5), (0, 500, 23.5), (0, 0, 1)),
                R=((1, 0, 0), (0, 1, 0), (0, 0, 1)),
                t=(0, 0, 0),
            )
        ],
    )


def _write(tmp_path: Path) -> Path:
    rng = np.random.default_rng(0)
    img = rng.integers(0, 255, (48, 64, 3), dtype=np.uint8)
    labels = np.zeros((48, 64), np.uint16)
    labels[10:20, 10:30] = 1
    labels[30:, :] = 1000
    depth = np.full((48, 64), np.nan, np.float32)
    depth[10:20, 10:30] = 10.0
    return write_scene(
        tmp_path / "scene",
        _calib(),
        [ViewData(img, img[:, :, 0].copy()[:, :, None].repeat(3, 2), labels, depth)],
        truth=_truth(),
        name="t",
    )


def test_round_trip(tmp_path: Path) -> None:
    root = _write(tmp_path)
    scene = read_scene(root)
    assert scene.name == "t"
    assert [v.id for v in scene.views] == ["00"]
    cal = scene.calib
    ref = _calib()
    np.testing.assert_allclose(cal.K1, ref.K1)
    np.testing.assert_allclose(cal.D1, ref.D1)
    np.testing.assert_allclose(cal.R, ref.R)
    np.testing.assert_allclose(cal.T, ref.T)
    assert cal.image_size == (64, 48)
    assert cal.baseline_m == pytest.approx(np.linalg.norm(ref.T))
    v = scene.view("00")
    assert read_image(v.left).shape == (48, 64, 3)
    assert read_image(v.left, grey=True).shape == (48, 64)
    assert v.labels is not None
    assert v.depth_left is not None
    lab = read_labels(v.labels)
    assert lab.dtype == np.uint16
    assert lab[35, 5] == 1000
    assert lab[15, 15] == 1
    dep = read_depth(v.depth_left)
    assert dep[15, 15] == 10.0
    assert np.isnan(dep[0, 0])
    assert scene.truth is not None
    assert scene.truth.part("body.front").d == -10.0
    assert scene.truth.pose("00").t == (0.0, 0.0, 0.0)
    # no temporary files left behind
    assert not [p for p in root.rglob("*") if ".tmp" in p.name]


def test_calib_readable_by_opencv(tmp_path: Path) -> None:
    root = _write(tmp_path)
    fs = cv2.FileStorage(str(root / "calib.yaml"), cv2.FILE_STORAGE_READ)
    assert fs.isOpened()
    np.testing.assert_allclose(fs.getNode("K1").mat(), _calib().K1)
    np.testing.assert_allclose(fs.getNode("T").mat().ravel(), _calib().T)
    assert int(fs.getNode("image_width").real()) == 64
    fs.release()


def test_calib_written_by_opencv_is_read(tmp_path: Path) -> None:
    """A calibration written by plain OpenCV code (a real rig) drops in unchanged."""
    path = tmp_path / "calib.yaml"
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    K = np.array([[900.0, 0, 640], [0, 900.0, 360], [0, 0, 1]])
    for name, value in [
        ("K1", K),
        ("D1", np.zeros((1, 5))),
        ("K2", K),
        ("D2", np.zeros((5, 1))),
        ("R", np.eye(3)),
        ("T", np.array([[-0.12], [0.0], [0.0]])),
    ]:
        fs.write(name, value)
    fs.write("image_width", 1280)
    fs.write("image_height", 720)
    fs.release()
    cal = read_calib(path)
    assert cal.image_size == (1280, 720)
    assert cal.D2.shape == (5,)


def _expect(root: Path, *fragments: str) -> None:
    with pytest.raises(FormatError) as info:
        read_scene(root)
    for f in fragments:
        assert f in str(info.value), str(info.value)


def test_missing_directory_and_index(tmp_path: Path) -> None:
    _expect(tmp_path / "nope", "nope", "not a directory")
    (tmp_path / "empty").mkdir()
    _expect(tmp_path / "empty", "scene.yaml", "no such file")


def test_bad_index_fields(tmp_path: Path) -> None:
    root = _write(tmp_path)
    index = root / "scene.yaml"
    text = index.read_text()
    index.write_text(text.replace("format: aida-kb-scene", "format: something"))
    _expect(root, "scene.yaml", "format")
    index.write_text(text.replace("left: views/00/left.png", "left: views/00/missing.png"))
    _expect(root, "scene.yaml", "views[0].left", "missing.png")
    index.write_text(text.replace("left: views/00/left.png", "left: ../../etc/passwd"))
    _expect(root, "scene.yaml", "views[0].left", "inside the scene directory")
    index.write_text("views: [\n")
    _expect(root, "scene.yaml", "not valid YAML")
    index.write_text(text.replace("views:", "viewz:"))
    _expect(root, "scene.yaml", "views")


def test_bad_calib_fields(tmp_path: Path) -> None:
    root = _write(tmp_path)
    calib = root / "calib.yaml"
    text = calib.read_text()
    calib.write_text(text.replace("K2:", "K3:"))
    _expect(root, "calib.yaml", "K2", "missing")
    calib.write_text(text.replace("image_width: 64", "image_width: -3"))
    _expect(root, "calib.yaml", "image_width")
    calib.write_text("not: [opencv")
    _expect(root, "calib.yaml")
    fs = cv2.FileStorage(str(calib), cv2.FILE_STORAGE_WRITE)
    for name in ("K1", "K2"):
        fs.write(name, np.eye(3))
    for name in ("D1", "D2"):
        fs.write(name, np.zeros(5))
    fs.write("R", np.diag([1.0, 1.0, -1.0]))
    fs.write("T", np.array([0.3, 0.0, 0.0]))
    fs.write("image_width", 64)
    fs.write("image_height", 48)
    fs.release()
    _expect(root, "calib.yaml", "field R", "rotation")


def test_bad_truth_fields(tmp_path: Path) -> None:
    root = _write(tmp_path)
    truth = root / "truth.json"
    data = json.loads(truth.read_text())
    data["parts"][0]["normal"] = [0.0, 0.0, -2.0]
    truth.write_text(json.dumps(data))
    _expect(root, "truth.json", "parts[0].normal", "unit length")
    data["parts"][0]["normal"] = [0.0, 0.0, -1.0]
    data["views"][0]["view"] = "07"
    truth.write_text(json.dumps(data))
    _expect(root, "truth.json", "views[0].view")


def test_bad_images(tmp_path: Path) -> None:
    root = _write(tmp_path)
    (root / "views/00/left.png").write_bytes(b"garbage")
    scene = read_scene(root)
    with pytest.raises(FormatError, match=r"left\.png"):
        read_image(scene.views[0].left)
    np.save(root / "views/00/depth_left.npy", np.zeros((3, 3, 3)))
    with pytest.raises(FormatError, match=r"depth_left\.npy"):
        read_depth(scene.views[0].depth_left or Path())


def test_hardening_regressions(tmp_path: Path) -> None:
    """Inputs that used to crash (cv2.error) or pass through silently."""
    root = _write(tmp_path)
    calib = root / "calib.yaml"
    text = calib.read_text()
    calib.write_text(text[: text.index("D1:") + 40])  # truncated inside the D1 node
    _expect(root, "calib.yaml", "field D1", "malformed opencv-matrix")
    calib.write_text(text)
    cal = _calib()
    singular = np.array([[500.0, 500.0, 31.5], [500.0, 500.0, 23.5], [0.0, 0.0, 1.0]])
    fs = cv2.FileStorage(str(calib), cv2.FILE_STORAGE_WRITE)
    for name, value in (("K1", singular), ("D1", cal.D1), ("K2", cal.K2), ("D2", cal.D2)):
        fs.write(name, value)
    fs.write("R", cal.R)
    fs.write("T", cal.T)
    fs.write("image_width", 64)
    fs.write("image_height", 48)
    fs.release()
    _expect(root, "calib.yaml", "field K1", "not a camera matrix")
    calib.write_text(text)
    truth = root / "truth.json"
    data = json.loads(truth.read_text())
    data["ground"] = {"label": 9, "normal": [float("nan"), 0.0, 0.0], "d": 1.0}
    truth.write_text(json.dumps(data))
    _expect(root, "truth.json", "ground.normal[0]", "finite")
    data["ground"] = None
    data["views"][0]["K"] = [[500, 0, 31.5], [0, 500, 23.5], [0, 0, 0]]
    truth.write_text(json.dumps(data))
    _expect(root, "truth.json", "views[0]", "fx, fy > 0")


def test_sixteen_bit_view_image_is_refused(tmp_path: Path) -> None:
    """cv2.IMREAD_COLOR would scale a 16-bit image down to 8 bits without a word."""
    path = tmp_path / "left.png"
    cv2.imwrite(str(path), np.full((48, 64), 4000, np.uint16))
    with pytest.raises(FormatError, match=r"left\.png: expected an 8-bit image, got uint16"):
        read_image(path)
    with pytest.raises(FormatError, match="8-bit"):
        read_image(path, grey=True)


def test_write_scene_into_a_file_is_a_format_error(tmp_path: Path) -> None:
    (tmp_path / "afile").write_text("x")
    with pytest.raises(FormatError, match="afile is a file, not a directory"):
        write_scene(tmp_path / "afile", _calib(), [])


def test_stereo_calib_with_nan_is_a_format_error() -> None:
    good = _calib()
    with pytest.raises(FormatError, match="field K2: contains NaN"):
        StereoCalib(good.K1, good.D1, np.full((3, 3), np.nan), good.D2, good.R, good.T, (64, 48))
    with pytest.raises(FormatError, match="field T: has 2 elements"):
        StereoCalib(good.K1, good.D1, good.K2, good.D2, good.R, np.zeros(2), (64, 48))
    with pytest.raises(FormatError, match="image size 0x48"):
        StereoCalib(good.K1, good.D1, good.K2, good.D2, good.R, good.T, (0, 48))


def test_write_scene_with_a_wrong_image_size_is_a_format_error(tmp_path: Path) -> None:
    img = np.zeros((47, 64, 3), np.uint8)
    with pytest.raises(FormatError, match="view 00: left image must be uint8 of size 64x48"):
        write_scene(tmp_path / "s", _calib(), [ViewData(img, img)])
    assert not (tmp_path / "s" / "scene.yaml").exists()


def test_view_id_cannot_escape_and_right_is_not_left(tmp_path: Path) -> None:
    """A view id names debug files: '../x' wrote outside the debug folder."""
    root = _write(tmp_path)
    index = root / "scene.yaml"
    text = index.read_text()
    index.write_text(text.replace("id: '00'", "id: ../../escaped"))
    _expect(root, "scene.yaml", "views[0].id", "pattern")
    index.write_text(text.replace("right: views/00/right.png", "right: views/00/left.png"))
    _expect(root, "scene.yaml", "views[0].right", "same file as the left image")


@pytest.mark.parametrize("bad", [np.inf, -2.0, 0.0])
def test_depth_map_values_are_positive_metres(tmp_path: Path, bad: float) -> None:
    depth = np.full((4, 5), np.nan, np.float32)
    depth[1, 1] = 10.0
    path = tmp_path / "depth_left.npy"
    np.save(path, depth)
    assert read_depth(path)[1, 1] == 10.0
    depth[2, 2] = bad
    np.save(path, depth)
    with pytest.raises(FormatError, match="positive finite metres"):
        read_depth(path)


def test_rounded_rotation_is_reorthonormalised_and_far_one_refused(tmp_path: Path) -> None:
    """A rig written with 6 significant digits (R orthonormal to ~1e-6, as Strecha's cameras)
    is read as the nearest rotation, which the camera check (1e-9) accepts; an R off by 1e-3
    is refused naming the file and the field."""
    from aida_kb.geometry.rotation import check_rotation

    calib = _calib()
    rounded = np.array([float(f"{x:.6g}") for x in (calib.R @ _rot_x(0.2137)).ravel()])
    raw = rounded.reshape(3, 3)
    assert np.abs(raw @ raw.T - np.eye(3)).max() > 1e-8  # the rounding is visible
    path = tmp_path / "calib.yaml"
    write_calib(path, StereoCalib(calib.K1, calib.D1, calib.K2, calib.D2, raw, calib.T, (64, 48)))
    read = read_calib(path)
    check_rotation(read.R, "R")  # would raise "not orthonormal" with the raw R
    assert np.abs(read.R - raw).max() < 2e-6
    far = raw + np.array([[0.0, 1e-3, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    write_calib(path, StereoCalib(calib.K1, calib.D1, calib.K2, calib.D2, far, calib.T, (64, 48)))
    with pytest.raises(FormatError, match=r"calib\.yaml: field R: not a rotation matrix"):
        read_calib(path)


def _rot_x(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
