"""`aida-kb demo`: lints the shipped knowledge and prints its net as a tree."""

from __future__ import annotations

from pathlib import Path

import pytest

from aida_kb.cli import _kbfiles
from aida_kb.cli._kbfiles import packaged_kb
from aida_kb.cli.main import main
from aida_kb.errors import FormatError

ROOT = Path(__file__).resolve().parents[2]


def test_packaged_kb_finds_the_source_checkout() -> None:
    path = packaged_kb("buildings.kb")
    assert path.is_file()
    assert path.read_text(encoding="utf-8") == (ROOT / "kb" / "buildings.kb").read_text(
        encoding="utf-8"
    )


def test_demo_prints_the_net_from_house_down_to_the_image_layer(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["demo"]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    house = next(i for i, line in enumerate(lines) if "House" in line and "(scene)" in line)
    body = next(i for i, line in enumerate(lines) if "con-of body: HouseBody" in line)
    walls = next(i for i, line in enumerate(lines) if "part front, back, left, right: Wall" in line)
    region = next(i for i, line in enumerate(lines) if "con-of region: Region" in line)
    assert house < body < walls < region
    assert "(image)" in lines[region]
    assert "[0..*]" in out  # cardinalities are shown
    assert "is-a alternatives of" in out
    assert "no problems in 1 file" in out
    assert "interpret" in out  # says what the later pipeline will do


def test_demo_on_a_broken_kb_fails_with_diagnostics(capsys: pytest.CaptureFixture[str]) -> None:
    broken = ROOT / "kb" / "examples" / "broken_syntax.kb"
    assert main(["demo", "--kb", str(broken)]) == 1
    out = capsys.readouterr().out
    assert "error[KB001]" in out
    assert "no net to show" in out


def test_packaged_kb_prefers_the_installed_wheel_data(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # An installed wheel has kb/ force-included as aida_kb/_data/kb (pyproject.toml).
    data = tmp_path / "_data" / "kb"
    data.mkdir(parents=True)
    (data / "buildings.kb").write_text("layers scene\n", encoding="utf-8")
    monkeypatch.setattr(_kbfiles.resources, "files", lambda package: tmp_path)
    assert packaged_kb("buildings.kb") == data / "buildings.kb"
    with pytest.raises(FormatError, match="missing from this installation"):
        packaged_kb("nothing-like-this.kb")
