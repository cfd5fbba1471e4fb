"""`aida-kb interpret`: tree output, --explain, -o, the empty result, bad input."""

from __future__ import annotations

from pathlib import Path

import pytest

from aida_kb.cli.main import main
from aida_kb.interpret.result import read_interpretation

ROOT = Path(__file__).resolve().parents[2]
KB = str(ROOT / "kb" / "buildings.kb")
FIXTURES = ROOT / "tests" / "fixtures"


def test_interpret_prints_tree_and_writes_json(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "interpretation.json"
    code = main(
        ["interpret", KB, str(FIXTURES / "house_occluded.json"), "--explain", "-o", str(out)]
    )
    text = capsys.readouterr().out
    assert code == 3  # one view, half hidden, fixes the front's normal only to 1.3 deg at 2 sd
    assert text.startswith("House doubtful: body.front: its normal is fixed")
    assert "(was: House verified (body.roof=GableRoof)" in text
    assert "└── body: HouseBody  [con-of]" in text
    assert "back: Wall  <- inserted from knowledge" in text
    assert "rejected hypotheses:" in text
    # a rejected alternative names its roof, the vertical and frame it was generated in and
    # its binding of regions to parts
    assert "[body.roof=HipRoof; vertical 0, frame from 00/1/00/2/00/3; body.right=00/1" in text
    interp = read_interpretation(out)
    assert interp.accepted
    assert interp.model is not None
    assert len(interp.model.parts) == 7
    # beside it, the result as instances: lint clean with the knowledge base's folder
    written = tmp_path / "interpretation.kb"
    assert f"wrote {out} and {written}" in text
    assert "instance body_back of Wall {" in written.read_text(encoding="utf-8")
    assert main(["lint", str(written), "--import-path", str(ROOT / "kb")]) == 0
    assert "no problems in 1 file" in capsys.readouterr().out
    # without the import path the import leaves the project: KB903, as documented
    assert main(["lint", str(written)]) == 1
    assert "KB903" in capsys.readouterr().out


def test_interpret_refuses_a_kb_output_over_an_input_or_twice(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    kb = tmp_path / "houses.kb"
    kb.write_text((ROOT / "kb" / "buildings.kb").read_text(encoding="utf-8"), encoding="utf-8")
    evidence = str(FIXTURES / "house_correct.json")
    # -o houses.json would put houses.kb over the knowledge base
    assert main(["interpret", str(kb), evidence, "-o", str(tmp_path / "houses.json")]) == 2
    assert "cannot write the output over the input file" in capsys.readouterr().err
    assert main(["interpret", str(kb), evidence, "-o", str(tmp_path / "r.kb")]) == 2
    assert "named twice as an output" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["houses.kb"]


def test_explain_names_the_rejecting_constraint_and_its_cost(
    capsys: pytest.CaptureFixture[str],
) -> None:
    code = main(["interpret", KB, str(FIXTURES / "house_asymmetric_roof.json"), "--explain"])
    text = capsys.readouterr().out
    # the asymmetric gable is accepted, its walls' and roof halves' normals fixed only to
    # 0.55-0.69 deg at 2 sd (doubtful: uncertainty.EDGE_BIAS_PX); the symmetric one was rejected
    assert code == 3
    assert text.startswith("House doubtful: body.front: its normal is fixed")
    assert "body.roof.front: its normal is fixed" in text.splitlines()[0]
    assert "(was: House verified (body.roof=AsymmetricGableRoof)" in text
    line = next(
        x
        for x in text.splitlines()
        if "[body.roof=GableRoof; vertical 0, " in x
        and "body.front=00/1" in x
        and x.startswith("  #")
    )
    assert "rejected: constraint 'slopes' at " in line
    # the rejecting constraint's .kb line: in the trace line and as a note with the source line
    assert "buildings.kb:" in line
    assert "note[KB400]: 'slopes' rejected HouseBody" in text
    assert "constraint slopes:" in text
    assert "(normalised)" in line


def test_no_house_exits_with_nothing_found_and_a_clear_message(
    capsys: pytest.CaptureFixture[str],
) -> None:
    code = main(["interpret", KB, str(FIXTURES / "no_house.json")])
    captured = capsys.readouterr()
    assert code == 4  # nothing found, not an error
    assert captured.out.startswith("no House in the evidence: ")
    assert "Traceback" not in captured.err


def test_bad_evidence_is_a_usage_error(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "evidence.json"
    bad.write_text('{"format": "aida-kb-evidence", "views": []}')
    assert main(["interpret", KB, str(bad)]) == 2
    assert "evidence.json" in capsys.readouterr().err
    assert main(["interpret", KB, str(tmp_path / "missing.json")]) == 2


def test_unknown_goal_fails(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["interpret", KB, str(FIXTURES / "no_house.json"), "--goal", "Castle"]) == 1
    assert "goal 'Castle' is not a concept" in capsys.readouterr().err


def test_output_that_is_a_directory_is_refused_before_interpreting(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # the evidence does not even exist: the output is checked first
    code = main(["interpret", KB, str(tmp_path / "missing.json"), "-o", str(tmp_path)])
    err = capsys.readouterr().err
    assert code == 2
    assert err.strip() == f"aida-kb: error: {tmp_path}: cannot write the output: it is a directory"


@pytest.mark.parametrize(
    ("goal", "expected"),
    [
        ("Wall", "goal 'Wall' is a concept of the world layer; the goal must be a scene-layer"),
        ("Castle", "goal 'Castle' is not a concept of the knowledge base (scene concepts: "),
    ],
)
def test_a_goal_outside_the_scene_layer_is_refused_up_front(
    goal: str, expected: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code = main(["interpret", KB, str(tmp_path / "missing.json"), "--goal", goal])
    captured = capsys.readouterr()
    assert code == 1
    assert captured.out == ""
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1
    assert expected in lines[0]
    assert "House" in lines[0]
