"""`lint --format sarif`: a SARIF 2.1.0 log, valid against the official schema's rules
(tests/cli/data/sarif-schema-2.1.0-subset.json, see its notice), with rules, levels,
locations and related locations."""

from __future__ import annotations

import json
from pathlib import Path

import jsonschema
import pytest

from aida_kb.cli.main import main

ROOT = Path(__file__).resolve().parents[2]
SCHEMA = json.loads(
    (Path(__file__).parent / "data" / "sarif-schema-2.1.0-subset.json").read_text("utf-8")
)
VALIDATOR = jsonschema.Draft4Validator(SCHEMA, format_checker=jsonschema.FormatChecker())


def _sarif(paths: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, dict[str, object]]:
    code = main(["lint", "--format", "sarif", *paths])
    return code, json.loads(capsys.readouterr().out)


def test_the_schema_is_a_valid_draft_4_schema() -> None:
    jsonschema.Draft4Validator.check_schema(SCHEMA)


def test_the_log_of_every_golden_file_is_valid(capsys: pytest.CaptureFixture[str]) -> None:
    code, log = _sarif([str(ROOT / "kb" / "examples")], capsys)
    assert code == 1
    VALIDATOR.validate(log)
    [run] = log["runs"]  # type: ignore[misc]
    results = run["results"]
    rules = run["tool"]["driver"]["rules"]
    assert len(results) > 40
    for result in results:
        assert rules[result["ruleIndex"]]["id"] == result["ruleId"]
    twice = next(r for r in results if r["ruleId"] == "KB110")
    assert twice["level"] == "error"
    assert "hint: rename one of them" in twice["message"]["text"]
    [related] = twice["relatedLocations"]
    assert related["message"]["text"] == "first defined here"
    region = twice["locations"][0]["physicalLocation"]["region"]
    assert region["startLine"] < region["endLine"] or region["startColumn"] < region["endColumn"]
    assert {r["level"] for r in results} == {"error", "warning"}


def test_a_clean_log_is_valid_and_empty(capsys: pytest.CaptureFixture[str]) -> None:
    code, log = _sarif([str(ROOT / "kb" / "buildings.kb")], capsys)
    assert code == 0
    VALIDATOR.validate(log)
    assert log["version"] == "2.1.0"
    assert log["runs"][0]["results"] == []  # type: ignore[index]


def test_the_validator_rejects_a_wrong_log(capsys: pytest.CaptureFixture[str]) -> None:
    """The schema check can fail: a level SARIF does not know, a column 0."""
    _, log = _sarif([str(ROOT / "kb" / "examples" / "broken_names.kb")], capsys)
    result = log["runs"][0]["results"][0]  # type: ignore[index]
    result["level"] = "fatal"
    assert not VALIDATOR.is_valid(log)
    result["level"] = "error"
    result["locations"][0]["physicalLocation"]["region"]["startColumn"] = 0
    assert not VALIDATOR.is_valid(log)
