"""Exports: the up axis, OBJ + MTL, binary glTF, CityJSON 2.0 (checked), PLY; `aida-kb export`."""

from __future__ import annotations

import json
import struct
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import trimesh

from aida_kb.cli.export import FORMATS
from aida_kb.cli.main import main
from aida_kb.errors import FormatError
from aida_kb.io.export import (
    EXPORT_FORMATS,
    Atlas,
    Georeference,
    cityjson_document,
    export_files,
    export_frame,
    glb_bytes,
    obj_files,
    ply_bytes,
    surface_class,
    write_files,
)
from aida_kb.io.model import ModelPart, ReconstructedModel, write_model
from aida_kb.synth.buildings import lshape_house

# the synthetic site frame is y up; the model below is turned so that its up is not an axis
TILT = np.array(
    [[1.0, 0.0, 0.0], [0.0, np.cos(0.3), -np.sin(0.3)], [0.0, np.sin(0.3), np.cos(0.3)]]
)


def _lshape() -> ReconstructedModel:
    """The synthetic L-shaped house (body and wing: two solids), tilted by TILT."""
    parts = []
    for solid in lshape_house().solids:
        for face in solid.faces:
            n = TILT @ face.normal
            poly = face.polygon @ TILT.T
            parts.append(
                ModelPart(
                    role=face.role,
                    concept=face.concept,
                    normal=(float(n[0]), float(n[1]), float(n[2])),
                    offset_m=float(n @ poly[0]),
                    polygon=[(float(x), float(y), float(z)) for x, y, z in poly],
                )
            )
    up = TILT @ np.array([0.0, 1.0, 0.0])
    return ReconstructedModel(parts=parts, up=(float(up[0]), float(up[1]), float(up[2])))


def test_export_frame_puts_the_estimated_vertical_on_the_up_axis() -> None:
    model = _lshape()
    up = np.array(model.up)
    for axes, axis in (("y-up", 1), ("z-up", 2)):
        frame = export_frame(model, axes)  # type: ignore[arg-type]
        R = frame.R_export_world
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
        assert np.linalg.det(R) == pytest.approx(1.0)
        np.testing.assert_allclose(frame.rotate(up)[0], np.eye(3)[axis], atol=1e-12)
        points = frame.apply([v for p in model.parts for v in p.polygon])
        assert points[:, axis].min() == pytest.approx(0.0, abs=1e-9)  # stands on up = 0
        T = np.array(frame.matrix)
        np.testing.assert_allclose(T[:3, :3], R)


def test_without_an_estimate_up_is_the_cameras_minus_y() -> None:
    model = _lshape().model_copy(update={"up": None})
    frame = export_frame(model, "y-up")
    np.testing.assert_allclose(frame.rotate([0.0, -1.0, 0.0])[0], [0.0, 1.0, 0.0], atol=1e-12)


def test_obj_loads_closed_with_outward_normals(tmp_path: Path) -> None:
    model = _lshape()
    write_files(tmp_path, obj_files(model))
    text = (tmp_path / "model.obj").read_text()
    assert "mtllib model.mtl" in text
    assert "T_export_world" in text
    assert text.count("\nf ") == len(model.parts)
    assert text.count("\nvn ") == len(model.parts)
    assert "g body.wings[0].front" in text
    mesh = trimesh.load(tmp_path / "model.obj", force="mesh")
    mesh.merge_vertices()
    bodies = mesh.split(only_watertight=False)
    assert len(bodies) == 2
    for body in bodies:
        assert body.is_watertight
        assert body.volume > 0  # outward winding
    # the vertex normals trimesh keeps agree with the file's face normals: up is +y
    assert mesh.bounds[0][1] == pytest.approx(0.0, abs=1e-6)


def test_glb_loads_with_the_frame_recorded() -> None:
    model = _lshape()
    data = glb_bytes(model)
    scene = trimesh.load(trimesh.util.wrap_as_stream(data), file_type="glb")
    assert list(scene.geometry) == ["unseen"]  # no texture given: everything neutral
    (mesh,) = scene.geometry.values()
    mesh.merge_vertices(merge_tex=True, merge_norm=True)
    assert mesh.is_watertight
    assert mesh.volume > 0  # outward winding
    obj = trimesh.load(trimesh.util.wrap_as_stream(obj_files(model)["model.obj"]), "obj")
    np.testing.assert_allclose(scene.bounds, obj.bounds, atol=1e-6)
    length = struct.unpack_from("<I", data, 12)[0]
    tree = json.loads(data[20 : 20 + length])
    assert len(tree["asset"]["extras"]["T_export_world"]) == 4


def test_textured_glb_and_obj_carry_uvs_and_the_image(tmp_path: Path) -> None:
    model = _lshape()
    rng = np.random.default_rng(0)
    image = rng.integers(0, 255, (64, 64, 3), dtype=np.uint8)
    uv = tuple(rng.random((len(p.polygon), 2)) for p in model.parts)
    seen = tuple(not p.role.endswith("floor") for p in model.parts)
    atlas = Atlas(image=image, uv=uv, seen=seen)
    scene = trimesh.load(trimesh.util.wrap_as_stream(glb_bytes(model, atlas)), file_type="glb")
    assert sorted(scene.geometry) == ["textured", "unseen"]
    textured = scene.geometry["textured"]
    assert textured.visual.uv.shape == (len(textured.vertices), 2)
    assert np.asarray(textured.visual.material.baseColorTexture).shape == (64, 64, 3)
    write_files(tmp_path, obj_files(model, atlas=atlas))
    assert (tmp_path / "model_atlas.png").is_file()
    assert "map_Kd model_atlas.png" in (tmp_path / "model.mtl").read_text()
    loaded = trimesh.load(tmp_path / "model.obj", force="mesh")
    assert loaded.visual.uv is not None
    assert min(loaded.visual.material.image.size) >= 64  # trimesh packs both materials


