"""editors/: the TextMate grammar's keywords are the Lark grammar's; the VS Code manifest
starts the server and points at files that exist."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path
from typing import Any

from aida_kb.dsl import ast, grammar_path
from aida_kb.lsp.complete import (
    DECLARATION_KEYWORDS,
    MEMBER_KEYWORDS,
    NEXT_KEYWORDS,
    QUALIFIER_KEYWORDS,
)

ROOT = Path(__file__).resolve().parents[2]
VSCODE = ROOT / "editors" / "vscode"
TM = VSCODE / "syntaxes" / "aida-kb.tmLanguage.json"


def lark_keywords() -> set[str]:
    """The words the Lark grammar writes as literals: its keywords."""
    text = grammar_path().read_text(encoding="utf-8")
    code = "\n".join(line.split("//", 1)[0] for line in text.splitlines())
    return set(re.findall(r'"([a-z][a-z-]*)"', code))


def alternatives(pattern: str) -> set[str]:
    """The words of a pattern's ``(?:a|b|c)`` group."""
    group = re.search(r"\(\?:([a-z|-]+)\)", pattern)
    assert group is not None, pattern
    return set(group.group(1).split("|"))


def grammar() -> dict[str, Any]:
    loaded: dict[str, Any] = json.loads(TM.read_text(encoding="utf-8"))
    return loaded


def test_textmate_keywords_are_the_lark_grammars() -> None:
    repo = grammar()["repository"]
    words = set()
    for p in repo["keywords"]["patterns"]:
        words |= alternatives(p["match"])
    words |= alternatives(repo["directions"]["match"])
    assert words == lark_keywords()
    assert set(ast.DIRECTIONS) == alternatives(repo["directions"]["match"])
    units = re.search(r"\\b\(([a-z|]+)\)\\b", repo["quantities"]["match"])
    assert units is not None
    assert tuple(units.group(1).split("|")) == ast.UNITS


def test_textmate_patterns_compile_and_match_whole_words() -> None:
    g = grammar()
    assert g["scopeName"] == "source.aida-kb"

    def patterns(node: Any) -> list[str]:
        found = []
        if isinstance(node, dict):
            for key in ("match", "begin", "end"):
                if key in node:
                    found.append(node[key])
            for value in node.values():
                found.extend(patterns(value))
        elif isinstance(node, list):
            for value in node:
                found.extend(patterns(value))
        return found

    for p in patterns(g):
        re.compile(p)  # the syntax used is common to Oniguruma and Python
    member = next(
        p["match"] for p in g["repository"]["keywords"]["patterns"] if "con-of" in p["match"]
    )
    assert re.search(member, "    con-of region: Region")
    assert not re.search(member, "    parts: Region")
    assert not re.search(member, "    my-part")
    quantity = re.compile(g["repository"]["quantities"]["match"])
    m = quantity.search("angle(a, b) == 90 deg +- 0.5deg")
    assert m is not None
    assert m.groups() == ("90", "deg")


def test_completion_keywords_are_grammar_keywords() -> None:
    words = lark_keywords()
    following = {w for _, after in NEXT_KEYWORDS for w in after}
    assert set(DECLARATION_KEYWORDS + MEMBER_KEYWORDS + QUALIFIER_KEYWORDS) | following <= words


def test_vscode_manifest_starts_the_server_for_kb_files() -> None:
    manifest = json.loads((VSCODE / "package.json").read_text(encoding="utf-8"))
    (language,) = manifest["contributes"]["languages"]
    assert language["extensions"] == [".kb"]
    json.loads((VSCODE / language["configuration"]).read_text(encoding="utf-8"))
    (tm,) = manifest["contributes"]["grammars"]
    assert tm["language"] == language["id"]
    assert (VSCODE / tm["path"]).resolve() == TM
    assert tm["scopeName"] == grammar()["scopeName"]
    command = manifest["contributes"]["configuration"]["properties"]["aidaKb.server.command"]
    assert command["default"] == ["aida-kb", "lsp"]
    main = VSCODE / manifest["main"]
    source = main.read_text(encoding="utf-8")
    assert '"aidaKb"' in source
    assert "server.command" in source
    assert "vscode-languageclient" in manifest["dependencies"]
    node = shutil.which("node")
    if node is not None:  # the script at least parses
        subprocess.run([node, "--check", str(main)], check=True, timeout=30)
