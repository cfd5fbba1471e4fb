"""`aida-kb reconstruct`: wrong options and outputs are refused before any vision work."""

from __future__ import annotations

from pathlib import Path

import pytest

from aida_kb.cli.main import main

ROOT = Path(__file__).resolve().parents[2]
KB = str(ROOT / "kb" / "buildings.kb")


def _one_error_line(capsys: pytest.CaptureFixture[str]) -> str:
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1, captured.err
    return lines[0]


def test_output_that_is_an_existing_file_is_refused_at_once(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    afile = tmp_path / "afile"
    afile.write_text("x")
    # the scene does not exist: the output is checked before the scene is read
    code = main(["reconstruct", KB, str(tmp_path / "no-scene"), "-o", str(afile), "--quiet"])
    line = _one_error_line(capsys)
    assert code == 2
    assert line == (
        f"aida-kb: error: {afile}: cannot create the output directory: "
        f"{afile} is a file, not a directory"
    )
    assert afile.read_text() == "x"


@pytest.mark.parametrize("views", ["00,00", "00,", ","])
def test_repeated_or_empty_view_ids_are_refused_first(
    views: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    code = main(["reconstruct", KB, str(tmp_path / "no-scene"), "-o", str(out), "--views", views])
    line = _one_error_line(capsys)
    assert code == 1
    assert line == f"aida-kb: error: --views {views!r}: expected distinct comma-separated view ids"
    assert not out.exists()


def test_a_world_layer_goal_is_refused_before_the_vision_stage(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code = main(
        ["reconstruct", KB, str(tmp_path / "no-scene"), "-o", str(tmp_path / "o"), "--goal", "Roof"]
    )
    line = _one_error_line(capsys)
    assert code == 1
    assert "goal 'Roof' is a concept of the world layer" in line


@pytest.mark.parametrize("command", ["reconstruct", "evidence", "register"])
@pytest.mark.parametrize("value", ["2", "300"])
def test_max_disp_out_of_range_is_refused_before_any_work(
    command: str, value: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    scene = tmp_path / "no-scene"
    argv = {
        "reconstruct": ["reconstruct", KB, str(scene), "-o", str(out)],
        "evidence": ["evidence", str(scene), "-o", str(out)],
        "register": ["register", str(scene / "model.json"), str(scene), "--view", "01"],
    }[command]
    code = main(
        [*argv, "--max-disp", value, "--quiet"]
        if command != "register"
        else [*argv, "--max-disp", value]
    )
    line = _one_error_line(capsys)
    assert code == 1
    assert line == f"aida-kb: error: --max-disp {value}: must lie within 3..256"
    assert not out.exists()