def test_cityjson_is_a_building_with_a_part_and_semantic_surfaces(check_cityjson: Any) -> None:
    model = _lshape()
    doc = cityjson_document(model)
    check_cityjson(doc)
    objects = doc["CityObjects"]
    assert [o["type"] for o in objects.values()] == ["Building", "BuildingPart"]
    assert objects["building"]["attributes"]["role"] == "body"
    assert objects["building-part-1"]["attributes"]["role"] == "body.wings[0]"
    kinds = {
        s["role"]: s["type"]
        for o in objects.values()
        for s in o["geometry"][0]["semantics"]["surfaces"]
    }
    for part in model.parts:
        expected = {"Wall": "WallSurface", "RoofPlane": "RoofSurface", "Floor": "GroundSurface"}
        assert kinds[part.role] == expected[part.concept], part.role
    # z up: the vertices' heights start at 0 (the ground)
    heights = np.array(doc["vertices"])[:, 2] * 0.001 + doc["transform"]["translate"][2]
    assert heights.min() == pytest.approx(0.0, abs=1e-3)


def test_surface_class_from_the_normal_and_height() -> None:
    assert surface_class(1.0, 5.0) == "RoofSurface"
    assert surface_class(np.cos(np.radians(60)), 5.0) == "RoofSurface"
    assert surface_class(0.02, 0.0) == "WallSurface"
    assert surface_class(-1.0, 0.0) == "GroundSurface"
    assert surface_class(-1.0, 3.0) == "OuterFloorSurface"


def test_ply_holds_the_points_in_the_export_frame() -> None:
    model = _lshape()
    points = np.array([[0.0, 0.0, 0.0], [1.0, 2.0, 3.0]])
    colours = np.array([[255, 0, 0], [0, 255, 0]], dtype=np.uint8)
    data = ply_bytes(points, colours, model)
    assert b"comment aida-kb frame y-up" in data
    cloud = trimesh.load(trimesh.util.wrap_as_stream(data), file_type="ply")
    np.testing.assert_allclose(cloud.vertices, export_frame(model).apply(points), atol=1e-5)
    np.testing.assert_array_equal(cloud.colors[:, :3], colours)
    with pytest.raises(FormatError, match="3 colours"):
        ply_bytes(points, np.zeros((3, 3), np.uint8), model)


def test_export_command_writes_each_format(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], check_cityjson: Any
) -> None:
    assert FORMATS == EXPORT_FORMATS
    write_model(tmp_path / "model.json", _lshape())
    out = tmp_path / "out"
    argv = ["export", str(tmp_path / "model.json"), "-o", str(out)]
    assert main([*argv, "--format", "obj", "--format", "glb", "--format", "cityjson"]) == 0
    assert sorted(p.name for p in out.iterdir()) == [
        "model.city.json",
        "model.glb",
        "model.mtl",
        "model.obj",
    ]
    check_cityjson(json.loads((out / "model.city.json").read_text()))
    capsys.readouterr()
    assert main([*argv, "--format", "ply"]) != 0
    assert "need the scene" in capsys.readouterr().err
    assert set(export_files(_lshape(), "glb")) == {"model.glb"}


def test_cityjson_georeference_turns_and_shifts_onto_the_map(
    tmp_path: Path, check_cityjson: Any, capsys: pytest.CaptureFixture[str]
) -> None:
    model = _lshape()
    local = cityjson_document(model)
    geo = Georeference((1000.0, 2000.0, 5.0), heading_deg=90.0, epsg=28992)
    doc = cityjson_document(model, georeference=geo)
    check_cityjson(doc)
    assert doc["metadata"]["referenceSystem"].endswith("/EPSG/0/28992")

    def world(d: dict[str, Any]) -> np.ndarray:
        return np.array(d["vertices"]) * 0.001 + np.array(d["transform"]["translate"])

    a, b = world(local), world(doc)
    # heading 90: the local +y (view 00's look) points east, local +x south
    np.testing.assert_allclose(b[:, 0], 1000.0 + a[:, 1], atol=2e-3)
    np.testing.assert_allclose(b[:, 1], 2000.0 - a[:, 0], atol=2e-3)
    np.testing.assert_allclose(b[:, 2], 5.0 + a[:, 2], atol=2e-3)
    write_model(tmp_path / "model.json", model)
    argv = ["export", str(tmp_path / "model.json"), "--format", "cityjson", "-o", str(tmp_path)]
    assert main([*argv, "--origin", "1000,2000,5", "--heading", "90", "--epsg", "28992"]) == 0
    written = json.loads((tmp_path / "model.city.json").read_text())
    np.testing.assert_allclose(world(written), b, atol=2e-3)
    capsys.readouterr()
    assert main([*argv, "--origin", "1000,x,5"]) != 0
    assert "--origin '1000,x,5': expected E,N,H" in capsys.readouterr().err
    assert main([*argv, "--epsg", "28992"]) != 0
    assert "give --origin too" in capsys.readouterr().err


def test_a_model_known_up_to_scale_claims_no_metres(tmp_path: Path) -> None:
    model = _lshape().model_copy(update={"units": "unknown"})
    assert "units: metres" in obj_files(_lshape())["model.obj"].decode()
    text = obj_files(model)["model.obj"].decode()
    assert "units: unknown (up to scale" in text
    assert "metres" not in text.splitlines()[1]
    doc = cityjson_document(model)
    assert "up to scale" in doc["metadata"]["title"]
    with pytest.raises(FormatError, match=r"up to scale only .* cannot be put on the map"):
        cityjson_document(model, georeference=Georeference((0.0, 0.0, 0.0)))
