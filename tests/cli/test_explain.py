"""`aida-kb explain CODE`."""

from __future__ import annotations

import pytest

from aida_kb.cli.main import main


def test_explain_prints_the_explanation_with_examples(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["explain", "kb3"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("# KB003: unknown unit\n")
    assert "## Bad" in out
    assert "## Fixed" in out
    assert "85 dg" in out


def test_unknown_code_is_a_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["explain", "KB777"]) == 2
    err = capsys.readouterr().err
    assert "unknown diagnostic code 'KB777'" in err
    assert "aida-kb explain --list" in err


def test_list_shows_every_code(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["explain", "--list"]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[0].startswith("KB001  error")


def test_no_code_is_a_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["explain"]) == 2
    assert "give a CODE" in capsys.readouterr().err


def test_on_a_terminal_the_markdown_is_formatted(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["explain", "KB003", "--color", "always"]) == 0
    out = capsys.readouterr().out
    assert "\x1b[" in out
    assert "KB003: unknown unit" in out
    assert "# KB003" not in out  # the heading is formatted, not shown as Markdown
    assert "85 dg" in out
