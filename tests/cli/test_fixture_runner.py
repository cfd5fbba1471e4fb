"""`aida-kb test`: diffs of wrong expectations, --update, exit status, lint of expectations.

The repository's fixtures themselves are run in tests/interpret/test_fixtures.py (with the
session's interpretations of their evidence)."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

from aida_kb.cli.main import main

ROOT = Path(__file__).resolve().parents[2]
KB_DIR = str(ROOT / "kb")
FIXTURES = ROOT / "tests" / "fixtures"


def test_the_expectations_lint_clean_and_are_in_the_canonical_layout(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["lint", "--strict", str(FIXTURES), "--import-path", KB_DIR]) == 0
    assert main(["fmt", "--check", str(FIXTURES)]) == 0
    capsys.readouterr()


def _copy(tmp_path: Path, name: str) -> Path:
    """A copy of fixture `name` in tmp_path (evidence and expectation, import made absolute)."""
    shutil.copy(FIXTURES / f"{name}.json", tmp_path / f"{name}.json")
    text = (FIXTURES / f"{name}.expected.kb").read_text(encoding="utf-8")
    out = tmp_path / f"{name}.expected.kb"
    out.write_text(text, encoding="utf-8")
    return out


def _line(path: Path, text: str) -> int:
    """The 1-based number of the first line of `path` that contains `text`."""
    lines = path.read_text(encoding="utf-8").splitlines()
    return next(k for k, line in enumerate(lines, 1) if text in line)


def test_a_wrong_expectation_gives_a_readable_diff_and_exit_1(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _copy(tmp_path, "wing_135")
    text = path.read_text(encoding="utf-8")
    wrong = (
        text.replace("of SkewWing {", "of RightWing {")
        .replace("by wings_meet", "by slopes")
        .replace("pitch = 38.31 deg", "pitch = 41 deg")
        .replace('region = "00/4"', 'region = "00/9"')
    )
    assert wrong.count("RightWing {") == 1
    path.write_text(wrong, encoding="utf-8")
    code = main(["test", str(path), "--import-path", KB_DIR])
    out = capsys.readouterr().out
    assert code == 1
    assert f"{path}: FAILED (" in out
    at = {k: _line(path, k) for k in ("wings_0 of RightWing", "by slopes", "pitch = 41 deg")}
    wing = at["wings_0 of RightWing"]
    assert f"{path}:{wing}: expected body.wings[0] of RightWing, got SkewWing" in out
    assert (
        f"{path}:{at['by slopes']}: expected 'slopes' to reject body.wings[0] of RightWing, "
        "got it rejected by 'Region#1', 'wings_meet'"
    ) in out
    assert (
        f"{path}:{at['pitch = 41 deg']}: expected body.roof.front.pitch = 41 deg +- 0.5 deg, "
        "got 38.34 deg"
    ) in out
    # the wing's subtree is not compared once its concept differs: the wrong region under it
    # is not reported separately
    assert '"00/9"' not in out
    assert out.splitlines()[-1].startswith("1 fixture: 1 failed in ")


def test_a_wrong_verdict_a_part_called_inserted_and_a_rejection_that_did_not_happen(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _copy(tmp_path, "house_correct")
    text = path.read_text(encoding="utf-8").replace("verdict doubtful", "verdict verified")
    # the back roof half called inserted, and the accepted roof expected rejected
    text = text.replace(
        'region = "00/4"', '"inserted from the knowledge base: no view shows this part"'
    )
    text = text.replace("reject body.roof of HipRoof", "reject body.roof of GableRoof")
    path.write_text(text, encoding="utf-8")
    assert main(["test", str(path), "--import-path", KB_DIR]) == 1
    out = capsys.readouterr().out
    verdict = _line(path, "verdict verified")
    assert (
        f"{path}:{verdict}: expected verdict verified, got doubtful: body.left: its normal" in out
    )
    back = _line(path, "instance body_roof_back")
    assert (
        f"{path}:{back}: expected body.roof.back inserted (no view shows it), "
        'got it seen: region = "00/4"'
    ) in out
    rejection = _line(path, "reject body.roof of GableRoof")
    assert (
        f"{path}:{rejection}: expected body.roof of GableRoof rejected, got it verified: "
        "[body.roof=GableRoof; vertical 0, frame from "
    ) in out


def test_update_rewrites_the_expectation_from_the_result_keeping_its_annotations(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv("CI", raising=False)
    path = _copy(tmp_path, "house_correct")
    good = path.read_text(encoding="utf-8")
    wrong = good.replace("verdict doubtful", "verdict verified").replace(
        "depth = 10 m", "depth = 12 m"
    )
    path.write_text(wrong, encoding="utf-8")
    assert main(["test", str(path), "--import-path", KB_DIR, "--update"]) == 0
    out = capsys.readouterr().out
    assert f"{path}: UPDATED (" in out
    assert "expected verdict verified, got doubtful" in out
    assert "expected body.depth = 12 m +- 0.35 m, got 9.905 m" in out
    new = path.read_text(encoding="utf-8")
    assert "// expect: verdict doubtful\n" in new
    assert "    depth = 9.905 m\n" in new  # the result's value, for review
    # the author's comments and the annotations stay: the tolerance line, and a value's
    # tolerance after its new value
    assert new.startswith("// A gable house 16 x 10 m, walls 9 m, roof pitch 35 deg")
    assert "// expect: tolerance 1 deg, 35 cm\n" in new
    assert re.search(r"    height = 12\.\d+ m  // expect: \+- 15 cm\n", new)
    assert 'import "buildings.kb"\n' in new
    assert main(["test", str(path), "--import-path", KB_DIR]) == 0
    assert main(["lint", str(path), "--import-path", KB_DIR]) == 0
    assert main(["fmt", "--check", str(path)]) == 0
    capsys.readouterr()


def test_update_is_refused_in_ci_unless_forced(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("CI", "true")
    path = _copy(tmp_path, "no_house")
    wrong = path.read_text(encoding="utf-8").replace("verdict nothing", "verdict verified")
    path.write_text(wrong + "instance house of House { body = b }\n", encoding="utf-8")
    assert main(["test", str(path), "--import-path", KB_DIR, "--update"]) == 2
    assert "refusing --update in CI" in capsys.readouterr().err
    assert path.read_text(encoding="utf-8").startswith(wrong)
    # forced: it runs (this expectation does not lint, so it is an error, and nothing is
    # written either: a bad expectation is never rewritten)
    assert main(["test", str(path), "--import-path", KB_DIR, "--update", "--force"]) == 2
    out = capsys.readouterr().out
    assert f"{path}: ERROR (" in out
    assert "error[KB104]: unknown instance 'b'" in out
    assert path.read_text(encoding="utf-8").startswith(wrong)


def test_bad_fixtures_are_errors_with_exit_2_and_no_fixture_is_5(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    lonely = tmp_path / "lonely.expected.kb"
    lonely.write_text('import "buildings.kb"\n// expect: verdict nothing\n', encoding="utf-8")
    assert main(["test", str(lonely), "--import-path", KB_DIR]) == 2
    assert "no input beside it: expected lonely.json" in capsys.readouterr().out
    path = _copy(tmp_path, "no_house")
    path.write_text('import "buildings.kb"\n', encoding="utf-8")
    assert main(["test", str(path), "--import-path", KB_DIR]) == 2
    assert "no '// expect: verdict ...' line" in capsys.readouterr().out
    path.write_text('import "buildings.kb"\n// expect: verdict nothing\n', encoding="utf-8")
    assert main(["test", str(path)]) == 2  # the import leaves the fixture's folder: KB901
    assert "error[KB901]" in capsys.readouterr().out
    assert main(["test", str(path), "--import-path", KB_DIR]) == 0
    empty = tmp_path / "empty"
    empty.mkdir()
    assert main(["test", str(empty)]) == 5
    assert main(["test", str(tmp_path / "missing")]) == 2
    capsys.readouterr()


def test_lint_catches_a_wrong_expectation_before_it_is_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _copy(tmp_path, "house_correct")
    good = path.read_text(encoding="utf-8")
    cases = {
        # a roof that needs four planes given two: the obligatory roles left unbound
        good.replace("of GableRoof {", "of HipRoof {"): ("KB141", "instance body_roof of"),
        good.replace("    width = 16 m", "    breadth = 16 m"): ("KB102", "breadth = 16 m"),
        good.replace("    tilt = 90 deg\n", "    tilt = 120 deg\n", 1): ("KB133", "tilt = 120"),
        good + "// expect: reject body.roof of GableRof by slopes\n": (
            "KB100",
            "GableRof",
        ),
        good.replace("tolerance 1 deg, 35 cm", "tolerance 1 px"): ("KB143", "tolerance 1 px"),
        good.replace("height = 9 m\n", "height = 9 m  // expect: +- 1 deg\n", 1): (
            "KB132",
            "+- 1 deg",
        ),
        good + "// expect: reject body.roof of HipRoof by steepness\n": ("KB143", "steepness"),
        good + "// expect: reject body.tower of HipRoof by slopes\n": ("KB143", "body.tower"),
    }
    for text, (code, where) in cases.items():
        path.write_text(text, encoding="utf-8")
        assert main(["lint", str(path), "--import-path", KB_DIR]) == 1, code
        out = capsys.readouterr().out
        assert f"{path}:{_line(path, where)}:" in out, (code, out)
        assert f"error[{code}]" in out, (code, out)
