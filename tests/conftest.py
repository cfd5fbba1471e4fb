"""Session fixtures shared across test folders: the demo, run once."""

from __future__ import annotations

import contextlib
import io
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest


@dataclass(frozen=True)
class DemoRun:
    """`aida-kb demo --out ROOT`: its exit status, what it printed, and ROOT."""

    code: int
    out: str
    root: Path


@pytest.fixture(scope="session")
def demo_run(tmp_path_factory: pytest.TempPathFactory) -> DemoRun:
    """The demo (render, reconstruct, texture, exports, report), run once per session."""
    from aida_kb.cli.main import main

    root = tmp_path_factory.mktemp("demo")
    buffer = io.StringIO()
    with contextlib.redirect_stdout(buffer):
        code = main(["demo", "--out", str(root)])
    return DemoRun(code, buffer.getvalue(), root)


@dataclass(frozen=True)
class LShapeRun:
    """The `lshape` preset (a wing at 135 degrees, one view, 480 x 360) rendered and
    reconstructed with kb/buildings.kb: the scene, the output directory and its result."""

    scene: Path
    out: Path
    result: Any


@pytest.fixture(scope="session")
def lshape_run(tmp_path_factory: pytest.TempPathFactory) -> LShapeRun:
    """The L-shape scene rendered and reconstructed once per session."""
    from aida_kb.interpret.pipeline import reconstruct_scene
    from aida_kb.kb import compile_path
    from aida_kb.synth.scenes import preset, render_scene

    root = tmp_path_factory.mktemp("lshape")
    kb = compile_path(Path(__file__).resolve().parents[1] / "kb" / "buildings.kb").kb
    assert kb is not None
    params = {"meeting_deg": "135", "image_width": "480", "image_height": "360", "focal_px": "600"}
    render_scene(preset("lshape", seed=0, views=1, params=params), root / "scene")
    result = reconstruct_scene(kb, root / "scene", root / "model")
    return LShapeRun(root / "scene", root / "model", result)


def _check_cityjson(doc: dict[str, Any]) -> None:
    """The checks of cjval (the CityJSON validator) that apply to this file, and closure.

    cjvalpy, cjio's validation engine, has no wheel for CPython 3.11 on Linux and no source
    distribution on PyPI, and val3dity is not on PyPI; so the test checks what they would:
    the root properties, integer vertices with a transform, vertex indices, the shape of the
    semantics and appearance arrays, parent/child links, and that every Solid is a closed,
    outward-oriented 2-manifold (val3dity's shell checks) with trimesh.
    """
    assert doc["type"] == "CityJSON"
    assert doc["version"] == "2.0"
    assert set(doc["transform"]) == {"scale", "translate"}
    vertices = np.array(doc["vertices"])
    assert vertices.dtype.kind == "i"
    assert vertices.shape[1] == 3
    assert len({tuple(v) for v in doc["vertices"]}) == len(vertices), "duplicate vertices"
    scale, translate = np.array(doc["transform"]["scale"]), np.array(doc["transform"]["translate"])
    world = vertices * scale + translate
    objects = doc["CityObjects"]
    n_uv = len(doc.get("appearance", {}).get("vertices-texture", []))
    n_materials = len(doc.get("appearance", {}).get("materials", []))
    for oid, obj in objects.items():
        assert obj["type"] in {"Building", "BuildingPart"}
        for child in obj.get("children", []):
            assert oid in objects[child]["parents"]
        for parent in obj.get("parents", []):
            assert oid in objects[parent]["children"]
        for geom in obj["geometry"]:
            assert geom["type"] == "Solid"
            assert geom["lod"] == "2"
            (shell,) = geom["boundaries"]
            surfaces = geom["semantics"]["surfaces"]
            assert geom["semantics"]["values"] == [list(range(len(shell)))]
            assert len(surfaces) == len(shell), "one semantic surface per face"
            assert {s["type"] for s in surfaces} <= {
                "WallSurface",
                "RoofSurface",
                "GroundSurface",
                "OuterFloorSurface",
            }
            for theme in geom.get("material", {}).values():
                (values,) = theme["values"]
                assert len(values) == len(shell)
                assert all(v is None or 0 <= v < n_materials for v in values)
            for theme in geom.get("texture", {}).values():
                (values,) = theme["values"]
                assert len(values) == len(shell)
                for surface, tex in zip(shell, values, strict=True):
                    if tex == [[None]]:
                        continue
                    assert len(tex) == len(surface)
                    assert len(tex[0]) == len(surface[0]) + 1
                    assert all(0 <= i < n_uv for i in tex[0][1:])
            triangles = []
            for surface in shell:
                (ring,) = surface
                assert len(ring) >= 3
                assert len(set(ring)) == len(ring)
                assert all(0 <= i < len(vertices) for i in ring)
                triangles += [(ring[0], ring[k], ring[k + 1]) for k in range(1, len(ring) - 1)]
            import trimesh

            mesh = trimesh.Trimesh(world, triangles, process=False)
            edges = Counter(map(tuple, np.sort(mesh.edges, axis=1).tolist()))
            assert set(edges.values()) == {2}, f"{oid}: the shell is not closed"
            assert mesh.is_winding_consistent
            assert mesh.volume > 0, f"{oid}: the shell is oriented inwards"


@pytest.fixture(scope="session")
def check_cityjson() -> Callable[[dict[str, Any]], None]:
    """Check a CityJSON document (see `_check_cityjson`); raises AssertionError."""
    return _check_cityjson
