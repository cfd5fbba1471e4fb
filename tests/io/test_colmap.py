"""COLMAP sparse models: text and binary read alike, pairs chosen by the documented rule,
`scene from-colmap` round-trips a model written from a synthetic scene (and reconstructs it
as well as the native scene)."""

from __future__ import annotations

import shutil
import struct
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from aida_kb.cli.main import main
from aida_kb.errors import FormatError
from aida_kb.io.colmap import (
    PairingRule,
    candidate_pairs,
    quaternion_to_rotation,
    read_colmap,
    rotation_to_quaternion,
)
from aida_kb.io.scene import read_scene
from aida_kb.synth.scenes import rot_y
from aida_kb.testing.colmap import SfmFrame, write_colmap_from_scene

# structure from motion's arbitrary frame: scaled by 0.37, turned by 40 deg, moved
FRAME = SfmFrame(scale=0.37, Q=tuple(map(tuple, rot_y(0.7))), offset=(3.0, -1.0, 2.0))


@pytest.fixture(scope="module")
def models(demo_run: Any, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The demo's rendered house as a COLMAP model, text and binary."""
    root = tmp_path_factory.mktemp("colmap")
    out = {}
    for fmt in ("text", "binary"):
        model, images = write_colmap_from_scene(
            demo_run.root / "scene",
            root / fmt,
            frame=FRAME,
            fmt=fmt,  # type: ignore[arg-type]
        )
        out[fmt], out[f"{fmt}-images"] = model, images
    return out


def test_quaternions_round_trip() -> None:
    rng = np.random.default_rng(3)
    for _ in range(20):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        q = q if q[0] >= 0 else -q
        np.testing.assert_allclose(rotation_to_quaternion(quaternion_to_rotation(q)), q, atol=1e-12)


def test_text_and_binary_models_read_alike(models: dict[str, Path]) -> None:
    text, binary = read_colmap(models["text"]), read_colmap(models["binary"])
    assert sorted(text.cameras) == sorted(binary.cameras) == [1, 2]
    assert {i.name for i in text.images.values()} == {
        "v00_left.png", "v00_right.png", "v01_left.png", "v01_right.png",
    }  # fmt: skip
    np.testing.assert_array_equal(text.point_ids, binary.point_ids)
    np.testing.assert_allclose(text.points, binary.points, atol=1e-12)
    for iid, image in text.images.items():
        other = binary.images[iid]
        np.testing.assert_allclose(image.R, other.R, atol=1e-12)
        np.testing.assert_allclose(image.t, other.t, atol=1e-12)
        np.testing.assert_array_equal(image.point_ids, other.point_ids)
    assert len(text.points) > 200


def test_pairs_follow_the_rule(models: dict[str, Path]) -> None:
    model = read_colmap(models["text"])
    pairs = candidate_pairs(model)
    # the two rigs; the cross-view pairs converge by 45 deg (beyond MAX_AXIS_ANGLE_DEG)
    assert [(p.left.name, p.right.name) for p in pairs] == [
        ("v00_left.png", "v00_right.png"),
        ("v01_left.png", "v01_right.png"),
    ] or [(p.left.name, p.right.name) for p in pairs] == [
        ("v01_left.png", "v01_right.png"),
        ("v00_left.png", "v00_right.png"),
    ]
    assert all(0.01 < p.ratio < 0.02 for p in pairs)
    assert candidate_pairs(model, PairingRule(max_axis_deg=60.0, max_ratio=1.0))[2:], (
        "cross pairs admitted"
    )
    assert not candidate_pairs(model, PairingRule(min_shared=100_000))


def test_from_colmap_round_trips_the_native_scene(
    demo_run: Any, models: dict[str, Path], tmp_path: Path
) -> None:
    native = read_scene(demo_run.root / "scene")
    baseline = native.calib.baseline_m
    for fmt in ("text", "binary"):
        out = tmp_path / fmt
        argv = ["scene", "from-colmap", str(models[fmt]), "--images", str(models[f"{fmt}-images"])]
        argv += ["-o", str(out), "--known-distance", "v00_left.png", "v00_right.png", str(baseline)]
        assert main(argv) == 0
        scene = read_scene(out)
        assert scene.metric
        assert scene.scale_factor == pytest.approx(1 / FRAME.scale, rel=1e-9)
        assert truth_pose_errors(native, scene) < 1e-9
        for mine, theirs in zip(scene.views, native.views, strict=True):
            for f in ("K1", "D1", "K2", "D2", "R", "T"):
                np.testing.assert_allclose(getattr(mine.rig, f), getattr(theirs.rig, f), atol=1e-9)
            assert mine.left.read_bytes() == theirs.left.read_bytes()
            assert mine.right.read_bytes() == theirs.right.read_bytes()
    # without a known distance: up to scale, and said so in scene.yaml
    out = tmp_path / "unknown"
    argv = ["scene", "from-colmap", str(models["text"]), "--images", str(models["text-images"])]
    assert main([*argv, "-o", str(out)]) == 0
    scene = read_scene(out)
    assert scene.scale == "unknown"
    assert scene.views[0].rig.baseline_m == pytest.approx(baseline * FRAME.scale)
    assert yaml.safe_load((out / "scene.yaml").read_text())["scale"] == "unknown"


def truth_pose_errors(native: Any, scene: Any) -> float:
    """The largest difference between the scene's view poses and the native truth's."""
    assert native.truth is not None
    worst = 0.0
    for view in scene.views[1:]:
        pose = native.truth.pose(view.id)
        R, t = view.pose
        worst = max(worst, float(np.abs(R - np.array(pose.R)).max()))
        worst = max(worst, float(np.abs(t - np.array(pose.t)).max()))
    return worst


def _copy(src: Path, dst: Path) -> Path:
    shutil.copytree(src, dst)
    return dst


def test_bad_models_name_the_file_and_place(models: dict[str, Path], tmp_path: Path) -> None:
    text = _copy(models["text"], tmp_path / "t")
    cams = (text / "cameras.txt").read_text().splitlines()
    (text / "cameras.txt").write_text(
        "\n".join([*cams[:2], "1 OPENCV_FISHEYE 640 480 1 1 1 1 0 0 0 0"])
    )
    with pytest.raises(FormatError, match=r"cameras\.txt:3: camera 1: model OPENCV_FISHEYE is not"):
        read_colmap(text)
    (text / "cameras.txt").write_text("\n".join([*cams[:2], "1 PINHOLE 640 480 800 x 320 240"]))
    with pytest.raises(FormatError, match=r"cameras\.txt:3: PARAMS: expected numbers"):
        read_colmap(text)
    binary = _copy(models["binary"], tmp_path / "b")
    data = (binary / "images.bin").read_bytes()
    (binary / "images.bin").write_bytes(data[:100])
    with pytest.raises(FormatError, match=r"images\.bin: .*truncated at byte|images\.bin: byte"):
        read_colmap(binary)
    (binary / "images.bin").write_bytes(struct.pack("<Q", 10**15) + data[8:])
    with pytest.raises(FormatError, match=r"images\.bin: byte 0: number of images .* exceeds"):
        read_colmap(binary)
    with pytest.raises(FormatError, match=r"no cameras\.bin or cameras\.txt"):
        read_colmap(tmp_path)


def test_from_colmap_refuses_without_writing(models: dict[str, Path], tmp_path: Path) -> None:
    out = tmp_path / "out"
    argv = ["scene", "from-colmap", str(models["text"]), "--images", str(tmp_path), "-o", str(out)]
    assert main(argv) == 2  # the images are not there
    assert not out.exists()
    argv[4] = str(models["text-images"])
    assert main([*argv, "--known-distance", "v00_left.png", "nope.png", "1"]) == 2
    assert main([*argv, "--known-distance", "v00_left.png", "v01_left.png", "-1"]) == 2
    assert not out.exists()
    # the output inside the input: refused
    argv[-1] = str(models["text-images"] / "scene")
    assert main(argv) == 2


# Margins of the round trip against the native reconstruction (the demo's): measured with
# benchmarks/colmap_roundtrip.py, the known pose of view 01 moves the result by well under these
NORMAL_MARGIN_DEG = 0.25
VERTEX_MARGIN_REL = 0.005


def test_from_colmap_scene_reconstructs_as_well_as_the_native_one(
    demo_run: Any, models: dict[str, Path], tmp_path: Path
) -> None:
    from aida_kb.interpret.evaluate import evaluate
    from aida_kb.interpret.pipeline import reconstruct_scene
    from aida_kb.interpret.result import read_interpretation
    from aida_kb.kb import compile_path

    native_dir = demo_run.root / "scene"
    native = read_scene(native_dir)
    assert native.truth is not None
    out = tmp_path / "sfm"
    argv = ["scene", "from-colmap", str(models["binary"]), "--images"]
    argv += [str(models["binary-images"]), "-o", str(out), "--known-distance"]
    argv += ["v00_left.png", "v00_right.png", str(native.calib.baseline_m)]
    assert main(argv) == 0
    # a COLMAP model carries no labels: the native scene's are added back, so that only what
    # from-colmap changes (rigs, poses, scale, files) differs from the native run
    index = yaml.safe_load((out / "scene.yaml").read_text())
    for view, theirs in zip(index["views"], native.views, strict=True):
        assert theirs.labels is not None
        shutil.copy(theirs.labels, out / "views" / view["id"] / "labels.png")
        view["labels"] = f"views/{view['id']}/labels.png"
    (out / "scene.yaml").write_text(yaml.safe_dump(index, sort_keys=False))
    kb = compile_path(Path(__file__).resolve().parents[2] / "kb" / "buildings.kb").kb
    assert kb is not None
    mine = evaluate(reconstruct_scene(kb, out, tmp_path / "model").interpretation, native.truth)
    theirs = evaluate(
        read_interpretation(demo_run.root / "model" / "interpretation.json"), native.truth
    )
    # the same verdict (the demo's second camera is fixed by its adjustment to about 0.1
    # degree: verified or doubtful by a hair, alike in both)
    assert mine.outcome == theirs.outcome != "nothing"
    assert mine.comparison is not None
    assert theirs.comparison is not None
    a, b = mine.comparison, theirs.comparison
    assert a.max_normal_error_deg <= b.max_normal_error_deg + NORMAL_MARGIN_DEG
    assert a.max_vertex_error_rel <= b.max_vertex_error_rel + VERTEX_MARGIN_REL
    cam = next(e for e in mine.cameras if e.view == "01")
    assert cam.angle_deg < 0.5
