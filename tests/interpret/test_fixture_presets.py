"""A written interpretation.kb is an expectation its own result meets (docs/testing.md).

The full check over every synthetic preset at its default size (render, reconstruct, lint,
reconstruct again through ``aida-kb test``) is ``benchmarks/fixture_presets.py``; here the
demo's house (rendered once per session) is compared with its own result, and the cheapest
scene, a 320x240 one-view house, goes the whole way through ``aida-kb test`` as a scene
fixture.
"""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

import pytest

from aida_kb.cli.main import main
from aida_kb.interpret.fixture import compare
from aida_kb.interpret.result import read_interpretation
from aida_kb.kb import compile_path
from aida_kb.kb.expectation import expected_tree

ROOT = Path(__file__).resolve().parents[2]
KB_DIR = str(ROOT / "kb")
# 320x240, one view: reconstructs in about a second and the house is found (tests/batch)
TINY = {"image_width": "320", "image_height": "240", "focal_px": "400"}


def test_the_demo_houses_interpretation_kb_is_met_by_its_own_result(demo_run: Any) -> None:
    folder = demo_run.root / "model"
    path = folder / "interpretation.kb"
    result = compile_path(path, search_paths=[KB_DIR])
    assert not result.diagnostics
    assert result.kb is not None
    root = result.kb.files[0]
    tree = expected_tree(result.kb, root, path.read_text(encoding="utf-8"))
    assert tree.annotations.verdict in ("verified", "doubtful")
    assert tree.nodes[""].concept == "House"
    assert tree.nodes["body.roof"].concept == "GableRoof"
    kb = result.kb.model_copy(
        update={"instances": {n: i for n, i in result.kb.instances.items() if i.span.file != root}}
    )
    interp = read_interpretation(folder / "interpretation.json")
    assert compare(kb, tree, interp) == []
    # and the comparison is no rubber stamp: the same result judged otherwise differs
    other = "doubtful" if tree.annotations.verdict == "verified" else "verified"
    diffs = compare(kb, tree, interp.model_copy(update={"verdict": other, "doubts": ["x"]}))
    assert [d.message for d in diffs] == [
        f"expected verdict {tree.annotations.verdict}, got {other}: x"
    ]


def test_a_scene_fixture_of_a_small_house_passes_through_aida_kb_test(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from aida_kb.synth.scenes import preset, render_scene

    scene, out = tmp_path / "house", tmp_path / "out"
    render_scene(preset("house", seed=1, views=1, params=TINY), scene, supersample=1)
    assert main(["reconstruct", str(ROOT / "kb" / "buildings.kb"), str(scene), "-o", str(out)]) == 0
    written = out / "interpretation.kb"
    assert main(["lint", str(written), "--import-path", KB_DIR]) == 0
    # the one-file form: NAME.expected.kb beside the scene folder NAME/ (the same depth as the
    # output folder, so the written relative import holds)
    shutil.copy(written, tmp_path / "house.expected.kb")
    capsys.readouterr()
    assert main(["test", str(tmp_path), "--import-path", KB_DIR]) == 0
    text = capsys.readouterr().out
    assert f"{tmp_path / 'house.expected.kb'}: passed (" in text
    assert text.splitlines()[-1].startswith("1 fixture: 1 passed in ")
