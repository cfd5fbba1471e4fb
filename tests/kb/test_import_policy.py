"""Imports stay inside the project (KB903): the foreign file is neither read nor echoed."""

from __future__ import annotations

from pathlib import Path

import pytest

from aida_kb.cli.main import main
from aida_kb.kb import compile_path

LIB = "concept T in world {}\n"


def _project(tmp_path: Path, *imports: str) -> Path:
    (tmp_path / "proj").mkdir()
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "lib.kb").write_text(LIB)
    (tmp_path / "secret.txt").write_text("SECRET=hunter2\n")
    (tmp_path / "proj" / "link.kb").symlink_to(tmp_path / "secret.txt")
    root = tmp_path / "proj" / "main.kb"
    root.write_text("".join(f'import "{i}"\n' for i in imports) + "layers scene > world\n")
    return root


@pytest.mark.parametrize(
    "target",
    ["/etc/passwd", "/proc/self/environ", "../other/lib.kb", "link.kb", "../secret.txt"],
)
def test_import_outside_the_project_is_refused_unread(
    tmp_path: Path, target: str, capsys: pytest.CaptureFixture[str]
) -> None:
    root = _project(tmp_path, target)
    result = compile_path(root)
    assert [d.code for d in result.diagnostics if d.is_error] == ["KB903"]
    assert list(result.sources) == [str(root)]  # nothing else was read
    assert main(["lint", str(root)]) == 1
    out = capsys.readouterr()
    text = out.out + out.err
    assert "SECRET" not in text
    assert "root:" not in text


def test_import_path_widens_the_project(tmp_path: Path) -> None:
    root = _project(tmp_path, "lib.kb")
    assert [d.code for d in compile_path(root).diagnostics if d.is_error] == ["KB901"]
    widened = compile_path(root, search_paths=[str(tmp_path / "other")])
    assert widened.ok, widened.diagnostics
    assert main(["validate", str(root), "--import-path", str(tmp_path / "other")]) == 0


def test_imports_inside_the_project_still_work(tmp_path: Path) -> None:
    root = _project(tmp_path, "sub/lib.kb")
    (root.parent / "sub").mkdir()
    (root.parent / "sub" / "lib.kb").write_text(LIB)
    assert compile_path(root).ok
