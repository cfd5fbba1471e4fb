"""`aida-kb fmt`: --check, rewriting in place, files with syntax errors left alone."""

from __future__ import annotations

from pathlib import Path

import pytest

from aida_kb.cli.main import main

ROOT = Path(__file__).resolve().parents[2]
UGLY = "layers a>b\nconcept X in a{part p:X // trailing\n}\n"
PRETTY = "layers a > b\n\nconcept X in a {\n    part p: X  // trailing\n}\n"


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def test_the_kb_tree_is_formatted(capsys: pytest.CaptureFixture[str]) -> None:
    """Every file below kb/ is in the canonical layout; the two with syntax errors on purpose
    (kb/examples/broken_syntax*.kb, golden tests of the parser's recovery) are left out by the
    project file kb/aida-kb.toml, and refused when named."""
    every = sorted((ROOT / "kb").rglob("*.kb"))
    code, out, err = _run(["fmt", "--check", str(ROOT / "kb")], capsys)
    summary = f"0 file(s) would be reformatted, {len(every) - 2} left unchanged\n"
    assert out == summary, f"run: aida-kb fmt kb/\n{out}{err}"
    assert (code, err) == (0, "")
    broken = ROOT / "kb" / "examples" / "broken_syntax.kb"
    code, out, err = _run(["fmt", "--check", str(broken)], capsys)
    assert code == 1
    assert "examples/broken_syntax.kb:6:10: not formatted: KB001" in err


def test_check_lists_the_files_and_writes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "sub").mkdir()
    ugly, pretty = tmp_path / "sub" / "ugly.kb", tmp_path / "pretty.kb"
    ugly.write_text(UGLY, encoding="utf-8")
    pretty.write_text(PRETTY, encoding="utf-8")
    code, out, _ = _run(["fmt", "--check", str(tmp_path)], capsys)
    assert code == 1
    assert out.splitlines() == [
        f"would reformat {ugly}",
        "1 file(s) would be reformatted, 1 left unchanged",
    ]
    assert ugly.read_text(encoding="utf-8") == UGLY


def test_fmt_rewrites_then_check_passes(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    ugly = tmp_path / "ugly.kb"
    ugly.write_text(UGLY, encoding="utf-8")
    code, out, _ = _run(["fmt", str(ugly)], capsys)
    assert (code, out) == (0, f"reformatted {ugly}\n1 file(s) reformatted, 0 left unchanged\n")
    assert ugly.read_text(encoding="utf-8") == PRETTY
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ugly.kb"], "no temporary file left"
    code, out, _ = _run(["fmt", "--check", str(ugly)], capsys)
    assert (code, out) == (0, "0 file(s) would be reformatted, 1 left unchanged\n")


def test_file_with_a_syntax_error_is_left_untouched(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    broken, ugly = tmp_path / "broken.kb", tmp_path / "ugly.kb"
    source = "layers a\nconcept X in a{ part : X }\n"
    broken.write_text(source, encoding="utf-8")
    ugly.write_text(UGLY, encoding="utf-8")
    code, out, err = _run(["fmt", str(broken), str(ugly)], capsys)
    assert code == 1
    assert out.endswith("1 file(s) reformatted, 0 left unchanged\n")
    assert broken.read_text(encoding="utf-8") == source
    assert ugly.read_text(encoding="utf-8") == PRETTY, "the other files are still formatted"
    errors = [line for line in err.splitlines() if "error" in line]
    assert errors == [
        f"aida-kb: error: {broken}:2:22: not formatted: KB001 expected a role name after "
        "'part', found ':'"
    ]
    assert "Traceback" not in err


def test_missing_path_is_a_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = _run(["fmt", "--check", "does/not/exist.kb"], capsys)
    assert code == 2
    assert "does/not/exist.kb: no such file or directory" in err
