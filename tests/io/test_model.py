"""model.json and model.obj: round trip, validation, closed mesh."""

from __future__ import annotations

import json
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from aida_kb.errors import FormatError
from aida_kb.io.model import (
    ModelPart,
    ReconstructedModel,
    obj_text,
    read_model,
    write_model,
    write_obj,
)


def _cube(size: float = 2.0) -> ReconstructedModel:
    s = size
    corners = {(i, j, k): (i * s, j * s, k * s) for i in (0, 1) for j in (0, 1) for k in (0, 1)}
    faces = {
        "x0": ((-1, 0, 0), 0.0, [(0, 0, 0), (0, 0, 1), (0, 1, 1), (0, 1, 0)]),
        "x1": ((1, 0, 0), s, [(1, 0, 0), (1, 1, 0), (1, 1, 1), (1, 0, 1)]),
        "y0": ((0, -1, 0), 0.0, [(0, 0, 0), (1, 0, 0), (1, 0, 1), (0, 0, 1)]),
        "y1": ((0, 1, 0), s, [(0, 1, 0), (0, 1, 1), (1, 1, 1), (1, 1, 0)]),
        "z0": ((0, 0, -1), 0.0, [(0, 0, 0), (0, 1, 0), (1, 1, 0), (1, 0, 0)]),
        "z1": ((0, 0, 1), s, [(0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]),
    }
    parts = [
        ModelPart(
            role=f"box.{name}",
            concept="Plane",
            normal=(float(n[0]), float(n[1]), float(n[2])),
            offset_m=d,
            polygon=[corners[c] for c in poly],
        )
        for name, (n, d, poly) in faces.items()
    ]
    return ReconstructedModel(parts=parts)


def test_model_json_round_trip(tmp_path: Path) -> None:
    model = _cube()
    write_model(tmp_path / "model.json", model)
    assert read_model(tmp_path / "model.json") == model


def test_obj_is_closed_and_welded(tmp_path: Path) -> None:
    write_obj(tmp_path / "model.obj", _cube())
    text = (tmp_path / "model.obj").read_text()
    assert sum(line.startswith("v ") for line in text.splitlines()) == 8
    faces = [line.split()[1:] for line in text.splitlines() if line.startswith("f ")]
    assert len(faces) == 6
    edges: Counter[frozenset[str]] = Counter()
    for face in faces:
        for a, b in zip(face, face[1:] + face[:1], strict=True):
            edges[frozenset((a, b))] += 1
    assert len(edges) == 12
    assert set(edges.values()) == {2}, "every edge of a closed mesh is shared by two faces"


def test_obj_text_uses_part_roles() -> None:
    assert "g box.z1" in obj_text(_cube())


def test_nan_and_bad_normals_are_rejected_with_file_and_field(tmp_path: Path) -> None:
    data = json.loads(_cube().model_dump_json())
    data["parts"][2]["polygon"][1][0] = float("nan")
    bad = tmp_path / "model.json"
    bad.write_text(json.dumps(data))
    with pytest.raises(
        FormatError, match=r"(?s)model\.json.*parts\[2\]\.polygon\[1\]\[0\].*finite"
    ):
        read_model(bad)
    data = json.loads(_cube().model_dump_json())
    data["parts"][0]["normal"] = [0.0, 0.0, 2.0]
    bad.write_text(json.dumps(data))
    with pytest.raises(FormatError, match="length 2, not 1"):
        read_model(bad)


def test_malformed_json_names_line(tmp_path: Path) -> None:
    bad = tmp_path / "model.json"
    bad.write_text('{"parts": [\n  {,]}')
    with pytest.raises(FormatError, match=r"model\.json:2:4: not valid JSON"):
        read_model(bad)
    with pytest.raises(FormatError, match="no such file"):
        read_model(tmp_path / "missing.json")


def _camera(**change: object) -> dict[str, object]:
    camera: dict[str, object] = {
        "view": "00",
        "K": [[800.0, 0.0, 319.5], [0.0, 800.0, 239.5], [0.0, 0.0, 1.0]],
        "R": [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        "t": [0.0, 0.0, 0.0],
        "image_width": 640,
        "image_height": 480,
    }
    camera.update(change)
    return camera


@pytest.mark.parametrize(
    ("camera", "field", "message"),
    [
        (_camera(K=[[0, 0, 0], [0, 0, 0], [0, 0, 1]]), "cameras[0]", "fx, fy > 0"),
        (_camera(R=[[1, 0, 0], [0, 1, 0], [0, 0, -1]]), "cameras[0]", "reflection"),
        (_camera(R=[[2, 0, 0], [0, 1, 0], [0, 0, 1]]), "cameras[0]", "rotation"),
        (_camera(t=[0, 0, 1e300]), "cameras[0].t[2]", "beyond"),
        (_camera(t=[0, "1", 0]), "cameras[0].t[1]", "got str"),
        (_camera(image_width=False), "cameras[0].image_width", "got bool"),
    ],
)
def test_bad_camera_is_rejected_in_one_line(
    tmp_path: Path, camera: dict[str, object], field: str, message: str
) -> None:
    data = json.loads(_cube().model_dump_json())
    data["cameras"] = [camera]
    bad = tmp_path / "model.json"
    bad.write_text(json.dumps(data))
    with pytest.raises(FormatError) as info:
        read_model(bad)
    text = str(info.value)
    assert text.startswith(f"{bad}: field {field}")
    assert message in text
    assert "\n" not in text


def test_good_camera_is_read(tmp_path: Path) -> None:
    data = json.loads(_cube().model_dump_json())
    data["cameras"] = [_camera()]
    path = tmp_path / "model.json"
    path.write_text(json.dumps(data))
    assert read_model(path).cameras[0].K[0][0] == 800.0


def test_building_a_part_with_nan_in_code_is_a_format_error() -> None:
    """API level: the same one-line FormatError as for a file, not pydantic's ValidationError."""
    with pytest.raises(FormatError, match=r"^ModelPart: field normal\[0\]: must be a finite"):
        ModelPart(
            role="a",
            concept="Wall",
            normal=(float("nan"), 0.0, 1.0),
            offset_m=1.0,
            polygon=[(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)],
        )


@pytest.mark.parametrize(
    ("edit", "field", "message"),
    [
        (lambda m: m["parts"][0].update(offset_m=50.0), "parts[0]", "off the part's plane"),
        (
            lambda m: m["parts"][0].update(polygon=[m["parts"][0]["polygon"][0]] * 3),
            "parts[0]",
            "zero area",
        ),
        (lambda m: m["parts"].append(m["parts"][0]), "part roles must be unique", "box.x0"),
        (
            lambda m: m.update(cameras=[_camera(), _camera()]),
            "camera views must be unique",
            "00",
        ),
    ],
)
def test_inconsistent_model_is_rejected(
    tmp_path: Path, edit: Callable[[dict[str, Any]], None], field: str, message: str
) -> None:
    data = json.loads(_cube().model_dump_json())
    edit(data)
    bad = tmp_path / "model.json"
    bad.write_text(json.dumps(data))
    with pytest.raises(FormatError) as info:
        read_model(bad)
    assert field in str(info.value)
    assert message in str(info.value)
