"""Scene format version 2: per-view calibration and pose, scale (unknown or one known length);
version 1 still read."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from aida_kb.errors import FormatError
from aida_kb.io.scene import (
    SCENE_VERSION,
    BaselineScale,
    DistanceScale,
    ScaleEntry,
    StereoCalib,
    ViewData,
    read_scene,
    triangulate_pair,
    write_scene,
)


def _rig(f: float, baseline: float, size: tuple[int, int] = (64, 48)) -> StereoCalib:
    w, h = size
    K = np.array([[f, 0.0, (w - 1) / 2], [0.0, f, (h - 1) / 2], [0.0, 0.0, 1.0]])
    return StereoCalib(
        K, np.zeros(5), K.copy(), np.zeros(5), np.eye(3), np.array([-baseline, 0, 0]), size
    )


def _img(w: int, h: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, 255, (h, w, 3), dtype=np.uint8)


def _rot_y(deg: float) -> np.ndarray:
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _two_rigs(tmp_path: Path, scale: object = "metres") -> Path:
    a, b = _rig(500.0, 0.3), _rig(800.0, 0.5, (80, 60))
    pose = (_rot_y(10.0), np.array([1.0, 0.0, 0.2]))
    return write_scene(
        tmp_path / "s",
        None,
        [
            ViewData(_img(64, 48, 0), _img(64, 48, 1), calib=a),
            ViewData(_img(80, 60, 2), _img(80, 60, 3), calib=b, pose=pose),
        ],
        scale=scale,  # type: ignore[arg-type]
    )


def test_per_view_calibration_and_pose_round_trip(tmp_path: Path) -> None:
    root = _two_rigs(tmp_path)
    index = yaml.safe_load((root / "scene.yaml").read_text())
    assert index["version"] == SCENE_VERSION == 2
    assert index["calib"] is None
    assert index["views"][1]["calib"] == "views/01/calib.yaml"
    scene = read_scene(root)
    v0, v1 = scene.views
    assert v0.rig.K1[0, 0] == 500.0
    assert v1.rig.K1[0, 0] == 800.0
    assert v1.rig.image_size == (80, 60)
    assert v1.rig.baseline_m == pytest.approx(0.5)
    assert v0.pose is None
    assert v1.pose is not None
    np.testing.assert_allclose(v1.pose[0], _rot_y(10.0), atol=1e-12)
    np.testing.assert_allclose(v1.pose[1], [1.0, 0.0, 0.2])
    assert scene.calib is v0.rig
    assert scene.metric
    assert scene.scale_factor == 1.0
    assert root / "views/01/calib.yaml" in scene.files


def test_version_1_is_still_read(tmp_path: Path) -> None:
    root = write_scene(
        tmp_path / "s", _rig(500.0, 0.3), [ViewData(_img(64, 48, 0), _img(64, 48, 1))]
    )
    text = (root / "scene.yaml").read_text().replace("version: 2", "version: 1")
    text = text.replace("scale: metres\n", "")
    (root / "scene.yaml").write_text(text)
    scene = read_scene(root)
    assert scene.views[0].rig.baseline_m == pytest.approx(0.3)
    assert scene.metric
    # version-2 fields in a version-1 file are refused, naming the field
    (root / "scene.yaml").write_text(text + "scale: unknown\n")
    with pytest.raises(FormatError, match=r"scene\.yaml.*scale.*version 2"):
        read_scene(root)


def test_unknown_scale_is_kept_and_said(tmp_path: Path) -> None:
    scene = read_scene(_two_rigs(tmp_path, "unknown"))
    assert scene.scale == "unknown"
    assert not scene.metric
    assert scene.views[1].rig.baseline_m == pytest.approx(0.5)  # units untouched


def test_a_known_baseline_fixes_the_scale(tmp_path: Path) -> None:
    scale = ScaleEntry(baseline=BaselineScale(view="01", metres=0.25))
    scene = read_scene(_two_rigs(tmp_path, scale))
    assert scene.metric
    assert scene.scale_factor == pytest.approx(0.5)
    assert scene.views[1].rig.baseline_m == pytest.approx(0.25)
    assert scene.views[0].rig.baseline_m == pytest.approx(0.15)
    pose = scene.views[1].pose
    assert pose is not None
    np.testing.assert_allclose(pose[1], [0.5, 0.0, 0.1])


def test_a_known_distance_fixes_the_scale(tmp_path: Path) -> None:
    rig = _rig(500.0, 0.3)
    # two points 2 units apart at depth 10 (scene units), projected into both images
    pts = np.array([[-1.0, 0.2, 10.0], [1.0, 0.2, 10.0]])
    left = (pts @ rig.K1.T)[:, :2] / pts[:, 2:]
    pr = pts + rig.T
    right = (pr @ rig.K2.T)[:, :2] / pr[:, 2:]
    np.testing.assert_allclose(triangulate_pair(rig, left, right), pts, atol=1e-9)
    dist = DistanceScale.model_validate(
        {"view": "00", "left": left.tolist(), "right": right.tolist(), "metres": 5.0}
    )
    scene = read_scene(_two_rigs(tmp_path, ScaleEntry(distance=dist)))
    assert scene.scale_factor == pytest.approx(2.5)
    assert scene.views[0].rig.baseline_m == pytest.approx(0.75)
    # the same pixel in both images: parallel rays, no depth -> refused, naming the field
    bad = DistanceScale.model_validate(
        {"view": "00", "left": left.tolist(), "right": left.tolist(), "metres": 5.0}
    )
    root = _two_rigs(tmp_path / "b", ScaleEntry(distance=bad))
    with pytest.raises(FormatError, match=r"scene\.yaml: field scale\.distance: .*parallel"):
        read_scene(root)


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda d: d["views"][1].pop("calib"), r"views\[1\]\.calib: missing"),
        (
            lambda d: d["views"][0].update(pose={"R": np.eye(3).tolist(), "t": [1, 0, 0]}),
            r"views\[0\]\.pose: view 00",
        ),
        (
            lambda d: d["views"][1]["pose"].update(R=(2 * np.eye(3)).tolist()),
            r"views\[1\]\.pose\.R: not a rotation",
        ),
        (
            lambda d: d.update(scale={"baseline": {"view": "07", "metres": 1.0}}),
            r"scale\.baseline\.view: no view '07'",
        ),
        (lambda d: d.update(scale={"baseline": {"view": "00", "metres": -1.0}}), r"scale"),
        (lambda d: d.update(scale="feet"), r"scale"),
    ],
)
def test_bad_version_2_fields_name_the_field(tmp_path: Path, edit: object, message: str) -> None:
    root = _two_rigs(tmp_path)
    data = yaml.safe_load((root / "scene.yaml").read_text())
    edit(data)  # type: ignore[operator]
    (root / "scene.yaml").write_text(yaml.safe_dump(data))
    with pytest.raises(FormatError, match=message):
        read_scene(root)
