"""The pre-commit hooks (.pre-commit-hooks.yaml): each hook's entry, run on every .kb file of
the repository as pre-commit would name them, passes; on a broken file it fails."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest
import yaml

from aida_kb.cli.main import main

ROOT = Path(__file__).resolve().parents[2]
HOOKS = yaml.safe_load((ROOT / ".pre-commit-hooks.yaml").read_text(encoding="utf-8"))


def _argv(hook: dict[str, str]) -> list[str]:
    entry = shlex.split(hook["entry"])
    assert entry[0] == "aida-kb"
    return entry[1:]


def test_there_is_a_validate_and_a_fmt_hook() -> None:
    assert {h["id"] for h in HOOKS} == {"aida-kb-validate", "aida-kb-fmt"}
    for hook in HOOKS:
        assert hook["language"] == "python"
        assert re.search(hook["files"], "kb/buildings.kb")
        assert not re.search(hook["files"], "README.md")


@pytest.mark.parametrize("hook", HOOKS, ids=lambda h: h["id"])
def test_every_kb_file_of_the_repository_passes(
    hook: dict[str, str], capsys: pytest.CaptureFixture[str]
) -> None:
    """The golden files broken on purpose are named too: kb/aida-kb.toml leaves them out."""
    files = sorted(str(p) for p in (ROOT / "kb").rglob("*.kb") if re.search(hook["files"], str(p)))
    assert any("broken_syntax" in f for f in files)
    assert main([*_argv(hook), *files]) == 0, capsys.readouterr()


@pytest.mark.parametrize("hook", HOOKS, ids=lambda h: h["id"])
def test_a_broken_file_fails(hook: dict[str, str], tmp_path: Path) -> None:
    bad = tmp_path / "bad.kb"
    bad.write_text("layers scene > world\nconcept A in scene {\n    part x Wall\n}\n")
    assert main([*_argv(hook), str(bad)]) == 1
