"""No command writes an output over one of its inputs: refused before any work, one line, exit 2.

Every case of issue 16 that overwrote an input and exited 0. The inputs are compared by
content afterwards: nothing was touched.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest

from aida_kb.cli.main import main
from aida_kb.io.scene import StereoCalib, ViewData, write_scene

ROOT = Path(__file__).resolve().parents[2]
KB = ROOT / "kb" / "buildings.kb"


def _scene(tmp_path: Path, calib_name: str = "calib.yaml") -> Path:
    K = np.array([[60.0, 0.0, 31.5], [0.0, 60.0, 23.5], [0.0, 0.0, 1.0]])
    calib = StereoCalib(K, np.zeros(5), K, np.zeros(5), np.eye(3), np.array([-0.3, 0, 0]), (64, 48))
    rng = np.random.default_rng(0)
    img = rng.integers(0, 255, (48, 64, 3), dtype=np.uint8)
    scene = write_scene(tmp_path / "scene", calib, [ViewData(img, img.copy())])
    if calib_name != "calib.yaml":
        (scene / "calib.yaml").rename(scene / calib_name)
        index = scene / "scene.yaml"
        index.write_text(index.read_text().replace("calib.yaml", calib_name))
    return scene


def _snapshot(paths: list[Path]) -> dict[Path, bytes]:
    return {p: p.read_bytes() for p in paths}


def _refused(argv: list[str], capsys: pytest.CaptureFixture[str], needle: str) -> None:
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 2, err
    errors = [line for line in err.splitlines() if line.startswith("aida-kb: error:")]
    assert len(errors) == 1, err
    assert needle in errors[0]
    assert "Traceback" not in err


def test_evidence_over_the_calibration(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    scene = _scene(tmp_path)
    before = _snapshot([scene / "calib.yaml", scene / "scene.yaml"])
    argv = ["evidence", str(scene), "-o", str(scene / "calib.yaml"), "--quiet"]
    _refused(argv, capsys, "cannot write the output over the input file")
    assert _snapshot(list(before)) == before


def test_evidence_through_a_symlink_onto_an_image(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scene = _scene(tmp_path)
    left = next(scene.rglob("left.png"))
    link = tmp_path / "ev.json"
    link.symlink_to(left)
    before = _snapshot([left])
    _refused(["evidence", str(scene), "-o", str(link), "--quiet"], capsys, "over the input")
    assert _snapshot([left]) == before


@pytest.mark.parametrize("command", ["compile", "graph"])
def test_compile_and_graph_over_their_kb(
    command: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    kb = tmp_path / "b.kb"
    shutil.copy(KB, kb)
    before = kb.read_bytes()
    _refused([command, str(kb), "-o", str(kb)], capsys, "over the input file")
    assert kb.read_bytes() == before


def test_compile_over_an_imported_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "base.kb").write_text("layers scene > world\nconcept Thing in world {}\n")
    main_kb = tmp_path / "main.kb"
    main_kb.write_text('import "base.kb"\nconcept Other in world is-a Thing {}\n')
    before = (tmp_path / "base.kb").read_bytes()
    _refused(["compile", str(main_kb), "-o", str(tmp_path / "base.kb")], capsys, "base.kb")
    assert (tmp_path / "base.kb").read_bytes() == before


def test_calibrate_over_an_input_image(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    board = tmp_path / "board"
    board.mkdir()
    img = np.zeros((48, 64), np.uint8)
    for name in ("left_01.png", "right_01.png"):
        cv2.imwrite(str(board / name), img)
    before = _snapshot([board / "left_01.png"])
    argv = ["calibrate", str(board), "-o", str(board / "left_01.png")]
    _refused(argv, capsys, "over the input file")
    assert _snapshot([board / "left_01.png"]) == before


def test_reconstruct_into_the_scene(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    scene = _scene(tmp_path, calib_name="evidence.json")
    before = _snapshot(sorted(p for p in scene.rglob("*") if p.is_file()))
    argv = ["reconstruct", str(KB), str(scene), "-o", str(scene), "--quiet"]
    _refused(argv, capsys, "cannot write the outputs there")
    assert _snapshot(list(before)) == before


def test_disparity_and_certainty_into_one_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    img = np.zeros((48, 64), np.uint8)
    left, right = tmp_path / "l.png", tmp_path / "r.png"
    cv2.imwrite(str(left), img)
    cv2.imwrite(str(right), img)
    out = tmp_path / "d.npy"
    argv = ["disparity", str(left), str(right), "-o", str(out), "--certainty", str(out)]
    _refused(argv, capsys, "named twice as an output")
    assert not out.exists()


def test_disparity_over_its_left_image_via_a_hard_link(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    img = np.zeros((48, 64), np.uint8)
    left, right = tmp_path / "l.png", tmp_path / "r.png"
    cv2.imwrite(str(left), img)
    cv2.imwrite(str(right), img)
    alias = tmp_path / "alias.npy"
    alias.hardlink_to(left)
    before = left.read_bytes()
    _refused(["disparity", str(left), str(right), "-o", str(alias)], capsys, "over the input")
    assert left.read_bytes() == before


def test_reconstruct_while_another_run_writes_there(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from aida_kb.io.atomic import output_lock

    scene = _scene(tmp_path)
    out = tmp_path / "model"
    with output_lock(out):
        argv = ["reconstruct", str(KB), str(scene), "-o", str(out), "--quiet"]
        _refused(argv, capsys, "another run is writing its outputs there")
    assert not any(out.iterdir())


def test_reconstruct_into_a_folder_of_other_files(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scene = _scene(tmp_path)
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("keep me")
    argv = ["reconstruct", str(KB), str(scene), "-o", str(out), "--quiet"]
    _refused(argv, capsys, "not an output folder of this command")
    assert (out / "notes.txt").read_text() == "keep me"
