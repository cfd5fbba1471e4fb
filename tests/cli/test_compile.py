"""`aida-kb compile` and `aida-kb schema`: the resolved model as JSON and its JSON Schema."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from aida_kb.cli.main import main
from aida_kb.kb import KnowledgeBase

ROOT = Path(__file__).resolve().parents[2]
BUILDINGS = ROOT / "kb" / "buildings.kb"


def test_compile_writes_the_resolved_model(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "kb.json"
    assert main(["compile", str(BUILDINGS), "-o", str(out)]) == 0
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err == ""  # buildings.kb is lint-clean
    kb = KnowledgeBase.model_validate_json(out.read_text(encoding="utf-8"))
    assert kb.layers == ("scene", "world", "image")
    body = kb.concepts["HouseBody"]
    assert body.con_ofs == {}
    assert set(body.parts) >= {"front", "back", "left", "right", "roof"}
    corner = next(c for c in body.constraints if c.label == "corner_fl")
    assert corner.kind == "angle"
    assert math.isclose(corner.value or 0.0, math.pi / 2)
    # inherited con-of, resolved: Wall gets Plane's region
    assert kb.concepts["Wall"].con_ofs["region"].declared_in == "Plane"


def test_compile_to_stdout_is_json(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["compile", str(BUILDINGS)]) == 0
    data = json.loads(capsys.readouterr().out)
    assert "HouseBody" in data["concepts"]


def test_compile_with_errors_writes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.kb"
    bad.write_text("layers scene > world\nconcept A in scene { part x: Nowhere }\n", "utf-8")
    out = tmp_path / "kb.json"
    out.write_text("previous", encoding="utf-8")
    assert main(["compile", str(bad), "-o", str(out)]) == 1
    assert out.read_text(encoding="utf-8") == "previous"  # untouched
    err = capsys.readouterr().err
    assert "error[KB100]" in err
    assert "^" in err


def test_compile_unreadable_file_is_a_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["compile", "no/such.kb"]) == 2
    assert "no/such.kb" in capsys.readouterr().err


def test_schema_describes_what_compile_writes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["schema"]) == 0
    schema = json.loads(capsys.readouterr().out)
    assert schema["title"] == "KnowledgeBase"
    assert set(schema["required"]) >= {"layers", "concepts", "templates", "instances"}
    assert "ConstraintSpec" in schema["$defs"]
    out = tmp_path / "s.json"
    assert main(["schema", "-o", str(out)]) == 0
    assert json.loads(out.read_text(encoding="utf-8")) == schema
