"""Outputs published as a set: SIGTERM mid-publish leaves the old or the new set, never a mix
and no temporary folder; a lock refuses a second run into the same place."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from aida_kb.errors import FormatError
from aida_kb.io.atomic import check_publishable, output_lock, publish_dir

# Publishes a new set of three files into OUT, sending itself SIGTERM after the first file.
PUBLISH = r"""
import os, signal, sys
from pathlib import Path
from aida_kb.io.atomic import output_lock, publish_dir
out = Path(sys.argv[1])
with output_lock(out), publish_dir(out) as work:
    for i, name in enumerate(("a.json", "b.json", "c.json")):
        (work / name).write_text("new")
        if i == 0:
            os.kill(os.getpid(), signal.SIGTERM)
print("published", flush=True)
"""


def test_sigterm_mid_publish_leaves_the_new_set_whole(tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    for name in ("a.json", "b.json"):
        (out / name).write_text("old")
    run = subprocess.run(
        [sys.executable, "-c", PUBLISH, str(out)], capture_output=True, text=True, check=False
    )
    assert run.returncode == -15, run.stderr  # killed by the held-back SIGTERM ...
    assert "published" not in run.stdout  # ... right after the publishing block
    assert {p.name: p.read_text() for p in out.iterdir()} == {
        "a.json": "new",
        "b.json": "new",
        "c.json": "new",
    }
    assert sorted(p.name for p in tmp_path.iterdir()) == [".out.lock", "out"]


def test_failed_publish_keeps_the_old_set(tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "a.json").write_text("old")
    with pytest.raises(RuntimeError, match="half-way"), publish_dir(out) as work:
        (work / "a.json").write_text("new")
        raise RuntimeError("failed half-way")
    assert (out / "a.json").read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["out"]


def test_published_folder_gets_the_umask_permissions(tmp_path: Path) -> None:
    old = os.umask(0o022)
    try:
        with publish_dir(tmp_path / "out") as work:
            (work / "a.json").write_text("x")
    finally:
        os.umask(old)
    assert (tmp_path / "out").stat().st_mode & 0o777 == 0o755


def test_a_second_run_into_the_same_place_is_refused(tmp_path: Path) -> None:
    out = tmp_path / "out"
    with (
        output_lock(out),
        pytest.raises(FormatError, match="another run is writing"),
        output_lock(out),
    ):
        pass
    with output_lock(out):  # released: the next run goes ahead
        pass


def test_a_folder_with_foreign_files_is_not_replaced(tmp_path: Path) -> None:
    (tmp_path / "notes.txt").write_text("mine")
    with pytest.raises(FormatError, match=r"not an output folder of this command .*notes\.txt"):
        check_publishable(tmp_path, ["model.json"])
    assert check_publishable(tmp_path / "new", ["model.json"]) == tmp_path / "new"
