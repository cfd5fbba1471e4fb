"""Which scenes a batch run reconstructs, and the key (output name) of each.

A scene is a directory holding ``scene.yaml`` (docs/formats.md). Under a folder given to
`find_scenes` every such directory is a scene; the search does not descend into a scene (its
subfolders belong to it) nor into hidden folders (``.git``, a batch run's ``.work``).
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from aida_kb.errors import FormatError
from aida_kb.io.jsonio import read_text_file

SCENE_FILE = "scene.yaml"


@dataclass(frozen=True)
class SceneRef:
    """One scene of a batch: its directory (absolute) and its key, the name of its output."""

    path: Path
    key: str


def is_scene(directory: Path) -> bool:
    """True if `directory` holds a scene index (``scene.yaml``)."""
    return (directory / SCENE_FILE).is_file()


def _walk(root: Path) -> list[Path]:
    """Every scene directory under `root` (itself included), in sorted order."""
    if is_scene(root):
        return [root]
    found: list[Path] = []
    for here, dirs, files in os.walk(root):
        if SCENE_FILE in files:
            found.append(Path(here))
            dirs[:] = []  # a scene's subfolders belong to it
            continue
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))
    return sorted(found)


def find_scenes(roots: Sequence[str | os.PathLike[str]]) -> list[Path]:
    """The scene directories under `roots` (absolute); FormatError for a missing folder."""
    scenes: list[Path] = []
    for root in roots:
        path = Path(root)
        if not path.exists():
            raise FormatError(f"{path}: no such directory")
        if not path.is_dir():
            raise FormatError(f"{path}: not a directory (give scene folders or their parents)")
        scenes += [p.resolve() for p in _walk(path)]
    return scenes


def read_scene_list(list_file: str | os.PathLike[str]) -> list[Path]:
    """The scene directories named in `list_file`, one per line (absolute paths).

    Blank lines and lines starting with ``#`` are skipped; a relative path is relative to
    the list file's folder. A line that names no scene directory is a FormatError naming
    the file and line.
    """
    file = Path(list_file)
    text = read_text_file(file)
    scenes: list[Path] = []
    for number, line in enumerate(text.splitlines(), start=1):
        entry = line.strip()
        if not entry or entry.startswith("#"):
            continue
        path = Path(entry) if Path(entry).is_absolute() else file.parent / entry
        if not is_scene(path):
            raise FormatError(f"{file}:{number}: {entry}: not a scene directory (no {SCENE_FILE})")
        scenes.append(path.resolve())
    return scenes


def scene_refs(scenes: Iterable[Path]) -> list[SceneRef]:
    """Each scene once (first occurrence kept), keyed by its path below their common folder.

    The key is the scene's path relative to the deepest folder that holds every scene's
    parent, so keys are distinct and stay the same when a run is started again with the
    same scenes: ``city/a``, ``city/b/c`` -> ``a``, ``b/c``; a single ``city/a`` -> ``a``.
    """
    unique = list(dict.fromkeys(Path(p).resolve() for p in scenes))
    if not unique:
        return []
    common = Path(os.path.commonpath([str(p.parent) for p in unique]))
    return [SceneRef(p, p.relative_to(common).as_posix()) for p in unique]


def check_output_root(out: Path, scenes: Sequence[SceneRef]) -> None:
    """Refuse (FormatError) an output folder that is a scene directory or inside one."""
    target = out.resolve()
    for ref in scenes:
        if target == ref.path or ref.path in target.parents:
            raise FormatError(
                f"{out}: the output folder is inside the scene {ref.path}; "
                "outputs are never written into inputs"
            )
