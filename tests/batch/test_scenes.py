"""Which scenes a batch runs, and the output key of each."""

from __future__ import annotations

from pathlib import Path

import pytest

from aida_kb.batch.scenes import check_output_root, find_scenes, read_scene_list, scene_refs
from aida_kb.errors import FormatError


def _scene(path: Path) -> Path:
    path.mkdir(parents=True)
    (path / "scene.yaml").write_text("views: []\n")
    return path


def test_scenes_are_found_below_folders_but_not_inside_scenes_or_hidden_folders(
    tmp_path: Path,
) -> None:
    a = _scene(tmp_path / "city" / "a")
    _scene(a / "chessboard")  # belongs to scene a
    bc = _scene(tmp_path / "city" / "b" / "c")
    _scene(tmp_path / "city" / ".work" / "x")
    (tmp_path / "city" / "empty").mkdir()
    assert find_scenes([tmp_path / "city"]) == [a.resolve(), bc.resolve()]
    # a scene given itself is that scene
    assert find_scenes([a]) == [a.resolve()]


def test_keys_are_paths_below_the_common_folder_and_repeats_are_dropped(tmp_path: Path) -> None:
    a = _scene(tmp_path / "city" / "a")
    bc = _scene(tmp_path / "city" / "b" / "c")
    refs = scene_refs([a, bc, a])
    assert [r.key for r in refs] == ["a", "b/c"]
    assert [r.key for r in scene_refs([bc])] == ["c"]
    assert scene_refs([]) == []


def test_a_list_file_names_scenes_relative_to_itself(tmp_path: Path) -> None:
    a = _scene(tmp_path / "city" / "a")
    b = _scene(tmp_path / "elsewhere" / "b")
    listing = tmp_path / "city" / "scenes.txt"
    listing.write_text(f"# the scenes\n\na\n  {b}  \n")
    assert read_scene_list(listing) == [a.resolve(), b.resolve()]
    listing.write_text("a\nnot-there\n")
    with pytest.raises(FormatError) as info:
        read_scene_list(listing)
    assert str(info.value) == (f"{listing}:2: not-there: not a scene directory (no scene.yaml)")


def test_missing_folders_and_outputs_inside_a_scene_are_refused(tmp_path: Path) -> None:
    with pytest.raises(FormatError, match="no such directory"):
        find_scenes([tmp_path / "nope"])
    (tmp_path / "file").write_text("x")
    with pytest.raises(FormatError, match="not a directory"):
        find_scenes([tmp_path / "file"])
    a = _scene(tmp_path / "a")
    refs = scene_refs([a])
    with pytest.raises(FormatError, match="inside the scene"):
        check_output_root(a / "out", refs)
    check_output_root(tmp_path / "out", refs)
