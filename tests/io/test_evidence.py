"""evidence.json: round trip, validation with file/field errors, schema kept in sync."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from aida_kb.errors import FormatError
from aida_kb.io.evidence import (
    Evidence,
    evidence_schema_text,
    read_evidence,
    write_evidence,
)

SCHEMA = Path(__file__).resolve().parents[2] / "docs" / "schemas" / "evidence.schema.json"

I3 = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
K = [[800.0, 0.0, 319.5], [0.0, 800.0, 239.5], [0.0, 0.0, 1.0]]
CAHV = {
    "C": [0.0, 0.0, 0.0],
    "A": [0.0, 0.0, 1.0],
    "H": [800.0, 0.0, 319.5],
    "V": [0.0, 800.0, 239.5],
}


def _data() -> dict[str, Any]:
    camera = {"K": K, "D": [0.0] * 5, "R": I3, "t": [0.0, 0.0, 0.0], "cahv": CAHV}
    right = {**camera, "t": [-0.4, 0.0, 0.0], "cahv": {**CAHV, "C": [0.4, 0.0, 0.0]}}
    region = {
        "id": 1,
        "label": 2,
        "pixel_count": 1000,
        "depth_pixel_count": 900,
        "inlier_count": 850,
        "area_m2": 12.5,
        "n_init": [0.0, 0.0, -1.0],
        "d_init": -20.0,
        "c_init": [0.5, 0.2, 20.0],
        "w_c": 640.0,
        "rms_m": 0.03,
        "mean_certainty": 0.64,
        "bbox": [10, 20, 60, 70],
    }
    view = {
        "id": "00",
        "frame": "world",
        "image_width": 640,
        "image_height": 480,
        "left": camera,
        "right": right,
        "segmentation": "labels",
        "disparity_density": 0.8,
        "regions": [region, {**region, "id": 2, "label": 4}],
        "lines": [
            {
                "id": 1,
                "p1": [10.25, 20.5],
                "p2": [60.0, 20.75],
                "length_px": 49.76,
                "contrast": 30.0,
                "regions": [1, 2],
                "left_region": 1,
                "right_region": 2,
            }
        ],
        "contours": [{"id": 1, "region": 1, "points": [[10, 20], [60, 20], [60, 70]]}],
    }
    return {"scene": "house", "views": [view]}


def _view(d: dict[str, Any]) -> dict[str, Any]:
    view: dict[str, Any] = d["views"][0]
    return view


def _line(d: dict[str, Any]) -> dict[str, Any]:
    line: dict[str, Any] = _view(d)["lines"][0]
    return line


def test_round_trip(tmp_path: Path) -> None:
    ev = Evidence.model_validate(_data())
    path = tmp_path / "evidence.json"
    write_evidence(path, ev)
    back = read_evidence(path)
    assert back == ev
    assert back.view("00").region(2).label == 4
    assert back.format == "aida-kb-evidence"
    with pytest.raises(KeyError):
        back.view("07")


@pytest.mark.parametrize(
    ("edit", "field", "message"),
    [
        (lambda d: d["views"][0]["regions"][0].update(n_init=[0, 0, 2]), "regions[0]", "unit"),
        (lambda d: d["views"][0]["lines"][0].update(regions=[1, 9]), "views[0]", "unknown"),
        (lambda d: d["views"][0]["contours"][0].update(region=5), "views[0]", "unknown region"),
        (lambda d: d["views"][0]["regions"][1].update(id=1), "views[0]", "unique"),
        (lambda d: d["views"][0]["regions"][0].update(w_c=2000.0), "regions[0]", "w_c"),
        (lambda d: d["views"][0]["regions"][0].update(c_init=[0, "nan", 1]), "c_init", "number"),
        (lambda d: d["views"][0].update(frame="site"), "views[0].frame", "world"),
        (lambda d: d["views"][0]["left"].update(D=[0.0, 1.0]), "views[0].left", "coefficients"),
        (lambda d: d["views"][0]["left"].update(R=[[2, 0, 0], I3[1], I3[2]]), "left", "rotation"),
        (lambda d: d["views"].append(d["views"][0]), "json: view", "view ids must be unique"),
        (lambda d: d.update(format="something"), "format", "aida-kb-evidence"),
        # regressions from the hardening review: each was accepted and flowed on silently
        (lambda d: _line(d).update(p2=_line(d)["p1"]), "lines[0]", "zero length"),
        (lambda d: _line(d).update(length_px=5.0), "lines[0]", "not the distance"),
        (
            lambda d: _line(d).update(p1=[5000, 20.5], p2=[5049.75, 20.75]),
            "views[0]",
            "far outside",
        ),
        (lambda d: _view(d)["regions"][0].update(bbox=[60, 20, 10, 70]), "regions[0]", "x0 <="),
        (lambda d: _view(d)["regions"][0].update(bbox=[0, 0, 640, 9]), "region 1: bbox", "exceeds"),
        (lambda d: _view(d)["regions"][0].update(c_init=[0, 1e300, 1]), "c_init[1]", "beyond"),
        (lambda d: _view(d)["regions"][0].update(pixel_count=10**9), "regions[0]", "its bbox"),
        (lambda d: _view(d)["regions"][0].update(d_init="-20"), "d_init", "got str"),
        (lambda d: _view(d).update(image_width=True), "image_width", "got bool"),
        (lambda d: _view(d).update(right=_view(d)["left"]), "views[0]", "zero baseline"),
        (lambda d: _view(d)["left"].update(t=[1.0, 0, 0]), "views[0].left", "cahv.C"),
        (lambda d: _view(d)["left"].update(R=[I3[0], I3[1], [0, 0, -1]]), "left", "reflection"),
        (lambda d: _view(d)["left"].update(K=[[0, 0, 0], [0, 0, 0], [0, 0, 1]]), "left", "fx, fy"),
    ],
)
def test_invalid_evidence_names_file_and_field(
    tmp_path: Path, edit: Any, field: str, message: str
) -> None:
    data = _data()
    edit(data)
    path = tmp_path / "evidence.json"
    path.write_text(json.dumps(data), encoding="utf-8")
    with pytest.raises(FormatError) as info:
        read_evidence(path)
    text = str(info.value)
    assert "\n" not in text, "one line"
    assert text.startswith(str(path))
    assert field in text
    assert message in text


def test_not_json_and_missing_file(tmp_path: Path) -> None:
    path = tmp_path / "evidence.json"
    path.write_text('{"views": [', encoding="utf-8")
    with pytest.raises(FormatError, match=r"evidence.json:1:\d+: not valid JSON"):
        read_evidence(path)
    with pytest.raises(FormatError, match="no such file"):
        read_evidence(tmp_path / "missing.json")


def test_schema_file_in_sync() -> None:
    assert SCHEMA.read_text(encoding="utf-8") == evidence_schema_text(), (
        "docs/schemas/evidence.schema.json is stale; regenerate with: .venv/bin/python -c "
        '"from aida_kb.io.evidence import evidence_schema_text as s; '
        "open('docs/schemas/evidence.schema.json','w').write(s())\""
    )
    schema = json.loads(SCHEMA.read_text(encoding="utf-8"))
    assert "views" in schema["required"]
    assert {"Region", "LineSegment", "Contour", "EvidenceCamera"} <= set(schema["$defs"])
