"""`aida-kb lsp --check`: a server started and driven through the protocol, its findings printed."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from aida_kb.cli.main import main

ROOT = Path(__file__).resolve().parents[2]


def test_check_prints_what_an_editor_is_shown(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(ROOT)
    fixture = "tests/fixtures/house_correct.expected.kb"  # imports buildings.kb from kb/
    files = ["kb/buildings.kb", "kb/examples/broken_names.kb", fixture]
    code = main(["lsp", "--check", *files, "--import-path", "kb"])
    out = capsys.readouterr().out
    assert code == 1  # broken_names.kb has errors
    text = (ROOT / "kb" / "buildings.kb").read_text(encoding="utf-8")
    concepts = len(re.findall(r"^(?:abstract )?concept ", text, re.M))
    templates = len(re.findall(r"^template ", text, re.M))
    assert (
        f"kb/buildings.kb: 0 errors, 0 other diagnostics; outline: {concepts} concepts, "
        f"1 layers, {templates} templates\n"
    ) in out
    assert (
        "kb/examples/broken_names.kb:10:18: error[KB100]: unknown concept 'HouseBdy' for role "
        "'body' of House\n    hint: did you mean 'HouseBody'?\n"
    ) in out
    assert re.search(r"kb/examples/broken_names\.kb: [1-9]\d* errors", out)
    instances = len(re.findall(r"^instance ", (ROOT / fixture).read_text(encoding="utf-8"), re.M))
    assert (
        f"{fixture}: 0 errors, 0 other diagnostics; outline: 1 imports, {instances} instances\n"
        in out
    )


def test_check_of_a_missing_file_is_a_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["lsp", "--check", "no/such.kb"]) == 2
    assert (
        capsys.readouterr().err
        == "aida-kb: error: no/such.kb: cannot read: No such file or directory\n"
    )
