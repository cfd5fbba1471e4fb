"""Tiny rendered scenes shared by the batch tests (rendered once per session)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from aida_kb.synth.scenes import preset, render_scene

# 320x240 single views: each reconstructs in about a second, and the house is found (at
# 160x120 it is not: too few pixels per wall for a region).
TINY = {"image_width": "320", "image_height": "240", "focal_px": "400"}
TINY_SEEDS = (1, 2, 3)
KB_PATH = Path(__file__).resolve().parents[2] / "kb" / "buildings.kb"


@pytest.fixture(scope="session")
def tiny_houses(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder of three tiny one-view gable houses, ``house1`` .. ``house3``."""
    root = tmp_path_factory.mktemp("batch") / "tiny"
    for seed in TINY_SEEDS:
        spec = preset("house", seed=seed, views=1, params=TINY)
        render_scene(spec, root / f"house{seed}", supersample=1)
    return root


@pytest.fixture
def city(tiny_houses: Path, tmp_path: Path) -> Path:
    """A private copy of the tiny houses, to add scenes to or break."""
    return Path(shutil.copytree(tiny_houses, tmp_path / "city"))


@pytest.fixture(scope="session")
def kb() -> object:
    """The shipped kb/buildings.kb, compiled."""
    from aida_kb.kb import compile_path

    result = compile_path(KB_PATH)
    assert result.kb is not None
    return result.kb
