"""`aida-kb lint` and `aida-kb validate`: output formats, exit codes, file collection."""

from __future__ import annotations

import contextlib
import io
import json
import tempfile
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from aida_kb.cli.main import main

ROOT = Path(__file__).resolve().parents[2]
BROKEN = ROOT / "kb" / "examples" / "broken_syntax.kb"
BUILDINGS = ROOT / "kb" / "buildings.kb"
SPAN_KEYS = {"file", "line", "column", "end_line", "end_column"}
KEYS = {"code", "severity", "message", "hint", "related", *SPAN_KEYS}


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main(argv)
    captured = capsys.readouterr()
    return code, captured.out, captured.err


@pytest.mark.parametrize("command", ["lint", "validate"])
def test_clean_file_exits_zero(command: str, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = _run([command, str(BUILDINGS)], capsys)
    assert code == 0
    assert "no problems in 1 file" in out
    assert err == ""


@pytest.mark.parametrize("command", ["lint", "validate"])
def test_broken_file_text_has_location_source_line_and_caret(
    command: str, capsys: pytest.CaptureFixture[str]
) -> None:
    code, out, _ = _run([command, "--color", "never", str(BROKEN)], capsys)
    assert code == 1
    lines = out.splitlines()
    head = next(i for i, line in enumerate(lines) if ":6:10: error[KB001]:" in line)
    assert "expected a role name after 'part'" in lines[head]
    assert lines[head + 2].startswith("6 |     part : HouseBody")
    assert lines[head + 3] == "  |          ^"
    assert "\x1b[" not in out
    if command == "lint":  # the compiler's warnings about what the broken declarations left
        assert "5 errors, 4 warnings in 1 file" in out
        assert "warning[KB301]" in out
    else:
        assert "5 errors in 1 file" in out
        assert "warning[" not in out


def test_json_is_one_array_with_exactly_the_contract_keys(
    capsys: pytest.CaptureFixture[str],
) -> None:
    code, out, _ = _run(["lint", "--format", "json", str(BROKEN)], capsys)
    assert code == 1
    data = json.loads(out)
    assert isinstance(data, list)
    assert [d["severity"] for d in data].count("error") == 5
    assert {d["severity"] for d in data} == {"error", "warning"}
    for item in data:
        assert set(item) == KEYS
        assert item["file"].endswith("broken_syntax.kb")
    first = data[0]
    assert (first["code"], first["line"], first["column"]) == ("KB001", 6, 10)
    assert (first["end_line"], first["end_column"]) == (6, 11)


def test_clean_json_is_an_empty_array(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = _run(["validate", "--format", "json", str(BUILDINGS)], capsys)
    assert code == 0
    assert json.loads(out) == []


def test_the_shipped_kb_project_is_clean(capsys: pytest.CaptureFixture[str]) -> None:
    """kb/aida-kb.toml leaves the golden files (broken on purpose) out of a walk of kb/."""
    code, out, _ = _run(["lint", "--format", "json", str(ROOT / "kb")], capsys)
    assert code == 0
    assert [d for d in json.loads(out) if d["severity"] == "error"] == []


def test_a_named_excluded_directory_is_linted(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = _run(["lint", "--format", "json", str(ROOT / "kb" / "examples")], capsys)
    assert code == 1
    files = {Path(d["file"]).name for d in json.loads(out)}
    assert {"broken_syntax.kb", "broken_names.kb", "cycle_b.kb"} <= files


def test_json_carries_hints_and_related_places(capsys: pytest.CaptureFixture[str]) -> None:
    names = ROOT / "kb" / "examples" / "broken_names.kb"
    code, out, _ = _run(["lint", "--format", "json", str(names)], capsys)
    assert code == 1
    data = json.loads(out)
    twice = next(d for d in data if d["code"] == "KB110")
    assert twice["hint"] == "rename one of them or delete the repetition"
    [first] = twice["related"]
    assert set(first) == {*SPAN_KEYS, "message"}
    assert first["message"] == "first defined here"
    assert first["line"] < twice["line"]


def test_missing_file_is_a_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = _run(["lint", "does/not/exist.kb"], capsys)
    assert code == 2
    assert "does/not/exist.kb: no such file or directory" in err
    assert "Traceback" not in err


def test_non_utf8_file_is_a_usage_error(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "latin1.kb"
    bad.write_bytes("// caf\xe9\n".encode("latin-1"))
    code, _, err = _run(["validate", str(bad)], capsys)
    assert code == 2
    assert "latin1.kb: not UTF-8" in err


_TEXT = BUILDINGS.read_text(encoding="utf-8")


@settings(max_examples=40, derandomize=True, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.integers(0, len(_TEXT)),
            st.integers(0, 12),
            st.sampled_from(
                ["", "}", "{", "(", '"', "/*", "part", "concept", ":", "\t", "家", "9"]
            ),
        ),
        min_size=1,
        max_size=4,
    )
)
def test_mutated_buildings_give_diagnostics_never_a_traceback(
    edits: list[tuple[int, int, str]],
) -> None:
    text = _TEXT
    for at, cut, insert in edits:
        at = min(at, len(text))
        text = text[:at] + insert + text[at + cut :]
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "mutant.kb"
        path.write_text(text, encoding="utf-8")
        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = main(["lint", "--format", "json", str(path)])
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
            text_code = main(["lint", str(path)])
    assert code == text_code
    assert code in (0, 1)
    assert "Traceback" not in err.getvalue()
    assert "internal error" not in err.getvalue()
    data = json.loads(out.getvalue())
    assert (code == 1) == any(d["severity"] == "error" for d in data)


WARN_ONLY = """layers scene > world > image
template unused(a: Plane, b: Plane) { parallel(a, b) }
concept House in scene { con-of body: Body }
concept Plane in world { con-of region: Region [0..1] }
concept Body in world { part front: Plane }
concept Region in image { measure position(self) +- 1 px }
"""


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (["lint"], 0),
        (["lint", "--strict"], 1),
        (["validate"], 0),
        (["validate", "--strict"], 1),
    ],
)
def test_warnings_fail_only_with_strict(
    argv: list[str], expected: int, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "warn.kb"
    path.write_text(WARN_ONLY, encoding="utf-8")
    code, out, _ = _run([*argv, "--format", "json", str(path)], capsys)
    assert code == expected
    data = json.loads(out)
    assert {d["code"] for d in data} == ({"KB300"} if argv != ["validate"] else set())


def test_semantic_errors_show_related_notes_and_imports_are_followed(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "lib.kb").write_text(
        "concept A is-a B { }\nconcept B is-a A { }\n", encoding="utf-8"
    )
    root = tmp_path / "root.kb"
    root.write_text('import "lib.kb"\nimport "gone.kb"\nlayers scene > world\n', encoding="utf-8")
    code, out, _ = _run(["validate", "--color", "never", str(root)], capsys)
    assert code == 1  # a missing import is an error in the knowledge base, not a usage error
    assert "error[KB901]: imported file 'gone.kb' does not exist" in out
    assert "error[KB120]: is-a cycle: " in out
    assert "lib.kb:1:16: note: A is-a B" in out
    assert "1 | concept A is-a B { }" in out


def test_a_file_imported_by_two_linted_files_reports_once(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "lib.kb").write_text("concept A in nowhere { }\n", encoding="utf-8")
    for name in ("a.kb", "b.kb"):
        (tmp_path / name).write_text('import "lib.kb"\nlayers scene\n', encoding="utf-8")
    code, out, _ = _run(["validate", "--format", "json", str(tmp_path)], capsys)
    assert code == 1
    data = json.loads(out)
    unknown = [d for d in data if d["code"] == "KB101"]
    assert len(unknown) == 1
    assert unknown[0]["file"].endswith("lib.kb")


def test_a_symlink_loop_is_reported_not_a_crash(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "good.kb").write_text(BUILDINGS.read_text(encoding="utf-8"), encoding="utf-8")
    (tmp_path / "loop.kb").symlink_to(tmp_path / "loop.kb")
    code, out, err = _run(["lint", str(tmp_path)], capsys)
    assert code == 2
    assert "loop.kb: cannot read" in err
    assert "internal error" not in err
    assert "no problems in 1 file" in out
