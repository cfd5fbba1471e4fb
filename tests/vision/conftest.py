"""Rendered scenes shared by the vision tests (rendered once per session)."""

from __future__ import annotations

from pathlib import Path

import pytest

from aida_kb.synth.scenes import preset, render_scene

SMALL = {"image_width": "320", "image_height": "240", "focal_px": "400"}


@pytest.fixture(scope="session")
def small_house(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 320x240 two-view gable house (fast; for the stereo and pipeline tests)."""
    out = tmp_path_factory.mktemp("vision") / "small_house"
    render_scene(preset("house", seed=5, params=SMALL), out)
    return out


@pytest.fixture(scope="session")
def house_640(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The 640x480 two-view house of the Done-when figures (normals within 2 degrees)."""
    out = tmp_path_factory.mktemp("vision") / "house_640"
    render_scene(preset("house", seed=0), out)
    return out


@pytest.fixture(scope="session")
def small_chessboard(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Six 320x240 chessboard pairs seen by a known rig (its calib.yaml is the truth)."""
    out = tmp_path_factory.mktemp("vision") / "chessboard"
    render_scene(preset("chessboard", seed=1, views=6, params=SMALL), out)
    return out
