"""Every request at every name of every .kb file of the repository answers without an error:
the features on the analyses directly (the protocol tests cover the wiring)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from lsprotocol import types

from aida_kb.kb import compile_path
from aida_kb.lsp import features
from aida_kb.lsp.analysis import Analysis
from aida_kb.lsp.complete import completions
from aida_kb.lsp.convert import uri_of_path
from aida_kb.lsp.diagnose import publishable

ROOT = Path(__file__).resolve().parents[2]
FILES = sorted((ROOT / "kb").rglob("*.kb"))


@pytest.mark.parametrize("path", FILES, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_request_at_every_word_answers(path: Path) -> None:
    text = path.read_text(encoding="utf-8")
    uri = uri_of_path(str(path))
    a = Analysis(uri, text)
    shown = publishable(a)
    # the compiler's own diagnostics, as `aida-kb lint` reports them for this file alone
    linted = [d for d in compile_path(path, library=True).diagnostics if d.span.file == str(path)]
    assert [(d.code, d.range.start.line + 1, d.range.start.character + 1) for d in shown][
        : len(linted)
    ] == [(d.code, d.span.line, d.span.column) for d in linted]
    assert features.document_symbols(a) or not a.module or not a.module.items
    lines = text.split("\n")
    named = 0
    for n, line in enumerate(lines):
        completions(a, text, types.Position(n, len(line)))
        for word in re.finditer(r"[A-Za-z_]\w*|\"", line):  # names, keywords, import strings
            c = word.start()
            at = types.Position(n, c)
            occ = features.occurrence_at(a, uri, at)
            features.hover(a, uri, at)
            found = features.definition(a, uri, at)
            if occ is not None:
                named += 1
                assert found, f"{path.name}:{n + 1}:{c + 1}: a name without its declaration"
                refs = features.references(a, [], uri, at, True)
                assert features.prepare_rename(a, uri, at) is not None
                assert any(r.range == a.lines(a.path).range(occ.span) for r in refs if r.uri == uri)
        features.code_actions(
            a, uri, types.Range(types.Position(n, 0), types.Position(n, 0)), shown
        )
    if a.index.occurrences:
        assert named > 0
