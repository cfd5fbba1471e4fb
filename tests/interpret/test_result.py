"""interpretation.json: the pydantic result round-trips and rejects malformed files."""

from __future__ import annotations

from pathlib import Path

import pytest
from pydantic import ValidationError

from aida_kb.errors import FormatError
from aida_kb.interpret.result import (
    INSERTED,
    ConstraintResidual,
    HypothesisTrace,
    Instance,
    Interpretation,
    read_interpretation,
    write_interpretation,
)


def _example() -> Interpretation:
    return Interpretation(
        goal="House",
        accepted=True,
        message="House verified",
        instances=[
            Instance(role="", concept="House", instance_of="House", parent=None, link="goal"),
            Instance(
                role="body.floor",
                concept="Floor",
                instance_of="Floor",
                parent="body",
                link="part-of",
                bindings=[INSERTED],
            ),
        ],
        residuals=[
            ConstraintResidual(
                label="slopes",
                kind="symmetry",
                concept="HouseBody",
                owner="body",
                parts=["body.front", "body.roof.front", "body.back", "body.roof.back"],
                residual=0.001,
                unit="rad",
                sigma=0.0087,
                normalised_cost=0.11,
                threshold=10.828,
                reject_above=None,
                rejected=False,
            )
        ],
        trace=[
            HypothesisTrace(id=0, parent=None, concept="House", role="", status="verified", step=3),
            HypothesisTrace(
                id=1,
                parent=0,
                concept="RightWing",
                role="body.wings[0]",
                status="rejected",
                step=2,
                reason="constraint too costly",
                constraint="meeting",
                cost=41.5,
            ),
        ],
        expanded=3,
    )


def test_round_trip(tmp_path: Path) -> None:
    value = _example()
    write_interpretation(tmp_path / "i.json", value)
    back = read_interpretation(tmp_path / "i.json")
    assert back == value
    assert back.instance("body.floor").bindings == [INSERTED]
    assert [h.constraint for h in back.rejected()] == ["meeting"]
    with pytest.raises(KeyError):
        back.instance("body.nothing")


def test_malformed_file_names_field(tmp_path: Path) -> None:
    bad = tmp_path / "bad.json"
    bad.write_text('{"goal": "House", "accepted": "maybe", "message": "", "expanded": 0}')
    with pytest.raises(FormatError, match=r"bad\.json.*accepted"):
        read_interpretation(bad)


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("residual", float("nan")),
        ("sigma", float("nan")),
        ("normalised_cost", float("inf")),
        ("threshold", float("nan")),
        ("reject_above", float("-inf")),
    ],
)
def test_a_non_finite_residual_number_is_refused_at_construction(field: str, value: float) -> None:
    row = _example().residuals[0].model_dump()
    row[field] = value
    with pytest.raises(ValidationError, match=rf"{field}\n.*finite"):
        ConstraintResidual(**row)


def test_a_non_finite_cost_is_refused_but_a_huge_one_is_kept() -> None:
    trace = _example().trace[1].model_dump()
    trace["cost"] = float("nan")
    with pytest.raises(ValidationError, match=r"cost\n.*finite"):
        HypothesisTrace(**trace)
    whole = _example().model_dump()
    whole["cost"] = float("nan")
    with pytest.raises(ValidationError, match=r"cost\n.*finite"):
        Interpretation(**whole)
    trace["cost"] = 3.5e15  # a far-off hypothesis: residual a million sigma away
    assert HypothesisTrace(**trace).cost == 3.5e15
