"""Preset parameters (`aida-kb synth --set`): bad values are a GeometryError, never a crash."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aida_kb.cli.main import main
from aida_kb.errors import GeometryError
from aida_kb.synth.scenes import preset


@pytest.mark.parametrize(
    ("name", "key", "value", "message"),
    [
        ("house", "width", "nan", "finite"),
        ("house", "width", "inf", "finite"),
        ("house", "focal_px", "0", "must be in"),
        ("house", "baseline", "0", "must be in"),
        ("house", "baseline", "-0.5", "must be in"),
        ("house", "image_width", "0", "must be in"),
        ("house", "image_width", "1e9", "must be in"),
        ("house", "k1", "nan", "finite"),
        ("house", "noise_sigma", "-1", "must be in"),
        ("house", "floors", "2.5", "whole number"),
        ("house", "floors", "0", "must be in"),
        ("house", "distance", "-10", "must be in"),
        ("house", "height", "1e-9", "must be in"),
        ("house", "wall", "nan", "choose one of"),
        ("turntable", "angles", "0,nan", "comma-separated degrees"),
        ("turntable", "angles", ",", "comma-separated degrees"),
        ("chessboard", "cols", "1", "must be in"),
        ("oriel", "n_oriels", "-1", "must be in"),
    ],
)
def test_bad_parameter_is_a_geometry_error(name: str, key: str, value: str, message: str) -> None:
    with pytest.raises(GeometryError, match=message) as info:
        preset(name, params={key: value})
    assert f"{key}={value}" in str(info.value)


def test_good_parameters_are_used() -> None:
    spec = preset("house", params={"width": "18", "floors": "2", "image_width": "320"})
    assert spec.rig.image_size == (320, 480)
    floor = spec.model.face("body.floor").polygon
    assert floor[:, 0].max() - floor[:, 0].min() == pytest.approx(18.0)
    assert len(preset("turntable", params={"angles": "0,90"}).views_site) == 2


def test_cli_reports_a_bad_value_and_writes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "scene"
    assert main(["synth", "house", "-o", str(out), "--set", "focal_px=nan", "--quiet"]) == 1
    err = capsys.readouterr().err
    assert "focal_px=nan" in err
    assert "internal error" not in err
    assert not out.exists()


@pytest.mark.parametrize("seed", [-1, 2**31, 10**23])
def test_seed_out_of_range_is_a_geometry_error(seed: int) -> None:
    with pytest.raises(GeometryError, match=f"--seed {seed}: must be in"):
        preset("house", seed=seed)


def test_largest_seed_renders(tmp_path: Path) -> None:
    from aida_kb.synth.scenes import MAX_SEED, render_scene

    spec = preset(
        "house", seed=MAX_SEED, views=1, params={"image_width": "48", "image_height": "32"}
    )
    render_scene(spec, tmp_path / "s", supersample=1)
    assert (tmp_path / "s" / "scene.yaml").is_file()


@pytest.mark.parametrize(
    ("params", "message"),
    [
        ({"n_oriels": "20"}, "20 oriels 3 m wide do not fit side by side on a 14 m front wall"),
        ({"n_oriels": "1", "oriel_width": "100"}, "1 oriels 100 m wide do not fit"),
    ],
)
def test_oriels_that_overlap_are_refused(params: dict[str, str], message: str) -> None:
    with pytest.raises(GeometryError, match=message):
        preset("oriel", params=params)
    assert len(preset("oriel", params={"n_oriels": "3"}).model.solids) == 4


def test_the_tower_preset_renders_the_parts_kb_tower_declares() -> None:
    from aida_kb.interpret.knowledge import Knowledge
    from aida_kb.kb import compile_path

    kb = compile_path(Path(__file__).resolve().parents[2] / "kb" / "tower.kb").kb
    assert kb is not None
    knowledge = Knowledge.from_kb(kb)
    real = knowledge.realisation("Tower")
    assert real is not None
    (structure,) = knowledge.structures(real.concept, real.role, "", "con-of")
    spec = preset("tower", params={"side": "8", "height": "12", "pitch_deg": "40"})
    faces = {f.role: f for f in spec.model.faces}
    assert set(faces) == {leaf.role for leaf in structure.leaves}
    assert spec.model.concept == "Tower"
    assert {faces[leaf.role].concept for leaf in structure.leaves} == {
        leaf.concept for leaf in structure.leaves
    }
    slope = faces["shaft.cap.north"].normal
    assert float(np.degrees(np.arccos(slope[1]))) == pytest.approx(40.0)
    with pytest.raises(GeometryError, match="pitch must be in"):
        preset("tower", params={"pitch_deg": "85"})
