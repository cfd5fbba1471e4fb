"""Atomic writes leave either the old file or the complete new one."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest

from aida_kb.errors import FormatError
from aida_kb.io.atomic import (
    atomic_path,
    check_output,
    check_outputs,
    make_dirs,
    write_text_atomic,
)


def test_write_text_atomic_replaces_target(tmp_path: Path) -> None:
    target = tmp_path / "sub" / "out.json"
    write_text_atomic(target, "first")
    write_text_atomic(target, "second")
    assert target.read_text() == "second"
    assert sorted(p.name for p in target.parent.iterdir()) == ["out.json"]


def test_failed_write_keeps_old_file_and_leaves_no_temporary(tmp_path: Path) -> None:
    target = tmp_path / "model.obj"
    target.write_text("old")
    with pytest.raises(RuntimeError, match="half-way"), atomic_path(target) as tmp:
        tmp.write_text("partial")
        raise RuntimeError("failed half-way")
    assert target.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["model.obj"]


def test_temporary_keeps_suffix(tmp_path: Path) -> None:
    with atomic_path(tmp_path / "depth.npy") as tmp:
        assert tmp.suffix == ".npy"
        tmp.write_bytes(b"x")
    assert (tmp_path / "depth.npy").read_bytes() == b"x"


def test_output_below_a_file_is_a_format_error(tmp_path: Path) -> None:
    blocker = tmp_path / "afile"
    blocker.write_text("x")
    with pytest.raises(FormatError, match=r"afile is a file, not a directory"):
        write_text_atomic(blocker / "sub" / "out.json", "{}")
    with pytest.raises(FormatError, match=r"afile is a file, not a directory"):
        make_dirs(blocker / "scene")
    assert blocker.read_text() == "x"


def test_output_onto_a_directory_is_a_format_error(tmp_path: Path) -> None:
    (tmp_path / "out").mkdir()
    with pytest.raises(FormatError, match=r"out: cannot write the output: it is a directory"):
        write_text_atomic(tmp_path / "out", "{}")
    assert list((tmp_path / "out").iterdir()) == []


def test_check_output_refuses_an_input_and_creates_the_folder(tmp_path: Path) -> None:
    source = tmp_path / "left.png"
    source.write_bytes(b"png")
    with pytest.raises(FormatError, match="over the input file"):
        check_output(tmp_path / "." / "left.png", [source])
    assert check_output(tmp_path / "new" / "d.npy", [source]) == tmp_path / "new" / "d.npy"
    assert (tmp_path / "new").is_dir()
    assert source.read_bytes() == b"png"


@pytest.mark.parametrize("umask", [0o022, 0o077, 0o002])
def test_output_files_get_the_umask_permissions(tmp_path: Path, umask: int) -> None:
    old = os.umask(umask)
    try:
        write_text_atomic(tmp_path / "out.json", "x")
        with atomic_path(tmp_path / "img.png") as tmp:
            tmp.write_bytes(b"y")
    finally:
        os.umask(old)
    for name in ("out.json", "img.png"):
        assert stat.S_IMODE((tmp_path / name).stat().st_mode) == 0o666 & ~umask


def test_check_outputs_refuses_inputs_duplicates_and_folders_around_inputs(
    tmp_path: Path,
) -> None:
    src = tmp_path / "in" / "a.png"
    src.parent.mkdir()
    src.write_bytes(b"a")
    (tmp_path / "link.png").symlink_to(src)
    with pytest.raises(FormatError, match="over the input file"):
        check_outputs([tmp_path / "link.png"], [src])
    with pytest.raises(FormatError, match="over the input file"):
        check_outputs([tmp_path / "in" / ".." / "in" / "a.png"], [src])
    with pytest.raises(FormatError, match="named twice"):
        check_outputs([tmp_path / "o.npy", tmp_path / "." / "o.npy"])
    with pytest.raises(FormatError, match="is or contains the input"):
        check_outputs([], [src], directories=[tmp_path])
    with pytest.raises(FormatError, match="lies inside the input"):
        check_outputs([], [tmp_path / "in"], directories=[tmp_path / "in" / "sub"])
    # a new file in the input's folder is fine
    assert check_outputs([tmp_path / "in" / "b.json"], [src]) == [tmp_path / "in" / "b.json"]
