"""`aida-kb calibrate` refuses impossible options before looking at any image."""

from __future__ import annotations

from pathlib import Path

import pytest

from aida_kb.cli.main import main


@pytest.mark.parametrize(
    ("option", "value", "message"),
    [
        ("--square", "nan", "positive side length"),
        ("--square", "0", "positive side length"),
        ("--square", "-0.06", "positive side length"),
        ("--pattern", "1x6", "at least 2x2"),
        ("--pattern", "9x6x2", "COLSxROWS"),
    ],
)
def test_bad_option_is_an_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], option: str, value: str, message: str
) -> None:
    out = tmp_path / "calib.yaml"
    assert main(["calibrate", str(tmp_path), "-o", str(out), option, value]) == 1
    err = capsys.readouterr().err
    assert message in err
    assert err.count("\n") == 1
    assert not out.exists()


def test_output_onto_a_directory_is_refused_first(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "out").mkdir()
    assert main(["calibrate", str(tmp_path), "-o", str(tmp_path / "out")]) == 2
    assert "it is a directory" in capsys.readouterr().err
