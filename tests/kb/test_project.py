"""Projects of .kb files (docs/language.md §2.3): roots and libraries, the "imported from"
chain, a root that is also imported, and the project file's exclusions."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from aida_kb.cli.main import main
from aida_kb.kb import compile_path
from aida_kb.kb.project import find_project

LIBRARY = """\
concept Roof in world {
    part face: Plane
}
"""
ROOT_FILE = """\
import "lib/roofs.kb"
layers scene > world > image

concept House in scene {
    con-of body: Body
}

concept Body in world {
    part roof: Roof
}

concept Plane in world {}
"""


def _project(tmp: Path) -> Path:
    (tmp / "lib").mkdir()
    (tmp / "lib" / "roofs.kb").write_text(LIBRARY, encoding="utf-8")
    (tmp / "house.kb").write_text(ROOT_FILE, encoding="utf-8")
    return tmp


Found = list[dict[str, object]]


def _lint(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, Found]:
    code = main(["lint", "--format", "json", *argv])
    out = capsys.readouterr().out
    return code, json.loads(out)


def test_a_library_uses_names_of_its_root_and_lints_in_its_context(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """roofs.kb names Plane, which only the root that imports it defines: linted on its own it
    would be an unknown concept; in the project it is checked as its root sees it."""
    _project(tmp_path)
    code, found = _lint([str(tmp_path)], capsys)
    assert [d for d in found if d["severity"] == "error"] == []
    assert code == 0
    # named alone, without a project file its project is its own folder: Plane is unknown
    code, found = _lint([str(tmp_path / "lib" / "roofs.kb")], capsys)
    assert (code, [(d["code"], d["line"]) for d in found]) == (1, [("KB100", 2)])
    # an (empty) project file above marks the project: checked in its root's context
    (tmp_path / "aida-kb.toml").write_text("", encoding="utf-8")
    code, found = _lint([str(tmp_path / "lib" / "roofs.kb")], capsys)
    assert (code, [d for d in found if d["severity"] == "error"]) == (0, [])


def test_a_library_nobody_imports_is_checked_without_layers(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    lib = tmp_path / "alone.kb"
    lib.write_text("concept Roof in world {\n    part face: Plane\n}\n", encoding="utf-8")
    code, found = _lint([str(lib)], capsys)
    assert code == 1
    assert [(d["code"], d["line"]) for d in found] == [("KB100", 2)]  # no KB112: a library
    result = compile_path(lib)  # compiled as a root (compile, interpret), layers are required
    assert "KB112" in {d.code for d in result.diagnostics}


def test_an_error_in_an_imported_file_carries_the_import_chain(tmp_path: Path) -> None:
    _project(tmp_path)
    (tmp_path / "lib" / "roofs.kb").write_text(LIBRARY.replace("Plane", "Plan"), encoding="utf-8")
    (tmp_path / "site.kb").write_text(
        'import "house.kb"\nlayers scene > world > image\n', encoding="utf-8"
    )
    result = compile_path(tmp_path / "site.kb")
    [error] = result.errors
    assert (Path(error.span.file).name, error.code, error.span.line) == ("roofs.kb", "KB100", 2)
    notes = [(Path(span.file).name, span.line, text) for span, text in error.related]
    assert [n[:2] for n in notes] == [("house.kb", 1), ("site.kb", 1)]
    assert notes[0][2].endswith("roofs.kb imported from " + str(tmp_path / "house.kb") + ":1")
    assert notes[1][2].endswith("house.kb imported from " + str(tmp_path / "site.kb") + ":1")


def test_an_imported_root_may_repeat_the_same_layers(tmp_path: Path) -> None:
    _project(tmp_path)
    (tmp_path / "site.kb").write_text(
        'import "house.kb"\nlayers scene > world > image\n', encoding="utf-8"
    )
    assert compile_path(tmp_path / "site.kb").ok
    (tmp_path / "site.kb").write_text('import "house.kb"\nlayers scene > world\n', encoding="utf-8")
    bad = [d for d in compile_path(tmp_path / "site.kb").errors if d.code == "KB112"]
    assert [d.message for d in bad] == ["a second, different layers declaration"]


def test_importing_a_folder_says_so(tmp_path: Path) -> None:
    _project(tmp_path)
    (tmp_path / "site.kb").write_text(
        'import "lib"\nlayers scene > world > image\n', encoding="utf-8"
    )
    [error] = compile_path(tmp_path / "site.kb").errors
    assert error.code == "KB901"
    assert error.message == "imported 'lib' is a folder, not a .kb file"


def test_the_project_file_excludes_per_command(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    _project(tmp_path)
    (tmp_path / "golden").mkdir()
    (tmp_path / "golden" / "bad.kb").write_text("concept {\n", encoding="utf-8")
    (tmp_path / "aida-kb.toml").write_text(
        '[lint]\nexclude = ["golden"]\n[fmt]\nexclude = ["golden/*.kb"]\n', encoding="utf-8"
    )
    project = find_project(tmp_path / "lib")
    assert project.file == tmp_path / "aida-kb.toml"
    assert project.excluded(tmp_path / "golden" / "bad.kb", "validate")
    assert not project.excluded(tmp_path / "house.kb", "lint")
    code, found = _lint([str(tmp_path)], capsys)
    assert (code, [d for d in found if d["severity"] == "error"]) == (0, [])
    assert main(["fmt", "--check", str(tmp_path)]) == 0  # bad.kb has syntax errors: left out
    assert "bad.kb" not in capsys.readouterr().err
    code, found = _lint([str(tmp_path / "golden")], capsys)  # named: linted
    assert code == 1
    assert {Path(str(d["file"])).name for d in found} == {"bad.kb"}


def test_a_wrong_project_file_is_a_usage_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    _project(tmp_path)
    (tmp_path / "aida-kb.toml").write_text('[lint]\nexclude = "golden"\n', encoding="utf-8")
    assert main(["lint", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "aida-kb.toml: [lint] exclude must be a list of paths" in err
    assert "Traceback" not in err
